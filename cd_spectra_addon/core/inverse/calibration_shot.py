"""A calibration shot through the product's own inverse path: photo of a known lamp → gains.

Kept apart from :mod:`.calibration` (the profile data, its fit and its files) because it runs
the estimator's stages — :func:`.stages.read_photo` — which themselves apply calibrations:
the same pose fit, masks, focal length and "no rainbow" refusal as an estimate, so a photo that
could not be estimated cannot become a calibration either.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .stages import Reading, read_photo
from ..calibration.calibration import (PIPELINE_GAIN_LIMITS, PIPELINE_MIN_SIGNAL, PIPELINE_SMOOTH_BINS, Calibration, fit_gains,
                          new_metadata, save_calibration, unexplained_share)
from ..calibration.camera_fit import CameraPrior, fit_sensitivities
from ..calibration.camera_pipeline import FAMILY, fit_pipeline
from ..spectra.cameras import GENERIC_CAMERA, CameraProfile
from ..scene.capture import DEFAULT_PRESET, Preset, load_preset
from ..errors import CDSpectraError, NoDiscError
from .load import load_for_estimate
from .estimate import AUTO, camera_prior_for, resolve_camera
from ..readout.forward_matrix import feature_matrix
from ..photo.clipping import clipped_channels
from ..photo.images import LinearImage
from ..spectrum.model import load_model
from ..spectra.grid import WAVELENGTHS_NM

# In-camera file of a camera without a profile: rounds of (processing, sensitivities). Phone HEIC
# of cameras unlike the 52, 30 synthetic SPDs (`camera_files --synthetic`): MAE 0.133 / 0.081 /
# 0.076 / 0.070 / 0.076 after 1 / 3 / 5 / 8 / 16 rounds; ~0.1 s a round for a 192-px photo.
PIPELINE_CAMERA_ROUNDS = 8

__all__ = ["fit_calibration", "gains_from_image", "measure_calibration", "calibrate_photo"]


def _check_reference(reference_spd: NDArray[np.float64]) -> NDArray[np.float64]:
    ref = np.asarray(reference_spd, dtype=np.float64)
    if ref.shape != WAVELENGTHS_NM.shape or not np.all(np.isfinite(ref)) or ref.max() <= 0 or ref.min() < 0:
        raise CDSpectraError("the known lamp's spectrum must be 81 finite, non-negative values on 380–780 nm")
    return ref


def fit_calibration(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset, camera: CameraProfile,
                    generic_camera: bool = False, pipeline: bool | None = None, prior: CameraPrior | None = None,
                    name: str = "calibration", metadata: dict[str, Any] | None = None
                    ) -> tuple[Calibration, Reading]:
    """The calibration a loaded photo of a known lamp gives, and the photo's analysis with it.

    In order: for an in-camera file (``pipeline`` None: when the loader judged it processed) the
    camera's matrix and tone curve (:func:`.camera_pipeline.fit_pipeline`), which later photos
    then have undone before their readout; with a camera ``prior`` the camera's own
    sensitivities (:func:`.camera_fit.fit_sensitivities`: for the generic profile, which is
    nobody's camera); last, per-bin gains for what is left."""
    ref = _check_reference(reference_spd)
    try:
        analysis = read_photo(image, preset, camera, generic_camera=generic_camera)
    except NoDiscError as exc:
        raise NoDiscError(f"{exc} — calibration needs a photo of the disc lit by the known lamp, taken like the "
                          "later photos") from exc
    processed = image.processed if pipeline is None else pipeline
    first, own = analysis, camera
    fitted, sensitivities = None, None
    # With both to fit, alternately: the processing fitted against the generic camera's colours
    # bends its tone curve to absorb their error, which the camera's own fitted sensitivities
    # then undo round by round (see PIPELINE_CAMERA_ROUNDS).
    for _ in range(PIPELINE_CAMERA_ROUNDS if processed and prior is not None else 1):
        if processed:
            readout = first.uncalibrated
            predicted = np.einsum("bcl,l->bc", feature_matrix(first.response, own), ref)
            bins = readout.pixel_bin
            index = readout.pixels.index
            low, high = (m.reshape(-1, 3)[index] for m in clipped_channels(image.rgb, image.saturated))
            # Pixels the readout left out as saturated are read too: their clipped channels are bounds.
            use = readout.valid[bins] & ((readout.pixel_weight > 0) | np.asarray(image.saturated).reshape(-1)[index])
            observed = np.asarray(image.rgb, np.float64).reshape(-1, 3)[index]
            # Later rounds refit the member of the family the first round chose.
            family = FAMILY if fitted is None else ((fitted.tone, fitted.gamut),)
            fitted = fit_pipeline(observed[use], predicted[bins[use]] * readout.pixels.amplitude[use, None],
                                  low=low[use], high=high[use], family=family)
            undo = Calibration("pipeline", np.ones_like(predicted), preset.name, camera.name, {}, fitted)
            analysis = read_photo(image, preset, camera, generic_camera=generic_camera, calibration=undo, fit=first.fit,
                                  known_spd=ref)
        if prior is not None:
            sensitivities = fit_sensitivities(analysis.uncalibrated, analysis.response, ref, prior)
            own = CameraProfile(camera.name, sensitivities)
    if sensitivities is not None:
        analysis = replace(analysis, posed=replace(analysis.posed, camera=own), matrix=feature_matrix(analysis.response, own))
    predicted = np.einsum("bcl,l->bc", analysis.matrix, ref)
    limits = {} if fitted is None else {"min_signal": PIPELINE_MIN_SIGNAL, "limits": PIPELINE_GAIN_LIMITS,
                                           "smooth_bins": PIPELINE_SMOOTH_BINS}
    gains = fit_gains(analysis.uncalibrated.values, analysis.uncalibrated.valid, predicted, **limits)
    meta = {**dict(metadata or {}),
            "unexplained": round(unexplained_share(analysis.uncalibrated.values, analysis.uncalibrated.valid,
                                                   predicted), 4)}
    return Calibration(name, gains, preset.name, camera.name, meta, fitted, sensitivities), analysis


def gains_from_image(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset,
                     camera: CameraProfile, generic_camera: bool = False) -> tuple[NDArray[np.float64], Reading]:
    """Per-bin gains only (no pipeline, no fitted camera): for camera-native photos with a
    measured profile, and the gains-only baseline."""
    cal, analysis = fit_calibration(image, reference_spd, preset, camera, generic_camera, pipeline=False)
    return cal.gains, analysis


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


def measure_calibration(path: str | Path, reference_spd: NDArray[np.float64], name: str,
                        preset: str = DEFAULT_PRESET, camera: str = "", reference_name: str = "") -> Calibration:
    """Calibration ``name`` from a photo file of a lamp whose SPD is known: the in-camera
    pipeline when the file is an in-camera rendering, the camera's own sensitivities when its
    profile is the generic one (the camera is not one of the profiles), then the gains."""
    _check_reference(reference_spd)  # before the photo is read: the cheaper mistake first
    camera = camera or AUTO
    preset_obj = load_preset(preset)
    image = load_for_estimate(path, preset_obj)  # read as the later photos will be
    model = _model_if_needed(camera)
    cam, generic, camera, _ = resolve_camera(camera, image, model)
    prior = camera_prior_for(model) if generic else None
    metadata = new_metadata(str(path), reference_name or "reference SPD")
    cal, analysis = fit_calibration(image, reference_spd, preset_obj, cam, generic, prior=prior, name=name,
                                    metadata=metadata)
    cal.metadata["rainbow_contrast"] = float(analysis.fit.rainbow_contrast)
    if cal.pipeline is not None:
        cal.metadata["processed"] = image.processed_reason or "fitted on request"
    return replace(cal, camera=camera)


def calibrate_photo(path: str | Path, reference_spd: NDArray[np.float64], name: str, preset: str = DEFAULT_PRESET,
                    camera: str = "", directory: Path | None = None, reference_name: str = "") -> Path:
    """Measure this camera + disc + set-up's gains (and, for an in-camera JPEG/HEIC, its
    processing; for a camera without a profile, its sensitivities) from a photo of a lamp whose
    SPD is known; save as calibration ``name``."""
    return save_calibration(measure_calibration(path, reference_spd, name, preset, camera, reference_name), directory)
