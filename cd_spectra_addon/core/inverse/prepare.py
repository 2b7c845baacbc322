"""The one inverse path from a loaded photo to what the solve and the network see.

``prepare`` is used by the estimator, the calibration shot, dataset building and solver/fusion
tuning alike, so every product-side step — the saturated|invalid mask, the greyscale-photo
camera collapse, the focal length from EXIF, the pose fit (:mod:`..pose.fit`, any set-up:
the preset is only its start), the calibration gains and the "no rainbow" refusal — also
shapes the training data. ``physics_spd`` and ``network_inputs``
are the next two steps, shared the same way: a dataset sample and a product estimate of the
same photo see identical features (tests/test_inverse_path.py).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..readout.ambient import dark_offset, readout_pixels, rough_offset
from ..calibration.calibration import Calibration
from ..spectra.cameras import CameraProfile
from ..scene.capture import Preset, Scene
from ..planning.capture_advice import advice_for_photo
from ..scene.diffraction import LobePixels, PixelDiffraction
from ..errors import CDSpectraError, NoDiscError, PhotoError
from ..readout.forward_matrix import bin_response, feature_matrix
from ..photo.images import ExifInfo, LinearImage
from ..spectrum.model import model_inputs
from ..pose.fit import fit_pose
from ..pose.result import PoseFit
from ..readout.readout import Readout, extract_readout
from ..spectrum.solve import GaussianPrior, physics_solve, prior_solve

MIN_RAINBOW_CONTRAST = 0.3  # the fitted disc must explain the photo far better than a misplaced one
MIN_VALID_BINS = 10  # λ₁ bins (5 nm each) a readout needs before a spectrum is worth solving for
MAX_SATURATED_SHARE = 0.9  # a photo clipped almost everywhere holds no rainbow to read
# An 8-bit photo whose rainbow peaks below this share of full scale (sRGB code ≈ 25) is mostly
# quantisation: at 0.5 % exposure the physics-only MAE rose from 0.004 to 0.13 (CIE A), and at
# 0.3 % the rainbow is no longer found (bench/reliability.md).
DIM_LEVEL_8BIT = 0.01

__all__ = ["Analysis", "prepare", "focal_px_for", "focal_px_of", "physics_spd", "network_inputs",
           "MIN_RAINBOW_CONTRAST", "MAX_SATURATED_SHARE", "DIM_LEVEL_8BIT"]


@dataclass
class Analysis:
    """Everything the solve needs about one photo, in the photo's loaded pixel coordinates."""

    fit: PoseFit
    scene: Scene
    readout: Readout  # after the calibration's gains, when there is one
    uncalibrated: Readout  # as measured (what a calibration shot fits its gains to)
    response: NDArray[np.float64]  # R[bin, λ] without the camera
    camera: CameraProfile  # the sensitivities solved with (collapsed to grey for a greyscale photo)
    matrix: NDArray[np.float64]  # (NB, 3, 81) feature forward matrix with that camera
    generic_camera: bool
    focal_px: float
    focal_source: str  # "exif", "exif-35mm", "preset" or "given"
    calibration: Calibration | None = None
    ambient: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))  # offset removed per channel
    timing_ms: dict[str, float] = field(default_factory=dict)


def focal_px_for(image: LinearImage, preset: Preset) -> tuple[float, str]:
    """Focal length in loaded pixels and where it came from.

    EXIF FocalLength × FocalPlaneXResolution is exact for the sensor's pixels; the 35 mm
    equivalent assumes the long side spans 36 mm; otherwise the preset's field of view.
    """
    return focal_px_of(image.exif, image.rgb.shape[1], image.scale, image.displayed_size, preset)


def focal_px_of(exif: ExifInfo, width: int, scale: float, displayed_size: tuple[int, int],
                preset: Preset) -> tuple[float, str]:
    """:func:`focal_px_for` of an image ``width`` loaded pixels wide at ``scale`` original pixels
    per loaded one, from a photo of ``displayed_size``: known before the pixels are decoded."""
    if exif.focal_length_mm and exif.focal_plane_px_per_mm:
        value = exif.focal_length_mm * exif.focal_plane_px_per_mm / scale
        if math.isfinite(value) and value > 0:
            return value, "exif"
    if exif.focal_length_35mm:
        value = exif.focal_length_35mm / 36.0 * max(displayed_size) / scale  # a window keeps the pitch
        if math.isfinite(value) and value > 0:
            return value, "exif-35mm"
    cam = preset.camera
    return cam.focal_length_mm / cam.sensor_width_mm * width, "preset"


def _with_gains(readout: Readout, calibration: Calibration | None) -> Readout:
    if calibration is None:
        return readout
    gains = calibration.gains
    return replace(readout, values=readout.values / gains, noise=readout.noise / gains)


