"""Every rendition figure of a batch of SPDs at once: CIE 13.3, CIE 2017 / TM-30, peak and
dominant wavelength.

One call computes a whole batch — the estimate's SPD and the SPDs drawn from its uncertainty —
with matrix products over the baked tables, so the ranges cost little more than the figures.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..spectra.colour import cmfs_1nm, hat_cmfs, spd_to_xyz
from ..spectra.grid import WAVELENGTHS_NM
from .cri import special_indices
from .fidelity import Fidelity, fidelity

__all__ = ["EQUAL_ENERGY_XY", "Figures", "figures", "dominant_wavelength"]

EQUAL_ENERGY_XY = (1.0 / 3.0, 1.0 / 3.0)
"""The white a light's dominant wavelength is taken from (CIE illuminant E)."""


@dataclass(frozen=True)
class Figures:
    """The figures of n SPDs (rows)."""

    cri_ri: NDArray[np.float64]  # (n, 14) R1–R14
    fidelity: Fidelity
    peak_wavelength_nm: NDArray[np.float64]  # (n,)
    dominant_wavelength_nm: NDArray[np.float64]  # (n,) negative: the complementary wavelength (a purple)

    @property
    def cri_ra(self) -> NDArray[np.float64]:
        return self.cri_ri[:, :8].mean(axis=1)

    @property
    def cri_r9(self) -> NDArray[np.float64]:
        return self.cri_ri[:, 8]


@lru_cache(maxsize=1)
def _locus() -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """(wavelengths, xy of the spectral locus, its edges) — the last edge closes it: the purples."""
    wl, cmf = cmfs_1nm()
    locus = cmf[:, :2] / cmf.sum(axis=1, keepdims=True)
    return wl, locus, np.roll(locus, -1, axis=0) - locus


def dominant_wavelength(xy: ArrayLike, white: tuple[float, float] = EQUAL_ENERGY_XY) -> NDArray[np.float64]:
    """Dominant wavelength (nm, whole nm of the 1 nm locus) of chromaticities (..., 2) seen from
    ``white``, as ``colour.dominant_wavelength``: where the ray from the white through the colour
    meets the spectral locus (CIE 1931 2°, 360–780 nm), the locus wavelength nearest to that
    point; where it meets the line of purples, minus the complementary wavelength (the ray
    backwards). NaN at the white itself."""
    wl, locus, edge = _locus()
    p = np.asarray(xy, dtype=np.float64)
    flat = p.reshape(-1, 2)
    rel = locus - np.asarray(white, dtype=np.float64)  # white → each edge's start
    rel_x_edge = rel[:, 0] * edge[:, 1] - rel[:, 1] * edge[:, 0]
    purples = locus.shape[0] - 1

    def hit(d: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(index of the locus point nearest to where the ray along ``d`` leaves the locus,
        whether it leaves through the purples)."""
        cross = d[:, 0:1] * edge[None, :, 1] - d[:, 1:2] * edge[None, :, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = rel_x_edge / cross
            u = (rel[None, :, 0] * d[:, 1:2] - rel[None, :, 1] * d[:, 0:1]) / cross
        t[~((t > 0) & (u >= 0) & (u <= 1))] = np.inf
        first = np.argmin(t, axis=1)
        along = u[np.arange(d.shape[0]), first]
        nearest = np.where(along < 0.5, first, (first + 1) % locus.shape[0])
        return np.where(np.isfinite(t[np.arange(d.shape[0]), first]), nearest, -1), first == purples

    direction = flat - np.asarray(white, dtype=np.float64)
    index, purple = hit(direction)
    if np.any(purple):
        index[purple] = hit(-direction[purple])[0]
    out = np.where(purple, -wl[index], wl[index])
    out = np.where((index >= 0) & np.any(direction != 0, axis=1), out, np.nan)
    return out.reshape(p.shape[:-1])


def figures(spds: ArrayLike) -> Figures:
    """The figures of SPDs (n, 81) on the product grid (each validated as any SPD: finite,
    non-negative, not all zero — CDSpectraError otherwise)."""
    rows = np.atleast_2d(np.asarray(spds, dtype=np.float64))
    spd_to_xyz(rows)  # the checks, with their messages
    rows = rows / rows.max(axis=1, keepdims=True)
    xyz = rows @ hat_cmfs()
    xy = xyz[:, :2] / xyz.sum(axis=1, keepdims=True)
    return Figures(cri_ri=special_indices(rows, xyz), fidelity=fidelity(rows, xyz),
                   peak_wavelength_nm=WAVELENGTHS_NM[np.argmax(rows, axis=1)],
                   dominant_wavelength_nm=dominant_wavelength(xy))
