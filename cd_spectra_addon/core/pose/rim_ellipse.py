"""The disc's outline, where the photo shows it: a circle of known radius seen as an ellipse.

A lit disc (room light, a white card behind it, the diffuse base of its lacquer) stands out from
a dark surround as an ellipse. With the focal length from EXIF, a circle of radius R seen as an
ellipse of semi-axes a ≥ b fixes the camera's distance (≈ f·R/a), how far the disc is turned
from the line of sight (cos θ ≈ b/a) and about which image axis (the major one) — up to the sign
of the turn, so it gives two poses (:func:`circle_poses` solves them exactly: near and oblique,
those rules of thumb are degrees and millimetres off). The general-pose fit takes both as starts where an outline is
found and never needs one: under a small lamp in a dark room (and in this project's simulator)
the disc's base is far below the rainbow and no outline shows.

A lit disc is found by moments, not edges: threshold between the surround and the disc (Otsu on
the luminance), take the mask's second moments as an ellipse, and accept it only if the mask
fills that ellipse (area within 15 %, ≥ 90 % of the mask inside it) — a rainbow alone, two thin
streaks, is far from elliptic and is rejected. A dark disc on a lit surround (Kim's real photos:
a breadboard lit around the disc, the far side dark) has no such mask; its outline is found from
edges (:mod:`.edge_outline`) where the lit one is not.

Without EXIF the focal length is unknown; a circle of known radius at a known distance fixes it
(:func:`focal_px_from_outline`, the exact projection of the circle, wherever it is in the frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..photo.resample import box_downsample, box_factor, channel_sum
from .edge_outline import conic_ellipse, dark_disc_outline

WORK_SIDE = 256  # the outline is found on an image of about this size
MIN_SHARE = 0.02  # of the image the disc must cover
AREA_TOLERANCE = 0.15
MIN_INSIDE = 0.9
MIN_CONTRAST = 3.0  # disc level / surround level

__all__ = ["Ellipse", "disc_ellipse", "disc_base", "circle_poses", "project_circle", "outline_mismatch", "circle_distance_mm",
           "focal_px_from_outline"]


@dataclass(frozen=True)
class Ellipse:
    centre_px: tuple[float, float]  # (row, col) in the given image's pixels
    major_px: float  # semi-axes, major ≥ minor
    minor_px: float
    angle: float  # of the major axis, radians from the image's +x (columns) towards −y (up)
    lit: bool = True  # the disc brighter than its surround (a mask's moments), else darker (edges)
    image_size: tuple[int, int] | None = None  # (width, height) of the image it was found in

    def inside(self, rows: NDArray[np.floating], cols: NDArray[np.floating], scale: float = 1.0) -> NDArray[np.bool_]:
        """Which (row, col) positions lie inside the outline with its semi-axes times ``scale``."""
        dr, dc = np.asarray(rows) - self.centre_px[0], np.asarray(cols) - self.centre_px[1]
        c, s = math.cos(self.angle), math.sin(self.angle)
        u = (dc * c - dr * s) / (scale * self.major_px)
        v = (dc * s + dr * c) / (scale * self.minor_px)
        return u * u + v * v <= 1.0


def _otsu(values: NDArray[np.float64]) -> float:
    lo, hi = float(np.min(values)), float(np.max(values))
    if hi - lo < 1024.0 * np.spacing(max(abs(lo), abs(hi), np.finfo(np.float64).tiny)):
        # too narrow a range for 256 distinct bin edges (numpy raises: a photo of subnormal
        # values, found by hypothesis): nothing to split
        return lo
    hist, edges = np.histogram(values, bins=256)
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(hist)
    w1 = w0[-1] - w0
    m0 = np.cumsum(hist * centres)
    mu0 = np.divide(m0, w0, out=np.zeros_like(m0, dtype=np.float64), where=w0 > 0)
    mu1 = np.divide(m0[-1] - m0, w1, out=np.zeros_like(m0, dtype=np.float64), where=w1 > 0)
    between = w0 * w1 * (mu0 - mu1) ** 2
    return float(centres[int(np.argmax(between))])


def disc_ellipse(rgb: NDArray[np.floating], saturated: NDArray[np.bool_] | None = None,
                 dark: bool = True) -> Ellipse | None:
    """The disc's outline as an ellipse in ``rgb``'s pixels, or None where none shows: a lit disc
    on a dark surround, else (``dark``) a dark disc on a lit one."""
    height, width = rgb.shape[:2]
    factor = box_factor(max(height, width), WORK_SIDE)
    small = box_downsample(rgb, factor)
    lum = channel_sum(small)
    if saturated is not None:
        sat = box_downsample(np.asarray(saturated, dtype=np.float64), factor) > 0
        lum = np.where(sat, np.nan, lum)
    finite = lum[np.isfinite(lum)]
    if finite.size < 64 or not float(np.max(finite)) > 0:
        return None
    found = _lit_disc(lum, finite)
    if found is None and dark:
        found = _dark_disc(small, lum, finite)
    if found is None:
        return None
    to_full = float(factor)
    return replace(found, centre_px=((found.centre_px[0] + 0.5) * to_full - 0.5,
                                     (found.centre_px[1] + 0.5) * to_full - 0.5),
                   major_px=found.major_px * to_full, minor_px=found.minor_px * to_full, image_size=(width, height))


def _dark_disc(small: NDArray[np.float64], lum: NDArray[np.float64], finite: NDArray[np.float64]) -> Ellipse | None:
    """A dark disc on a lit surround (work pixels), saturated pixels read as the photo's 99th
    percentile (a glint on the disc is no edge of it)."""
    fill = float(np.percentile(finite, 99))
    rgb = np.where(np.isfinite(lum)[..., None], small, fill / 3.0)
    found = dark_disc_outline(rgb)
    if found is None:
        return None
    return Ellipse(found.centre, found.major, found.minor, found.angle, lit=False)


def _lit_disc(lum: NDArray[np.float64], finite: NDArray[np.float64]) -> Ellipse | None:
    """A lit disc on a dark surround, by the moments of the bright mask (work pixels)."""
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
    return Ellipse((float(r0), float(c0)), major, minor, angle)


def circle_poses(ellipse: Ellipse, radius_mm: float, focal_px: float, image_size: tuple[int, int]
                 ) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
    """The two (centre, unit normal towards the camera) in the camera frame (mm) of a circle of
    ``radius_mm`` seen as ``ellipse``: the exact back-projection (:func:`_circular_sections`).
    Why not the ellipse's centre, f·R/a and cos θ = b/a: near and oblique, perspective moves the
    image of the circle's centre off the ellipse's and stretches its near side. A phone 125 mm
    from a disc turned 39° had that start's centre 15 mm and its normal 3.5° off, and no strategy
    found the rainbow from there (pose_errors' distant-lamp lit table, capture 12)."""
    out = []
    for normal, middle, radius in _circular_sections(ellipse, focal_px, image_size):
        centre = middle * (radius_mm / radius)
        out.append((centre, normal if normal @ centre < 0 else -normal))
    return out


def disc_base(rgb: NDArray[np.floating], ellipse: Ellipse, saturated: NDArray[np.bool_] | None = None
              ) -> NDArray[np.float64]:
    """Per-channel level of the lit disc itself (median inside 90 % of its outline: most of a disc
    is dark between the streaks), which the first-order model does not explain."""
    height, width = rgb.shape[:2]
    rows, cols = np.mgrid[0:height, 0:width]
    inside = ellipse.inside(rows, cols, 0.9)
    if saturated is not None:
        inside &= ~np.asarray(saturated)
    if not np.any(inside):
        return np.zeros(3)
    return np.median(np.asarray(rgb, dtype=np.float64)[inside], axis=0)


# --- the exact projection of a circle, and the focal length it gives -------------------------


def _ray(row: float, col: float, focal_px: float, image_size: tuple[int, int]) -> NDArray[np.float64]:
    width, height = image_size
    return np.array([col + 0.5 - width / 2.0, height / 2.0 - (row + 0.5), -focal_px])


def project_circle(centre_mm: NDArray[np.floating], normal: NDArray[np.floating], radius_mm: float, focal_px: float,
                   image_size: tuple[int, int]) -> Ellipse:
    """The ellipse a circle (centre and normal in the camera frame: x right, y up, the camera
    looking along −z) makes in a centred pinhole image of ``image_size`` (width, height)."""
    normal = np.asarray(normal, dtype=np.float64) / np.linalg.norm(normal)
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.linspace(0.0, 2.0 * math.pi, 24, endpoint=False)
    points = np.asarray(centre_mm, dtype=np.float64) + radius_mm * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))
    if not np.all(points[:, 2] < 0):
        raise ValueError("the circle is not wholly in front of the camera")
    x, y = focal_px * points[:, 0] / -points[:, 2], focal_px * points[:, 1] / -points[:, 2]
    _, _, vt = np.linalg.svd(np.stack([x * x, x * y, y * y, x, y, np.ones_like(x)], axis=1))
    shape = conic_ellipse(vt[-1])  # x right, y up: its angle turns towards up, as Ellipse's does
    if shape is None:
        raise ValueError("the circle does not project to an ellipse")
    x0, y0, major, minor, angle = shape
    width, height = image_size
    return Ellipse((height / 2.0 - y0 - 0.5, x0 + width / 2.0 - 0.5), major, minor, angle % math.pi,
                   image_size=image_size)


