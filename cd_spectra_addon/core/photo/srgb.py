"""The sRGB transfer function (IEC 61966-2-1), both ways, for 8/16-bit photo files.

Its constants live here once: every other use of the curve (the camera pipeline's fit needs
its slope) calls these functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SRGB_LINEAR_KNEE", "SRGB_ENCODED_KNEE", "SRGB_TOE_SLOPE", "SRGB_GAMMA", "SRGB_SCALE", "SRGB_OFFSET",
           "srgb_encode", "srgb_decode", "srgb_encode_slope"]

SRGB_LINEAR_KNEE = 0.0031308  # linear value where the straight toe meets the power curve
SRGB_ENCODED_KNEE = 0.04045  # the same point, encoded (IEC's rounded 12.92 × 0.0031308)
SRGB_TOE_SLOPE = 12.92
SRGB_GAMMA = 2.4
SRGB_SCALE = 1.055  # encoded = SCALE · linear^(1/GAMMA) − OFFSET above the knee
SRGB_OFFSET = 0.055


def srgb_encode(linear: ArrayLike) -> NDArray[np.float64]:
    """Linear [0, 1] → sRGB-encoded [0, 1] (values outside are clipped first)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= SRGB_LINEAR_KNEE, SRGB_TOE_SLOPE * x,
                    SRGB_SCALE * np.power(x, 1.0 / SRGB_GAMMA) - SRGB_OFFSET)


def srgb_decode(encoded: ArrayLike) -> NDArray[np.float64]:
    """sRGB-encoded [0, 1] → linear [0, 1]."""
    y = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(y <= SRGB_ENCODED_KNEE, y / SRGB_TOE_SLOPE,
                    np.power((y + SRGB_OFFSET) / SRGB_SCALE, SRGB_GAMMA))


def srgb_encode_slope(linear: ArrayLike) -> NDArray[np.float64]:
    """d srgb_encode / d linear for linear values in [0, 1] (not clipped: the caller masks
    what lies outside). Finite at 0, where the toe's slope applies."""
    x = np.asarray(linear, dtype=np.float64)
    return np.where(x <= SRGB_LINEAR_KNEE, SRGB_TOE_SLOPE,
                    (SRGB_SCALE / SRGB_GAMMA) * np.power(np.maximum(x, 1e-12), 1 / SRGB_GAMMA - 1))
