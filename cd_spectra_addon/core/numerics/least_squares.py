"""Small nonlinear least-squares tools for the pose fits (numpy only: no scipy in the add-on)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["levenberg_marquardt", "cauchy"]


def levenberg_marquardt(residuals, x0: NDArray[np.float64], steps: NDArray[np.float64], max_iter: int = 30,
                        jacobian: Callable[[NDArray[np.float64]], NDArray[np.float64]] | None = None,
                        tol: float = 1e-5) -> tuple[NDArray[np.float64], float, int]:
    """Minimise Σ r(x)² with the given ``jacobian`` or a forward-difference one (``steps``);
    returns (x, cost, evaluations).

    ``residuals`` must return a vector of fixed length and order whatever x is (each entry the
    same pixel or term), else the Jacobian is noise. Stops when a step improves the cost by less
    than ``tol`` (relative) or no step improves it."""
    x = x0.copy()
    r = residuals(x)
    cost = float(r @ r)
    evals = 1
    lam = 1e-2
    for _ in range(max_iter):
        if jacobian is not None:
            jac = jacobian(x)
            evals += 1
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


def cauchy(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cauchy loss as residuals: sqrt(log(1 + r²)), so outliers (second order, glare) barely pull."""
    return np.sign(r) * np.sqrt(np.log1p(r * r))
