"""Aiming white sources at a target CCT / Duv, as lamp makers bin their products.

Only the white families (LEDs, tri-phosphor fluorescent, metal halide) use it. The colorimetry
is the core's (:mod:`cd_spectra_addon.core.spectra.colour`): the CIE 1931 2° observer
integrated over each grid sample's hat, the CIE Planckian locus and Ohno's CCT / Duv, so the
prior aims its whites with the same numbers the product reports. An observer and the locus
are not light sources: the prior still reads no measured spectrum.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.spectra.colour import (
    cct_duv_to_uv1960,
    hat_cmfs,
    uv1960_to_xy,
    uv_to_cct_ohno2013,
    xy_to_uv1960,
    xyz_to_xy,
)
from cd_spectra_addon.core.spectra.grid import N_BANDS

Array = NDArray[np.float64]
Generator = np.random.Generator


def _xyz(spd: Array) -> Array:
    """CIE XYZ of grid SPDs (..., 81) → (..., 3); rows may be zero (a mix without a fixed part)."""
    return spd @ hat_cmfs()


def _target_xy(cct: Array, duv: Array) -> Array:
    """Chromaticity at (CCT, Duv): the Planckian point moved by Duv along the locus normal."""
    return uv1960_to_xy(cct_duv_to_uv1960(cct, duv))


def _solve_mix(parts: Array, fixed: Array, fixed_share: Array, target_xy: Array) -> tuple[Array, Array]:
    """Weights w (m, 3) ≥ 0 hoped for, so that Σ wᵢ·partᵢ + fixed has chromaticity ``target_xy``
    and ``fixed`` (rescaled) carries ``fixed_share`` of the luminance Y. NaN where singular.

    Three linear equations per row (x and y conditions and the luminance split), by Cramer's rule.
    """
    pxyz = _xyz(parts)  # (m, 3 parts, 3)
    fxyz = _xyz(fixed)  # (m, 3)
    fy = fxyz[:, 1]
    scale = np.divide(fixed_share, fy, out=np.zeros_like(fy), where=fy > 0)
    fxyz = fxyz * scale[:, None]
    x, y = target_xy[:, 0:1], target_xy[:, 1:2]
    s = pxyz.sum(-1)
    r0 = pxyz[..., 0] - x * s  # (m, 3)
    r1 = pxyz[..., 1] - y * s
    r2 = pxyz[..., 1]
    fs = fxyz.sum(-1)
    rhs = np.stack([-(fxyz[:, 0] - x[:, 0] * fs), -(fxyz[:, 1] - y[:, 0] * fs), 1.0 - fixed_share], -1)
    c12, c20, c01 = np.cross(r1, r2), np.cross(r2, r0), np.cross(r0, r1)
    det = np.einsum("mi,mi->m", r0, c12)
    w = (rhs[:, 0:1] * c12 + rhs[:, 1:2] * c20 + rhs[:, 2:3] * c01)
    with np.errstate(divide="ignore", invalid="ignore"):
        w = w / det[:, None]
    w[np.abs(det) < 1e-300] = np.nan
    return w, scale


def white_mix(
    rng: Generator,
    n: int,
    make: Callable[[Generator, int], tuple[Array, Array, Array]],
    targets: Callable[[Generator, int], tuple[Array, Array]],
    part_share: Sequence[tuple[float, float]] | None = None,
) -> Array:
    """Rows aimed at sampled (CCT, Duv) targets: ``make`` gives 3 parts + a fixed part and its
    luminance share; rows whose target lies outside the parts' gamut (or whose parts' luminance
    shares fall outside ``part_share``) are redrawn."""
    out = np.empty((n, N_BANDS))
    todo = np.arange(n)
    bounds = None if part_share is None else np.asarray(part_share, dtype=np.float64)
    for _ in range(50):
        m = todo.size
        parts, fixed, share = make(rng, m)
        cct, duv = targets(rng, m)
        w, scale = _solve_mix(parts, fixed, share, _target_xy(cct, duv))
        ok = np.all(np.isfinite(w) & (w >= 0), axis=1)
        if bounds is not None:
            lum = w * _xyz(parts)[..., 1]  # each part's share of Y (total Y is 1)
            ok &= np.all((lum >= bounds[:, 0]) & (lum <= bounds[:, 1]), axis=1)
        out[todo[ok]] = np.einsum("mk,mkb->mb", w[ok], parts[ok]) + fixed[ok] * scale[ok, None]
        todo = todo[~ok]
        if todo.size == 0:
            return out
    # Give up aiming for the last few: a valid (if off-target) mix beats a hang.
    wf = np.nan_to_num(np.clip(w[~ok], 0.0, None)) + 1e-3
    out[todo] = np.einsum("mk,mkb->mb", wf, parts[~ok]) + fixed[~ok] * scale[~ok, None]
    return out


def cct_duv(spd: Array) -> tuple[Array, Array]:
    """CCT (K) and Duv of SPDs (m, 81) with positive power, by Ohno (2014) as the product
    reports them (no range check: far from the locus the numbers are only a direction)."""
    cct_duv_rows = uv_to_cct_ohno2013(xy_to_uv1960(xyz_to_xy(_xyz(spd))))
    return cct_duv_rows[..., 0], cct_duv_rows[..., 1]
