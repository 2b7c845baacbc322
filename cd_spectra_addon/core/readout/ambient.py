"""Room light and black level: a per-channel offset under the whole photo, measured and removed.

Ambient light and a camera's black level add roughly the same amount to every pixel. The
first-order model I = A(λ₁)·amplitude has no constant term, so an offset both confuses the pose
fit (its energy sits everywhere, also where the geometry predicts darkness) and leaks into every
λ₁ bin as a flat, colour-tinted floor in the spectrum. It is measured where the disc can show no
diffracted light: on the tracks where the lobe is invisible (|v| ≫ σ, no order of any kind
reaches the lens), else on the clear hub between the hole and the tracks.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import Scene
from ..scene.diffraction import PixelDiffraction, pixel_diffraction

# Offsets below this share of full scale are left alone: an 8-bit photo's dark noise floor
# (1 % noise → read noise 0.002) and its quantisation are about this size, and a nominal photo
# must come out exactly as before.
MIN_OFFSET = 0.003
ROUGH_PERCENTILE = 10.0  # before the pose is known: a low percentile of the whole photo
MIN_DARK_PIXELS = 200
INVISIBLE = 1e-4  # lobe visibility below which a pixel carries no diffracted light

__all__ = ["MIN_OFFSET", "rough_offset", "dark_offset"]


def _significant(offset: NDArray[np.float64]) -> NDArray[np.float64]:
    offset = np.clip(np.nan_to_num(offset, nan=0.0), 0.0, None)
    return offset if float(np.max(offset)) >= MIN_OFFSET else np.zeros(3)


def rough_offset(rgb: NDArray[np.float64], excluded: NDArray[np.bool_] | None = None) -> NDArray[np.float64]:
    """Per-channel offset from the darkest tenth of the photo (for the pose fit, before the
    geometry is known; it underestimates a uniform offset slightly, never overstates it)."""
    flat = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    if excluded is not None:
        flat = flat[~np.asarray(excluded).reshape(-1)]
    if flat.shape[0] == 0:
        return np.zeros(3)
    return _significant(np.percentile(flat, ROUGH_PERCENTILE, axis=0))


def dark_offset(rgb: NDArray[np.float64], scene: Scene, excluded: NDArray[np.bool_] | None = None,
                pixels: PixelDiffraction | None = None) -> NDArray[np.float64]:
    """Per-channel median of the disc pixels the fitted geometry says are dark (zero if too few
    such pixels or the offset is insignificant). ``pixels``: the scene's diffraction coordinates
    of all its disc pixels, where the caller has them."""
    px = pixel_diffraction(scene) if pixels is None else pixels
    flat = np.asarray(rgb, dtype=np.float64).reshape(-1, 3)
    ok = np.ones(px.index.size, dtype=bool) if excluded is None else ~np.asarray(excluded).reshape(-1)[px.index]
    glint = np.hypot(px.u, px.v) < 0.05  # well clear of the mirror glint and its halo
    dark = ok & ~glint & px.on_tracks & (px.visibility < INVISIBLE)
    if int(np.sum(dark)) < MIN_DARK_PIXELS:
        disc = scene.preset.disc
        dark = ok & ~glint & (px.radius_mm < disc.grating_r_min_mm - 1.0)
    if int(np.sum(dark)) < MIN_DARK_PIXELS:
        return np.zeros(3)
    return _significant(np.median(flat[px.index[dark]], axis=0))
