"""Core progress callbacks shown in FreeCAD's progress indicator (the status bar in the GUI)."""
import FreeCAD


class FreeCADProgress:
    """Use as `with FreeCADProgress("Reconstructing") as progress: picoscan.decode(..., progress=progress)`.
    `should_cancel`, if given, is asked at every report; True stops the core call (picoscan.Error "cancelled")."""

    STEPS = 100

    def __init__(self, title, should_cancel=None):
        self.title = title
        self.should_cancel = should_cancel
        self.indicator = None
        self.done = 0
        self.last_stage = ""

    def __enter__(self):
        # Headless (freecadcmd) the indicator prints every step to the console: only the GUI gets it.
        if FreeCAD.GuiUp:
            self.indicator = FreeCAD.Base.ProgressIndicator()
            self.indicator.start(self.title, self.STEPS)
        return self

    def __exit__(self, *exc):
        if self.indicator is not None:
            self.indicator.stop()
        return False

    def __call__(self, fraction, stage):
        # The core reports each stage from 0 to 1: the indicator restarts when the stage changes.
        if stage != self.last_stage and self.indicator is not None:
            self.last_stage = stage
            self.done = 0
            self.indicator.stop()
            self.indicator.start("%s: %s" % (self.title, stage), self.STEPS)
        target = int(max(0.0, min(1.0, fraction)) * self.STEPS)
        while self.done < target and self.indicator is not None:
            self.indicator.next()
            self.done += 1
        return not (self.should_cancel and self.should_cancel())


def cancel_point(progress, fraction, stage):
    """Reports `stage` from Python work between core calls, and raises picoscan.Error("cancelled: ...")
    when progress answers False (the Cancel button), as the core's calls do."""
    if progress is not None and not progress(fraction, stage):
        import picoscan

        raise picoscan.Error("cancelled: " + stage)


def run_in_background(title, work, should_cancel=None, poll=None):
    """Runs work(progress) -> result, where progress(fraction, stage) is handed to the core's long calls
    (and to cancel_point between them). The one way PicoScan runs long work: in the GUI the work runs on
    a worker thread (the core releases the GIL) while the GUI thread shows a progress dialog with Cancel
    and keeps answering events; Cancel makes the core raise picoscan.Error("cancelled: ..."). The work
    must not touch document objects or widgets: read them before, change them after. poll(), if given,
    runs on the GUI thread while the work runs (and once after), e.g. to show what the work found so
    far. Headless, it simply runs. Exceptions of the work are re-raised here."""
    if not FreeCAD.GuiUp:
        try:
            with FreeCADProgress(title, should_cancel) as progress:
                return work(progress)
        finally:
            if poll is not None:
                poll()
    import threading
    import time

    from PySide2 import QtCore, QtWidgets

    import FreeCADGui

    dialog = QtWidgets.QProgressDialog(title, "Cancel", 0, 1000, FreeCADGui.getMainWindow())
    dialog.setWindowTitle("PicoScan")
    dialog.setObjectName("PicoScanProgress")
    dialog.setWindowModality(QtCore.Qt.WindowModal)  # the GUI repaints and answers, but starts nothing else
    dialog.setMinimumDuration(300)
    state = {"fraction": 0.0, "stage": "", "result": None, "error": None}

    def progress(fraction, stage):
        state["fraction"], state["stage"] = fraction, stage
        return not (dialog_cancelled.is_set() or (should_cancel is not None and should_cancel()))

    def run():
        try:
            state["result"] = work(progress)
        except BaseException as error:  # handed to the GUI thread, raised there
            state["error"] = error

    dialog_cancelled = threading.Event()
    dialog.canceled.connect(dialog_cancelled.set)
    worker = threading.Thread(target=run, name="PicoScan " + title, daemon=True)
    worker.start()
    started = time.monotonic()
    while worker.is_alive():
        if dialog.wasCanceled():  # also when cancelled by a call rather than the button
            dialog_cancelled.set()
        if not dialog.isVisible() and time.monotonic() - started > 0.3:
            dialog.show()  # Qt shows it only when it predicts a long wait; Cancel is offered for any wait
        dialog.setLabelText("%s: %s" % (title, state["stage"]) if state["stage"] else title)
        dialog.setValue(int(1000 * max(0.0, min(1.0, state["fraction"]))))
        if poll is not None:
            poll()
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)
        worker.join(0.02)
        time.sleep(0)
    if poll is not None:
        poll()
    dialog.reset()
    dialog.setParent(None)  # gone from the main window at once, not at the next deferred delete
    dialog.deleteLater()
    if state["error"] is not None:
        raise state["error"]
    return state["result"]


def run_on_gui_thread(title, action):
    """Runs action() -> result on the GUI thread, for work FreeCAD does only there and cannot stop
    (its view provider meshing a big shape to draw it), with the progress dialog showing `title`
    (busy, without Cancel) so that the user sees what the GUI waits for. Headless, it simply runs."""
    if not FreeCAD.GuiUp:
        return action()
    from PySide2 import QtCore, QtWidgets

    import FreeCADGui

    dialog = QtWidgets.QProgressDialog(title, None, 0, 0, FreeCADGui.getMainWindow())
    dialog.setWindowTitle("PicoScan")
    dialog.setObjectName("PicoScanProgress")
    dialog.setWindowModality(QtCore.Qt.WindowModal)
    dialog.setMinimumDuration(0)
    dialog.show()
    for _ in range(3):  # laid out and painted before the GUI thread is taken
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.AllEvents, 20)
    try:
        return action()
    finally:
        dialog.reset()
        dialog.setParent(None)
        dialog.deleteLater()


def run_freecad_process(script, arguments, progress, shown, what):
    """Runs `script` (a file of picoscan_wb) in FreeCAD's Python as a separate process, for FreeCAD
    work that holds the GIL and cannot be stopped (OpenCASCADE), with FreeCAD's library folder as
    its first argument. Its stdout lines that are JSON objects are its answers; while it runs, each
    {"stage": ...} is shown as shown.format(stage) and Cancel (progress answering False) ends the
    process at once. Returns the answers; raises picoscan.Error "<what> failed in its own process
    (<its last line>)" when it failed."""
    import json
    import os
    import subprocess
    import sys
    import threading
    import time

    import Part  # its folder is FreeCAD's library folder

    import picoscan

    python = os.path.join(sys.base_prefix, "bin", "python%d.%d" % sys.version_info[:2])  # FreeCAD's own Python
    if not os.path.isfile(python):
        raise picoscan.Error("%s: FreeCAD's Python interpreter %s is missing" % (what, python))
    # -S: no site module (its .pth files and imports, 0.04 s): the scripts need only FreeCAD's folder.
    command = [python, "-S", script, os.path.dirname(Part.__file__)] + [str(a) for a in arguments]
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []

    def read_lines():
        for line in child.stdout:
            lines.append(line.strip())

    def answers():
        return [json.loads(line) for line in list(lines) if line.startswith("{")]
    reader = threading.Thread(target=read_lines, name="PicoScan " + what, daemon=True)
    reader.start()
    try:
        while child.poll() is None or reader.is_alive():
            stages = [answer["stage"] for answer in answers() if "stage" in answer]
            cancel_point(progress, 0.0, shown.format(stages[-1] if stages else "starting"))
            time.sleep(0.05)
    except BaseException:  # Cancel (or anything else): the process stops now
        child.kill()
        child.wait()
        raise
    if child.returncode != 0:
        raise picoscan.Error("%s failed in its own process (%s)" % (what, (lines or ["exit code %d" % child.returncode])[-1]))
    return answers()
