"""CIE 224:2017 colour fidelity and ANSI/IES TM-30 fidelity, gamut and hue-bin figures.

The computation of ``colour.colour_fidelity_index`` (methods "CIE 2017" and "ANSI/IES TM-30-18";
colour-science 0.4.6), vectorised over a batch of test lights: 380–780 nm at 1 nm, the 99 colour
evaluation samples (CES), the CIE 1964 10° observer, CIECAM02 → CAM02-UCS (:mod:`.cam02`), the
reference's CCT by Ohno (2013) from the CIE 1931 2° chromaticity — a Planckian radiator below
4000 K, CIE daylight above 5000 K, and between them the two mixed linearly in CCT after scaling
each to the same Y. TM-30-20 changed no formula of these figures; Rf of TM-30 is CIE 2017's Rf.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..spectra.colour import uv_to_cct_in_table
from ..spectra.illuminants import C2_ITS90_NM_K, planck_radiance
from .cam02 import xyz_to_jab
from .cri import daylight_m
from .tables import rendition_tables, sample_weights

__all__ = ["N_BINS", "PLANCK_BELOW_K", "DAYLIGHT_ABOVE_K", "Fidelity", "reference_cct", "fidelity_reference", "delta_e_to_rf",
           "fidelity"]

N_BINS = 16
PLANCK_BELOW_K = 4000.0
DAYLIGHT_ABOVE_K = 5000.0
_C_F = 6.73  # CIE 224:2017's scale factor from ΔE′ to Rf
_BIN_ANGLES = np.radians(22.5 * np.arange(N_BINS) + 11.25)  # the angles bisecting the hue bins


@dataclass(frozen=True)
class Fidelity:
    """CIE 2017 / TM-30 figures of a batch of n lights (NaN in a hue bin with no sample)."""

    cct: NDArray[np.float64]  # (n,) the reference's CCT (Ohno)
    rf: NDArray[np.float64]  # (n,) Rf
    rg: NDArray[np.float64]  # (n,) Rg
    rf_hj: NDArray[np.float64]  # (n, 16) local fidelity per hue bin
    rcs_hj: NDArray[np.float64]  # (n, 16) local chroma shift, % (TM-30's Rcs,hj × 100)
    rhs_hj: NDArray[np.float64]  # (n, 16) local hue shift (radians of the unit circle)
    cvg_reference_hue: NDArray[np.float64]  # (n, 16) mean reference hue per bin, degrees
    cvg_test: NDArray[np.float64]  # (n, 16, 2) the colour vector graphic's test points (reference circle = 1)


def delta_e_to_rf(delta_e: NDArray[np.float64]) -> NDArray[np.float64]:
    """CIE 224:2017's fidelity scale: Rf = 10 ln(1 + exp((100 − 6.73 ΔE′) / 10))."""
    return 10.0 * np.log1p(np.exp((100.0 - _C_F * np.asarray(delta_e, dtype=np.float64)) / 10.0))


