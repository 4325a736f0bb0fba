"""Hardware capture through the capture issue's `picoscan capture` command: it shows the patterns
full screen on the projector and grabs them with the camera (or its virtual stand-in). Run as a
separate process, so the projector window and the camera never block FreeCAD, and Stop can end it."""
import os
import shutil
import subprocess
import time

import picoscan


def cli_path():
    """The `picoscan` command: $PICOSCAN_CLI, else the one on PATH."""
    path = os.environ.get("PICOSCAN_CLI") or shutil.which("picoscan")
    if not path or not os.access(path, os.X_OK):
        raise picoscan.Error("picoscan: command not found (install PicoScan with 'cmake --install', or set PICOSCAN_CLI)")
    return path


def capture_command(folder, camera, calibration_file, projector_screen=None, shifts=8):
    command = [cli_path(), "capture", "--camera", camera, "--out", folder, "--calibration", calibration_file,
               "--shifts", str(shifts)]
    if projector_screen is not None:
        command += ["--projector-screen", str(projector_screen)]
    if camera == "virtual":
        command += ["--latency-ms", "0"]  # nothing to wait for
    return command


def capture(folder, camera, calibration_file, projector_screen=None, should_cancel=None, shifts=8):
    """Captures a capture set into `folder`. Raises picoscan.Error with the command's own one-line
    message when it fails, or "cancelled" when should_cancel() turns True (the frames taken so far
    stay in the folder; 'picoscan capture --resume' completes them)."""
    if not calibration_file or not os.path.isfile(calibration_file):
        raise picoscan.Error("%s: calibration file does not exist" % (calibration_file or "(no calibration file)"))
    if not camera:
        raise picoscan.Error("Camera: give a webcam index (0), a device (/dev/video0), a video file, or 'virtual'")
    process = subprocess.Popen(capture_command(folder, camera, calibration_file, projector_screen, shifts),
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while process.poll() is None:
        if should_cancel and should_cancel():
            process.terminate()
            process.wait()
            raise picoscan.Error("cancelled: capture stopped; the frames taken so far are in %s" % folder)
        time.sleep(0.05)
    output, errors = process.communicate()
    if process.returncode != 0:
        lines = [line for line in (errors or output).splitlines() if line.strip()]
        raise picoscan.Error(lines[-1] if lines else "picoscan capture failed with exit code %d" % process.returncode)
    return calibration_file
