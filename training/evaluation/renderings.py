"""In-camera renderings built independently of the family the calibration models (evaluation only).

The calibration's own pipeline family (:class:`~cd_spectra_addon.core.calibration.camera_pipeline.CameraPipeline`)
and its sampler (``training/simulation/camera_pipelines.py``) share an author and assumptions:
the rendering is metered on its own output, so nothing clips at the top. A calibration fitted
and tested on them learns that family. The renderings here are written from what cameras and
raw converters do, without that code, and are held out of every fit and prior:

* ``ordinary``: a fixed daylight white balance (D55, green gain 1, so red and blue gains > 1 push warm or
  cool colours past full scale), a 3×3 camera→sRGB matrix fitted to the CIE 1931 observer's
  sRGB colour-matching functions *clipped at the sRGB gamut* (what a profile fitted on
  spectral colours that the display cannot show does), per-channel clipping, the sRGB curve
  and an S-shaped picture style (a logistic contrast curve), 8-bit;
* ``luma-curve``: the same matrix, but the picture style's contrast applied to luminance
  (every channel scaled by one factor: hue-preserving, as many raw converters do), and
  out-of-gamut colours compressed towards their luminance rather than clipped per channel;
* ``curve-first``: a per-channel film-like tone curve on the white-balanced camera RGB
  *before* the matrix (a camera profile's look table), then the matrix and the sRGB curve;
* ``phone``: a phone's look — +25 % saturation, a hue twist of the reds towards orange,
  highlight roll-off, and local tone mapping (each pixel's exposure lifted by how dark its
  neighbourhood is);
* ``libraw``: not here — LibRaw's own rendering of a DNG (rawpy ``postprocess``), see
  :func:`libraw_render`.

Each function maps a (H, W, 3) camera-native linear image (full scale 1) to the file-linear
image that :func:`training.simulation.photo.write_photo` writes as 8-bit sRGB codes; the exposure
is the caller's (``camera_renderings``: as README's capture step 5 says, or the raw peak at 80 %).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.spectra import colour
from cd_spectra_addon.core.spectra.cameras import CameraProfile
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from cd_spectra_addon.core.spectra.illuminants import daylight_spd

__all__ = ["RENDERINGS", "Rendering", "camera_to_srgb", "libraw_render", "white_gains", "xyz_to_camera"]

Rendering = Callable[[NDArray[np.float64], CameraProfile], NDArray[np.float64]]
LUMA = np.array([0.2126, 0.7152, 0.0722])
WHITE_K = 5500.0
ROLL_KNEE = 0.7  # the phone look's highlight roll-off starts here (linear display value)
CONTRAST = 6.0  # the logistic S-curve's steepness (blended half and half with the plain curve)


def white_gains(camera: CameraProfile) -> NDArray[np.float64]:
    """Daylight white balance: the gains that make D55 neutral, green's gain 1."""
    white = camera.sensitivities.T @ daylight_spd(WHITE_K)
    return white[1] / white


@lru_cache(maxsize=16)
def _matrix(name: str, sens_bytes: bytes) -> NDArray[np.float64]:
    sens = np.frombuffer(sens_bytes, np.float64).reshape(-1, 3)
    band = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
    target = colour.xyz_to_working_rgb(colour.spd_to_xyz(np.eye(WAVELENGTHS_NM.size)), colour.LINEAR_REC709)
    target = np.clip(target, 0.0, None)  # the spectral colours, clipped at the sRGB gamut
    camera = CameraProfile(name, sens)
    balanced = sens * white_gains(camera)
    fit, *_ = np.linalg.lstsq(balanced[band], target[band], rcond=None)
    m = fit.T
    return m / (m @ np.ones(3))[:, None]  # balanced white → equal sRGB


def camera_to_srgb(camera: CameraProfile) -> NDArray[np.float64]:
    """(3, 3) white-balanced camera RGB → linear sRGB (see the module doc)."""
    sens = np.ascontiguousarray(camera.sensitivities, np.float64)
    return _matrix(camera.name, sens.tobytes())