def reference_cct(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """CCT of the reference (n,) from the light's CIE 1960 uv (n, 2): Ohno on colour's 1000–25 000 K
    table, as ``colour.quality.cfi2017.CCT_reference_illuminant``."""
    table = rendition_tables().cfi_planckian_table
    return uv_to_cct_in_table(uv, table[:, 0], table[:, 1:])[..., 0]


def _mixture(cct: NDArray[np.float64]) -> NDArray[np.float64]:
    """Share of daylight in the reference (n,): 0 below 4000 K, 1 above 5000 K, linear between."""
    return np.clip((cct - PLANCK_BELOW_K) / (DAYLIGHT_ABOVE_K - PLANCK_BELOW_K), 0.0, 1.0)


def fidelity_reference(cct: NDArray[np.float64]) -> NDArray[np.float64]:
    """The reference illuminant at ``cct`` (n,) on 380–780 nm / 1 nm, (n, 401), scaled to the same
    Y (what the 4000–5000 K mixture needs; the figures do not depend on the scale)."""
    t = rendition_tables()
    temps = np.asarray(cct, dtype=np.float64)
    planck = planck_radiance(t.cfi_wavelength_nm, np.maximum(temps, 100.0)[:, None], C2_ITS90_NM_K)
    daylight = daylight_m(np.maximum(temps, PLANCK_BELOW_K)) @ t.cfi_daylight_basis.T
    planck /= (planck @ t.cfi_cmf_2[:, 1])[:, None]
    daylight /= (daylight @ t.cfi_cmf_2[:, 1])[:, None]
    m = _mixture(temps)[:, None]
    return (1.0 - m) * planck + m * daylight


def _reference_xyz(cct: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(the CES' XYZ sums (n, 297), the white's (n, 3)) under the reference at ``cct``, without
    building daylight at 1 nm: its sums are linear in (1, M1, M2)."""
    t, w = rendition_tables(), sample_weights()
    m = _mixture(cct)
    samples = np.zeros((cct.size, w.cfi_1nm.shape[1]))
    white = np.zeros((cct.size, 3))
    planck = m < 1.0
    if np.any(planck):
        light = planck_radiance(t.cfi_wavelength_nm, np.maximum(cct[planck], 100.0)[:, None], C2_ITS90_NM_K)
        light *= ((1.0 - m[planck]) / (light @ t.cfi_cmf_2[:, 1]))[:, None]
        samples[planck], white[planck] = light @ w.cfi_1nm, light @ t.cfi_cmf_10
    daylight = m > 0.0
    if np.any(daylight):
        coeff = daylight_m(np.maximum(cct[daylight], PLANCK_BELOW_K))
        coeff *= (m[daylight] / (coeff @ (t.cfi_daylight_basis.T @ t.cfi_cmf_2[:, 1])))[:, None]
        samples[daylight] += coeff @ (t.cfi_daylight_basis.T @ w.cfi_1nm)
        white[daylight] += coeff @ (t.cfi_daylight_basis.T @ t.cfi_cmf_10)
    return samples, white


def _jab(samples: NDArray[np.float64], white: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """CAM02-UCS J′a′b′ (n, 99, 3) and hue (n, 99) of the CES from their XYZ sums (n, 297) and the
    white's (n, 3), at any common scale."""
    scale = (100.0 / white[:, 1])[:, None]
    xyz = samples.reshape(samples.shape[0], -1, 3) * scale[:, :, None]
    return xyz_to_jab(xyz, (white * scale)[:, None, :])


def _polygon_area(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Shoelace area of the polygons (..., 16, 2) in bin order (as colour's ``averages_area``)."""
    nxt = np.roll(points, -1, axis=-2)
    return 0.5 * np.sum(points[..., 0] * nxt[..., 1] - points[..., 1] * nxt[..., 0], axis=-1)


def _bin_means(values: NDArray[np.float64], bins: NDArray[np.int64], count: NDArray[np.float64]
               ) -> NDArray[np.float64]:
    """Per-bin means (n, 16, ...) of ``values`` (n, 99, ...) over samples in ``bins`` (n, 99)."""
    n = values.shape[0]
    flat = (bins + N_BINS * np.arange(n)[:, None]).ravel()
    rest = values.shape[2:]
    cols = values.reshape(n * values.shape[1], -1)
    sums = np.stack([np.bincount(flat, weights=cols[:, k], minlength=n * N_BINS) for k in range(cols.shape[1])],
                    axis=-1).reshape(n, N_BINS, *rest)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / count.reshape(n, N_BINS, *(1,) * len(rest))


def fidelity(spds: NDArray[np.float64], xyz: NDArray[np.float64]) -> Fidelity:
    """Every CIE 2017 / TM-30 figure of lights on the product grid (n, 81), whose CIE 1931 XYZ
    (n, 3) the caller has (any scale)."""
    w = sample_weights()
    xyz = np.asarray(xyz, dtype=np.float64)
    den = xyz[:, 0] + 15.0 * xyz[:, 1] + 3.0 * xyz[:, 2]
    cct = reference_cct(np.stack([4.0 * xyz[:, 0] / den, 6.0 * xyz[:, 1] / den], axis=-1))
    jab_t, _ = _jab(spds @ w.cfi_grid, spds @ w.cfi_white_grid)
    jab_r, hue_r = _jab(*_reference_xyz(cct))
    delta_e = np.linalg.norm(jab_t - jab_r, axis=-1)  # (n, 99)
    rf = delta_e_to_rf(delta_e.mean(axis=1))
    bins = np.minimum(np.floor(hue_r / 22.5).astype(np.int64), N_BINS - 1)
    count = np.stack([np.bincount(row, minlength=N_BINS) for row in bins]).astype(np.float64) if bins.shape[0] < 8 \
        else np.bincount((bins + N_BINS * np.arange(bins.shape[0])[:, None]).ravel(),
                         minlength=bins.shape[0] * N_BINS).reshape(-1, N_BINS).astype(np.float64)
    avg_t = _bin_means(jab_t[..., 1:], bins, count)
    avg_r = _bin_means(jab_r[..., 1:], bins, count)
    rf_hj = delta_e_to_rf(_bin_means(delta_e, bins, count))
    hue_bin = _bin_means(hue_r, bins, count)
    rg = 100.0 * _polygon_area(avg_t) / _polygon_area(avg_r)
    norm = np.linalg.norm(avg_r, axis=-1)
    shift = (avg_t - avg_r) / norm[..., None]
    cos, sin = np.cos(_BIN_ANGLES), np.sin(_BIN_ANGLES)
    rcs = 100.0 * (shift[..., 0] * cos + shift[..., 1] * sin)
    rhs = -shift[..., 0] * sin + shift[..., 1] * cos
    hue_rad = np.radians(hue_bin)
    cvg = np.stack([np.cos(hue_rad), np.sin(hue_rad)], axis=-1) + shift
    return Fidelity(cct=cct, rf=rf, rg=rg, rf_hj=rf_hj, rcs_hj=rcs, rhs_hj=rhs, cvg_reference_hue=hue_bin, cvg_test=cvg)
