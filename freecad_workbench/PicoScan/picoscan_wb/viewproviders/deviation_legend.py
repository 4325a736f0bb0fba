"""The Deviation map's colour legend in the 3D view: a colour bar from -range to +range in the map's
own colours (the core's deviation_colour), labelled at the ends, at the tolerance band's edges and
at 0. A heads-up overlay like the colour bars of FreeCAD's FEM results: its own orthographic camera
puts it at a fixed place of the viewport (the right edge, below the navigation cube), drawn over the
scene, whatever the view's orientation. It sits in the map's own scene (its view provider's root),
so it goes with the object (deleted, undone, document closed); shown while the map is shown, built
again when a recompute changes the range."""
import math

from pivy import coin

import picoscan

# Where the bar is, in viewport coordinates (-1 to 1 across and up; the camera ignores the aspect).
BAR_LEFT, BAR_RIGHT = 0.86, 0.90
BAR_BOTTOM, BAR_TOP = -0.70, 0.50
LABEL_RIGHT = 0.845  # labels end just left of the bar
LABEL_DROP = 0.015   # a label's baseline this far below its value, so the text is centred on it


def viewport_pixel(x, y, width, height):
    """(column, row from the top) of a point in the legend's viewport coordinates."""
    return int(round((x + 1) / 2 * (width - 1))), int(round((1 - y) / 2 * (height - 1)))


def bar_y(distance_mm, range_mm):
    return BAR_BOTTOM + (distance_mm + range_mm) / (2 * range_mm) * (BAR_TOP - BAR_BOTTOM)


def label_values(tolerance_mm, range_mm):
    """The distances labelled, top to bottom: +range, +tolerance, 0, -tolerance, -range."""
    return [range_mm, tolerance_mm, 0.0, -tolerance_mm, -range_mm]


def label_text(value_mm, tolerance_mm):
    """A label: signed, with enough decimals to tell the tolerance (0.050 for a 0.05 mm tolerance)."""
    decimals = max(3, int(math.ceil(-math.log10(tolerance_mm))) + 1)
    return "0" if value_mm == 0 else "%+.*f" % (decimals, value_mm)


def _colour(distance_mm, tolerance_mm, range_mm):
    return tuple(channel / 255.0 for channel in picoscan.deviation_colour(distance_mm, tolerance_mm, range_mm))


def _bar(tolerance_mm, range_mm):
    """Three quads, coloured per vertex: blue to cyan (inside), green (the tolerance band), yellow
    to red (outside). The core's scale is linear in |d| between the tolerance and the range, so
    Gouraud shading between the band's edges and the ends gives its colours exactly."""
    just_outside = tolerance_mm + 1e-9 * range_mm
    stops = [(-range_mm, -range_mm), (-tolerance_mm, -just_outside),  # (height, colour of the distance)
             (-tolerance_mm, -tolerance_mm), (tolerance_mm, tolerance_mm),
             (tolerance_mm, just_outside), (range_mm, range_mm)]
    points, colours = [], []
    for low, high in zip(stops[0::2], stops[1::2]):
        for (height, distance), x in ((low, BAR_LEFT), (low, BAR_RIGHT), (high, BAR_RIGHT), (high, BAR_LEFT)):
            points.append((x, bar_y(height, range_mm), 0.0))
            colours.append(_colour(distance, tolerance_mm, range_mm))
    separator = coin.SoSeparator()
    material = coin.SoMaterial()
    material.diffuseColor.setValues(0, len(colours), colours)
    binding = coin.SoMaterialBinding()
    binding.value = coin.SoMaterialBinding.PER_VERTEX
    coordinates = coin.SoCoordinate3()
    coordinates.point.setValues(0, len(points), points)
    faces = coin.SoFaceSet()
    faces.numVertices.setValues(0, 3, [4, 4, 4])
    for node in (material, binding, coordinates, faces):
        separator.addChild(node)
    return separator


def _text(lines, x, y, justification):
    separator = coin.SoSeparator()
    translation = coin.SoTranslation()
    translation.translation = (x, y, 0)
    text = coin.SoText2()
    text.string.setValues(0, len(lines), lines)
    text.justification = justification
    for node in (translation, text):
        separator.addChild(node)
    return separator


class Legend:
    """The legend's nodes, kept by the map's view provider; `labels` the texts shown, top to bottom."""

    def __init__(self, root):
        self.switch = coin.SoSwitch()
        self.switch.whichChild = coin.SO_SWITCH_NONE
        # FreeCAD's own group that keeps a node out of the bounding box: "fit all" and "fit
        # selection" then frame the scan, not the legend at the document's origin.
        skip = coin.SoType.fromName("SoSkipBoundingGroup")
        if skip.isBad():
            self.holder = coin.SoSeparator()
        else:
            self.holder = coin.cast(skip.createInstance(), "SoGroup")
            self.holder.getField("mode").set("EXCLUDE_BBOX")
        self.holder.addChild(self.switch)
        self.content = None
        self.labels = []
        root.addChild(self.holder)

    def update(self, tolerance_mm, range_mm, visible):
        """Shows the legend of a map with this tolerance and colour range (none for range 0: not measured)."""
        shown = visible and range_mm > 0 and tolerance_mm > 0
        if shown and self.labels != self._labels(tolerance_mm, range_mm):
            self._build(tolerance_mm, range_mm)
        self.switch.whichChild = 0 if shown and self.content is not None else coin.SO_SWITCH_NONE

    @staticmethod
    def _labels(tolerance_mm, range_mm):
        return [label_text(value, tolerance_mm) for value in label_values(tolerance_mm, range_mm)]

    def _build(self, tolerance_mm, range_mm):
        # SoAnnotation: drawn last, over the scene, whatever the depth.
        content = coin.SoAnnotation()
        style = coin.SoPickStyle()
        style.style = coin.SoPickStyle.UNPICKABLE  # a click on the legend selects nothing
        camera = coin.SoOrthographicCamera()
        camera.viewportMapping = coin.SoCamera.LEAVE_ALONE  # -1..1 across the whole viewport, whatever its shape
        camera.position = (0, 0, 5)
        camera.height = 2
        camera.nearDistance = 1
        camera.farDistance = 10
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR
        filled = coin.SoDrawStyle()  # the map's points' style would otherwise draw the bar as dots
        filled.style = coin.SoDrawStyle.FILLED
        font = coin.SoFont()
        font.size = 14
        text_colour = coin.SoBaseColor()
        text_colour.rgb = (0.1, 0.1, 0.1)
        for node in (coin.SoResetTransform(), style, camera, light, filled, _bar(tolerance_mm, range_mm), font, text_colour):
            content.addChild(node)
        labels = self._labels(tolerance_mm, range_mm)
        for value, text in zip(label_values(tolerance_mm, range_mm), labels):
            content.addChild(_text([text], LABEL_RIGHT, bar_y(value, range_mm) - LABEL_DROP, coin.SoText2.RIGHT))
        content.addChild(_text(["Deviation (mm)"], BAR_RIGHT, BAR_TOP + 0.04, coin.SoText2.RIGHT))
        content.addChild(_text(["green: within +-%s" % label_text(tolerance_mm, tolerance_mm)[1:]],
                               BAR_RIGHT, BAR_BOTTOM - 0.07, coin.SoText2.RIGHT))
        if self.content is not None:
            self.switch.removeChild(self.content)
        self.switch.addChild(content)
        self.content = content
        self.labels = labels
