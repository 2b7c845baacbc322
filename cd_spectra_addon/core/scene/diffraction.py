"""Per-pixel diffraction coordinate of a :class:`~.capture.Scene`: which wavelength each pixel's
first order shows, and how visible the lobe is there (the geometry is :mod:`.kernel`'s).

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
from .kernel import diffraction_along

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

    ``rows``/``cols`` may give sub-pixel sample positions for the pixels in ``index``. The
    geometry is :func:`.kernel.diffraction_along` in the world frame; only pixels whose ray meets
    the disc annulus are kept.
    """
    width, height = scene.preset.camera.image_size_px
    if index is None:
        index = np.arange(width * height, dtype=np.int64)
    index = np.asarray(index, dtype=np.int64)
    if rows is None or cols is None:
        rows, cols = np.divmod(index, width)
    dirs = scene.pixel_rays(rows, cols)
    hit, geo = diffraction_along(dirs, scene.camera_position, scene.disc_center, scene.disc_normal,
                                 scene.light_position)
    disc = scene.preset.disc
    radius_mm = geo.radius * 1e3
    on_disc = (radius_mm >= disc.hole_radius_mm) & (radius_mm <= disc.rim_radius_mm)
    keep = np.flatnonzero(on_disc)
    sigma = scene.preset.light.lobe_sigma
    u, v = geo.u[keep], geo.v[keep]
    return PixelDiffraction(
        index=index[np.flatnonzero(hit)[keep]],
        lambda1_nm=np.abs(u) * disc.pitch_um * 1e3,
        visibility=np.exp(-(v * v) / (2.0 * sigma * sigma)),
        gain=geo.gain[keep],
        radius_mm=radius_mm[keep],
        on_tracks=(radius_mm[keep] >= disc.grating_r_min_mm) & (radius_mm[keep] <= disc.grating_r_max_mm),
        u=u,
        v=v,
        points=geo.points[keep],
        view=geo.view[keep],
    )
