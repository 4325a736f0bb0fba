"""PicoScan workbench: document objects, view providers, task panels and commands over the
compiled `picoscan` module (which sits beside this package in the workbench folder)."""
import os

WORKBENCH_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ICON_DIR = os.path.join(WORKBENCH_DIR, "Resources", "icons")


def icon_path(name):
    return os.path.join(ICON_DIR, name + ".svg")
