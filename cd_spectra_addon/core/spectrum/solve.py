"""Physics-only inverse: regularised non-negative least squares against the forward matrix.

Rows are the valid (bin, channel) features weighted by their noise plus a model-error floor;
the prior is smoothness (second differences), which a lamp's narrow lines violate — the
learned correction (:mod:`.model`) is there for those. The result is in the photo's own
units (exposure included); callers peak-normalise.

Each solve has two faces: ``solve_*``/``blend_bands`` work on :class:`Rows` (one photo's, or
several photos' stacked by :mod:`.joint`), and ``*_solve``/``band_blend`` are the same solves on
one photo's readout and forward matrix — so a joint estimate of one photo is the single estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..numerics.nnls import nnls_normal
from ..spectra.grid import WAVELENGTHS_NM
from ..readout.readout import Readout

SMOOTHNESS = 3e-2  # relative to the data term's mean curvature (bench/solver_tuning.md, synthetic spectra)
MODEL_ERROR_FLOOR = 0.01  # features are trusted to 1 % of their peak at best
PRIOR_STRENGTH = 0.3  # weight of the Gaussian prior (1 = fully Bayesian); bench/solver_tuning.md
PRIOR_JITTER = 1e-3  # added to the prior covariance's diagonal before inverting
SCALE_BAND_NM = (420.0, 680.0)  # where every camera sees well: sets the prior's scale
# Narrow lines: prior variance added per bin, per unit² of the bin's excess over the estimate's
# running median of LINE_WINDOW bins (peak-normalised); bench/line_tuning.md, synthetic spectra.
LINE_ALLOWANCE = 0.3
LINE_WINDOW = 7

__all__ = ["SMOOTHNESS", "GaussianPrior", "Rows", "rows_for", "fused_solve", "photo_scale", "band_blend",
           "second_difference", "line_excess", "system", "physics_solve", "prior_solve", "solve_physics",
           "solve_prior", "solve_fused", "blend_bands", "rows_scale", "scale_to"]


@dataclass(frozen=True)
class GaussianPrior:
    """Mean and covariance of peak-normalised SPDs from the synthetic prior (never from lamps)."""

    mean: NDArray[np.float64]
    covariance: NDArray[np.float64]

    @classmethod
    def from_samples(cls, spds: NDArray[np.float64]) -> "GaussianPrior":
        return cls(np.mean(spds, axis=0), np.cov(np.asarray(spds, dtype=np.float64).T))

    def precision(self, jitter: float = PRIOR_JITTER) -> NDArray[np.float64]:
        n = self.mean.size
        return np.linalg.inv(self.covariance + jitter * np.eye(n))


def second_difference(n: int) -> NDArray[np.float64]:
    d = np.zeros((n - 2, n))
    idx = np.arange(n - 2)
    d[idx, idx], d[idx, idx + 1], d[idx, idx + 2] = 1.0, -2.0, 1.0
    return d


@dataclass(frozen=True)
class Rows:
    """The weighted rows of one solve: the SPD's ``n`` columns first, then free columns (per-photo
    backgrounds, and a joint solve's photo brightnesses) that no prior touches. Every solve below
    works on rows, so one photo and a stack of photos (:mod:`.joint`) share each solve."""

    a: NDArray[np.float64]  # (m, n + free)
    y: NDArray[np.float64]  # (m,)
    scale: float  # the peak feature; 0 where there is no usable data
    n: int

    @property
    def spectral(self) -> NDArray[np.float64]:
        return self.a[:, :self.n]


def rows_for(readout: Readout, matrix: NDArray[np.float64], gain: NDArray[np.float64] | None = None,
             background: bool = True, floor: NDArray[np.float64] | None = None,
             columns: NDArray[np.float64] | None = None) -> Rows:
    """Weighted rows of one photo's valid features (see :func:`system`)."""
    return Rows(*system(readout, matrix, gain, background, floor, columns), n=matrix.shape[-1])