def prepare(
    image: LinearImage,
    preset: Preset,
    camera: CameraProfile,
    *,
    generic_camera: bool = False,
    calibration: Calibration | None = None,
    focal_px: float | None = None,
    fit: PoseFit | None = None,
    pixels: PixelDiffraction | None = None,
) -> Analysis:
    """Photo → pose → readout → forward matrix, refusing photos that hold no rainbow.

    ``fit`` skips the pose fit (training reuses fits of its capture geometries; the evaluation
    injects centre errors); ``focal_px`` overrides EXIF; ``pixels`` are the fitted scene's
    per-pixel diffraction coordinates when the caller already has them (a cache: they depend on
    the scene alone). Raises :class:`PhotoError` for a photo
    clipped almost everywhere and :class:`NoDiscError` where no CD rainbow is found.
    """
    t0 = time.perf_counter()
    clipped = float(np.mean(image.saturated))
    if clipped > MAX_SATURATED_SHARE:
        raise PhotoError(f"{image.path or 'the photo'}: over-exposed, {100 * clipped:.0f}% of the photo is clipped "
                         "at full scale — use a much shorter exposure (or dim the lamp)")
    if image.is_grey:
        camera = CameraProfile(camera.name, np.repeat(camera.sensitivities.sum(axis=1, keepdims=True) / 3.0, 3,
                                                      axis=1))
    source = "given"
    if focal_px is None:
        focal_px, source = focal_px_for(image, preset)
    rgb = np.asarray(image.rgb, dtype=np.float64)
    if calibration is not None and calibration.pipeline is not None:
        rgb = calibration.pipeline.to_native(rgb)  # undo the camera's matrix and tone curve (JPEG/HEIC)
    saturated = np.asarray(image.saturated) | np.asarray(image.invalid)
    height, width, _ = rgb.shape
    if fit is None:
        fit = fit_pose(rgb - rough_offset(rgb, saturated), preset, focal_px, sensitivities=camera.sensitivities,
                               saturated=saturated)
    t1 = time.perf_counter()
    scene = fit.scene(preset, (width, height))
    # Without a cache, the kernel is evaluated only where the lobe can be visible or the dark
    # is uncertain: the same readout and offset as from every pixel (tests/test_pixel_survey.py).
    lobe: PixelDiffraction | LobePixels = readout_pixels(scene) if pixels is None else pixels
    ambient = dark_offset(rgb, scene, saturated, lobe)
    measured = extract_readout(rgb - ambient if np.any(ambient) else rgb, saturated, scene,
                               lobe.pixels if isinstance(lobe, LobePixels) else lobe)
    t2 = time.perf_counter()
    readout = _with_gains(measured, calibration)
    if int(np.sum(readout.valid)) < MIN_VALID_BINS or fit.rainbow_contrast < MIN_RAINBOW_CONTRAST:
        name = Path(image.path).name or "the photo"
        hint = ""
        if clipped > 0.2:
            hint = f" ({100 * clipped:.0f}% of the photo is clipped: try a shorter exposure)"
        elif image.encoding.endswith("-8") and float(np.percentile(rgb, 99.5)) < DIM_LEVEL_8BIT:
            hint = " (the photo is very dark: try a longer exposure)"
        advice = advice_for_photo(preset, scene, fit.rainbow_contrast >= MIN_RAINBOW_CONTRAST, rgb, saturated,
                                  focal_px)
        raise NoDiscError(f"no CD rainbow found in {name}{hint}: {advice}")
    response = bin_response(scene, readout)
    t3 = time.perf_counter()
    return Analysis(fit=fit, scene=scene, readout=readout, uncalibrated=measured, response=response, camera=camera,
                    matrix=feature_matrix(response, camera), generic_camera=generic_camera, focal_px=float(focal_px),
                    focal_source=source, calibration=calibration, ambient=ambient,
                    timing_ms={"geometry": (t1 - t0) * 1e3, "profile": (t2 - t1) * 1e3, "forward": (t3 - t2) * 1e3})


def physics_spd(analysis: Analysis, prior: tuple[GaussianPrior, NDArray[np.float64]] | None) -> NDArray[np.float64]:
    """The physics solve in the photo's units: under the Gaussian prior (with its precision
    matrix) when given, else smoothness-regularised only."""
    if prior is not None:
        return prior_solve(analysis.readout, analysis.matrix, prior[0], precision=prior[1])
    return physics_solve(analysis.readout, analysis.matrix)


def network_inputs(analysis: Analysis, physics: NDArray[np.float64]) -> NDArray[np.float32]:
    """The learned model's input vector for this photo (layout: :data:`.model.INPUT_LAYOUT`)."""
    return model_inputs(analysis.readout, analysis.camera.sensitivities, physics,
                        analysis.scene.preset.light.lobe_sigma, analysis.generic_camera, analysis.fit.residual)
