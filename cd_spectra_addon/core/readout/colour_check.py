"""Does the fitted wavelength axis agree with the camera's own colours? (a green pixel cannot be 620 nm)

Each λ₁ bin of the readout holds the lamp's light within a band a few nm wide (the lobe's blur),
so its colour is the camera's colour near that λ. Where the camera's colour changes quickly with
λ (blue-green to orange), a bin whose colour sits off the colour expected at its label says by
how many nm the label is off: the colour difference projected on the expected colour curve's
tangent, divided by its length. The expected colours are the estimated lamp's light under the
blur, as the pose fit's fine stage expects them: a narrow band (a blue LED, a white LED's pump)
lights the bins on its flanks in its peak's hue, which a flat spectrum's colours would read as
a shifted axis. The estimate comes from the same readout but cannot move a whole axis's colours:
a pose a few degrees off shifts all bins the same way, so the weighted median over the bins
estimates the wavelength axis's error, and the estimate's confidence falls with it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .readout import Readout
from ..spectra.cameras import camera_colours, lamp_light, unit_colours

CHECK_BAND_NM = (450.0, 640.0)  # where a camera's colour names λ to a few nm
MIN_BINS = 8

__all__ = ["CHECK_BAND_NM", "wavelength_shift_nm"]


def _camera_colour(lam: NDArray[np.float64], sensitivities: NDArray[np.float64], blur_nm: float,
                   spd: NDArray[np.float64] | None) -> NDArray[np.float64]:
    return unit_colours(camera_colours(lam, sensitivities, max(float(blur_nm), 1.0), spd))


def wavelength_shift_nm(readout: Readout, sensitivities: NDArray[np.float64], blur_nm: float,
                        spd: NDArray[np.float64] | None) -> float | None:
    """How many nm the readout's wavelength labels sit above what the camera's colours of the
    lamp's light ``spd`` (on the product grid; the estimate) say — None: a flat spectrum's —
    (weighted median over the valid bins in CHECK_BAND_NM; positive: labels too long); None with
    too few bins to tell."""
    lam = readout.lambda_nm
    use = readout.valid & (lam >= CHECK_BAND_NM[0]) & (lam <= CHECK_BAND_NM[1])
    values = readout.values[use]
    norm = np.linalg.norm(values, axis=1)
    use_idx = np.flatnonzero(use)[norm > 0]
    if use_idx.size < MIN_BINS:
        return None
    values = readout.values[use_idx]
    norm = np.linalg.norm(values, axis=1)
    unit = values / norm[:, None]
    lamp = lamp_light(spd)
    centre = _camera_colour(lam[use_idx], sensitivities, blur_nm, lamp)
    tangent = (_camera_colour(lam[use_idx] + 0.5, sensitivities, blur_nm, lamp)
               - _camera_colour(lam[use_idx] - 0.5, sensitivities, blur_nm, lamp))  # per nm
    slope2 = np.sum(tangent * tangent, axis=1)
    shift = np.sum((unit - centre) * tangent, axis=1) / np.maximum(slope2, 1e-300)  # colour's λ − label
    weight = norm * slope2
    order = np.argsort(shift)
    cum = np.cumsum(weight[order])
    if not cum[-1] > 0:
        return None
    median = float(shift[order][np.searchsorted(cum, 0.5 * cum[-1])])
    return -median if np.isfinite(median) else None
