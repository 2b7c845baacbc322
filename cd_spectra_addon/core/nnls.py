"""Non-negative least squares on the normal equations (Lawson & Hanson's active set), numpy only.

Blender's Python has no scipy. The spectral problems here have 81 unknowns, so working on the
81 × 81 normal matrix makes each active-set step a tiny dense solve.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["nnls_normal"]


def nnls_normal(gram: NDArray[np.float64], rhs: NDArray[np.float64], max_iter: int | None = None,
                tol: float = 1e-10) -> NDArray[np.float64]:
    """argmin_x ½xᵀGx − rᵀx subject to x ≥ 0, for a symmetric positive (semi)definite G."""
    n = rhs.size
    max_iter = max_iter or 5 * n
    x = np.zeros(n)
    passive = np.zeros(n, dtype=bool)
    scale = max(float(np.max(np.abs(rhs))), 1e-300)
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
