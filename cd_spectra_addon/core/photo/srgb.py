"""The sRGB transfer function (IEC 61966-2-1), both ways, for 8/16-bit photo files."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["srgb_encode", "srgb_decode"]


def srgb_encode(linear: ArrayLike) -> NDArray[np.float64]:
    """Linear [0, 1] → sRGB-encoded [0, 1] (values outside are clipped first)."""
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded: ArrayLike) -> NDArray[np.float64]:
    """sRGB-encoded [0, 1] → linear [0, 1]."""
    y = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(y <= 0.04045, y / 12.92, np.power((y + 0.055) / 1.055, 2.4))
