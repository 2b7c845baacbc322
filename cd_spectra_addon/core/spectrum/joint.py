"""One SPD from several photos of the same lamp, each at its own unknown brightness.

Every photo sees the lamp through its own capture (its forward matrix) and at its own
brightness: exposure, camera gain and the lamp's distance multiply all of its features by one
factor s_k. The photos' weighted rows (:func:`.solve.rows_for`) are stacked, each photo with its
own background columns, and the SPD is solved from all of them by the same solve that reads one
photo (:func:`.solve.solve_physics`, :func:`.solve.solve_prior`, ...).

The brightnesses are fitted with the SPD, by Gauss–Newton steps on the photos' own residuals
y_k − s_k A_k E − c_k: around the current (s, E₀), s_k A_k E ≈ s_k A_k E + δ_k A_k E₀ is linear
in (E, δ, c), so each step is one solve of the stacked rows with a column ±A_k E₀ per photo
(the reference photo is held at s = 1: the SPD's overall scale is free anyway), and a few steps
settle the scales. Two simpler schemes fail here: alternating (scales from the SPD, then the SPD
from the scales) crawls when the photos overlap little in wavelength, since each photo's part
of the SPD is fitted by that photo alone and its scale hardly moves per round; and solving for
1/s_k linearly (y_k/s_k = A_k E + c_k) lets a photo's data shrink with its scale, which the
smoothness and prior terms reward — on two complementary synthetic photos the second photo's
scale ran away to 0. The SPD is then solved once more from the rows stacked at those scales.

One photo has no brightness to fit: its stacked rows are its own rows, so the joint solve of
one photo is exactly the single-photo solve. Exposure does not matter: a photo 3× brighter has
3× its features and noise, so its scale comes out 3× and its weighted rows are unchanged.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .solve import Rows, rows_scale

SCALE_TOLERANCE = 1e-10  # relative change of every photo's brightness at which the solve stops
MAX_ROUNDS = 50
DAMPING = 0.1  # of the data's curvature along a brightness step
# The model-error floor of features 0, 1, 2, 3 bins from the edge of a photo's tracks, where
# another photo reads them further in (see edge_floors): about the measured error ÷ the floor.
EDGE_FACTORS = np.array([5.0, 5.0, 3.0, 1.5])

Solve = Callable[[Rows], NDArray[np.float64]]  # rows → x (the SPD's n values, then the free columns)

__all__ = ["JointSolve", "joint_solve", "stacked_rows", "usable", "edge_floors", "SCALE_TOLERANCE"]


@dataclass(frozen=True)
class JointSolve:
    """The SPD (in the reference photo's units) and what was fitted around it."""

    spd: NDArray[np.float64]  # (n,)
    scales: NDArray[np.float64]  # (K,) each photo's brightness relative to the reference; 0 = not used
    rows: Rows  # the stacked rows at those brightnesses (the SPD's last solve)
    reference: int  # the photo held at brightness 1 (-1: none usable)
    rounds: int  # solves spent finding the brightnesses
    converged: bool


def edge_floors(valid: Sequence[NDArray[np.bool_]]) -> list[NDArray[np.float64] | None]:
    """Per photo, what its features' model-error floor is multiplied by (None: nothing).

    A photo's features within a few bins of the edge of its tracks (the data area's inner or
    outer radius, where a pixel's footprint straddles the edge) are off by several times the
    floor: on synthetic photos of 48 spectra at 150, 210 and 300 mm, the true SPD missed the
    features 0–2 bins from an edge by 4.5–6.9 % of the peak (median; 150 and 300 mm) against
    0.2–0.9 % further in. One photo has nothing better there; in a joint estimate another photo
    may read those wavelengths away from its own edges, and then it should decide them. Ends of
    the feature grid are not edges, and a bin no other photo reads well keeps its weight — so
    one photo, or the same photo twice, is solved exactly as alone."""
    edge = [_edge_distance(v) for v in valid]
    out: list[NDArray[np.float64] | None] = []
    for k, dist in enumerate(edge):
        inner = np.zeros(dist.size, dtype=bool)
        for j, other in enumerate(edge):
            if j != k:
                inner |= other >= len(EDGE_FACTORS)
        near = inner & (dist >= 0) & (dist < len(EDGE_FACTORS))
        factor = np.where(near, EDGE_FACTORS[np.clip(dist, 0, len(EDGE_FACTORS) - 1)], 1.0)
        out.append(factor if np.any(factor > 1.0) else None)
    return out


def _edge_distance(valid: NDArray[np.bool_]) -> NDArray[np.int64]:
    """Per bin, how many valid bins lie between it and the nearest edge of its run of valid bins
    (a large number at the grid's own ends; -1 where the bin is not valid)."""
    valid = np.asarray(valid, dtype=bool)
    size = valid.size
    far = size + 1
    left = np.full(size, -1, dtype=np.int64)
    right = np.full(size, -1, dtype=np.int64)
    run = far
    for i in range(size):  # bins since the run started (far when it started at the grid's end)
        run = (far if i == 0 else run + 1 if valid[i - 1] else 0) if valid[i] else -1
        left[i] = run
    run = far
    for i in range(size - 1, -1, -1):
        run = (far if i == size - 1 else run + 1 if valid[i + 1] else 0) if valid[i] else -1
        right[i] = run
    return np.where(valid, np.minimum(left, right), -1)


def usable(rows: Rows) -> bool:
    """Whether a photo's rows can take part: some features, a positive scale, all finite."""
    return bool(rows.scale > 0 and rows.a.shape[0] > 0 and np.all(np.isfinite(rows.a))
                and np.all(np.isfinite(rows.y)))


def stacked_rows(photos: Sequence[Rows], scales: Sequence[float], weights: Sequence[float] | None = None,
                 tangent: NDArray[np.float64] | None = None, reference: int = -1
                 ) -> tuple[Rows, NDArray[np.float64]]:
    """The photos with a positive scale stacked, and the units of their brightness columns.

    Each photo's rows × √weight, its spectral and its own free (background) columns × its scale
    (so its background keeps the weight against its spectrum that it has on its own). With
    ``tangent`` (the current SPD), every photo but ``reference`` also gets a column A_k·tangent
    for its new brightness, the old one's share moved to the right-hand side (a Gauss–Newton
    step); each such column is normalised to the spectral columns' mean square, so the solves'
    tiny ridge does not hold the step back, and the returned units turn its value into the
    brightness."""
    used = [k for k, s in enumerate(scales) if s > 0]
    if not used:
        n = photos[0].n if photos else 0
        return Rows(np.zeros((0, n)), np.zeros(0), 0.0, n), np.zeros(0)
    w = np.ones(len(photos)) if weights is None else np.asarray(weights, dtype=np.float64)
    if len(used) == 1 and tangent is None and scales[used[0]] == 1.0 and w[used[0]] == 1.0:
        return photos[used[0]], np.zeros(0)  # one photo: its own rows, exactly
    n = photos[used[0]].n
    free = [photos[k].a.shape[1] - n for k in used]
    steps = [k for k in used if k != reference] if tangent is not None else []
    m = sum(photos[k].a.shape[0] for k in used)
    first_step = n + sum(free)
    a = np.zeros((m, first_step + len(steps)))
    y = np.zeros(m)
    row, col = 0, n
    spans = []
    for k, extra in zip(used, free):
        rows = photos[k]
        r = slice(row, row + rows.a.shape[0])
        root = float(np.sqrt(w[k]))
        a[r, :n] = rows.a[:, :n] * (scales[k] * root)
        a[r, col:col + extra] = rows.a[:, n:] * (scales[k] * root)
        y[r] = rows.y * root
        spans.append((r, slice(col, col + extra)))
        row, col = r.stop, col + extra
    # The solves' ridge is a share of the whole stack's spectral weight; each photo's free
    # columns are scaled up by as much as the stack outweighs the photo, so that ridge holds its
    # background exactly as it does when the photo is solved alone (a photo given twice is then
    # solved exactly as once).
    total = float(np.sum(a[:, :n] ** 2))
    for r, c in spans:
        own = float(np.sum(a[r, :n] ** 2))
        if own > 0:
            a[r, c] *= np.sqrt(total / own)
    units = np.zeros(len(steps))
    if steps:
        spectral_ms = float(np.sum(a[:, :n] ** 2)) / n
        row = 0
        for k in used:
            rows = photos[k]
            r = slice(row, row + rows.a.shape[0])
            row = r.stop
            if k not in steps:
                continue
            j = steps.index(k)
            column = rows.a[:, :n] @ tangent * float(np.sqrt(w[k]))
            norm = float(np.sqrt(column @ column))
            units[j] = np.sqrt(spectral_ms) / norm if norm > 0 else 1.0
            y[r] += scales[k] * column  # the old brightness' share: the column carries the new one
            a[r, first_step + j] = column * units[j]
        # Levenberg–Marquardt damping: a row per step that holds the brightness where it is, as
        # strongly as DAMPING of what the data say about it. Where the photos share too little
        # of the spectrum to tell their brightness apart, the data say nothing and the step stops.
        damp = np.zeros((len(steps), a.shape[1]))
        damp[np.arange(len(steps)), first_step + np.arange(len(steps))] = np.sqrt(DAMPING * spectral_ms)
        a = np.concatenate([a, damp])
        y = np.concatenate([y, np.sqrt(DAMPING * spectral_ms) * np.asarray([scales[k] for k in steps]) / units])
    return Rows(a, y, max(photos[k].scale for k in used), n), units


def joint_solve(photos: Sequence[Rows], solve: Solve, weights: Sequence[float] | None = None) -> JointSolve:
    """One SPD from every usable photo's rows, with each photo's brightness (see the module doc).
    ``weights`` (default 1) scale each photo's say; a photo that is not :func:`usable` (or has
    weight 0) gets brightness 0 and no say."""
    n = photos[0].n if photos else 0
    ok = [k for k in range(len(photos)) if usable(photos[k]) and (weights is None or weights[k] > 0)]
    scales = np.zeros(len(photos))
    if not ok:
        return JointSolve(np.zeros(n), scales, stacked_rows(photos, scales)[0], -1, 0, True)
    # The reference: the photo with the most features (the SPD comes out in its units).
    reference = max(ok, key=lambda k: (photos[k].a.shape[0], -k))
    scales[reference] = 1.0
    others = [k for k in ok if k != reference]
    rounds, converged = 0, not others
    if others:  # the start: what the reference's SPD says each photo's brightness is
        spd = solve(photos[reference])[:n]
        for k in others:
            scales[k] = rows_scale(photos[k], spd) or photos[k].scale / photos[reference].scale
    while not converged and rounds < MAX_ROUNDS:
        rounds += 1
        rows, units = stacked_rows(photos, scales, weights, spd, reference)
        x = solve(rows)
        spd = x[:n]
        # A brightness may drop at most 10× per step (the solve keeps it ≥ 0).
        new = np.maximum(x[rows.a.shape[1] - len(others):] * units, 0.1 * scales[others])
        change = float(np.max(np.abs(new / scales[others] - 1.0)))
        scales[others] = new
        converged = change < SCALE_TOLERANCE
    rows = stacked_rows(photos, scales, weights)[0]
    return JointSolve(solve(rows)[:n], scales, rows, reference, rounds, converged)
