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
