"""The product's wavelength grids, and band-aware resampling onto the SPD grid.

Every SPD the product reads, learns or writes lives on 380–780 nm in 5 nm steps. A sample
``E_i`` stands for a triangular ("hat") basis function of half-width 5 nm around ``λ_i``, so an
SPD is the piecewise-linear curve through its samples. The forward model integrates each band
against the same hat (see :mod:`cd_spectra_addon.core.grating`), which keeps narrow lamp lines
from aliasing between samples.

The photo is read on a second grid: the readout's bins of the first-order wavelength λ₁
(:data:`FEATURE_LAMBDA_NM`, 350–870 nm, 5 nm wide), with the pixels whose lobe is at least
:data:`MIN_VISIBILITY` visible. The readout, its forward matrix, the pose fit and the capture
advice all bin λ₁ this way, so the grid is defined here, below all of them. :data:`VISIBLE_NM`
is the band that set-ups must cover and that the comparisons and the advice judge.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

WAVELENGTH_MIN_NM = 380.0
WAVELENGTH_MAX_NM = 780.0
WAVELENGTH_STEP_NM = 5.0
WAVELENGTHS_NM: NDArray[np.float64] = np.arange(380.0, 780.0 + 0.5, 5.0)
N_BANDS = WAVELENGTHS_NM.size  # 81

FEATURE_STEP_NM = 5.0
FEATURE_LAMBDA_NM: NDArray[np.float64] = np.arange(350.0, 870.0 + 0.5, FEATURE_STEP_NM)  # 105 bin centres
N_FEATURES = FEATURE_LAMBDA_NM.size
FEATURE_EDGE_NM = float(FEATURE_LAMBDA_NM[0] - FEATURE_STEP_NM / 2)  # lower edge of the first bin
MIN_VISIBILITY = 0.3  # a pixel counts where its first-order lobe, exp(−v²/2σ²), is at least this
VISIBLE_NM = (400.0, 700.0)  # the band a set-up must put on the data area and the comparisons judge

__all__ = [
    "WAVELENGTH_MIN_NM",
    "WAVELENGTH_MAX_NM",
    "WAVELENGTH_STEP_NM",
    "WAVELENGTHS_NM",
    "N_BANDS",
    "FEATURE_STEP_NM",
    "FEATURE_LAMBDA_NM",
    "N_FEATURES",
    "FEATURE_EDGE_NM",
    "MIN_VISIBILITY",
    "VISIBLE_NM",
    "feature_bins",
    "hat_integrals",
    "resample_to_grid",
    "peak_normalise",
]


def feature_bins(lambda_nm: ArrayLike, step_nm: float = FEATURE_STEP_NM) -> NDArray[np.int64]:
    """The readout bin of each first-order wavelength, counted from :data:`FEATURE_EDGE_NM` in
    steps of ``step_nm`` (the bins' own 5 nm, or a fraction for sub-bins). Indices outside
    0 … N − 1 mean outside the grid: the caller masks them."""
    return np.floor((np.asarray(lambda_nm, dtype=np.float64) - FEATURE_EDGE_NM) / step_nm).astype(np.int64)


def hat_integrals(
    wavelengths_nm: ArrayLike = WAVELENGTHS_NM,
    half_width_nm: float = WAVELENGTH_STEP_NM,
    lo_nm: float = WAVELENGTH_MIN_NM,
    hi_nm: float = WAVELENGTH_MAX_NM,
) -> NDArray[np.float64]:
    """Area of each band's hat inside [lo, hi] (5 nm inside the grid, 2.5 nm at its two ends)."""
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    h = float(half_width_nm)
    a = np.clip(lo_nm - lam, -h, h)  # clipped support relative to the centre
    b = np.clip(hi_nm - lam, -h, h)

    def primitive(t: NDArray[np.float64]) -> NDArray[np.float64]:
        return t - np.sign(t) * t * t / (2.0 * h)

    return np.maximum(primitive(b) - primitive(a), 0.0)


MIN_FINE_STEP_NM = 0.01  # finer structure than this is averaged by the linear interpolant


def resample_to_grid(
    wavelengths_nm: ArrayLike,
    values: ArrayLike,
    grid_nm: ArrayLike = WAVELENGTHS_NM,
) -> NDArray[np.float64]:
    """Resample spectra given at any sampling onto ``grid_nm`` (last axis of ``values``).

    Finer input is averaged under each grid hat (energy of a 1 nm-wide line is kept rather
    than missed between samples); coarser input is interpolated linearly. Outside the input's
    range the spectrum is taken as zero. NaN samples are rejected with a ValueError: a silent
    zero would look like a measured dark band.
    """
    wl = np.asarray(wavelengths_nm, dtype=np.float64)
    val = np.asarray(values, dtype=np.float64)
    grid = np.asarray(grid_nm, dtype=np.float64)
    if wl.ndim != 1 or wl.size < 2:
        raise ValueError("need at least two wavelength samples")
    if val.shape[-1] != wl.size:
        raise ValueError(f"{val.shape[-1]} values for {wl.size} wavelengths")
    if not np.all(np.isfinite(wl)) or not np.all(np.isfinite(val)):
        raise ValueError("wavelengths and values must be finite numbers")
    order = np.argsort(wl, kind="stable")
    wl, val = wl[order], val[..., order]
    if np.any(np.diff(wl) <= 0):
        raise ValueError("wavelengths must be distinct")
    step = float(grid[1] - grid[0]) if grid.size > 1 else WAVELENGTH_STEP_NM
    flat = val.reshape(-1, wl.size)
    if float(np.min(np.diff(wl))) >= step - 1e-9:
        # As coarse as the grid or coarser: the piecewise-linear curve itself.
        out = np.stack([np.interp(grid, wl, row, left=0.0, right=0.0) for row in flat])
        return out.reshape(val.shape[:-1] + (grid.size,))
    # Finer: dense 0.1 nm resampling, then hat-weighted average per grid sample. The step never
    # goes below MIN_FINE_STEP_NM: two samples 1e-9 nm apart once asked for a 6 TiB array.
    fine_step = max(min(0.1, float(np.min(np.diff(wl))) / 2.0), MIN_FINE_STEP_NM)
    fine = np.arange(grid[0] - step, grid[-1] + step + fine_step / 2, fine_step)
    dense = np.empty((flat.shape[0], fine.size))
    for k in range(flat.shape[0]):
        dense[k] = np.interp(fine, wl, flat[k], left=0.0, right=0.0)
    weights = np.clip(1.0 - np.abs(fine[None, :] - grid[:, None]) / step, 0.0, None)
    out = dense @ weights.T / weights.sum(axis=1)
    return out.reshape(val.shape[:-1] + (grid.size,))


def peak_normalise(spd: ArrayLike, axis: int = -1) -> NDArray[np.float64]:
    """Scale so the maximum along ``axis`` is exactly 1 (an all-zero spectrum stays zero)."""
    arr = np.asarray(spd, dtype=np.float64)
    peak = np.max(arr, axis=axis, keepdims=True)
    return np.divide(arr, peak, out=np.zeros_like(arr), where=peak > 0)
