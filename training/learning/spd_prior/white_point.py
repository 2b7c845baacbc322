"""Aiming white sources at a target CCT / Duv, as lamp makers bin their products.

Only the white families (LEDs, tri-phosphor fluorescent, metal halide) use it. CIE 1931 2° CMFs
by the analytic multi-lobe fit of Wyman, Sloan & Shirley (JCGT 2013): an observer model, not a
light source, and no table import; Planck's law from the core's illuminants.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cache

import numpy as np
from numpy.typing import NDArray

# Planck's law and c2 only: the prior takes no CIE illuminant from that module (tested).
from cd_spectra_addon.core.spectra.illuminants import planck
from cd_spectra_addon.core.spectra.grid import N_BANDS

from training.learning.spd_prior.grid import GRID

Array = NDArray[np.float64]
Generator = np.random.Generator

# ---------------------------------------------------------------------------------------------
# Colour helpers: only to aim white sources at a target CCT/Duv, as products are binned.
# CIE 1931 2° CMFs by the analytic multi-lobe fit of Wyman, Sloan & Shirley (JCGT 2013): an
# observer model, not a light source, and no table import.
# ---------------------------------------------------------------------------------------------
def _lobe(lam: Array, mu: float, s1: float, s2: float) -> Array:
    s = np.where(lam < mu, s1, s2)
    return np.exp(-0.5 * ((lam - mu) / s) ** 2)


@cache
def _cmf_grid() -> Array:
    lam = GRID
    x = 1.056 * _lobe(lam, 599.8, 37.9, 31.0) + 0.362 * _lobe(lam, 442.0, 16.0, 26.7) \
        - 0.065 * _lobe(lam, 501.1, 20.4, 26.2)
    y = 0.821 * _lobe(lam, 568.8, 46.9, 40.5) + 0.286 * _lobe(lam, 530.9, 16.3, 31.1)
    z = 1.217 * _lobe(lam, 437.0, 11.8, 36.0) + 0.681 * _lobe(lam, 459.0, 26.0, 13.8)
    return np.stack([x, y, z], axis=-1)  # (81, 3)


def _xyz(spd: Array) -> Array:
    return spd @ _cmf_grid()


def _uv(xyz: Array) -> Array:
    d = xyz[..., 0] + 15.0 * xyz[..., 1] + 3.0 * xyz[..., 2]
    return np.stack([4.0 * xyz[..., 0] / d, 6.0 * xyz[..., 1] / d], axis=-1)


def _target_xy(cct: Array, duv: Array) -> Array:
    """Chromaticity at (CCT, Duv): Planckian point moved by Duv along the locus normal in uv."""
    uv0 = _uv(_xyz(planck(GRID, cct[:, None])))
    uv1 = _uv(_xyz(planck(GRID, cct[:, None] * 1.01)))
    tan = uv1 - uv0
    normal = np.stack([tan[:, 1], -tan[:, 0]], axis=-1)  # towards +v: above the locus (greenish)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    u, v = (uv0 + duv[:, None] * normal).T
    den = 2.0 * u - 8.0 * v + 4.0
    return np.stack([3.0 * u / den, 2.0 * v / den], axis=-1)


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


@cache
def _locus_table() -> tuple[Array, Array]:
    t = np.geomspace(1000.0, 1e5, 600)
    return t, _uv(_xyz(planck(GRID, t[:, None])))


def cct_duv(spd: Array) -> tuple[Array, Array]:
    """Approximate CCT and Duv (nearest of 600 tabulated Planckian points, CCT within ~0.4 %):
    enough to keep mostly-white lamp families white."""
    t, loc = _locus_table()
    uv = _uv(_xyz(spd))
    d = uv[:, None, :] - loc[None, :, :]
    j = np.argmin(np.einsum("mtk,mtk->mt", d, d), axis=1)
    dist = np.sqrt(np.einsum("mk,mk->m", d[np.arange(j.size), j], d[np.arange(j.size), j]))
    return t[j], np.where(uv[:, 1] >= loc[j, 1], dist, -dist)
