"""The camera pipeline's wider family (issue 20): a tone curve on luminance, gamut compression.

The model's members, their inverse, their files, and the fit choosing between them from one
calibration photo's pixels (synthetic spectral colours through a known pipeline, 8-bit codes).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from cd_spectra_addon.core.calibration.camera_pipeline import (LUMA, CameraPipeline, compress_gamut,
                                                               fit_pipeline)
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from training.simulation.camera_pipelines import TYPICAL, pipeline_for

CAMERA = load_camera(DEFAULT_CAMERA)


def _member(tone: str, gamut: str = "clip") -> CameraPipeline:
    base = pipeline_for(CAMERA, TYPICAL)
    return CameraPipeline(base.matrix, base.curve_in, base.curve_out, tone, gamut)


def _spectral_pixels(n: int, seed: int) -> np.ndarray:
    """Rainbow-like camera-native pixels: single wavelengths plus some white, many intensities."""
    rng = np.random.default_rng(seed)
    band = CAMERA.sensitivities[(WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)]
    white = CAMERA.sensitivities.sum(axis=0) / CAMERA.sensitivities.sum()
    a = rng.uniform(0.02, 0.25, n)[:, None]
    return band[rng.integers(0, band.shape[0], n)] * a + white * a * rng.uniform(0, 1, n)[:, None]


def _eight_bit(linear: np.ndarray) -> np.ndarray:
    return srgb_decode(np.round(srgb_encode(linear) * 255) / 255)


def test_a_luminance_curve_is_undone_where_nothing_clipped():
    pipe = _member("luminance")
    native = np.random.default_rng(0).uniform(0.0, 0.3, (500, 3))
    display = native @ pipe.matrix.T
    inside = np.all((display > 1e-3) & (display < 0.999), axis=1)
    file = pipe.to_file(native)
    back = pipe.to_native(file)
    ok = inside & np.all(file < 0.999, axis=1)
    assert ok.sum() > 100
    np.testing.assert_allclose(back[ok], native[ok], rtol=1e-4, atol=1e-7)
    # hue-preserving: every channel of a pixel scaled by the same factor
    ratio = file[ok] / display[ok]
    np.testing.assert_allclose(ratio / ratio[:, :1], 1.0, rtol=1e-6)


def test_gamut_compression_keeps_luminance_and_leaves_in_gamut_colours_alone():
    rng = np.random.default_rng(1)
    colours = rng.uniform(-0.3, 0.9, (400, 3))
    out = compress_gamut(colours)
    assert np.all(out >= -1e-12) and np.all(out <= 1.0 + 1e-12)
    inside = np.all((colours >= 0) & (colours <= 1), axis=1)
    np.testing.assert_allclose(out[inside], colours[inside])
    y = colours @ LUMA
    moved = ~inside & (y > 0) & np.all(colours <= 1, axis=1)
    top_ok = moved & (out.max(axis=1) < 1 - 1e-9)
    np.testing.assert_allclose(out[top_ok] @ LUMA, y[top_ok], rtol=1e-9)
    np.testing.assert_allclose(out[moved].min(axis=1), 0.0, atol=1e-12)


def test_members_survive_their_file_and_unknown_members_are_refused():
    for tone, gamut in (("channel", "clip"), ("luminance", "clip"), ("luminance", "compress")):
        pipe = _member(tone, gamut)
        data = json.loads(json.dumps(pipe.to_json()))
        again = CameraPipeline.from_json(data)
        assert (again.tone, again.gamut) == (tone, gamut)
        x = np.random.default_rng(2).uniform(-0.1, 0.5, (50, 3))
        np.testing.assert_allclose(again.to_file(x), pipe.to_file(x), atol=1e-5)
    assert "tone" not in _member("channel").to_json()  # files of the original family are unchanged
    with pytest.raises(CDSpectraError, match="tone curve"):
        _member("sideways")
    with pytest.raises(CDSpectraError, match="gamut"):
        _member("channel", "fold")


@pytest.mark.parametrize("tone,gamut", [("channel", "clip"), ("luminance", "compress")])
def test_the_fit_picks_the_member_that_rendered_the_photo(tone, gamut):
    truth = _member(tone, gamut)
    native = _spectral_pixels(2500, 4)
    observed = _eight_bit(truth.to_file(native))
    fitted = fit_pipeline(observed, native * 5.0)
    assert (fitted.tone, fitted.gamut) == (tone, gamut)
    # where the camera neither clipped nor compressed, the fitted inverse gives back the native
    # colour (up to the exposure the fit cannot know)
    display = native @ truth.matrix.T
    inside = np.all((display > 0.02) & (display < 0.9), axis=1) & np.all(observed < 0.95, axis=1)
    assert inside.sum() > 300
    back = fitted.to_native(observed)[inside]
    scale = np.sum(back * native[inside]) / np.sum(native[inside] ** 2)
    assert np.median(np.abs(back / scale - native[inside])) < 0.01 * native.mean()
