"""The disc's outline, where the photo shows it: a circle of known radius seen as an ellipse.

A lit disc (room light, a white card behind it, the diffuse base of its lacquer) stands out from
a dark surround as an ellipse. With the focal length from EXIF, a circle of radius R seen as an
ellipse of semi-axes a ≥ b fixes the camera's distance (≈ f·R/a), how far the disc is turned
from the line of sight (cos θ ≈ b/a) and about which image axis (the major one) — up to the sign
of the turn, so it gives two poses. The general-pose fit takes both as starts where an outline is
found and never needs one: under a small lamp in a dark room (and in this project's simulator)
the disc's base is far below the rainbow and no outline shows.

Found by moments, not edges: threshold between the surround and the disc (Otsu on the
luminance), take the mask's second moments as an ellipse, and accept it only if the mask fills
that ellipse (area within 15 %, ≥ 90 % of the mask inside it) — a rainbow alone, two thin streaks,
is far from elliptic and is rejected.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..photo.resample import box_downsample, channel_sum

WORK_SIDE = 256  # the outline is found on an image of about this size
MIN_SHARE = 0.02  # of the image the disc must cover
AREA_TOLERANCE = 0.15
MIN_INSIDE = 0.9
MIN_CONTRAST = 3.0  # disc level / surround level

__all__ = ["Ellipse", "disc_ellipse", "disc_base", "circle_poses"]


@dataclass(frozen=True)
class Ellipse:
    centre_px: tuple[float, float]  # (row, col) in the given image's pixels
    major_px: float  # semi-axes, major ≥ minor
    minor_px: float
    angle: float  # of the major axis, radians from the image's +x (columns) towards −y (up)


def _otsu(values: NDArray[np.float64]) -> float:
    hist, edges = np.histogram(values, bins=256)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(hist)
    w1 = w0[-1] - w0
    m0 = np.cumsum(hist * centres)
    mu0 = np.divide(m0, w0, out=np.zeros_like(m0, dtype=np.float64), where=w0 > 0)
    mu1 = np.divide(m0[-1] - m0, w1, out=np.zeros_like(m0, dtype=np.float64), where=w1 > 0)
    between = w0 * w1 * (mu0 - mu1) ** 2
    return float(centres[int(np.argmax(between))])


def disc_ellipse(rgb: NDArray[np.floating], saturated: NDArray[np.bool_] | None = None) -> Ellipse | None:
    """The disc's outline as an ellipse in ``rgb``'s pixels, or None where none shows."""
    height, width = rgb.shape[:2]
    factor = max(1, int(round(max(height, width) / WORK_SIDE)))
    lum = channel_sum(box_downsample(rgb, factor))
    if saturated is not None:
        sat = box_downsample(np.asarray(saturated, dtype=np.float64), factor) > 0
        lum = np.where(sat, np.nan, lum)
    finite = lum[np.isfinite(lum)]
    if finite.size < 64 or not float(np.max(finite)) > 0:
        return None
    # Clip the rainbow so its few bright pixels do not set the threshold between disc and surround.
    lum = np.minimum(np.nan_to_num(lum, nan=float(np.percentile(finite, 99))), float(np.percentile(finite, 99)))
    threshold = _otsu(lum.ravel())
    mask = lum > threshold
    share = float(np.mean(mask))
    if share < MIN_SHARE or share > 0.95:
        return None
    inside_level, outside_level = float(np.median(lum[mask])), float(np.median(lum[~mask]))
    if not inside_level > MIN_CONTRAST * max(outside_level, 1e-12):
        return None
    rows, cols = np.nonzero(mask)
    r0, c0 = rows.mean(), cols.mean()
    dr, dc = rows - r0, cols - c0
    cov = np.cov(np.stack([dc, -dr]))  # x right, y up
    evals, evecs = np.linalg.eigh(cov)
    if not evals[0] > 0:
        return None
    minor, major = 2.0 * math.sqrt(evals[0]), 2.0 * math.sqrt(evals[1])  # a uniform ellipse: σ² = a²/4
    angle = math.atan2(evecs[1, 1], evecs[0, 1])
    if abs(math.pi * major * minor - rows.size) > AREA_TOLERANCE * rows.size:
        return None
    u = (dc * math.cos(angle) - dr * math.sin(angle)) / major
    v = (dc * math.sin(angle) + dr * math.cos(angle)) / minor
    if float(np.mean(u * u + v * v <= 1.05)) < MIN_INSIDE:
        return None
    to_full = float(factor)
    return Ellipse(((r0 + 0.5) * to_full - 0.5, (c0 + 0.5) * to_full - 0.5), major * to_full, minor * to_full, angle)


def circle_poses(ellipse: Ellipse, radius_mm: float, focal_px: float, image_size: tuple[int, int]
                 ) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The two (centre, unit normal towards the camera) in the camera frame (mm) of a circle of
    ``radius_mm`` seen as ``ellipse`` (small-angle approximation: a start for the fit)."""
    width, height = image_size
    row, col = ellipse.centre_px
    ray = np.array([col + 0.5 - width / 2.0, height / 2.0 - (row + 0.5), -focal_px])
    ray /= np.linalg.norm(ray)
    distance = focal_px * radius_mm / ellipse.major_px
    centre = ray * distance
    tilt = math.acos(min(1.0, ellipse.minor_px / ellipse.major_px))
    axis = np.array([math.cos(ellipse.angle), math.sin(ellipse.angle), 0.0])  # the major axis: the turn's axis
    axis -= (axis @ ray) * ray
    axis /= np.linalg.norm(axis)
    facing = -ray
    out = []
    for sign in (1.0, -1.0):
        a = sign * tilt
        normal = facing * math.cos(a) + np.cross(axis, facing) * math.sin(a)  # Rodrigues, axis ⟂ facing
        out.append((centre, normal / np.linalg.norm(normal)))
    return out


def disc_base(rgb: NDArray[np.floating], ellipse: Ellipse, saturated: NDArray[np.bool_] | None = None
              ) -> NDArray[np.float64]:
    """Per-channel level of the lit disc itself (median inside 90 % of its outline: most of a disc
    is dark between the streaks), which the first-order model does not explain."""
    height, width = rgb.shape[:2]
    rows, cols = np.mgrid[0:height, 0:width]
    dr, dc = rows - ellipse.centre_px[0], cols - ellipse.centre_px[1]
    c, s = math.cos(ellipse.angle), math.sin(ellipse.angle)
    u = (dc * c - dr * s) / (0.9 * ellipse.major_px)
    v = (dc * s + dr * c) / (0.9 * ellipse.minor_px)
    inside = u * u + v * v <= 1.0
    if saturated is not None:
        inside &= ~np.asarray(saturated)
    if not np.any(inside):
        return np.zeros(3)
    return np.median(np.asarray(rgb, dtype=np.float64)[inside], axis=0)
