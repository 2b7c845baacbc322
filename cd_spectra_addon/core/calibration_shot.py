"""A calibration shot through the product's own inverse path: photo of a known lamp → gains.

Kept apart from :mod:`.calibration` (the profile data, its fit and its files) because it runs
the estimator's loading chain — :func:`.analysis.prepare` — which itself applies calibrations:
the same pose fit, masks, focal length and "no rainbow" refusal as an estimate, so a photo that
could not be estimated cannot become a calibration either.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .analysis import Analysis, prepare
from .calibration import Calibration, fit_gains, new_metadata, save_calibration
from .cameras import DEFAULT_CAMERA, GENERIC_CAMERA, CameraProfile
from .capture import DEFAULT_PRESET, Preset, load_preset
from .errors import CDSpectraError, NoDiscError
from .estimate import MAX_SIDE, camera_for
from .images import LinearImage, load_photo
from .model import load_model
from .spectral_grid import WAVELENGTHS_NM

__all__ = ["gains_from_image", "measure_gains", "calibrate_photo"]


def _check_reference(reference_spd: NDArray[np.float64]) -> NDArray[np.float64]:
    ref = np.asarray(reference_spd, dtype=np.float64)
    if ref.shape != WAVELENGTHS_NM.shape or not np.all(np.isfinite(ref)) or ref.max() <= 0 or ref.min() < 0:
        raise CDSpectraError("the known lamp's spectrum must be 81 finite, non-negative values on 380–780 nm")
    return ref


def gains_from_image(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset,
                     camera: CameraProfile, generic_camera: bool = False) -> tuple[NDArray[np.float64], Analysis]:
    """Per-bin gains (measured / predicted readout) of a loaded photo of a known lamp."""
    ref = _check_reference(reference_spd)
    try:
        analysis = prepare(image, preset, camera, generic_camera=generic_camera)
    except NoDiscError as exc:
        raise NoDiscError(f"{exc} — calibration needs a photo of the disc lit by the known lamp, taken like the "
                          "later photos") from exc
    predicted = np.einsum("bcl,l->bc", analysis.matrix, ref)
    return fit_gains(analysis.uncalibrated.values, analysis.uncalibrated.valid, predicted), analysis


def measure_gains(path: str | Path, reference_spd: NDArray[np.float64], preset: str = DEFAULT_PRESET,
                  camera: str = "") -> tuple[NDArray[np.float64], str, str, dict[str, Any]]:
    """(gains, preset name, camera name, metadata) from a photo file of a lamp whose SPD is known."""
    _check_reference(reference_spd)  # before the photo is read: the cheaper mistake first
    camera = camera or DEFAULT_CAMERA
    preset_obj = load_preset(preset)
    image = load_photo(path, max_side=MAX_SIDE)
    cam, generic = camera_for(camera, load_model() if camera == GENERIC_CAMERA else None)
    gains, analysis = gains_from_image(image, reference_spd, preset_obj, cam, generic)
    return gains, preset_obj.name, camera, {"rainbow_contrast": float(analysis.fit.rainbow_contrast)}


def calibrate_photo(path: str | Path, reference_spd: NDArray[np.float64], name: str, preset: str = DEFAULT_PRESET,
                    camera: str = "", directory: Path | None = None, reference_name: str = "") -> Path:
    """Measure this camera + disc + set-up's gains from a photo of a lamp whose SPD is known,
    save them as calibration ``name`` and return its path."""
    gains, preset_name, camera, extra = measure_gains(path, reference_spd, preset, camera)
    metadata = {**new_metadata(str(path), reference_name or "reference SPD"), **extra}
    return save_calibration(Calibration(name, gains, preset_name, camera, metadata), directory)
