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
from .calibration import (PIPELINE_GAIN_LIMITS, PIPELINE_MIN_SIGNAL, PIPELINE_SMOOTH_BINS, Calibration, fit_gains,
                          new_metadata, save_calibration)
from .camera_pipeline import CameraPipeline, fit_pipeline
from .cameras import GENERIC_CAMERA, CameraProfile
from .capture import DEFAULT_PRESET, Preset, load_preset
from .errors import CDSpectraError, NoDiscError
from .disc_window import load_for_estimate
from .estimate import AUTO, resolve_camera
from .images import LinearImage
from .model import load_model
from .spectral_grid import WAVELENGTHS_NM

__all__ = ["fit_calibration", "gains_from_image", "measure_gains", "calibrate_photo"]


def _check_reference(reference_spd: NDArray[np.float64]) -> NDArray[np.float64]:
    ref = np.asarray(reference_spd, dtype=np.float64)
    if ref.shape != WAVELENGTHS_NM.shape or not np.all(np.isfinite(ref)) or ref.max() <= 0 or ref.min() < 0:
        raise CDSpectraError("the known lamp's spectrum must be 81 finite, non-negative values on 380–780 nm")
    return ref


def fit_calibration(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset, camera: CameraProfile,
                    generic_camera: bool = False, pipeline: bool | None = None
                    ) -> tuple[NDArray[np.float64], CameraPipeline | None, Analysis]:
    """Per-bin gains (measured / predicted readout) of a loaded photo of a known lamp, and for
    an in-camera file (``pipeline`` None: when the loader judged it processed) first the
    camera's matrix and tone curve (:func:`.camera_pipeline.fit_pipeline`), which later photos
    then have undone before their readout; the gains fix what is left."""
    ref = _check_reference(reference_spd)
    try:
        analysis = prepare(image, preset, camera, generic_camera=generic_camera)
    except NoDiscError as exc:
        raise NoDiscError(f"{exc} — calibration needs a photo of the disc lit by the known lamp, taken like the "
                          "later photos") from exc
    fitted = None
    if image.processed if pipeline is None else pipeline:
        readout = analysis.uncalibrated
        predicted = np.einsum("bcl,l->bc", analysis.matrix, ref)
        bins = readout.pixel_bin
        use = readout.valid[bins] & (readout.pixel_weight > 0)
        observed = np.asarray(image.rgb, np.float64).reshape(-1, 3)[readout.pixels.index]
        fitted = fit_pipeline(observed[use], predicted[bins[use]] * readout.pixels.amplitude[use, None])
        undo = Calibration("pipeline", np.ones_like(predicted), preset.name, camera.name, {}, fitted)
        analysis = prepare(image, preset, camera, generic_camera=generic_camera, calibration=undo, fit=analysis.fit)
    predicted = np.einsum("bcl,l->bc", analysis.matrix, ref)
    limits = {} if fitted is None else {"min_signal": PIPELINE_MIN_SIGNAL, "limits": PIPELINE_GAIN_LIMITS,
                                           "smooth_bins": PIPELINE_SMOOTH_BINS}
    return fit_gains(analysis.uncalibrated.values, analysis.uncalibrated.valid, predicted, **limits), fitted, analysis


def gains_from_image(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset,
                     camera: CameraProfile, generic_camera: bool = False) -> tuple[NDArray[np.float64], Analysis]:
    """Per-bin gains only (no pipeline): for camera-native photos, and the gains-only baseline."""
    gains, _, analysis = fit_calibration(image, reference_spd, preset, camera, generic_camera, pipeline=False)
    return gains, analysis


def _model_if_needed(camera: str) -> Any:
    """The shipped model when the generic profile may be needed (it carries it), else None."""
    if camera == GENERIC_CAMERA:
        return load_model()
    if camera == AUTO:
        try:
            return load_model()
        except CDSpectraError:
            return None  # resolve_camera falls back to the default camera's profile
    return None


def measure_gains(path: str | Path, reference_spd: NDArray[np.float64], preset: str = DEFAULT_PRESET,
                  camera: str = "") -> tuple[NDArray[np.float64], str, str, dict[str, Any], CameraPipeline | None]:
    """(gains, preset name, camera name, metadata, pipeline) from a photo file of a lamp whose
    SPD is known; the pipeline is fitted when the file is an in-camera rendering."""
    _check_reference(reference_spd)  # before the photo is read: the cheaper mistake first
    camera = camera or AUTO
    preset_obj = load_preset(preset)
    image = load_for_estimate(path, preset_obj)  # read as the later photos will be
    cam, generic, camera, _ = resolve_camera(camera, image, _model_if_needed(camera))
    gains, pipeline, analysis = fit_calibration(image, reference_spd, preset_obj, cam, generic)
    extra: dict[str, Any] = {"rainbow_contrast": float(analysis.fit.rainbow_contrast)}
    if pipeline is not None:
        extra["processed"] = image.processed_reason or "fitted on request"
    return gains, preset_obj.name, camera, extra, pipeline


def calibrate_photo(path: str | Path, reference_spd: NDArray[np.float64], name: str, preset: str = DEFAULT_PRESET,
                    camera: str = "", directory: Path | None = None, reference_name: str = "") -> Path:
    """Measure this camera + disc + set-up's gains (and, for an in-camera JPEG/HEIC, its
    processing) from a photo of a lamp whose SPD is known; save as calibration ``name``."""
    gains, preset_name, camera, extra, pipeline = measure_gains(path, reference_spd, preset, camera)
    metadata = {**new_metadata(str(path), reference_name or "reference SPD"), **extra}
    return save_calibration(Calibration(name, gains, preset_name, camera, metadata, pipeline), directory)
