"""Box averages of images in linear light: the pose fit's coarse levels and the outline's preview."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["box_downsample"]


def box_downsample(image: NDArray[np.floating], factor: int) -> NDArray[np.float64]:
    """Mean over factor × factor blocks (trailing rows/columns dropped): pixel ``[i, j]`` of the
    result covers input pixels ``[i·factor, (i+1)·factor)``, so a point at input (r, c) lies at
    ((r + 0.5)/factor − 0.5, (c + 0.5)/factor − 0.5)."""
    if factor <= 1:
        return np.asarray(image, dtype=np.float64)
    h, w = image.shape[0] // factor * factor, image.shape[1] // factor * factor
    a = np.asarray(image[:h, :w], dtype=np.float64)
    return a.reshape(h // factor, factor, w // factor, factor, *a.shape[2:]).mean(axis=(1, 3))
