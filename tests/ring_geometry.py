"""Independent grating-equation predictions for the tests (plain vector maths, no product code)."""

from __future__ import annotations

import math

import numpy as np


def coaxial_first_order_radius_px(lam_nm: float, pitch_um: float, focal_px: float) -> float:
    """Light and camera together on the axis: 2 sin θ = λ/d, image radius = f tan θ."""
    theta = math.asin(lam_nm / (2.0 * pitch_um * 1e3))
    return focal_px * math.tan(theta)


def first_order_radius_mm_on_x_axis(
    lam_nm: float, pitch_um: float, camera_mm: np.ndarray, light_mm: np.ndarray, side: float, m: int = -1
) -> float:
    """Radius r (mm) of the point (side·r, 0, 0) where (ωi + ωo)·r̂ = mλ/d (order m = ±1; −1 is
    the inward-pointing order a coaxial lamp makes), by bisection.

    For lamp and camera in the xz-plane the tangential component vanishes on the x axis, so
    the grating equation alone fixes the bright point of the first order there."""
    target = lam_nm / (pitch_um * 1e3)

    def excess(r: float) -> float:
        p = np.array([side * r, 0.0, 0.0])
        wi = (light_mm - p) / np.linalg.norm(light_mm - p)
        wo = (camera_mm - p) / np.linalg.norm(camera_mm - p)
        return m * np.dot(wi + wo, np.array([side, 0.0, 0.0])) - target

    lo, hi = 1.0, 59.0
    if excess(lo) * excess(hi) > 0:
        raise ValueError("no first-order crossing on the disc")
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if excess(lo) * excess(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def radial_peak_px(image: np.ndarray, center_rc: tuple[float, float], r_min: float, r_max: float,
                   step: float = 0.25) -> float:
    """Radius of the brightest ring between r_min and r_max (azimuthal mean, parabolic refine)."""
    rows, cols = np.indices(image.shape)
    radius = np.hypot(rows - center_rc[0], cols - center_rc[1])
    edges = np.arange(r_min, r_max + step, step)
    idx = np.digitize(radius.ravel(), edges) - 1
    ok = (idx >= 0) & (idx < edges.size - 1)
    sums = np.bincount(idx[ok], weights=image.ravel()[ok], minlength=edges.size - 1)
    counts = np.bincount(idx[ok], minlength=edges.size - 1)
    profile = sums / np.maximum(counts, 1)
    return _parabolic_peak(profile, edges[:-1] + step / 2, step)


def line_peak_px(image: np.ndarray, start_rc: np.ndarray, direction_rc: np.ndarray, t_min: float,
                 t_max: float, step: float = 0.1) -> float:
    """Distance along a line (pixels) of the brightest point, by bilinear sampling."""
    t = np.arange(t_min, t_max, step)
    pts = start_rc[None, :] + t[:, None] * direction_rc[None, :]
    r0 = np.floor(pts[:, 0]).astype(int)
    c0 = np.floor(pts[:, 1]).astype(int)
    fr, fc = pts[:, 0] - r0, pts[:, 1] - c0
    values = (image[r0, c0] * (1 - fr) * (1 - fc) + image[r0 + 1, c0] * fr * (1 - fc)
              + image[r0, c0 + 1] * (1 - fr) * fc + image[r0 + 1, c0 + 1] * fr * fc)
    return _parabolic_peak(values, t, step)


def _parabolic_peak(values: np.ndarray, positions: np.ndarray, step: float) -> float:
    k = int(np.argmax(values))
    if 0 < k < values.size - 1:
        a, b, c = values[k - 1], values[k], values[k + 1]
        denom = a - 2 * b + c
        if denom < 0:
            return float(positions[k] + 0.5 * (a - c) / denom * step)
    return float(positions[k])
