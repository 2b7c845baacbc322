"""Where the disc is, before the pose fit: the window of the photo the estimate reads closely.

A wide lens sees the disc across a fraction of the frame: a 24 mm lens at 32 cm (the
`tripod-oblique` set-up) across ~25 % of it, so a whole-frame read at 1024 px leaves the disc
~190 px and the streak's 400–700 nm ~40 px — 7 nm of λ₁ per pixel, coarser than the 5 nm bins,
which then alias (bins without a pixel). So the estimate reads a preview first, and when the disc
in it is smaller than :data:`DISC_MIN_PX`, reads the window around it — centred on the image
centre, so the camera model stays a centred pinhole — at the resolution that gives the disc about
:data:`DISC_TARGET_PX`. The window reaches the preset's rim projected with the photo's focal
length, widened for pose errors, and every bright pixel.

Measured (simulator, `phone-near-axis`, 24 LSPDD lamps, a 12 MP phone JPEG, 1 % noise per
photo pixel): whole frame (disc 416 px) MAE 400–700 0.0205 / Δu'v' 0.0009 in 2.3 s; a window with
the disc at 832 px 0.0214 / 0.0011 in 4.5 s — no better at twice the time once the disc has
~400 px, hence the threshold.

A disc at least twice :data:`DISC_READ_PX` wide is read at the power-of-two reduction that
leaves it at least that wide, box-averaged in linear light from the preview (no other decode, and
a JPEG's codes averaged over no larger a draft block than before: a camera-sized file's saturated
spots and tone curve are judged at the preview's resolution). Each read pixel is then the average
of whole preview pixels, the footprint the forward model integrates over. Measured (`make bench`'s
operating points, 41 LSPDD lamps, 768 px cd-default JPEGs, disc ~690 px): read at 768 px MAE
400–700 0.0118, 380–780 0.0251, Δu'v' 0.0006 in 351 ms; at 384 px (disc ~345 px) 0.0117,
0.0246, 0.0004 in 201 ms — no worse, and the readout of a 24 MP photo's near-axis rings falls from
88 to 18 ms. (At 512 px, a reduction of 1.5 that mixes pixels unevenly, 0.0122.) Only for a
camera above the disc (``near_axis``), whose first order fills whole rings: an oblique set-up's
streak is a few pixels wide, and read at half size (bench/setup_samples.md's photos, disc 800 →
400 px) `tripod-oblique` went from MAE 0.016 to 0.026 with "only 57 % of 400–700 nm is visible"
on every photo (its streak's end bins fell below the readout's minimum pixel weight), and
`phone-distant-lamp` kept its MAE but was warned on every photo (confidence 1.00 → 0.83).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .stages import focal_px_for, focal_px_of
from ..scene.capture import Preset, Scene
from ..scene.relative_pose import near_axis
from ..photo.images import LinearImage, PhotoReader, reduced

PREVIEW_SIDE = 1024  # the first, whole-frame read
DISC_MIN_PX = 400  # a disc this wide in the preview is read as it is
DISC_TARGET_PX = 720  # ...a smaller one is read through a window that gives it about this much
DISC_READ_PX = 320  # a disc at least twice this wide is read reduced, at least this wide (see the module doc)
MARGIN = 1.25  # the window reaches this much beyond the preset's rim (camera or lamp placed off, another distance)
BRIGHT_SHARE = 0.05  # pixels above this share of the preview's brightest are rainbow (or glint): keep them in
BRIGHT_PAD_PX = 8  # preview pixels kept around the brightest pixels
RIM_POINTS = 72

__all__ = ["PREVIEW_SIDE", "DISC_MIN_PX", "DISC_TARGET_PX", "DISC_READ_PX", "disc_half_extent", "reduction",
           "load_for_estimate"]


def disc_half_extent(image: LinearImage, preset: Preset) -> tuple[float, float, float]:
    """(x, y, diameter): how far, in the image's loaded pixels, from the image centre the disc
    may reach — the preset's rim seen with this photo's focal length, ×:data:`MARGIN`, and every
    bright pixel — and how wide the preset's disc looks."""
    height, width = image.rgb.shape[:2]
    focal_px, _ = focal_px_for(image, preset)
    rim = _rim_extent(width, height, focal_px, preset)
    if rim is None:
        return width / 2.0, height / 2.0, float(max(width, height))
    hx, hy, diameter = rim
    centre_r, centre_c = (height - 1) / 2.0, (width - 1) / 2.0
    bright = _bright(image.rgb)
    if bright.any():
        r, c = np.nonzero(bright)
        hx = max(hx, float(np.max(np.abs(c - centre_c))) + BRIGHT_PAD_PX)
        hy = max(hy, float(np.max(np.abs(r - centre_r))) + BRIGHT_PAD_PX)
    return min(hx, width / 2.0), min(hy, height / 2.0), diameter


