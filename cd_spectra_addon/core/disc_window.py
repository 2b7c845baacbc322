"""Where the disc is, before the pose fit: the window of the photo the estimate reads closely.

A phone or a wide lens sees the disc across a fraction of the frame (a phone 21 cm above it:
~40 %; a 24 mm lens at 32 cm: ~25 %). Reading the whole frame at 1024 px leaves the rainbow a
few hundred pixels, where one pixel spans 4–8 nm of λ₁ and whole 5 nm bins get no pixel
(`phone-near-axis`, simulator, 8 LSPDD lamps: MAE 400–700 0.029 at 512 px, 0.020 at 1024 px,
0.018 with the disc at twice that — the true-pose figure). So the estimate first reads a
preview, finds how far from the image centre the disc can reach — the preset's rim projected
with the photo's focal length, widened for pose errors, and every bright pixel — and then reads
that window centred on the image centre (the camera model stays a centred pinhole) at up to
:data:`WINDOW_SIDE` pixels. When the preview is already as sharp as that, it is used as it is.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .analysis import focal_px_for
from .capture import Preset, Scene
from .images import LinearImage, load_photo

PREVIEW_SIDE = 1024  # the first, whole-frame read
WINDOW_SIDE = 1400  # long side of the window around the disc (the disc gets ~1000–1100 px of it)
MARGIN = 1.25  # the window reaches this much beyond the preset's rim (camera or lamp placed off, another distance)
BRIGHT_SHARE = 0.05  # pixels above this share of the preview's brightest are rainbow (or glint): keep them in
BRIGHT_PAD_PX = 8  # preview pixels kept around the brightest pixels
RIM_POINTS = 72
# A window covering more than this share of the frame gains little over the preview and would cost
# a full-resolution decode (a 24 MP JPEG: 240 ms instead of 75 ms): then the preview is read.
WHOLE_FRAME_SHARE = 0.5

__all__ = ["PREVIEW_SIDE", "WINDOW_SIDE", "disc_half_extent", "load_for_estimate"]


def disc_half_extent(image: LinearImage, preset: Preset) -> tuple[float, float]:
    """How far (x, y, in the image's loaded pixels) from the image centre the disc may reach: the
    preset's rim seen with this photo's focal length, ×:data:`MARGIN`, and every bright pixel."""
    height, width = image.rgb.shape[:2]
    focal_px, _ = focal_px_for(image, preset)
    camera = preset.camera
    posed = replace(preset, camera=replace(camera, image_size_px=(width, height),
                                           focal_length_mm=focal_px * camera.sensor_width_mm / width))
    scene = Scene(posed)
    angle = np.linspace(0.0, 2.0 * math.pi, RIM_POINTS, endpoint=False)
    rim = preset.disc.rim_radius_mm * 1e-3 * np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=1)
    rows, cols = scene.project(rim @ scene.disc_rotation.T + scene.disc_center).T
    centre_r, centre_c = (height - 1) / 2.0, (width - 1) / 2.0
    ok = np.isfinite(rows) & np.isfinite(cols)
    hx = MARGIN * float(np.max(np.abs(cols[ok] - centre_c))) if np.any(ok) else width / 2.0
    hy = MARGIN * float(np.max(np.abs(rows[ok] - centre_r))) if np.any(ok) else height / 2.0
    bright = _bright(image.rgb)
    if bright.any():
        r, c = np.nonzero(bright)
        hx = max(hx, float(np.max(np.abs(c - centre_c))) + BRIGHT_PAD_PX)
        hy = max(hy, float(np.max(np.abs(r - centre_r))) + BRIGHT_PAD_PX)
    return min(hx, width / 2.0), min(hy, height / 2.0)


def _bright(rgb: NDArray[np.floating]) -> NDArray[np.bool_]:
    lum = np.asarray(rgb, dtype=np.float32).sum(axis=2)
    peak = float(lum.max())
    return lum > BRIGHT_SHARE * peak if peak > 0 else np.zeros(lum.shape, bool)


def load_for_estimate(path: str | Path, preset: Preset) -> LinearImage:
    """The photo as the estimate reads it: the preview, or the window around the disc when that
    gives the disc more pixels (see the module doc)."""
    preview = load_photo(path, max_side=PREVIEW_SIDE)
    if preview.scale <= 1.0:
        return preview  # already every pixel the file has
    hx, hy = disc_half_extent(preview, preset)
    height, width = preview.rgb.shape[:2]
    if hx * hy > WHOLE_FRAME_SHARE * (width / 2.0) * (height / 2.0):
        return preview  # the disc fills the frame: the preview already gives it ~1000 px
    half = (hx * preview.scale, hy * preview.scale)
    window_scale = max(1.0, math.ceil(2.0 * max(half) / WINDOW_SIDE))
    if window_scale >= preview.scale:
        return preview
    return load_photo(path, max_side=WINDOW_SIDE, centre_crop_px=half)
