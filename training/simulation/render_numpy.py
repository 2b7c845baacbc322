"""numpy twin of the Cycles basis render: the per-band radiance cube of a posed capture.

Same BRDF as the OSL shader (:mod:`cd_spectra_addon.core.scene.grating`), same pinhole camera and
box pixel filter; anti-aliasing by a stratified ``ss × ss`` grid per pixel instead of Cycles'
random samples. The diffracted orders are sparse in λ (a pixel sees a lobe a few nm wide), so
each sample only touches the bands near its lobe centre — ~50× less work than dense bands.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.scene import grating
from cd_spectra_addon.core.scene.capture import Scene
from cd_spectra_addon.core.spectra.grid import WAVELENGTH_STEP_NM, WAVELENGTHS_NM, hat_integrals

__all__ = ["render_cube"]


def render_cube(
    scene: Scene,
    supersample: int = 4,
    wavelengths_nm: NDArray[np.float64] = WAVELENGTHS_NM,
    rows_per_chunk: int = 32,
) -> NDArray[np.float32]:
    """Radiance cube (bands, height, width), float32, box-filtered over each pixel."""
    preset = scene.preset
    width, height = preset.camera.image_size_px
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    step = WAVELENGTH_STEP_NM
    if lam.size > 1 and not np.allclose(np.diff(lam), step):
        raise ValueError("render_cube needs bands on a regular 5 nm grid")
    n_bands = lam.size
    areas = hat_integrals(lam)
    optics = grating.GratingOptics(preset.disc, preset.light.lobe_sigma)
    cube = np.zeros((n_bands, height * width), dtype=np.float64)
    offsets = (np.arange(supersample) + 0.5) / supersample - 0.5
    sub_r, sub_c = np.meshgrid(offsets, offsets, indexing="ij")
    sub_r, sub_c = sub_r.ravel(), sub_c.ravel()
    n_sub = sub_r.size

    for row0 in range(0, height, rows_per_chunk):
        rows = np.arange(row0, min(row0 + rows_per_chunk, height))
        rr, cc = np.meshgrid(rows, np.arange(width), indexing="ij")
        pix = ((rr - row0) * width + cc).ravel()  # index within this chunk
        sample_r = (rr.ravel()[:, None] + sub_r[None, :]).ravel()
        sample_c = (cc.ravel()[:, None] + sub_c[None, :]).ravel()
        sample_pix = np.repeat(pix, n_sub)
        dirs = scene.pixel_rays(sample_r, sample_c)
        points, hit = scene.intersect_disc(dirs)
        if not np.any(hit):
            continue
        points, dirs, sample_pix = points[hit], dirs[hit], sample_pix[hit]
        frame = grating.surface_frame(
            points,
            scene.camera_position,
            scene.light_position,
            scene.disc_center,
            scene.disc_normal,
            preset.disc.medium_index,
            preset.light.intensity,
            view_directions=-dirs,
        )
        first, last = row0 * width, (rows[-1] + 1) * width
        chunk = np.zeros((n_bands, last - first))
        _accumulate(chunk, frame, optics, sample_pix, lam, areas, n_sub)
        cube[:, first:last] = chunk
    return cube.reshape(n_bands, height, width).astype(np.float32)


def _accumulate(
    cube: NDArray[np.float64],
    frame: grating.SurfaceFrame,
    optics: grating.GratingOptics,
    sample_pix: NDArray[np.int64],
    lam: NDArray[np.float64],
    areas: NDArray[np.float64],
    n_sub: int,
) -> None:
    n_bands, n_pix = cube.shape
    sparse = grating.band_radiance_sparse(frame, optics, lam)
    cube += np.outer(areas, np.bincount(sample_pix, weights=sparse.diffuse_per_nm / n_sub, minlength=n_pix))
    flat = sparse.band * n_pix + sample_pix[sparse.point]
    cube += np.bincount(flat, weights=sparse.value / n_sub, minlength=n_bands * n_pix).reshape(n_bands, n_pix)
