"""The reference data of colour rendition, baked from colour-science, and the 1 nm view of an SPD.

``rendition_tables.npz`` (``make bake-colour``, ``tools/bake_colour.py``) holds colour-science's
own arrays (test colour samples, colour evaluation samples, the 10° observer, the daylight basis
as each method interpolates it, Robertson's lines), so the figures here are colour-science's
computation, not a re-derivation. The CIE 1931 2° observer comes from the colour module's tables.

An SPD of the product is the piecewise-linear curve through its 81 samples, zero outside
380–780 nm; CIE 13.3 and CIE 224:2017 / TM-30 sum at 1 nm, so every sum here is over that curve
sampled at 1 nm — the same SPD colour-science is given in the parity tests.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..spectra.colour import cmfs_1nm
from ..spectra.grid import WAVELENGTHS_NM

__all__ = ["TABLES_FILE", "RenditionTables", "rendition_tables", "interpolation_matrix", "SampleWeights",
           "sample_weights"]

TABLES_FILE = Path(__file__).with_name("rendition_tables.npz")


@dataclass(frozen=True)
class RenditionTables:
    cri_wavelength_nm: NDArray[np.float64]  # (421,) 360–780 nm
    cri_cmf: NDArray[np.float64]  # (421, 3) CIE 1931 2°
    cri_tcs: NDArray[np.float64]  # (421, 14) TCS01–14
    cri_daylight_basis: NDArray[np.float64]  # (421, 3) S0, S1, S2, linearly interpolated
    robertson_lines: NDArray[np.float64]  # (31, 4) mired, u, v, slope
    cfi_wavelength_nm: NDArray[np.float64]  # (401,) 380–780 nm
    cfi_cmf_2: NDArray[np.float64]  # (401, 3) CIE 1931 2° (CCT and the reference's Y)
    cfi_cmf_10: NDArray[np.float64]  # (401, 3) CIE 1964 10°
    cfi_ces: NDArray[np.float64]  # (401, 99) the colour evaluation samples
    cfi_daylight_basis: NDArray[np.float64]  # (401, 3) S0, S1, S2, Sprague-interpolated
    cfi_planckian_table: NDArray[np.float64]  # (k, 3) T, u, v: colour's Ohno table, 1000–25 000 K


def _frozen(values: NDArray[np.float64]) -> NDArray[np.float64]:
    arr = np.array(values, dtype=np.float64)
    arr.flags.writeable = False
    return arr


@lru_cache(maxsize=1)
def rendition_tables() -> RenditionTables:
    """The baked tables, loaded once (a few ms)."""
    with np.load(TABLES_FILE, allow_pickle=False) as data:
        arrays = {key: _frozen(data[key]) for key in data.files if key != "source"}
    wl, cmf = cmfs_1nm()
    if not np.array_equal(arrays["cri_wavelength_nm"], wl):
        raise RuntimeError(f"{TABLES_FILE.name} was baked for another wavelength range than the colour tables")
    start = int(round(arrays["cfi_wavelength_nm"][0] - wl[0]))
    return RenditionTables(cri_cmf=cmf, cfi_cmf_2=_frozen(cmf[start:start + arrays["cfi_wavelength_nm"].size]),
                           **arrays)


def interpolation_matrix(wavelengths_nm: NDArray[np.float64]) -> NDArray[np.float64]:
    """(len(wavelengths), 81): the product's SPD (linear between samples, zero outside
    380–780 nm) at ``wavelengths_nm``, as a matrix so that a batch of SPDs is one product."""
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    step = float(WAVELENGTHS_NM[1] - WAVELENGTHS_NM[0])
    hats = np.clip(1.0 - np.abs(lam[:, None] - WAVELENGTHS_NM[None, :]) / step, 0.0, None)
    inside = (lam >= WAVELENGTHS_NM[0] - 1e-9) & (lam <= WAVELENGTHS_NM[-1] + 1e-9)
    return hats * inside[:, None]


@dataclass(frozen=True)
class SampleWeights:
    """The sums a light's figures need, as matrices: ``light @ W`` gives the samples' XYZ
    (..., samples × 3, flattened) for a light on the product grid (``*_grid``, the 1 nm curve
    through its 81 samples) or at 1 nm (a reference illuminant)."""

    cri_grid: NDArray[np.float64]  # (81, 14·3)
    cri_1nm: NDArray[np.float64]  # (421, 14·3)
    cfi_grid: NDArray[np.float64]  # (81, 99·3)
    cfi_1nm: NDArray[np.float64]  # (401, 99·3)
    cfi_white_grid: NDArray[np.float64]  # (81, 3) 10° white


@lru_cache(maxsize=1)
def sample_weights() -> SampleWeights:
    t = rendition_tables()
    cri = (t.cri_tcs[:, :, None] * t.cri_cmf[:, None, :]).reshape(t.cri_cmf.shape[0], -1)
    cfi = (t.cfi_ces[:, :, None] * t.cfi_cmf_10[:, None, :]).reshape(t.cfi_cmf_10.shape[0], -1)
    to_cri, to_cfi = interpolation_matrix(t.cri_wavelength_nm), interpolation_matrix(t.cfi_wavelength_nm)
    return SampleWeights(cri_grid=_frozen(to_cri.T @ cri), cri_1nm=_frozen(cri), cfi_grid=_frozen(to_cfi.T @ cfi),
                         cfi_1nm=_frozen(cfi), cfi_white_grid=_frozen(to_cfi.T @ t.cfi_cmf_10))
