"""Calibrate task panel: board, one capture folder per board pose, output file, and a live report
(corners found per pose as they are observed, then the errors of the calibration)."""
import os

import FreeCAD
import FreeCADGui
from PySide import QtGui

import picoscan
from picoscan_wb.commands.base import INPUT_ERRORS, show_message
from picoscan_wb.progress import cancel_point, run_in_background


class CalibrateTaskPanel:
    """The command that opens this panel keeps it as its `panel` (for tests and macros)."""

    def __init__(self):
        self.form = QtGui.QWidget()
        self.form.setWindowTitle("PicoScan calibration")
        layout = QtGui.QFormLayout(self.form)
        self.board = QtGui.QLineEdit("chessboard:9x6:20")
        self.board.setToolTip("chessboard:COLSxROWS:SQUARE_MM, circles:..., acircles:..., charuco:COLSxROWS:SQUARE_MM:MARKER_MM")
        layout.addRow("Board", self.board)
        self.poses = QtGui.QListWidget()
        self.poses.setToolTip("One capture folder per board pose (10 or more, tilted in different directions)")
        layout.addRow("Pose captures", self.poses)
        buttons = QtGui.QHBoxLayout()
        add, remove = QtGui.QPushButton("Add folder..."), QtGui.QPushButton("Remove")
        add.clicked.connect(self.add_folder)
        remove.clicked.connect(lambda: [self.poses.takeItem(self.poses.row(item)) for item in self.poses.selectedItems()])
        buttons.addWidget(add)
        buttons.addWidget(remove)
        layout.addRow("", buttons)
        self.output = QtGui.QLineEdit(os.path.join(os.path.expanduser("~"), "picoscan_calibration.yml"))
        self.output.setToolTip("Where the calibration (.yml) is written, with an HTML report beside it; "
                               "Scan and Import capture set read it")
        layout.addRow("Output file", self.output)
        self.report = QtGui.QPlainTextEdit()
        self.report.setReadOnly(True)
        self.report.setToolTip("What each pose gave and the calibration's reprojection errors")
        layout.addRow("Report", self.report)
        self.result = None
        self.report_lines = []  # the report's text, also after the panel has closed

    def add_folder(self):
        folder = QtGui.QFileDialog.getExistingDirectory(self.form, "Capture folder of one board pose")
        if folder:
            self.poses.addItem(folder)

    def pose_folders(self):
        return [self.poses.item(row).text() for row in range(self.poses.count())]

    def log(self, line):
        self.report_lines.append(line)
        self.report.appendPlainText(line)
        QtGui.QApplication.processEvents()

    def calibrate(self):
        """Observes every pose, calibrates, writes the calibration and an HTML report beside it."""
        board = picoscan.parse_board_spec(self.board.text().strip())
        folders = self.pose_folders()
        if not folders:
            raise picoscan.Error("Pose captures: add one capture folder per board pose")
        output = self.output.text().strip()
        if not output.lower().endswith((".yml", ".yaml", ".xml", ".json")):
            raise picoscan.Error("%s: the calibration file must end in .yml, .yaml, .xml or .json"
                                 % (output or "Output file"))
        for folder in folders:
            if not os.path.isdir(folder):
                raise picoscan.Error("%s: capture folder does not exist" % folder)
        self.report.clear()
        self.report_lines = []
        found = []  # report lines the worker adds; shown on the GUI thread as they come

        def show_found():
            for line in found[len(self.report_lines):]:
                self.log(line)

        def work(progress):  # off the GUI thread: loading and observing every pose takes seconds each
            observations = []
            for index, folder in enumerate(folders):
                cancel_point(progress, index / float(len(folders)), "observing board poses")
                observation = picoscan.observe_pose(picoscan.load_capture_set(folder), board)
                observations.append(observation)
                found.append("%s: %d corners, %d with projector points%s" % (
                    os.path.basename(folder), observation.corner_count, observation.projector_corner_count,
                    " - " + observation.problem if observation.problem else ""))
            report = picoscan.calibrate_rig(observations, progress=progress)
            found.append("camera RMS %.3f px, projector RMS %.3f px, stereo RMS %.3f px" % (
                report.camera_rms_px, report.projector_rms_px, report.stereo_rms_px))
            found.extend("%s not used: %s" % (pose.name, pose.reason) for pose in report.poses if not pose.used)
            found.extend("warning: " + warning for warning in report.warnings)
            cancel_point(progress, 1.0, "writing the calibration")
            picoscan.write_calibration(report.calibration, output)
            picoscan.write_calibration_report(report, board, os.path.splitext(output)[0] + "_report.html")
            found.append("written: " + output)
            return report

        report = run_in_background("Calibrating", work, poll=show_found)
        self.result = report
        return report

    def accept(self):
        try:
            self.calibrate()
        except INPUT_ERRORS as error:
            FreeCAD.Console.PrintError("PicoScan calibration: %s\n" % error)
            show_message("PicoScan: Calibrate", str(error))
            return False  # the panel stays open for corrections
        FreeCADGui.Control.closeDialog()
        return True

    def reject(self):
        FreeCADGui.Control.closeDialog()
        return True