def outline_mismatch(found: Ellipse, drawn: Ellipse) -> NDArray[np.float64]:
    """How far a capture's rim (``drawn``, :func:`project_circle`) is from the outline the photo
    shows (``found``): the centres' offset over the found major semi-axis (row, col), and the
    ellipticities' difference, each a vector (1 − minor/major) at twice its major axis's angle —
    continuous where a near-circle's axis angle is not. Free of the drawn disc's size: the fit
    keeps the preset's distance, and a photo taken nearer is no other pose."""

    def ellipticity(e: Ellipse) -> NDArray[np.float64]:
        k = 1.0 - e.minor_px / e.major_px
        return np.array([k * math.cos(2.0 * e.angle), k * math.sin(2.0 * e.angle)])

    offset = (np.array(drawn.centre_px) - np.array(found.centre_px)) / found.major_px
    return np.concatenate([offset, ellipticity(drawn) - ellipticity(found)])


def _image_conic(ellipse: Ellipse, image_size: tuple[int, int]) -> NDArray[np.float64]:
    """3×3 conic of the ellipse in centred image coordinates (x right, y up, pixels)."""
    x0, y0, _ = _ray(*ellipse.centre_px, 0.0, image_size)
    c, s = math.cos(ellipse.angle), math.sin(ellipse.angle)
    rot = np.array([[c, s], [-s, c]])  # image → ellipse axes
    quad = rot.T @ np.diag([ellipse.major_px ** -2, ellipse.minor_px ** -2]) @ rot
    centre = np.array([x0, y0])
    out = np.empty((3, 3))
    out[:2, :2] = quad
    out[:2, 2] = out[2, :2] = -quad @ centre
    out[2, 2] = centre @ quad @ centre - 1.0
    return out