def _s_curve(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """A picture style's contrast on encoded values: half plain, half a logistic S through 0.5."""
    x = np.clip(x, 0.0, 1.0)
    lo, hi = 1.0 / (1.0 + np.exp(CONTRAST * 0.5)), 1.0 / (1.0 + np.exp(-CONTRAST * 0.5))
    s = (1.0 / (1.0 + np.exp(-CONTRAST * (x - 0.5))) - lo) / (hi - lo)
    return 0.5 * x + 0.5 * s


def ordinary(native: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
    display = (native * white_gains(camera)) @ camera_to_srgb(camera).T
    return srgb_decode(_s_curve(srgb_encode(np.clip(display, 0.0, 1.0))))


def _compress_gamut(display: NDArray[np.float64]) -> NDArray[np.float64]:
    """Out-of-gamut colours moved towards their own luminance until no channel is negative,
    then scaled so no channel passes 1 (hue kept, saturation given up)."""
    y = np.clip(display @ LUMA, 1e-9, None)[..., None]
    lowest = display.min(axis=-1, keepdims=True)
    t = np.where(lowest < 0, y / np.maximum(y - lowest, 1e-12), 1.0)  # the share of chroma kept
    out = y + (display - y) * t
    top = out.max(axis=-1, keepdims=True)
    return np.where(top > 1.0, out / np.maximum(top, 1e-12), out)


def luma_curve(native: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
    display = _compress_gamut((native * white_gains(camera)) @ camera_to_srgb(camera).T)
    y = np.clip(display @ LUMA, 1e-9, 1.0)
    factor = srgb_decode(_s_curve(srgb_encode(y))) / y
    return np.clip(display * factor[..., None], 0.0, 1.0)


def curve_first(native: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
    balanced = np.clip(native * white_gains(camera), 0.0, None)
    film = balanced * (1.0 + balanced / 4.0) / (1.0 + balanced)  # a film-like shoulder, 1 → 0.625
    return np.clip((film / 0.625) @ camera_to_srgb(camera).T, 0.0, 1.0)


def _hue_twist(display: NDArray[np.float64]) -> NDArray[np.float64]:
    """Reds turned towards orange: green lifted in proportion to how much red leads it."""
    r, g, b = display[..., 0], display[..., 1], display[..., 2]
    lead = np.clip(r - np.maximum(g, b), 0.0, None)
    return np.stack([r, g + 0.12 * lead, b], axis=-1)


def _box_blur(x: NDArray[np.float64], radius: int) -> NDArray[np.float64]:
    out = x
    for axis in (0, 1):
        c = np.cumsum(np.pad(out, [(radius + 1, radius) if a == axis else (0, 0) for a in range(out.ndim)],
                             mode="edge"), axis=axis)
        hi = np.take(c, np.arange(2 * radius + 1, c.shape[axis]), axis=axis)
        lo = np.take(c, np.arange(0, c.shape[axis] - 2 * radius - 1), axis=axis)
        out = (hi - lo) / (2 * radius + 1)
    return out


def phone(native: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
    m = camera_to_srgb(camera)
    boost = 1.25 * np.eye(3) - 0.25 * np.ones((3, 1)) * LUMA
    display = _hue_twist((native * white_gains(camera)) @ (boost @ m).T)
    y = np.clip(display @ LUMA, 0.0, None)
    local = _box_blur(y, max(2, y.shape[1] // 40))
    lift = np.clip(0.35 / np.maximum(local, 0.02), 1.0, 2.5) ** 0.5  # dark surroundings lifted up to 1.6×
    display = display * lift[..., None]
    # Highlight roll-off: a shoulder from 0.7, slope 1 there, full scale at 1.3 (a brighter colour
    # is never written darker: every camera's tone curve is monotone).
    over = np.clip(display - ROLL_KNEE, 0.0, None)
    rolled = np.minimum(display, ROLL_KNEE) + over / (1.0 + over / (1.0 - ROLL_KNEE) * 0.5)
    return srgb_decode(_s_curve(srgb_encode(np.clip(rolled, 0.0, 1.0))))


RENDERINGS: dict[str, Rendering] = {"ordinary": ordinary, "luma-curve": luma_curve, "curve-first": curve_first,
                                    "phone": phone}


def xyz_to_camera(camera: CameraProfile) -> NDArray[np.float64]:
    """(3, 3) XYZ (D65-referred) → camera RGB: the DNG ColorMatrix of this camera, from its
    sensitivities (least squares over 400–700 nm), normalised so D65 gives camera green 1."""
    band = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
    cmfs = colour.spd_to_xyz(np.eye(WAVELENGTHS_NM.size))
    fit, *_ = np.linalg.lstsq(cmfs[band], camera.sensitivities[band], rcond=None)  # xyz @ fit ≈ camera
    m = fit.T
    d65 = colour.spd_to_xyz(daylight_spd(6504.0))
    return m / float((m @ (d65 / d65[1]))[1])


def libraw_render(dng: Path, white_balance: NDArray[np.float64]) -> NDArray[np.float64]:
    """LibRaw's own rendering of a DNG (rawpy ``postprocess``: AHD demosaic, the file's camera
    matrix, ``white_balance`` as the user's multipliers, sRGB primaries and curve, 8 bits,
    highlights clipped, no auto-brightening): the file-linear image of its 8-bit output."""
    import rawpy

    with rawpy.imread(str(dng)) as raw:
        rgb = raw.postprocess(user_wb=[float(white_balance[0]), float(white_balance[1]), float(white_balance[2]),
                                       float(white_balance[1])],
                              output_color=rawpy.ColorSpace.sRGB, gamma=(2.4, 12.92), no_auto_bright=True,
                              output_bps=8, highlight_mode=rawpy.HighlightMode.Clip)
    return srgb_decode(rgb.astype(np.float64) / 255.0)
