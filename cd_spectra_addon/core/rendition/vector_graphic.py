"""The TM-30 colour vector graphic as an image, drawn with numpy (for Blender's panel, where
there is no plotting library, and for the README).

The graphic as ANSI/IES TM-30 and colour-science draw it: the reference gamut is the unit
circle (each hue bin at its mean reference hue); each bin's test point lies at the bin's
average CAM02-UCS a′b′ shift from it, normalised by the reference average's chroma; the
test points joined in bin order are the test gamut (red), an arrow per bin in the bin's colour;
dashed lines divide the 16 hue bins, white circles mark ±20 % chroma. The background is each
bin's colour, faded. No text: the panel writes the figures beside it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["BIN_COLOURS", "vector_graphic_points", "vector_graphic_image"]

# TM-30's hue-bin colours (as colour-science's plotting uses them), bins 1–16.
BIN_COLOURS = ("#E62828", "#E74B4B", "#FB812E", "#FFB529", "#CBCA46", "#7EB94C", "#41C06D", "#009C7C",
               "#16BCB0", "#00A4BF", "#0085C3", "#3B62AA", "#4568AE", "#6A4E85", "#9D69A1", "#A74F81")
_TEST_COLOUR = "#F05046"
_EXTENT = 1.5  # the graphic spans −1.5 … 1.5 in both directions


def _rgb(hex_colour: str) -> NDArray[np.float64]:
    """Hex colour → sRGB values 0–1 (the graphic is display-referred, as icons and PNGs are)."""
    return np.array([int(hex_colour[i:i + 2], 16) for i in (1, 3, 5)]) / 255.0


def vector_graphic_points(rendition: dict[str, Any]) -> tuple[list[tuple[float, float]], list[tuple[float, float]]] | None:
    """(reference points on the unit circle, test points), 16 each, from an estimate's rendition
    JSON; None when the graphic is undefined (no rendition, or an empty hue bin)."""
    cvg = rendition.get("tm30_cvg") if rendition and rendition.get("defined") else None
    hues, test = (cvg or {}).get("reference_hue_deg"), (cvg or {}).get("test_xy")
    if not hues or not test or len(hues) != 16 or len(test) != 16:
        return None
    if any(not isinstance(h, (int, float)) for h in hues) or any(
            not (isinstance(p, list) and len(p) == 2 and all(isinstance(v, (int, float)) for v in p)) for p in test):
        return None
    ref = [(math.cos(math.radians(h)), math.sin(math.radians(h))) for h in hues]
    return ref, [(float(x), float(y)) for x, y in test]


class _Canvas:
    """An RGB image over −1.5 … 1.5 that lines are painted on with anti-aliased edges, each
    only within its own bounding box (a 256² graphic in a few ms)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self.px = 2 * _EXTENT / size
        self.centres = -_EXTENT + (np.arange(size) + 0.5) * self.px
        x, y = np.meshgrid(self.centres, self.centres)  # row 0 at the bottom (y = −1.5)
        hue_bin = (np.floor(np.degrees(np.arctan2(y, x)) % 360.0 / 22.5).astype(int)) % 16
        palette = np.stack([_rgb(c) for c in BIN_COLOURS])
        self.image = 0.45 * palette[hue_bin] + 0.55  # each bin's colour, faded
        self.image[np.hypot(x, y) < 0.15] = 1.0

    def _window(self, lo: tuple[float, float], hi: tuple[float, float], pad: float) -> tuple[slice, slice]:
        def index(v: float) -> int:
            return int(np.clip(np.floor((v + _EXTENT) / self.px), 0, self.size))

        return (slice(index(lo[1] - pad), index(hi[1] + pad) + 1), slice(index(lo[0] - pad), index(hi[0] + pad) + 1))

    def _blend(self, rows: slice, cols: slice, distance: NDArray[np.float64], width_px: float,
               colour: NDArray[np.float64]) -> None:
        cover = np.clip(width_px / 2 + 0.5 - distance / self.px, 0.0, 1.0)[..., None]
        block = self.image[rows, cols]
        self.image[rows, cols] = block * (1 - cover) + colour * cover

    def segment(self, a: tuple[float, float], b: tuple[float, float], width_px: float,
                colour: NDArray[np.float64]) -> None:
        rows, cols = self._window((min(a[0], b[0]), min(a[1], b[1])), (max(a[0], b[0]), max(a[1], b[1])),
                                  width_px * self.px)
        x, y = np.meshgrid(self.centres[cols], self.centres[rows])
        dx, dy = b[0] - a[0], b[1] - a[1]
        length2 = dx * dx + dy * dy
        t = np.clip(((x - a[0]) * dx + (y - a[1]) * dy) / length2, 0.0, 1.0) if length2 > 0 else 0.0
        self._blend(rows, cols, np.hypot(x - (a[0] + t * dx), y - (a[1] + t * dy)), width_px, colour)

    def circle(self, radius: float, width_px: float, colour: NDArray[np.float64]) -> None:
        x, y = np.meshgrid(self.centres, self.centres)
        self._blend(slice(None), slice(None), np.abs(np.hypot(x, y) - radius), width_px, colour)


def vector_graphic_image(rendition: dict[str, Any], size: int = 256) -> NDArray[np.float32] | None:
    """The graphic as a (size, size, 4) RGBA image of sRGB display values 0–1 (what Blender's
    previews and a PNG hold), bottom row first (Blender's order); None where
    :func:`vector_graphic_points` is None."""
    points = vector_graphic_points(rendition)
    if points is None:
        return None
    ref, test = points
    canvas = _Canvas(size)
    white, grey, black = np.ones(3), np.full(3, 0.45), np.zeros(3)
    for radius in (0.8, 0.9, 1.1, 1.2):
        canvas.circle(radius, 1.0, white)
    for k in range(16):  # dashed bin dividers from r = 0.15 out to the edge
        c, s = math.cos(2 * math.pi * k / 16), math.sin(2 * math.pi * k / 16)
        for start in np.arange(0.15, 1.5, 0.1):
            canvas.segment((start * c, start * s), ((start + 0.06) * c, (start + 0.06) * s), 1.0, grey)
    canvas.circle(1.0, 2.0, black)
    for k in range(16):  # an arrow per bin: reference → test, in the bin's colour
        colour = _rgb(BIN_COLOURS[k])
        canvas.segment(ref[k], test[k], 2.0, colour)
        canvas.segment(test[k], test[k], 6.0, colour)
    red = _rgb(_TEST_COLOUR)
    for k in range(16):
        canvas.segment(test[k], test[(k + 1) % 16], 2.5, red)
    return np.concatenate([canvas.image, np.ones((size, size, 1))], axis=-1).astype(np.float32)