def _circular_sections(ellipse: Ellipse, focal_px: float, image_size: tuple[int, int] | None,
                       signs: tuple[float, ...] = (1.0, -1.0)
                       ) -> list[tuple[NDArray[np.float64], NDArray[np.float64], float]]:
    """The two circles the cone of rays through ``ellipse`` holds (Safaee-Rad et al. 1992): each
    plane's unit normal, and the centre and radius of its section, in front of the camera, at a
    scale of the plane's choosing (similar triangles: times R / radius for a circle of radius R).
    ``signs`` picks them (both are equally far: a distance needs one)."""
    size = image_size or ellipse.image_size
    if size is None:
        raise ValueError("the image size is needed: where the lens's axis meets the image")
    k = np.diag([focal_px, focal_px, -1.0])  # camera point (x, y, z) → homogeneous image point
    cone = k @ _image_conic(ellipse, size) @ k
    evals, evecs = np.linalg.eigh(cone)
    if np.sum(evals > 0) == 1:
        evals, evecs = -evals[::-1], evecs[:, ::-1]  # two positive, one negative
    l3, l2, l1 = evals  # ascending: l3 < 0 < l2 ≤ l1
    if not (l3 < 0 < l2):
        raise ValueError("the outline is not the image of a circle in front of the camera")
    t = np.linspace(0.0, 2.0 * math.pi, 36, endpoint=False)
    c, s = math.cos(ellipse.angle), math.sin(ellipse.angle)
    x0, y0, _ = _ray(*ellipse.centre_px, 0.0, size)
    px = x0 + ellipse.major_px * np.cos(t) * c - ellipse.minor_px * np.sin(t) * s
    py = y0 + ellipse.major_px * np.cos(t) * s + ellipse.minor_px * np.sin(t) * c
    rays = np.stack([px, py, np.full_like(px, -focal_px)], axis=1)
    out = []
    # a circular section's normal, in the cone's eigenbasis (e1, e2, e3) = columns (2, 1, 0)
    for sign in signs:
        normal = sign * evecs[:, 2] * math.sqrt((l1 - l2) / (l1 - l3)) + evecs[:, 0] * math.sqrt((l2 - l3) / (l1 - l3))
        normal /= np.linalg.norm(normal)
        along = rays @ normal
        if np.any(along == 0) or np.any(np.sign(along) != np.sign(along[0])):
            raise ValueError("the outline's cone has no circular section in front of the camera")
        points = rays / np.abs(along)[:, None]  # the rays cut by the plane normal·p = ±1, in front
        centre = points.mean(axis=0)  # not the circle's centre: the rays are spaced evenly in the image
        radius, _, middle = _circle_in_plane(points, normal, centre)
        if radius > 0:
            out.append((normal, middle, radius))
    return out


