"""Small nonlinear least-squares tools (numpy only: no scipy in the add-on).

:func:`levenberg_marquardt` is the one damped Gauss–Newton solver of the core: the pose fits
give it finite-difference steps, the camera pipeline's fit an analytic Jacobian.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["levenberg_marquardt", "valley_step", "cauchy"]

Vector = NDArray[np.float64]


def levenberg_marquardt(residuals: Callable[[Vector], Vector], x0: Vector, steps: Vector | None = None,
                        max_iter: int = 30, *, jacobian: Callable[[Vector], NDArray[np.float64]] | None = None,
                        tol: float = 1e-5) -> tuple[Vector, float, int]:
    """Minimise Σ r(x)²; returns (x, cost, residual evaluations).

    The Jacobian is ``jacobian(x)`` where given, else forward differences with ``steps`` (one
    per parameter). ``residuals`` must then return a vector of fixed length and order whatever
    x is (each entry the same pixel or term), else the Jacobian is noise.

    Each iteration solves (JᵀJ + λ·(diag JᵀJ + 1e-9))·δ = −Jᵀr. Marquardt's scaling by diag JᵀJ
    makes the step independent of the parameters' units. λ starts at 1e-2. An improving step
    is taken and λ divided by 3 (down to 1e-6). A worse one (NaN included) multiplies λ by 4,
    and a singular system by 10, up to 8 tries per iteration. The fit stops after
    ``max_iter`` iterations, when no try improves, or when the relative improvement of the
    cost falls below ``tol``.
    """
    if (jacobian is None) == (steps is None):
        raise ValueError("levenberg_marquardt needs either finite-difference steps or a jacobian")
    x = np.array(x0, copy=True)
    r = residuals(x)
    cost = float(r @ r)
    evals = 1
    lam = 1e-2
    for _ in range(max_iter):
        if jacobian is not None:
            jac = jacobian(x)
        else:
            jac = np.empty((r.size, x.size))
            for k in range(x.size):
                dx = np.zeros_like(x)
                dx[k] = steps[k]
                jac[:, k] = (residuals(x + dx) - r) / steps[k]
            evals += x.size
        jtj = jac.T @ jac
        g = jac.T @ r
        improved = False
        for _ in range(8):
            a = jtj + lam * np.diag(np.diag(jtj) + 1e-9)
            try:
                delta = -np.linalg.solve(a, g)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            r_new = residuals(x + delta)
            evals += 1
            c_new = float(r_new @ r_new)
            if c_new < cost:
                x, r, improved = x + delta, r_new, True
                rel = (cost - c_new) / max(cost, 1e-300)
                cost = c_new
                lam = max(lam / 3, 1e-6)
                break
            lam *= 4
        if not improved or rel < tol:
            break
    return x, cost, evals


def valley_step(cost: Callable[[Vector], float], x: Vector, cost_x: float, jacobian: NDArray[np.float64],
                step: float, reach: float, gain: float) -> Vector | None:
    """A point further down the valley a least-squares fit stopped in at ``x``, or None.

    LM creeps along a long, flat valley with tiny relative gains, so its tolerance ends it early.
    The valley's direction is the least eigenvector of JᵀJ (``jacobian`` at or near ``x``) scaled
    by its diagonal, normalised to a largest component of 1. ``cost`` is tried ``step`` either
    way; where one side is lower than ``cost_x`` by the relative ``gain``, the step doubles while
    the cost keeps falling, up to ``reach``. Two evaluations where x sits at the valley's bottom.
    """
    jtj = jacobian.T @ jacobian
    scale = np.sqrt(np.diag(jtj))
    if not np.all(np.isfinite(jtj)) or not np.all(scale > 0):
        return None
    _, vectors = np.linalg.eigh(jtj / np.outer(scale, scale))
    direction = vectors[:, 0] / scale
    direction /= np.max(np.abs(direction))
    tries = {t: cost(x + t * direction) for t in (-step, step)}
    t = min(tries, key=lambda k: tries[k])
    if not tries[t] < (1.0 - gain) * cost_x:
        return None
    while abs(t) < reach:
        further = cost(x + 2.0 * t * direction)
        if not further < tries[t]:
            break
        t *= 2.0
        tries[t] = further
    return x + t * direction


def cauchy(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cauchy loss as residuals: sqrt(log(1 + r²)), so outliers (second order, glare) barely pull."""
    return np.sign(r) * np.sqrt(np.log1p(r * r))
