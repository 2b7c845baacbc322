"""The bands the camera barely sees (380–410 and 680–780 nm), filled from what the photo says
about the kind of source.

A camera's sensitivities fade out below ~410 nm and above ~680 nm, so there the features hardly
constrain the SPD and any solve falls back on its prior: "what lamps usually do". For a thermal
source that is the wrong guess: a tungsten lamp keeps rising to 780 nm while the prior's tail
turns over near 700 nm, and normalising the estimate to its peak then scales the whole visible
curve wrong (issue 21: a halogen lamp read MAE 400–700 0.12 with its colour right).

A Planck radiator has two unknowns, its temperature and its brightness. Where a Planck curve
explains the photo's own features about as well as their noise allows (χ² per feature row,
the rows weighted by their noise and model-error floor as every solve weighs them), the source is
thermal and its tails are that Planck curve; the estimate hands over to it along a smooth ramp
into each blind band. Elsewhere (lines, phosphors, LEDs, filters) the estimate keeps its tails.
How good a fit counts as thermal (:data:`DEFAULT_SETTINGS`, or the model's ``tails`` metadata)
is chosen on synthetic spectra only (``training.learning.tune_tails``, bench/tails.md).

Beyond the camera the uncertainty is wider (:func:`widen_std`): at least a floor that grows into
each band, and where the kind of source is in doubt the disagreement of the two tails.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np
from numpy.typing import NDArray

from ..numerics.nnls import nnls_normal
from ..spectra.grid import WAVELENGTHS_NM
from ..spectra.illuminants import planck
from .solve import Rows

# The blind bands and the ramps into them: the estimate alone inside, the tail model fully from
# the band's outer part on (smoothstep between the two wavelengths).
VIOLET_RAMP_NM = (430.0, 400.0)
RED_RAMP_NM = (660.0, 700.0)
# Where each tail's level is taken from the estimate (the camera still sees well there): the
# Planck curve's shape continues the estimate from its own level, without a step where the
# estimate and a Planck curve of the whole photo disagree by a few per cent.
VIOLET_ANCHOR_NM = (420.0, 450.0)
RED_ANCHOR_NM = (620.0, 670.0)
TEMPERATURES_K = np.exp(np.linspace(np.log(1000.0), np.log(25000.0), 121))
# Floor of the uncertainty beyond the camera (peak-normalised units), reached at the band's far
# end: the tails are a model's guess there, not a reading.
BLIND_STD = 0.1

__all__ = ["TailSettings", "DEFAULT_SETTINGS", "PlanckFit", "planck_fit", "blind_weight", "thermal_weight",
           "with_tails", "joined_tails", "widen_std", "VIOLET_RAMP_NM", "RED_RAMP_NM"]


@dataclass(frozen=True)
class TailSettings:
    """χ² per feature row of the best Planck fit at which the tails are fully Planck
    (``thermal_chi2``) and at which they are fully the estimate's (``other_chi2``), linear
    between; and the hottest fitted temperature that counts as thermal at all: a filament lamp
    is below ~3500 K, while a smooth daylight-like spectrum can pass for a hotter Planck curve
    where the camera sees and leaves it in the tails."""

    thermal_chi2: float
    other_chi2: float
    max_temperature_k: float = float("inf")

    @classmethod
    def from_metadata(cls, meta: Mapping[str, Any] | None) -> "TailSettings | None":
        if not meta:
            return None
        return cls(float(meta["thermal_chi2"]), float(meta["other_chi2"]),
                   float(meta.get("max_temperature_k") or float("inf")))


# The shipped model's choice on synthetic spectra (bench/tails_tuning.md; its metadata carries it).
DEFAULT_SETTINGS = TailSettings(thermal_chi2=0.5, other_chi2=2.5)


@dataclass(frozen=True)
class PlanckFit:
    temperature_k: float
    scale: float  # × planck(λ, T) (1 at 560 nm) in the rows' units
    chi2_per_row: float  # of the rows against the Planck curve (and the free columns)
    spd: NDArray[np.float64]  # scale × planck on the product grid, the rows' units


def _smoothstep(x: NDArray[np.float64]) -> NDArray[np.float64]:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def blind_weight(wavelengths: NDArray[np.float64] = WAVELENGTHS_NM) -> NDArray[np.float64]:
    """0 where the camera sees, rising smoothly to 1 into each blind band."""
    lam = np.asarray(wavelengths, dtype=np.float64)
    violet = _smoothstep((VIOLET_RAMP_NM[0] - lam) / (VIOLET_RAMP_NM[0] - VIOLET_RAMP_NM[1]))
    red = _smoothstep((lam - RED_RAMP_NM[0]) / (RED_RAMP_NM[1] - RED_RAMP_NM[0]))
    return np.maximum(violet, red)


def planck_fit(rows: Rows) -> PlanckFit | None:
    """The Planck curve (temperature on a log grid of 1000–25000 K, then a parabola through the
    best three) whose brightness and the rows' free columns (backgrounds, non-negative as every
    solve has them) best reproduce the features; None where the rows hold no data."""
    n, a, y = rows.n, rows.a, rows.y
    if rows.scale <= 0 or a.shape[0] == 0:
        return None
    free = a[:, n:]
    g_free = free.T @ free
    r_free = free.T @ y
    spectral = a[:, :n]
    yy = float(y @ y)

    def chi2(t: float) -> tuple[float, NDArray[np.float64], NDArray[np.float64]]:
        p = planck(WAVELENGTHS_NM, t)
        col = spectral @ p
        g = np.empty((free.shape[1] + 1,) * 2)
        g[0, 0] = col @ col
        g[0, 1:] = g[1:, 0] = free.T @ col
        g[1:, 1:] = g_free
        rhs = np.concatenate([[col @ y], r_free])
        g += 1e-12 * np.trace(g) / g.shape[0] * np.eye(g.shape[0])
        x = nnls_normal(g, rhs)
        return max(yy - 2 * float(x @ rhs) + float(x @ g @ x), 0.0), x, p

    values = _grid_chi2(spectral, free, g_free, r_free, y, yy, chi2)
    k = int(np.clip(np.argmin(values), 1, TEMPERATURES_K.size - 2))
    lt = np.log(TEMPERATURES_K[k - 1:k + 2])
    c = np.polyfit(lt, values[k - 1:k + 2], 2)
    t_best = float(np.exp(-c[1] / (2 * c[0]))) if c[0] > 0 else float(TEMPERATURES_K[k])
    t_best = float(np.clip(t_best, TEMPERATURES_K[k - 1], TEMPERATURES_K[k + 1]))
    best, x, p = chi2(t_best)
    if not best <= values[k]:
        best, x, p = chi2(float(TEMPERATURES_K[k]))
        t_best = float(TEMPERATURES_K[k])
    return PlanckFit(t_best, float(x[0]), best / a.shape[0], float(x[0]) * p)


def _grid_chi2(spectral: NDArray[np.float64], free: NDArray[np.float64], g_free: NDArray[np.float64],
               r_free: NDArray[np.float64], y: NDArray[np.float64], yy: float, chi2) -> NDArray[np.float64]:
    """χ² of every grid temperature, the non-negative fits solved in batches. The solution of a
    positive definite problem is fixed by which coefficients are positive (its pattern), and
    neighbouring temperatures share patterns: ``chi2``'s NNLS finds a pattern for one unsolved
    temperature, one batched solve tries it on all the others, and each takes it where the
    optimality (KKT) conditions hold. 4–6 NNLS calls instead of 121: the spectrum stage's 12 ms
    had 8 in them."""
    n_t = TEMPERATURES_K.size
    cols = spectral @ planck(WAVELENGTHS_NM, TEMPERATURES_K[:, None]).T  # (rows, temperatures)
    k = free.shape[1] + 1
    g = np.empty((n_t, k, k))
    g[:, 0, 0] = np.einsum("rt,rt->t", cols, cols)
    g[:, 0, 1:] = g[:, 1:, 0] = cols.T @ free
    g[:, 1:, 1:] = g_free
    rhs = np.concatenate([(cols.T @ y)[:, None], np.broadcast_to(r_free, (n_t, k - 1))], axis=1)
    g += (1e-12 * np.trace(g, axis1=1, axis2=2) / k)[:, None, None] * np.eye(k)
    values = np.full(n_t, np.nan)
    tol = 1e-10 * np.maximum(np.max(np.abs(rhs), axis=1), 1e-300)
    tried: set[tuple[bool, ...]] = set()
    pattern = np.ones(k, dtype=bool)  # the unconstrained solution first
    while True:
        key = tuple(bool(v) for v in pattern)
        todo = np.flatnonzero(np.isnan(values))
        if key not in tried and np.any(pattern):
            tried.add(key)
            sub = np.ix_(todo, np.flatnonzero(pattern), np.flatnonzero(pattern))
            try:
                xp = np.linalg.solve(g[sub], rhs[np.ix_(todo, np.flatnonzero(pattern))][..., None])[..., 0]
            except np.linalg.LinAlgError:
                xp = None
            if xp is not None:
                x = np.zeros((todo.size, k))
                x[:, pattern] = xp
                grad = np.einsum("tij,tj->ti", g[todo], x) - rhs[todo]
                ok = np.all(xp > 0, axis=1) & np.all(grad[:, ~pattern] >= -tol[todo, None], axis=1)
                values[todo[ok]] = np.maximum(yy - np.einsum("tk,tk->t", x[ok], rhs[todo[ok]]), 0.0)
                todo = todo[~ok]
        if todo.size == 0:
            return values
        value, x, _ = chi2(float(TEMPERATURES_K[todo[0]]))
        values[todo[0]] = value
        pattern = x > 0


def thermal_weight(fit: PlanckFit | None, settings: TailSettings) -> float:
    """How far the tails are the Planck curve's: 1 at χ²/row ≤ ``thermal_chi2``, 0 at ≥
    ``other_chi2``, linear between; 0 without a fit or above ``max_temperature_k``."""
    if fit is None or not fit.scale > 0 or not np.isfinite(fit.chi2_per_row):
        return 0.0
    if fit.temperature_k > settings.max_temperature_k:
        return 0.0
    lo, hi = settings.thermal_chi2, settings.other_chi2
    if fit.chi2_per_row <= lo:
        return 1.0
    return float(np.clip((hi - fit.chi2_per_row) / max(hi - lo, 1e-12), 0.0, 1.0))


def with_tails(spd: NDArray[np.float64], rows: Rows, settings: TailSettings | None, fit: PlanckFit | None = None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None, PlanckFit | None, float]:
    """``spd`` (the rows' units, or any positive multiple: it is put at the rows' brightness) with
    its blind tails replaced by the Planck continuation as far as the photo says the source is
    thermal: each tail is the fitted Planck curve's shape at the level the estimate has next to
    it (:data:`VIOLET_ANCHOR_NM`, :data:`RED_ANCHOR_NM`). Returns (SPD peak 1, the Planck tails at
    the same scale or None, the fit, the thermal weight). Without settings the SPD is returned as it is (peak 1). ``fit``: the rows'
    :func:`planck_fit` when already known (tuning tries many settings on one photo)."""
    spd = np.clip(np.nan_to_num(np.asarray(spd, dtype=np.float64), nan=0.0, posinf=0.0), 0.0, None)
    peak = float(spd.max())
    if settings is None or peak <= 0:
        return (spd / peak if peak > 0 else spd), None, None, 0.0
    fit = planck_fit(rows) if fit is None else fit
    q = thermal_weight(fit, settings)
    if fit is None or not fit.scale > 0:
        return spd / peak, None, fit, 0.0
    # The estimate at the brightness that reproduces the features (as the Planck fit is).
    spectral = rows.a[:, :rows.n]
    pred = spectral @ spd
    s = float(pred @ rows.y) / max(float(pred @ pred), 1e-300)
    e = spd * s if s > 0 else spd * (float(fit.spd.max()) / peak)
    out, tails = joined_tails(e, fit.spd, q)
    top = float(out.max())
    if not top > 0:
        return spd / peak, None, fit, 0.0
    return out / top, tails / top, fit, q


def joined_tails(spd: NDArray[np.float64], planck_spd: NDArray[np.float64], weight: float = 1.0
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``spd`` with each blind tail handed over (``weight`` × :func:`blind_weight`) to the Planck
    curve's shape at the level ``spd`` has in that side's anchor band; returns (the joined SPD,
    the two tails at that scale, 0 where the camera sees). One join for the product and for the
    bench's ceiling of Planck tails (training.evaluation.tails)."""
    lam = WAVELENGTHS_NM
    tails = np.zeros_like(spd)
    for ramp, anchor in ((VIOLET_RAMP_NM, VIOLET_ANCHOR_NM), (RED_RAMP_NM, RED_ANCHOR_NM)):
        side = (lam <= ramp[0]) if ramp[1] < ramp[0] else (lam >= ramp[0])
        sel = (lam >= anchor[0]) & (lam <= anchor[1])
        p = planck_spd[sel]
        k = float(p @ spd[sel]) / max(float(p @ p), 1e-300)
        tails[side] = (k if k > 0 else 1.0) * planck_spd[side]
    w = weight * blind_weight()
    return (1.0 - w) * spd + w * tails, tails


def widen_std(std: NDArray[np.float64], spd: NDArray[np.float64], planck_tail: NDArray[np.float64] | None,
              thermal: float) -> NDArray[np.float64]:
    """The uncertainty with the blind bands widened: at least a floor rising to :data:`BLIND_STD`
    into each band, and where the photo leaves it open whether the source is thermal
    (0 < ``thermal`` < 1) the disagreement of the two tails (the Planck curve and ``spd``);
    unchanged where the camera sees, and NaN (no uncertainty given) stays NaN."""
    std = np.asarray(std, dtype=np.float64)
    b = blind_weight()
    floor = BLIND_STD * b
    if planck_tail is not None and 0.0 < thermal < 1.0:
        floor = np.maximum(floor, b * np.abs(np.asarray(planck_tail, dtype=np.float64) - spd))
    return np.where(np.isfinite(std), np.maximum(std, floor), std)
