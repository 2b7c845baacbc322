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

from . import grating
from .capture import Scene

__all__ = ["PixelDiffraction", "pixel_diffraction"]


@dataclass(frozen=True)
class PixelDiffraction:
    """Arrays over the selected pixels (flattened)."""

    index: NDArray[np.int64]  # flat pixel index into the (H, W) image
    lambda1_nm: NDArray[np.float64]  # first-order wavelength d·|u|
    visibility: NDArray[np.float64]  # exp(−v² / 2σ²)
    gain: NDArray[np.float64]  # irradiance · G/w² relative to the lamp's irradiance at the disc centre
    radius_mm: NDArray[np.float64]  # distance from the disc centre on the disc
    on_tracks: NDArray[np.bool_]  # inside the grating annulus
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    points: NDArray[np.float64]  # world positions on the disc (metres)
    view: NDArray[np.float64]  # unit directions to the camera

    @property
    def amplitude(self) -> NDArray[np.float64]:
        """What a unit of λ₁-profile becomes at this pixel: visibility × geometric gain."""
        return self.visibility * self.gain


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
    if scene.looks_straight_down and np.allclose(scene.disc_normal, (0.0, 0.0, 1.0), rtol=0, atol=1e-15):
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
    dist2 = np.einsum("ij,ij->i", to_light, to_light)
    wi = to_light / np.sqrt(dist2)[:, None]
    wo = -dirs
    h = wi + wo
    u = np.einsum("ij,ij->i", h, r_hat)
    v = np.einsum("ij,ij->i", h, t_hat)
    gain = _gain(scene, wi @ n, wo @ n, np.einsum("ij,ij->i", wi, wo), dist2)
    return _finish(scene, index, u, v, radius, points, wo, gain)


def _gain(scene: Scene, cos_i: NDArray[np.float64], cos_o: NDArray[np.float64], dot_io: NDArray[np.float64],
          dist2: NDArray[np.float64]) -> NDArray[np.float64]:
    """The BRDF's slowly varying geometric factor, irradiance × Stam's G/w² (as in
    grating.surface_frame), relative to its value where the lamp's axis meets the disc: pixels
    that share λ₁ then share A in I = A·visibility·gain wherever they are on the disc."""
    ci = np.clip(cos_i, grating.COS_EPS, 1.0)
    co = np.clip(cos_o, grating.COS_EPS, 1.0)
    w = ci + co
    g = (1.0 + dot_io) ** 2 / (ci * co * w * w)
    ref = float(np.sum((scene.light_position - scene.disc_center) ** 2))
    return np.where((cos_i > 0) & (cos_o > 0), g * ci * ref / dist2, 0.0)


def _untilted(scene: Scene, index: NDArray[np.int64], rows: NDArray[np.float64],
              cols: NDArray[np.float64]) -> PixelDiffraction:
    """Disc in the z = 0 plane, camera looking straight down (the on-axis camera model): rays meet the disc at an affine map of
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
    dist2 = dx * dx + dy * dy + lz * lz
    inv_l = 1.0 / np.sqrt(dist2)
    hx = dx * inv_l + wo[:, 0]
    hy = dy * inv_l + wo[:, 1]
    rx, ry = px / radius, py / radius
    u = hx * rx + hy * ry
    v = hy * rx - hx * ry  # t̂ = n × r̂ = (−r̂y, r̂x)
    points = np.stack([px, py, np.zeros_like(px)], axis=1)
    dot_io = (dx * wo[:, 0] + dy * wo[:, 1] + lz * wo[:, 2]) * inv_l
    gain = _gain(scene, lz * inv_l, wo[:, 2], dot_io, dist2)
    return _finish(scene, index, u, v, radius, points, wo, gain)


def _finish(scene: Scene, index: NDArray[np.int64], u: NDArray[np.float64], v: NDArray[np.float64],
            radius: NDArray[np.float64], points: NDArray[np.float64], view: NDArray[np.float64],
            gain: NDArray[np.float64]) -> PixelDiffraction:
    sigma = scene.preset.light.lobe_sigma
    disc = scene.preset.disc
    radius_mm = radius * 1e3
    return PixelDiffraction(
        index=index,
        lambda1_nm=np.abs(u) * disc.pitch_um * 1e3,
        visibility=np.exp(-(v * v) / (2.0 * sigma * sigma)),
        gain=gain,
        radius_mm=radius_mm,
        on_tracks=(radius_mm >= disc.grating_r_min_mm) & (radius_mm <= disc.grating_r_max_mm),
        u=u,
        v=v,
        points=points,
        view=view,
    )
