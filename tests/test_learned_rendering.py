"""A camera's rendering learned from a raw + JPEG pair (training/evaluation/learned_rendering.py):
fitted on a pair made by a known rendering, it must reproduce that rendering where it was not fitted."""

import numpy as np
import pytest

from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.evaluation.learned_rendering import KNOTS, LearnedRendering, fit_rendering
from training.evaluation.renderings import camera_to_srgb, white_gains

S = np.array([[1.9, -0.7, -0.2], [-0.25, 1.5, -0.25], [0.05, -0.55, 1.5]])  # a camera → sRGB, rows sum to 1
LOOK = np.array([[1.55, -0.15, 0.0], [-0.05, 1.45, -0.05], [0.0, -0.2, 1.55]])  # exposure + saturation, neutral kept


def _true_codes(cam, gains):
    x = srgb_encode(np.clip(cam @ (LOOK @ S @ np.diag(gains)).T, 0.0, 1.0))
    s_curve = np.clip(x + 0.12 * np.sin(2 * np.pi * x) * np.array([1.0, 0.8, 0.6]), 0.0, 1.0)  # per-channel contrast
    return np.round(s_curve * 255) / 255


def _scene(rng, h=240, w=320):
    """Smooth patches of many colours and levels (a raw image, camera-native, full scale 1)."""
    cells = rng.uniform(0.0, 0.9, (h // 16, w // 16, 3)) * rng.uniform(0.05, 1.0, (h // 16, w // 16, 1))
    return np.repeat(np.repeat(cells, 16, 0), 16, 1)


def test_a_rendering_learned_from_a_pair_reproduces_the_camera_on_other_colours():
    rng = np.random.default_rng(0)
    gains = np.array([1.8, 1.0, 1.4])
    raw = _scene(rng)
    fitted = fit_rendering(raw, _true_codes(raw, gains), S, name="test camera")
    assert fitted.rms_codes < 2.0 and fitted.curves.shape == (3, KNOTS)
    assert np.all(np.diff(fitted.curves, axis=1) >= 0)  # monotone
    other = _scene(np.random.default_rng(1))  # colours the fit never saw
    pred = fitted.tone(other @ (fitted.look @ S @ np.diag(fitted.pair_gains)).T)
    err = (srgb_encode(pred) - _true_codes(other, gains)) * 255
    assert np.sqrt(np.mean(err ** 2)) < 3.0
    np.testing.assert_allclose(fitted.pair_gains, gains / gains[1], rtol=0.03)  # the pair's white balance
    shape = fitted.look / np.trace(fitted.look)  # the look up to the exposure a curve can trade with it
    np.testing.assert_allclose(shape, LOOK / np.trace(LOOK), atol=0.02)


def test_clipped_codes_and_raw_are_bounds_not_values():
    """Over-exposed: a fifth of the pixels at 255. The fit leaves them out and still finds the curve."""
    rng = np.random.default_rng(2)
    gains = np.array([1.8, 1.0, 1.4])
    raw = _scene(rng) * 1.6
    raw_clipped = raw.max(axis=-1) >= 1.0
    raw = np.minimum(raw, 1.0)
    codes = _true_codes(raw, gains)
    assert np.mean(codes.max(axis=-1) >= 1.0) > 0.15
    fitted = fit_rendering(raw, codes, S, raw_clipped=raw_clipped)
    assert fitted.rms_codes < 2.5


def test_a_learned_rendering_renders_a_simulated_camera_like_the_renderings():
    camera = load_camera(DEFAULT_CAMERA)
    curves = np.tile(np.linspace(0.0, 1.0, KNOTS), (3, 1))
    plain = LearnedRendering("identity", np.eye(3), curves, 0.0, 1)
    native = np.random.default_rng(3).uniform(0.0, 0.5, (8, 8, 3))
    expected = np.clip((native * white_gains(camera)) @ camera_to_srgb(camera).T, 0.0, 1.0)
    np.testing.assert_allclose(plain(native, camera), srgb_decode(srgb_encode(expected)), atol=1e-9)


def test_a_pair_without_unclipped_blocks_is_refused_with_its_reason():
    raw = np.ones((64, 64, 3))
    with pytest.raises(ValueError, match="unclipped blocks"):
        fit_rendering(raw, np.ones((64, 64, 3)), S, name="white")