def _rim_extent(width: int, height: int, focal_px: float, preset: Preset) -> tuple[float, float, float] | None:
    """(x, y, diameter) of the preset's rim in an image ``width`` × ``height`` with this focal
    length: its reach from the image centre ×:data:`MARGIN`, and its width (None: not in view)."""
    camera = preset.camera
    posed = replace(preset, camera=replace(camera, image_size_px=(width, height),
                                           focal_length_mm=focal_px * camera.sensor_width_mm / width))
    scene = Scene(posed)
    angle = np.linspace(0.0, 2.0 * math.pi, RIM_POINTS, endpoint=False)
    rim = preset.disc.rim_radius_mm * 1e-3 * np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=1)
    rows, cols = scene.project(rim @ scene.disc_rotation.T + scene.disc_center).T
    centre_r, centre_c = (height - 1) / 2.0, (width - 1) / 2.0
    ok = np.isfinite(rows) & np.isfinite(cols)
    if not np.any(ok):
        return None
    diameter = float(max(np.ptp(cols[ok]), np.ptp(rows[ok])))
    return (MARGIN * float(np.max(np.abs(cols[ok] - centre_c))), MARGIN * float(np.max(np.abs(rows[ok] - centre_r))),
            diameter)


def _bright(rgb: NDArray[np.floating]) -> NDArray[np.bool_]:
    a = np.asarray(rgb, dtype=np.float32)
    lum = a[..., 0] + a[..., 1] + a[..., 2]  # = a.sum(axis=2), bit for bit, ~15× faster
    peak = float(lum.max())
    return lum > BRIGHT_SHARE * peak if peak > 0 else np.zeros(lum.shape, bool)


def _window(scale: float, hx: float, hy: float, diameter: float) -> tuple[int, tuple[float, float]] | None:
    """(max_side, centre_crop_px) of the window for a disc ``diameter`` wide in a preview read at
    ``scale``, reaching ``hx``, ``hy`` from its centre; None where the preview will do."""
    if diameter >= DISC_MIN_PX:
        return None
    window_scale = max(1.0, float(round(scale * diameter / DISC_TARGET_PX)))
    if window_scale >= scale:
        return None
    half = (hx * scale, hy * scale)
    return int(math.ceil(2.0 * max(half) / window_scale)), half


def reduction(diameter: float) -> int:
    """The reduction a whole-frame read of a disc ``diameter`` px wide gets (1: none): the largest
    power of two that leaves it at least :data:`DISC_READ_PX` wide."""
    k = 1
    while diameter >= 2 * k * DISC_READ_PX:
        k *= 2
    return k


def _guess_window(reader: PhotoReader, preset: Preset) -> None:
    """Start decoding the window the rim alone asks for while the preview decodes (a JPEG's
    preview and window are two draft scales, decoded side by side on two cores). Bright pixels
    beyond the rim may widen the window to another scale; the guess is then only wasted work."""
    layout = reader.layout(PREVIEW_SIDE)
    if layout is None:
        return
    width, height, scale, exif, shown = layout
    if scale <= 1.0:
        return
    focal_px, _ = focal_px_of(exif, width, scale, shown, preset)
    rim = _rim_extent(width, height, focal_px, preset)
    if rim is None:
        return
    hx, hy, diameter = rim
    window = _window(scale, min(hx, width / 2.0), min(hy, height / 2.0), diameter)
    if window is not None:
        reader.prefetch(*window)


def load_for_estimate(path: str | Path, preset: Preset) -> LinearImage:
    """The photo as the estimate reads it: the preview, the window around a small disc, or the
    preview reduced for a large one (see the module doc). One reader: a window at the preview's
    JPEG draft scale (or from any format that decodes whole) reuses the preview's decode, a
    JPEG's finer window is decoded alongside the preview where it can be foreseen, and only the
    image returned is judged for camera processing."""
    with PhotoReader(path) as reader:
        _guess_window(reader, preset)
        preview = reader.load(PREVIEW_SIDE, judge=False)
        _, _, diameter = extent = disc_half_extent(preview, preset)
        window = _window(preview.scale, *extent) if preview.scale > 1.0 else None
        if window is not None:
            return reader.load(window[0], centre_crop_px=window[1])
        return reader.judge(reduced(preview, reduction(diameter) if near_axis(preset) else 1))
