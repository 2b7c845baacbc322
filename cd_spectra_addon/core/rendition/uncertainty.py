"""SPDs drawn from an estimate and its per-wavelength uncertainty, for the figures' ranges.

An estimate gives a one-sigma ``spd_std`` per 5 nm sample but no covariance. The deviations are
drawn as ``spd + k · spd_std · z``, clipped at zero (a light has no negative power), with ``z``
of unit variance and a squared-exponential correlation over wavelength of length
:data:`CORRELATION_NM` (0: independent per sample). A correlated error — a misplaced bump, a
tilted tail — does not average away in the integrals behind every figure, so a longer length
gives wider ranges. Which length and factor ``k`` (:data:`STD_SCALE`) give ranges that hold the
truth was measured on synthetic photos (``training/evaluation/rendition_coverage.py``,
bench/rendition.md): the narrowest that cover Ra, R9, Rf and Rg on ≥ 90 % of them is the
network's own ``spd_std`` drawn independently (92 %; 40 nm covered 98–99 % with ranges twice as
wide). The real lamps the coverage is then measured on chose nothing.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CDSpectraError
from ..spectra.grid import N_BANDS, WAVELENGTHS_NM

__all__ = ["CORRELATION_NM", "STD_SCALE", "correlated_normals", "draw_spds"]

CORRELATION_NM = 0.0
STD_SCALE = 1.0


@lru_cache(maxsize=8)
def _factor(correlation_nm: float) -> NDArray[np.float64]:
    """L with L Lᵀ = the correlation matrix over the grid (identity for a length of 0)."""
    if correlation_nm <= 0:
        return np.eye(N_BANDS)
    gap = WAVELENGTHS_NM[:, None] - WAVELENGTHS_NM[None, :]
    corr = np.exp(-0.5 * (gap / correlation_nm) ** 2)
    # The squared-exponential matrix is numerically singular: an eigen-factor keeps it exact
    # where it is positive and drops the directions it has none in.
    values, vectors = np.linalg.eigh(corr)
    factor = vectors * np.sqrt(np.clip(values, 0.0, None))
    factor.flags.writeable = False
    return factor


def correlated_normals(n: int, seed: int, correlation_nm: float = CORRELATION_NM) -> NDArray[np.float64]:
    """(n, 81) standard normal deviates with the grid correlation of ``correlation_nm``, seeded."""
    rng = np.random.default_rng(seed)
    return rng.standard_normal((n, N_BANDS)) @ _factor(float(correlation_nm)).T


def draw_spds(spd: ArrayLike, std: ArrayLike, n: int, seed: int = 0,
              correlation_nm: float = CORRELATION_NM, scale: float = STD_SCALE) -> NDArray[np.float64]:
    """(n, 81) SPDs around ``spd`` with per-wavelength one-sigma ``std`` (times ``scale``),
    correlated over ``correlation_nm`` and clipped at zero; the same ``seed``, the same draws."""
    mean = np.asarray(spd, dtype=np.float64)
    sigma = np.asarray(std, dtype=np.float64)
    if mean.shape != (N_BANDS,) or sigma.shape != (N_BANDS,):
        raise CDSpectraError(f"an SPD and its uncertainty have {N_BANDS} values each; got {mean.shape} and {sigma.shape}")
    if not (np.all(np.isfinite(sigma)) and np.all(sigma >= 0)):
        raise CDSpectraError("the SPD's uncertainty must be finite and non-negative")
    return np.clip(mean + scale * sigma * correlated_normals(n, seed, correlation_nm), 0.0, None)
