"""In-camera renderings of synthetic photos: what a camera's JPEG or a phone's HEIC holds.

Randomised within what cameras and phones do (sources: dcraw/LibRaw's and Adobe DNG's camera
matrices, picture styles' documented contrast curves, phone "vivid" saturation):

* white balance: fixed daylight (≈ D55, the user's advice), or a preset between 2800 and 7500 K;
  the green gain is 1, red and blue gains make that illuminant neutral (gains ≥ 1, as cameras do);
* colour matrix: the 3×3 that best maps the camera's sensitivities to the sRGB colour-matching
  functions (least squares over 400–700 nm), rows normalised so neutral stays neutral, then a
  saturation boost of 0–30 % (phones up to 30 %);
* tone curve: sRGB, then an S-shaped picture-style contrast of 0–50 % and a gamma of 0.85–1.1;
* exposure: metered on the rendered image (its brightest 0.1 % of the metered area at 90 %), so
  gamut and highlight clipping happen where a camera's would.

:func:`sample_pipeline` returns a :class:`~cd_spectra_addon.core.calibration.camera_pipeline.CameraPipeline`,
the same model the calibration shot fits (with a finer, differently shaped curve than the fit
can represent: the fit is not handed its own model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from cd_spectra_addon.core.spectra import colour
from cd_spectra_addon.core.spectra.illuminants import daylight_spd, planck_spd
from cd_spectra_addon.core.calibration.camera_pipeline import CameraPipeline
from cd_spectra_addon.core.spectra.cameras import CameraProfile
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

__all__ = ["InCameraStyle", "sample_style", "pipeline_for", "sample_pipeline", "render_in_camera", "in_camera_exif",
           "TYPICAL"]

METER_LEVEL = 0.9
CURVE_SAMPLES = 65


@dataclass(frozen=True)
class InCameraStyle:
    white_balance_k: float  # the illuminant made neutral (daylight ≥ 4000 K, Planck below)
    saturation: float  # extra saturation, 0 = the fitted matrix
    contrast: float  # S-curve blend, 0 = plain sRGB
    gamma: float  # on the encoded value after the S-curve


TYPICAL = InCameraStyle(5500.0, 0.1, 0.25, 1.0)  # a DSLR's "standard" style, fixed daylight white balance


def sample_style(rng: np.random.Generator, fixed_daylight: bool = True) -> InCameraStyle:
    return InCameraStyle(5500.0 if fixed_daylight else float(rng.uniform(2800.0, 7500.0)),
                         float(rng.uniform(0.0, 0.3)), float(rng.uniform(0.0, 0.5)), float(rng.uniform(0.85, 1.1)))


def _illuminant(k: float) -> NDArray[np.float64]:
    return daylight_spd(k) if k >= 4000.0 else planck_spd(k)


def _srgb_cmfs() -> NDArray[np.float64]:
    """(81, 3) the colour-matching functions of linear sRGB's primaries."""
    xyz = colour.spd_to_xyz(np.eye(WAVELENGTHS_NM.size))
    return colour.xyz_to_working_rgb(xyz, colour.LINEAR_REC709)


def pipeline_for(camera: CameraProfile, style: InCameraStyle) -> CameraPipeline:
    """The camera's rendering in ``style`` (exposure scale 1: see :func:`render_in_camera`)."""
    sens = camera.sensitivities
    white = sens.T @ _illuminant(style.white_balance_k)
    gains = white.max() / white  # the illuminant's raw RGB → equal, every gain ≥ 1
    balanced = sens * gains
    band = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
    target = _srgb_cmfs()
    fit, *_ = np.linalg.lstsq(balanced[band], target[band], rcond=None)  # (3, 3): native → sRGB, row vectors
    matrix = fit.T
    matrix = matrix / matrix.sum(axis=1, keepdims=True)  # neutral stays neutral
    luma = np.array([0.2126, 0.7152, 0.0722])
    boost = (1 + style.saturation) * np.eye(3) - style.saturation * np.ones((3, 1)) * luma
    total = boost @ matrix @ np.diag(gains)
    u = np.linspace(0.0, 1.0, CURVE_SAMPLES)
    s_curve = (1 - style.contrast) * u + style.contrast * (3 * u ** 2 - 2 * u ** 3)
    out = np.power(s_curve, style.gamma)
    out[1:] = np.maximum(out[1:], out[:-1] + 1e-9)  # strictly increasing at the ends
    return CameraPipeline(total, u, out)


def sample_pipeline(camera: CameraProfile, rng: np.random.Generator, fixed_daylight: bool = True) -> CameraPipeline:
    return pipeline_for(camera, sample_style(rng, fixed_daylight))


def render_in_camera(native: NDArray[np.floating], pipeline: CameraPipeline,
                     meter: NDArray[np.bool_] | None = None) -> NDArray[np.float64]:
    """The file-linear image (write it as 8-bit sRGB codes) a camera renders from ``native``,
    metered on its own rendering (the brightest 0.1 % of the metered area at 90 %)."""
    native = np.asarray(native, np.float64)
    display = native @ pipeline.matrix.T
    region = display if meter is None or not np.any(meter) else display[meter]
    level = float(np.quantile(region.max(axis=-1), 0.999))
    scale = METER_LEVEL / level if level > 0 else 1.0
    return pipeline.to_file(native * scale)


def in_camera_exif(base: bytes, software: str = "Firmware Version 1.3.3") -> bytes:
    """``base`` EXIF plus what a camera's JPEG carries: ColorSpace sRGB, a manual (fixed) white
    balance, the firmware as Software."""
    exif = Image.Exif()
    exif.load(base)
    exif[0x0131] = software
    sub = exif.get_ifd(0x8769)
    sub[0xA001] = 1  # ColorSpace: sRGB
    sub[0xA403] = 1  # WhiteBalance: manual
    return exif.tobytes()
