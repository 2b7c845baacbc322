"""Non-negative least squares on the normal equations (Lawson & Hanson's active set), numpy only.

Blender's Python has no scipy. The spectral problems here have 81 unknowns, so working on the
81 × 81 normal matrix makes each active-set step a tiny dense solve.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["nnls_normal"]


def nnls_normal(gram: NDArray[np.float64], rhs: NDArray[np.float64], max_iter: int | None = None,
                tol: float = 1e-10, warm: bool = True) -> NDArray[np.float64]:
    """argmin_x ½xᵀGx − rᵀx subject to x ≥ 0, for a symmetric positive (semi)definite G.

    ``warm`` starts from the variables the unconstrained solution keeps positive (after the
    usual feasibility step), which usually leaves only a few active-set moves instead of one
    per variable; the optimality test at the end is the same, so the answer is too.
    """
    n = rhs.size
    max_iter = max_iter or 5 * n
    x = np.zeros(n)
    passive = np.zeros(n, dtype=bool)
    scale = max(float(np.max(np.abs(rhs))), 1e-300)
    if warm:
        try:
            z = np.linalg.solve(gram, rhs)
        except np.linalg.LinAlgError:
            z = np.zeros(n)
        start = z > 0
        while np.any(start):
            idx = np.flatnonzero(start)
            try:
                sub = np.linalg.solve(gram[np.ix_(idx, idx)], rhs[idx])
            except np.linalg.LinAlgError:
                break
            if np.all(sub > 0):
                x[idx] = sub
                passive = start
                break
            start[idx[sub <= 0]] = False
    for _ in range(max_iter):
        grad = rhs - gram @ x  # negative gradient
        free = ~passive & (grad > tol * scale)
        if not np.any(free):
            break
        passive[np.argmax(np.where(free, grad, -np.inf))] = True
        while True:
            idx = np.flatnonzero(passive)
            z = np.zeros(n)
            try:
                z[idx] = np.linalg.solve(gram[np.ix_(idx, idx)], rhs[idx])
            except np.linalg.LinAlgError:
                z[idx] = np.linalg.lstsq(gram[np.ix_(idx, idx)], rhs[idx], rcond=None)[0]
            if np.all(z[idx] > 0):
                x = z
                break
            neg = idx[z[idx] <= 0]
            alpha = np.min(x[neg] / np.maximum(x[neg] - z[neg], 1e-300))
            x = x + alpha * (z - x)
            passive &= x > tol * max(float(x.max()), 1e-300)
            x[~passive] = 0.0
    return np.maximum(x, 0.0)
