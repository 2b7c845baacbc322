"""Per-pixel diffraction coordinate: which wavelength each pixel's first order shows, and how
visible the lobe is there.

For a disc point with unit vectors ωi (to the lamp) and ωo (to the camera), the first order
lights up where |(ωi + ωo)·r̂| = λ/d, and only while the tangential part v = (ωi + ωo)·t̂ is
within the lobe width σ. So λ₁ = d·|u| is the feature coordinate that makes photos taken at
different distances, offsets and tilts comparable, and exp(−v²/2σ²) says which pixels carry
the spectrum at all (full rings for a coaxial lamp, two short streaks for a lamp beside the lens).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .capture import Scene

__all__ = ["PixelDiffraction", "pixel_diffraction"]


@dataclass(frozen=True)
class PixelDiffraction:
    """Arrays over the selected pixels (flattened)."""

    index: NDArray[np.int64]  # flat pixel index into the (H, W) image
    lambda1_nm: NDArray[np.float64]  # first-order wavelength d·|u|
    visibility: NDArray[np.float64]  # exp(−v² / 2σ²)
    radius_mm: NDArray[np.float64]  # distance from the disc centre on the disc
    on_tracks: NDArray[np.bool_]  # inside the grating annulus
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    points: NDArray[np.float64]  # world positions on the disc (metres)
    view: NDArray[np.float64]  # unit directions to the camera


def pixel_diffraction(scene: Scene, index: NDArray[np.int64] | None = None,
                      rows: NDArray[np.float64] | None = None,
                      cols: NDArray[np.float64] | None = None) -> PixelDiffraction:
    """λ₁ and lobe visibility at pixel centres (all pixels on the disc, or the given ones).

    ``rows``/``cols`` may give sub-pixel sample positions for the pixels in ``index``.
    """
    width, height = scene.preset.camera.image_size_px
    if index is None:
        index = np.arange(width * height, dtype=np.int64)
    index = np.asarray(index, dtype=np.int64)
    if rows is None or cols is None:
        rows = (index // width).astype(np.float64)
        cols = (index % width).astype(np.float64)
    if np.allclose(scene.disc_normal, (0.0, 0.0, 1.0), rtol=0, atol=1e-15):
        return _untilted(scene, index, rows, cols)
    dirs = scene.pixel_rays(rows, cols)
    points, hit = scene.intersect_disc(dirs)
    keep = np.flatnonzero(hit)
    index, dirs, points = index[keep], dirs[keep], points[keep]
    n = scene.disc_normal
    rel = points - scene.disc_center
    radial = rel - (rel @ n)[:, None] * n
    radius = np.linalg.norm(radial, axis=1)
    r_hat = radial / np.maximum(radius, 1e-12)[:, None]
    t_hat = np.cross(n, r_hat)
    to_light = scene.light_position - points
    wi = to_light / np.linalg.norm(to_light, axis=1, keepdims=True)
    wo = -dirs
    h = wi + wo
    u = np.einsum("ij,ij->i", h, r_hat)
    v = np.einsum("ij,ij->i", h, t_hat)
    return _finish(scene, index, u, v, radius, points, wo)


def _untilted(scene: Scene, index: NDArray[np.int64], rows: NDArray[np.float64],
              cols: NDArray[np.float64]) -> PixelDiffraction:
    """Disc in the z = 0 plane, camera looking down: rays meet the disc at an affine map of
    the pixel position, so everything reduces to 2-D arithmetic (~10× faster; the pose fit
    evaluates this hundreds of times)."""
    cam = scene.preset.camera
    width, height = cam.image_size_px
    f = cam.focal_px
    cx, cy, cz = scene.camera_position
    x = cols + 0.5 - width / 2.0
    y = height / 2.0 - (rows + 0.5)
    px = cx + x * (cz / f)
    py = cy + y * (cz / f)
    radius = np.hypot(px, py)
    disc = scene.preset.disc
    hit = (radius >= disc.hole_radius_mm * 1e-3) & (radius <= disc.rim_radius_mm * 1e-3) & (cz > 0)
    keep = np.flatnonzero(hit)
    index, x, y, px, py, radius = index[keep], x[keep], y[keep], px[keep], py[keep], radius[keep]
    inv = 1.0 / np.sqrt(x * x + y * y + f * f)
    wo = np.stack([-x * inv, -y * inv, f * inv], axis=1)
    lx, ly, lz = scene.light_position
    dx, dy = lx - px, ly - py
    inv_l = 1.0 / np.sqrt(dx * dx + dy * dy + lz * lz)
    hx = dx * inv_l + wo[:, 0]
    hy = dy * inv_l + wo[:, 1]
    rx, ry = px / radius, py / radius
    u = hx * rx + hy * ry
    v = hy * rx - hx * ry  # t̂ = n × r̂ = (−r̂y, r̂x)
    points = np.stack([px, py, np.zeros_like(px)], axis=1)
    return _finish(scene, index, u, v, radius, points, wo)


def _finish(scene: Scene, index: NDArray[np.int64], u: NDArray[np.float64], v: NDArray[np.float64],
            radius: NDArray[np.float64], points: NDArray[np.float64], view: NDArray[np.float64]
            ) -> PixelDiffraction:
    sigma = scene.preset.light.lobe_sigma
    disc = scene.preset.disc
    radius_mm = radius * 1e3
    return PixelDiffraction(
        index=index,
        lambda1_nm=np.abs(u) * disc.pitch_um * 1e3,
        visibility=np.exp(-(v * v) / (2.0 * sigma * sigma)),
        radius_mm=radius_mm,
        on_tracks=(radius_mm >= disc.grating_r_min_mm) & (radius_mm <= disc.grating_r_max_mm),
        u=u,
        v=v,
        points=points,
        view=view,
    )
