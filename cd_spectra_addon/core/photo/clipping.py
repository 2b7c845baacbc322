"""Which channels of an in-camera file were clipped: bounds, not values.

An in-camera rendering clips twice: at the display gamut (a spectral colour's weakest channel
goes negative in sRGB and is written as code 0) and at full scale (a warm lamp under daylight
white balance pushes red past 255). The rainbow's spectral colours are exactly the ones a camera
clips, so leaving such pixels out loses whole wavelength bins, and reading them as values
biases every bin they touch. A clipped channel says only "the true value is at most (at 0) or
at least (at 255) this": the calibration fit and the estimate's readout treat it so
(:func:`..calibration.camera_pipeline.fit_pipeline`, :mod:`..calibration.censoring`).

Thresholds are in 8-bit codes: JPEG's ringing next to a gamut-clipped colour leaves codes of
0–3 where the rendering wrote 0, and the loader already flags pixels with a channel at ≥ 250.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .srgb import srgb_decode

__all__ = ["LOW_CODE", "HIGH_CODE", "LOW_LINEAR", "HIGH_LINEAR", "clipped_channels"]

LOW_CODE = 3.0  # a channel at or below this 8-bit code was clipped at the gamut's floor
HIGH_CODE = 240.0  # ... at or above this, in a pixel the loader flags saturated, at full scale
LOW_LINEAR = float(srgb_decode(LOW_CODE / 255.0))
HIGH_LINEAR = float(srgb_decode(HIGH_CODE / 255.0))


def clipped_channels(rgb: NDArray[np.floating], saturated: NDArray[np.bool_]) -> tuple[NDArray[np.bool_],
                                                                                      NDArray[np.bool_]]:
    """(low, high): (H, W, 3) masks of channels clipped at the floor and at full scale, for an
    image of file-linear values (sRGB-decoded codes) and the loader's saturation mask."""
    a = np.asarray(rgb)
    low = a <= LOW_LINEAR
    high = (a >= HIGH_LINEAR) & np.asarray(saturated, bool)[..., None]
    return low, high