def system(readout: Readout, matrix: NDArray[np.float64], gain: NDArray[np.float64] | None = None,
           background: bool = True, floor: NDArray[np.float64] | None = None,
           columns: NDArray[np.float64] | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """Weighted rows (A, y) of the valid features and the data scale (peak feature).

    With ``background`` the last six columns are ± a constant per channel: ambient light and the
    dark floor an integer photo gets from noise clipped at zero are flat in λ₁, unlike any
    lamp seen through a camera, so they separate cleanly instead of becoming a fake IR tail.
    ``floor`` (per bin) multiplies the model-error floor: a joint estimate trusts a photo's
    features at the edge of its tracks less where another photo reads those wavelengths well.
    ``columns`` (NB, 3, F): more free, non-negative unknowns in the features' units, after the
    backgrounds (how far a gamut-compressed colour lies out along its ray: :mod:`..calibration.censoring`).
    """
    values = readout.values if gain is None else readout.values / np.where(gain > 0, gain, 1.0)
    valid = readout.valid
    y = values[valid].reshape(-1)
    a = matrix[valid].reshape(-1, matrix.shape[-1])
    if background:
        channel = np.tile(np.eye(3), (int(valid.sum()), 1))
        a = np.concatenate([a, channel, -channel], axis=1)
    if columns is not None:
        a = np.concatenate([a, np.asarray(columns, np.float64)[valid].reshape(y.size, -1)], axis=1)
    scale = float(np.max(np.abs(y))) if y.size else 0.0
    if scale <= 0:
        return a, y, 0.0
    noise = readout.noise[valid].reshape(-1)
    model_error = MODEL_ERROR_FLOOR * scale
    if floor is not None:
        model_error = model_error * np.repeat(floor[valid], 3)
    sigma = np.sqrt(noise ** 2 + model_error ** 2)
    return a / sigma[:, None], y / sigma, scale


def solve_physics(rows: Rows, smoothness: float = SMOOTHNESS) -> NDArray[np.float64]:
    """Non-negative x (the SPD's n values, then the free columns) minimising ‖A x − y‖² +
    λ‖D₂E‖², λ scaled to the data; zeros where there is no data."""
    n, a, y = rows.n, rows.a, rows.y
    if rows.scale <= 0 or a.shape[0] == 0:
        return np.zeros(a.shape[1])
    gram = a.T @ a
    d2 = second_difference(n)
    reg = np.zeros_like(gram)
    reg[:n, :n] = d2.T @ d2
    lam = smoothness * np.trace(gram[:n, :n]) / np.trace(reg[:n, :n])
    ridge = 1e-9 * np.trace(gram[:n, :n]) / n
    return nnls_normal(gram + lam * reg + ridge * np.eye(gram.shape[0]), a.T @ y)


def line_excess(spd: NDArray[np.float64], window: int = LINE_WINDOW) -> NDArray[np.float64]:
    """How far each bin stands above the running median of ``window`` bins around it (≥ 0):
    a narrow line's bins stand out, a continuum or a band wider than the window does not."""
    spd = np.asarray(spd, dtype=np.float64)
    half = window // 2
    padded = np.pad(spd, half, mode="edge")
    median = np.median(np.lib.stride_tricks.sliding_window_view(padded, window), axis=-1)
    return np.clip(spd - median, 0.0, None)


def _prior_map(data: tuple[NDArray[np.float64], NDArray[np.float64]], n: int, prior: GaussianPrior, strength: float,
               prec: NDArray[np.float64], s: float) -> NDArray[np.float64]:
    """The non-negative MAP solve with the prior at scale ``s`` (the photo's units per peak),
    from the rows' normal equations ``data`` = (AᵀA, Aᵀy), which it leaves as they are."""
    gram, rhs = data[0].copy(), data[1].copy()
    gram[:n, :n] += strength * prec / (s * s)
    rhs[:n] += strength * (prec @ prior.mean) / s
    gram += 1e-12 * np.trace(gram[:n, :n]) / n * np.eye(gram.shape[0])
    return nnls_normal(gram, rhs)


def solve_prior(rows: Rows, prior: GaussianPrior, strength: float = PRIOR_STRENGTH,
                precision: NDArray[np.float64] | None = None, smoothness: float = SMOOTHNESS,
                lines: float = 0.0, window: int = LINE_WINDOW) -> NDArray[np.float64]:
    """x of :func:`solve_physics` under the Gaussian prior (see :func:`prior_solve`).

    With ``lines`` > 0, a second pass lets narrow lines be as narrow as the photo says. The
    Gaussian prior has one covariance for every lamp, so it spreads a line the photo resolves
    into its neighbours (a fluorescent tube's 436 nm line read at 0.35 / 1.52 / 0.44 of the
    continuum's level where it is 0.07 / 2.0 / 0.08 - its energy right, its peak, and so every
    peak-normalised value, 30 % off). Each bin's variance grows by ``lines`` × its excess over
    the first pass's running median (squared, peak-normalised): a sparse-Bayesian step.
    A smooth spectrum's bins barely stand out, so its solve barely moves (CIE A, D65 and a
    white LED within 0.002 MAE in tests/test_tails.py).
    """
    n = rows.n
    first = solve_physics(rows, smoothness)
    spd = first[:n]
    band = (WAVELENGTHS_NM >= SCALE_BAND_NM[0]) & (WAVELENGTHS_NM <= SCALE_BAND_NM[1])
    s = float(spd[band].max()) or float(spd.max())
    if s <= 0:
        return first
    prec = prior.precision() if precision is None else precision
    data = (rows.a.T @ rows.a, rows.a.T @ rows.y)
    x = _prior_map(data, n, prior, strength, prec, s)
    if lines <= 0:
        return x
    s2 = float(x[:n][band].max())
    excess = line_excess(x[:n] / s2, window) if s2 > 0 else np.zeros(n)
    if not np.any(excess > 0):
        return x
    cov = prior.covariance + np.diag(lines * excess * excess) + PRIOR_JITTER * np.eye(n)
    return _prior_map(data, n, prior, strength, np.linalg.inv(cov), s2)


def physics_solve(readout: Readout, matrix: NDArray[np.float64], smoothness: float = SMOOTHNESS,
                  gain: NDArray[np.float64] | None = None, background: bool = True) -> NDArray[np.float64]:
    """Non-negative SPD (81,) minimising ‖A E − y‖² + λ‖D₂E‖² (λ scaled to the data), with
    free per-channel background terms (see :func:`system`)."""
    return solve_physics(rows_for(readout, matrix, gain, background), smoothness)[:matrix.shape[-1]]


def prior_solve(readout: Readout, matrix: NDArray[np.float64], prior: GaussianPrior,
                strength: float = PRIOR_STRENGTH, gain: NDArray[np.float64] | None = None,
                precision: NDArray[np.float64] | None = None, smoothness: float = SMOOTHNESS
                ) -> NDArray[np.float64]:
    """Non-negative MAP estimate under the Gaussian prior (a Wiener-style solve).

    The photo's scale is unknown, so the smoothness solve first sets it from the band every
    camera sees well; the prior then fills what the camera cannot see (its blind tails) with
    what lamps usually do there, instead of extrapolating a curve into the dark.
    """
    return solve_prior(rows_for(readout, matrix, gain), prior, strength, precision, smoothness)[:matrix.shape[-1]]


def scale_to(a: NDArray[np.float64], y: NDArray[np.float64], spd: NDArray[np.float64]) -> float:
    """Least-squares factor that makes ``spd`` reproduce the weighted features ``y``."""
    pred = a @ spd
    return float(pred @ y) / max(float(pred @ pred), 1e-300)


def rows_scale(rows: Rows, spd: NDArray[np.float64]) -> float:
    """The factor that puts a peak-normalised SPD into the rows' units; 0 where they cannot tell."""
    if rows.scale <= 0 or rows.a.shape[0] == 0:
        return 0.0
    s = scale_to(rows.spectral, rows.y, np.clip(np.asarray(spd, dtype=np.float64), 0.0, None))
    return s if s > 0 else 0.0


def photo_scale(readout: Readout, matrix: NDArray[np.float64], spd: NDArray[np.float64],
                gain: NDArray[np.float64] | None = None) -> float:
    """The factor that puts a peak-normalised SPD into the photo's units (what the features say
    its brightness is); 0 where the photo cannot tell."""
    return rows_scale(rows_for(readout, matrix, gain, background=False), spd)


def band_blend(readout: Readout, matrix: NDArray[np.float64], learned: NDArray[np.float64],
               physics: NDArray[np.float64], weight: NDArray[np.float64], gain: NDArray[np.float64] | None = None
               ) -> NDArray[np.float64]:
    """w(λ)·learned + (1 − w(λ))·physics, non-negative and peak-normalised (see :func:`blend_bands`)."""
    return blend_bands(rows_for(readout, matrix, gain, background=False), learned, physics, weight)


def blend_bands(rows: Rows, learned: NDArray[np.float64], physics: NDArray[np.float64],
                weight: NDArray[np.float64]) -> NDArray[np.float64]:
    """w(λ)·learned + (1 − w(λ))·physics, non-negative and peak-normalised.

    Each estimate is first put at the brightness that best reproduces the photo's features, so
    their levels agree wherever both are right and a band taken from one joins the other without
    a jump (peak-normalising each would not: a line's peak in one and a smooth bump in the other
    set different scales). The weight comes with the model: 1 where the learned stage beat
    physics + prior on synthetic photos, 0 where it did not, with smooth transitions."""
    w = np.clip(np.asarray(weight, dtype=np.float64), 0.0, 1.0)
    parts = []
    for spd in (learned, physics):
        spd = np.nan_to_num(np.clip(np.asarray(spd, dtype=np.float64), 0.0, None), nan=0.0, posinf=0.0)
        peak = float(spd.max())
        parts.append(spd / peak if peak > 0 else spd)
    scales = [rows_scale(rows, p) for p in parts]
    if all(sc > 0 for sc in scales):
        parts = [p * sc for p, sc in zip(parts, scales)]
    out = w * parts[0] + (1.0 - w) * parts[1]
    peak = float(out.max())
    return out / peak if peak > 0 else out


def fused_solve(readout: Readout, matrix: NDArray[np.float64], mean: NDArray[np.float64], std: NDArray[np.float64],
                strength: float, floor: float, gain: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Non-negative MAP estimate with the learned model's SPD and uncertainty as the prior
    (see :func:`solve_fused`)."""
    return solve_fused(rows_for(readout, matrix, gain), mean, std, strength, floor)


def solve_fused(rows: Rows, mean: NDArray[np.float64], std: NDArray[np.float64], strength: float,
                floor: float) -> NDArray[np.float64]:
    """Non-negative MAP estimate with the learned model's SPD and uncertainty as the prior.

    The network knows what lamps look like where the camera is nearly blind; the photo knows
    the colour exactly where it sees. Weighting the network's guess by its own uncertainty (not
    below ``floor``, peak-normalised units) and solving against the features keeps the estimate
    consistent with the photo — the physics decides where the data is strong.
    """
    n, a, y = rows.n, rows.a, rows.y
    mean = np.clip(np.asarray(mean, dtype=np.float64), 0.0, None)
    if rows.scale <= 0 or a.shape[0] == 0 or mean.max() <= 0:
        return mean
    s = scale_to(a[:, :n], y, mean)
    if not s > 0:
        return mean
    sig = np.maximum(np.asarray(std, dtype=np.float64), floor) * s
    gram = a.T @ a
    rhs = a.T @ y
    gram[:n, :n] += strength * np.diag(1.0 / sig ** 2)
    rhs[:n] += strength * (mean * s) / sig ** 2
    gram += 1e-12 * np.trace(gram[:n, :n]) / n * np.eye(gram.shape[0])
    return nnls_normal(gram, rhs)[:n]