def circle_distance_mm(ellipse: Ellipse, radius_mm: float, focal_px: float,
                       image_size: tuple[int, int] | None = None) -> float:
    """Distance from the camera to the centre of a circle of ``radius_mm`` seen as ``ellipse``
    with ``focal_px``: the exact back-projection (the circular sections of the ellipse's cone,
    Safaee-Rad et al. 1992), not f·R/a. Both of the two circles the cone holds are this far."""
    sections = _circular_sections(ellipse, focal_px, image_size, signs=(1.0,))
    if not sections:
        return math.nan
    _, middle, radius = sections[0]
    return float(np.linalg.norm(middle) * radius_mm / radius)


def _circle_in_plane(points: NDArray[np.float64], normal: NDArray[np.float64], origin: NDArray[np.float64]
                     ) -> tuple[float, float, NDArray[np.float64]]:
    """(radius, rms misfit, centre) of the circle through points of a plane (Kåsa's fit)."""
    n = normal / np.linalg.norm(normal)
    u = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(n, u)
    d = points - origin
    x, y = d @ u, d @ v
    sol, *_ = np.linalg.lstsq(np.stack([x, y, np.ones_like(x)], axis=1), x * x + y * y, rcond=None)
    cx, cy = sol[0] / 2.0, sol[1] / 2.0
    radius = math.sqrt(max(sol[2] + cx * cx + cy * cy, 0.0))
    misfit = float(np.sqrt(np.mean((np.hypot(x - cx, y - cy) - radius) ** 2)))
    return radius, misfit, origin + cx * u + cy * v


def focal_px_from_outline(ellipse: Ellipse, rim_radius_mm: float, distance_mm: float,
                          image_size: tuple[int, int] | None = None) -> float:
    """The focal length (pixels of the image the ellipse was found in) at which a circle of
    ``rim_radius_mm`` whose centre is ``distance_mm`` from the camera looks like ``ellipse``
    — for a photo without EXIF, with the distance from the capture's preset. About
    a·D/R; solved exactly (:func:`circle_distance_mm` grows with the focal length), so a disc
    off the image centre, as in a cropped photo, is no error. ``image_size`` (width, height)
    defaults to the ellipse's own: the lens's axis is taken to meet the image at its centre."""
    if not (rim_radius_mm > 0 and distance_mm > rim_radius_mm and ellipse.major_px > 0 and ellipse.minor_px > 0):
        raise ValueError("need a positive radius, a distance beyond it and a real ellipse")
    size = image_size or ellipse.image_size
    guess = ellipse.major_px * distance_mm / rim_radius_mm
    lo, hi = math.log(guess / 20.0), math.log(guess * 20.0)

    def excess(log_f: float) -> float:
        return circle_distance_mm(ellipse, rim_radius_mm, math.exp(log_f), size) - distance_mm

    if not (excess(lo) < 0 < excess(hi)):
        raise ValueError("no focal length puts a circle of that radius at that distance")
    for _ in range(80):  # bisection in log f: ~1e-12 relative
        mid = 0.5 * (lo + hi)
        if excess(mid) < 0:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))
