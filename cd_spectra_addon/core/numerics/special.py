"""Special functions the core needs, vectorised and numpy-only (Blender's Python has no scipy).

- :func:`erf` / :func:`erfc`: Numerical Recipes' Chebyshev fit of erfc, fractional error
  < 1.2e-7 — below float32 and far below render noise. The grating integrates its Gaussian
  lobes with :func:`erf`; the training prior hat-integrates its lines with :func:`erfc`.
- :func:`norm_ppf`: the inverse standard normal CDF Φ⁻¹ (Acklam's rational approximation,
  |error| < 1.2e-9); the readout uses it to undo noise clipped at zero.
- :data:`FWHM_PER_SIGMA`: a Gaussian's full width at half maximum in standard deviations.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["FWHM_PER_SIGMA", "erf", "erfc", "norm_ppf"]

FWHM_PER_SIGMA = 2.0 * math.sqrt(2.0 * math.log(2.0))  # 2.35482…


def _erfc_of_abs(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """erfc(|x|) by the Chebyshev fit (Numerical Recipes, 2nd ed., §6.2)."""
    z = np.abs(x)
    t = 1.0 / (1.0 + 0.5 * z)
    poly = -z * z - 1.26551223 + t * (1.00002368 + t * (0.37409196 + t * (0.09678418 + t * (
        -0.18628806 + t * (0.27886807 + t * (-1.13520398 + t * (1.48851587 + t * (
            -0.82215223 + t * 0.17087277))))))))
    return t * np.exp(poly)


def erfc(x: ArrayLike) -> NDArray[np.float64]:
    """Complementary error function 1 − erf(x), elementwise (fractional error < 1.2e-7)."""
    x = np.asarray(x, dtype=np.float64)
    r = _erfc_of_abs(x)
    return np.where(x >= 0, r, 2.0 - r)


def erf(x: ArrayLike) -> NDArray[np.float64]:
    """Error function, elementwise (absolute error < 1.2e-7)."""
    x = np.asarray(x, dtype=np.float64)
    r = _erfc_of_abs(x)
    return np.where(x >= 0, 1.0 - r, r - 1.0)


_A = (-3.969683028665376e01, 2.209460984245205e02, -2.759285104469687e02, 1.383577518672690e02,
      -3.066479806614716e01, 2.506628277459239e00)
_B = (-5.447609879822406e01, 1.615858368580409e02, -1.556989798598866e02, 6.680131188771972e01,
      -1.328068155288572e01)
_C = (-7.784894002430293e-03, -3.223964580411365e-01, -2.400758277161838e00, -2.549732539343734e00,
      4.374664141464968e00, 2.938163982698783e00)
_D = (7.784695709041462e-03, 3.224671290700398e-01, 2.445134137142996e00, 3.754408661907416e00)
_P_LOW = 0.02425  # below (and above 1 − this) the tail formula, between them the central one


def norm_ppf(p: ArrayLike) -> NDArray[np.float64]:
    """Inverse standard normal CDF Φ⁻¹(p), elementwise (Acklam's rational approximation,
    |error| < 1.2e-9); p is clipped to [1e-12, 1 − 1e-12], so the result stays finite."""
    a, b, c, d = _A, _B, _C, _D
    p = np.clip(np.asarray(p, dtype=np.float64), 1e-12, 1 - 1e-12)
    out = np.empty_like(p)
    low, high = p < _P_LOW, p > 1 - _P_LOW
    mid = ~(low | high)
    q = np.sqrt(-2 * np.log(np.where(low, p, 0.5)))
    num = ((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]
    den = (((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1
    out[low] = (num / den)[low]
    q = np.sqrt(-2 * np.log(np.where(high, 1 - p, 0.5)))
    num = ((((c[0] * q + c[1]) * q + c[2]) * q + c[3]) * q + c[4]) * q + c[5]
    den = (((d[0] * q + d[1]) * q + d[2]) * q + d[3]) * q + 1
    out[high] = -(num / den)[high]
    q = p - 0.5
    r = q * q
    num = (((((a[0] * r + a[1]) * r + a[2]) * r + a[3]) * r + a[4]) * r + a[5]) * q
    den = ((((b[0] * r + b[1]) * r + b[2]) * r + b[3]) * r + b[4]) * r + 1
    out[mid] = (num / den)[mid]
    return out
