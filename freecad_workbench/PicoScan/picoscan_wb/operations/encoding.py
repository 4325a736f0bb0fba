"""False-colour pictures of the decoded codes: projector column and row per camera pixel, fringe
modulation, and why pixels were rejected."""
import os

import numpy

import picoscan
from picoscan_wb.progress import cancel_point, run_in_background

# Colours (BGR) of the pixel status values of picoscan.decode.
STATUS_COLOURS = {
    picoscan.PixelStatus.kValid: (80, 200, 60),
    picoscan.PixelStatus.kDark: (40, 40, 40),
    picoscan.PixelStatus.kSaturated: (255, 255, 255),
    picoscan.PixelStatus.kUndecidedBit: (40, 40, 220),
    picoscan.PixelStatus.kLowModulation: (220, 120, 40),
}


def false_colour(values, low, high, valid):
    """Rainbow (blue -> red) BGR image of `values` scaled from low to high; black where not valid."""
    t = numpy.clip((numpy.nan_to_num(values) - low) / max(high - low, 1e-9), 0, 1)
    red = numpy.clip(1.5 - numpy.abs(4 * t - 3), 0, 1)
    green = numpy.clip(1.5 - numpy.abs(4 * t - 2), 0, 1)
    blue = numpy.clip(1.5 - numpy.abs(4 * t - 1), 0, 1)
    image = (numpy.stack([blue, green, red], axis=-1) * 255).astype(numpy.uint8)
    image[~valid] = 0
    return image


def encoding_images(capture_folder, output_folder, manifest_file=""):
    """Decodes the capture set and writes PNGs into output_folder, off the GUI thread with the progress
    dialog (Cancel: picoscan.Error "cancelled"). Returns {name: path}."""
    if not capture_folder or not os.path.isdir(capture_folder):
        raise picoscan.Error("%s: capture folder does not exist" % (capture_folder or "(no capture folder)"))
    return run_in_background("Decoding", lambda progress: _write_encoding_images(
        capture_folder, output_folder, manifest_file, progress))


def _write_encoding_images(capture_folder, output_folder, manifest_file, progress):
    captures = picoscan.load_capture_set(capture_folder, manifest_file, progress)
    codes = picoscan.decode(captures, progress=progress)
    cancel_point(progress, 1.0, "false-colour pictures")
    width, height = captures.sequence.projector_size
    valid = codes.mask > 0
    images = {
        "projector_u": false_colour(codes.projector_u, 0, width, valid),
        "status": numpy.zeros(codes.status.shape + (3,), numpy.uint8),
    }
    if captures.sequence.encodes_rows:
        images["projector_v"] = false_colour(codes.projector_v, 0, height, valid & numpy.isfinite(codes.projector_v))
    quality = codes.quality[valid]
    images["quality"] = false_colour(codes.quality, 0, float(numpy.percentile(quality, 99)) if quality.size else 1, valid)
    for status, colour in STATUS_COLOURS.items():
        images["status"][codes.status == int(status)] = colour
    os.makedirs(output_folder, exist_ok=True)
    paths = {}
    for name, image in images.items():
        paths[name] = os.path.join(output_folder, "encoding_%s.png" % name)
        picoscan.write_image(paths[name], image)
    return paths
