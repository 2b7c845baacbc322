"""Clipped channels of in-camera files are bounds (issue 20): in the calibration fit, in the
estimate's readout, and what a calibration says when it cannot explain its own photo.

Synthetic data only: a near-monochromatic spectrometer readout (each λ₁ bin a narrow band) of a
known lamp through a measured camera profile, rendered by a known pipeline that clips.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.calibration.calibration import (EXPLAIN_LIMIT, Calibration, calibration_warning,
                                                           unexplained_share)
from cd_spectra_addon.core.calibration.camera_pipeline import LUMA, compress_gamut, fit_pipeline
from cd_spectra_addon.core.calibration.censoring import uncensor
from cd_spectra_addon.core.photo.clipping import HIGH_LINEAR, LOW_LINEAR, clipped_channels
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.readout.readout import Readout
from cd_spectra_addon.core.scene.diffraction import PixelDiffraction
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.spectra.grid import FEATURE_LAMBDA_NM, N_FEATURES, WAVELENGTHS_NM
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from training.simulation.camera_pipelines import TYPICAL, pipeline_for

CAMERA = load_camera(DEFAULT_CAMERA)
PIPE = pipeline_for(CAMERA, TYPICAL)


def _forward() -> np.ndarray:
    """(NB, 3, 81): each λ₁ bin sees a 6 nm-wide band at its centre, through the camera."""
    r = np.exp(-0.5 * ((FEATURE_LAMBDA_NM[:, None] - WAVELENGTHS_NM[None, :]) / 6.0) ** 2)
    return r[:, None, :] * CAMERA.sensitivities.T[None, :, :]


def _readout(values: np.ndarray, censored: np.ndarray | None, valid: np.ndarray) -> Readout:
    empty = np.zeros(0)
    pixels = PixelDiffraction(**{f: empty.astype(np.int64) if f == "index" else empty.astype(bool) if f == "on_tracks"
                                 else np.zeros((3, 0)) if f in ("points_c", "view_c") else empty
                                 for f in PixelDiffraction.__dataclass_fields__})
    return Readout(lambda_nm=FEATURE_LAMBDA_NM.copy(), values=values, weight=np.ones(N_FEATURES),
                   saturated_fraction=np.zeros(N_FEATURES), valid=valid, noise=np.full(values.shape, 1e-4),
                   pixels=pixels, pixel_bin=np.zeros(0, np.int64), pixel_weight=np.zeros(0), censored=censored)


def _clipped_scene(top: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(true native values, display values as the camera clipped them, censor flags, valid)."""
    forward = _forward()
    native = np.einsum("bcl,l->bc", forward, known_lamp_spd("incandescent"))
    valid = (FEATURE_LAMBDA_NM >= 400) & (FEATURE_LAMBDA_NM <= 700)
    native = native / native[valid].max()
    display = native @ PIPE.matrix.T
    display = display / display[valid].max() * top  # the brightest colour `top` × full scale
    native = display @ np.linalg.inv(PIPE.matrix).T
    clipped = np.clip(display, 0.0, 1.0)
    censored = np.where(display < 0, -1, np.where(display > 1, 1, 0)).astype(np.int8)
    return native, clipped, censored, valid


def test_a_clipped_readout_comes_back_native_from_its_bounds():
    """Red clipped at full scale and spectral colours clipped at zero: read as values, the native
    readout is off by tens of per cent in the clipped bins; read as bounds, within 2 %."""
    native, clipped, censored, valid = _clipped_scene(top=1.6)
    assert np.sum(censored[valid] > 0) >= 5 and np.sum(censored[valid] < 0) >= 5
    as_values = uncensor(_readout(clipped, None, valid), PIPE.matrix, _forward())
    as_bounds = uncensor(_readout(clipped, censored, valid), PIPE.matrix, _forward())
    hit = valid & np.any(censored != 0, axis=1)
    peak = native[valid].max()
    err_values = np.abs(as_values.values[hit] - native[hit]).max() / peak
    err_bounds = np.abs(as_bounds.values[hit] - native[hit]).max() / peak
    assert err_values > 0.2
    assert err_bounds < 0.02
    assert as_bounds.censored is None


def test_a_calibration_shot_resolves_its_bounds_with_the_known_lamp():
    native, clipped, censored, valid = _clipped_scene(top=1.6)
    back = uncensor(_readout(clipped, censored, valid), PIPE.matrix, _forward(), known_spd=known_lamp_spd("A"))
    assert np.abs(back.values[valid] - native[valid]).max() < 0.02 * native[valid].max()


def test_nothing_flagged_is_the_plain_inverse():
    native, clipped, censored, valid = _clipped_scene(top=0.6)
    flat = native @ PIPE.matrix.T
    back = uncensor(_readout(flat, np.zeros_like(censored), valid), PIPE.matrix, _forward())
    np.testing.assert_allclose(back.values[valid], native[valid], atol=1e-12)


def _codes(file_linear: np.ndarray) -> np.ndarray:
    return np.round(srgb_encode(file_linear) * 255.0)


def _spectral_pixels(over: float, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(native, 8-bit codes, display) of spectral-colour pixels exposed so the brightest 5 % of
    pixels' strongest display channel is ``over`` × full scale (red clips at 255, weak channels
    at 0), with 1 % noise."""
    rng = np.random.default_rng(seed)
    band = CAMERA.sensitivities[(WAVELENGTHS_NM >= 420) & (WAVELENGTHS_NM <= 680)]
    n = 1500
    native = band[rng.integers(0, band.shape[0], n)] * rng.uniform(0.05, 0.9, n)[:, None]
    native = (native + 0.02 * rng.uniform(0, 1, (n, 3))) * (1 + 0.01 * rng.standard_normal((n, 3)))
    display = native @ PIPE.matrix.T
    scale = over / np.quantile(display.max(axis=1), 0.95)
    return native, _codes(PIPE.to_file(native * scale)), display * scale


def test_a_clipped_channel_is_a_bound_in_the_pipeline_fit():
    """Any value past the clip — 0 or the 1–3 codes JPEG ringing leaves, 245 or 255 — fits the
    same pipeline once flagged (a bound only penalises a model that crosses it); read as values
    they change the fit. With 40 % of the pixels clipped the fit still recovers the native colours
    of the unclipped ones to 1 %."""
    native, codes, display = _spectral_pixels(over=2.0)
    sat = np.any(codes >= 250, axis=1)
    assert sat.mean() > 0.3
    low, high = clipped_channels(srgb_decode(codes / 255.0), sat)
    ringing = np.where(low, 3.0, np.where(high, 245.0, codes))  # still past the clip: codes ≤ 3, ≥ 240
    a, b = (srgb_decode(c / 255.0) for c in (codes, ringing))
    inside = np.all((display > 0.02) & (display < 0.95), axis=1)

    def native_of(fitted, observed) -> np.ndarray:
        back = fitted.to_native(observed[inside])
        return back * np.sum(back * native[inside]) / np.sum(back * back)

    fa, fb = fit_pipeline(a, native, low=low, high=high), fit_pipeline(b, native, low=low, high=high)
    np.testing.assert_allclose(native_of(fa, a), native_of(fb, a), rtol=1e-6, atol=1e-9)
    va, vb = fit_pipeline(a, native), fit_pipeline(b, native)
    assert np.max(np.abs(native_of(va, a) - native_of(vb, a))) > 1e-4
    assert np.median(np.abs(native_of(fa, a) - native[inside])) < 0.01 * native[inside].mean()


def test_clip_masks_follow_the_codes():
    rgb = srgb_decode(np.array([[[0, 2, 4], [128, 250, 255]]], float) / 255.0)
    low, high = clipped_channels(rgb, np.array([[False, True]]))
    assert low[0, 0].tolist() == [True, True, False] and not low[0, 1].any()
    assert high[0, 1].tolist() == [False, True, True] and not high[0, 0].any()
    assert LOW_LINEAR < 0.001 < HIGH_LINEAR


def test_a_calibration_that_cannot_explain_its_photo_says_so():
    cal = Calibration("phone-jpeg", np.ones((N_FEATURES, 3)), "cd-default", DEFAULT_CAMERA,
                      {"unexplained": 2 * EXPLAIN_LIMIT}, PIPE)
    message = calibration_warning(cal)
    assert message is not None and "cannot explain its own photo" in message and "shoot RAW" in message
    assert calibration_warning(Calibration("ok", cal.gains, "cd-default", DEFAULT_CAMERA,
                                           {"unexplained": EXPLAIN_LIMIT / 2}, PIPE)) is None
    assert calibration_warning(Calibration("old", cal.gains, "cd-default", DEFAULT_CAMERA, {}, PIPE)) is None


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, (N_FEATURES, 3), elements=st.floats(0.0, 10.0)),
       arrays(np.float64, (N_FEATURES, 3), elements=st.floats(-1.0, 1.0)), st.floats(0.01, 100.0))
@example(np.full((N_FEATURES, 3), 2.5e-299), np.zeros((N_FEATURES, 3)), 1.0)  # q·q underflowed: share 1, not 0
def test_unexplained_share_is_zero_for_a_perfect_fit_and_bounded(predicted, wobble, scale):
    valid = np.ones(N_FEATURES, bool)
    if not np.any(predicted > 0):
        assert unexplained_share(predicted, valid, predicted) == 1.0  # nothing predicted: nothing explained
        return
    assert unexplained_share(predicted * scale, valid, predicted) == pytest.approx(0.0, abs=1e-9)
    share = unexplained_share(predicted * scale * (1 + 0.5 * wobble), valid, predicted)
    assert np.isfinite(share) and 0.0 <= share <= 2.0


@pytest.mark.slow
def test_a_photo_processed_beyond_the_family_gets_a_calibration_that_says_so(tmp_path):
    """A phone's local tone mapping and hue twist (a rendering the pipeline cannot represent):
    its CIE A calibration reports that it cannot explain its own photo, and estimates with it
    carry the warning at lower confidence; an ordinary camera rendering's calibration does not."""
    from cd_spectra_addon.core.inverse.estimate import estimate_image
    from cd_spectra_addon.core.spectrum.model import load_model
    from training.evaluation.camera_renderings import SETTINGS, Photographer, calibrate_like_the_cli

    model = load_model()
    shooter = Photographer(tmp_path, 128)
    dslr = SETTINGS[0]
    lamp = known_lamp_spd("incandescent")
    flagged = {}
    for rendering in ("phone", "ordinary"):
        shot = shooter.jpeg(lamp, CAMERA, dslr.exif, rendering, 99, f"cal-{rendering}")
        cal, _ = calibrate_like_the_cli([shot], ("incandescent",), "auto", model, shooter.preset)
        flagged[rendering] = calibration_warning(cal)
        if rendering == "phone":
            photo = shooter.jpeg(known_lamp_spd("D65"), CAMERA, dslr.exif, rendering, 5, "photo")
            est = estimate_image(photo, preset=shooter.preset, calibration=cal, model=model)
            assert any("cannot explain its own photo" in w for w in est.warnings)
            assert est.confidence <= 0.6
            assert est.to_json()["calibration_check"]["explains_its_photo"] is False  # the number travels
            assert np.all(np.isfinite(est.spd)) and np.isfinite(est.confidence)  # poor, never NaN
        assert np.isfinite(cal.metadata["processing_rms_codes"]) and cal.metadata["processing_rms_codes"] > 0
    assert flagged["phone"] is not None and "shoot RAW" in flagged["phone"]
    assert flagged["ordinary"] is None


@pytest.mark.slow  # two CIE A calibrations and two estimates of 128 px JPEGs (~25 s)
def test_a_calibrated_jpeg_with_a_blinking_rainbow_says_it_is_over_exposed(tmp_path):
    """A calibrated in-camera file keeps its full-scale channels as bounds, so the loader's
    saturation mask no longer counted them: an ordinary rendering with 40 % of its rainbow at
    code 255 read at confidence 1.00 with no word of it. Now it says so and loses confidence
    (not below half: the bounds still carry information); the same capture exposed as README's
    step 5 says (no blinking highlights) does not."""
    from cd_spectra_addon.core.inverse.estimate import estimate_image
    from cd_spectra_addon.core.spectrum.model import load_model
    from training.evaluation.camera_renderings import SETTINGS, Photographer, calibrate_like_the_cli

    model = load_model()
    dslr = SETTINGS[0]
    read = {}
    for metering in ("raw", "rendering"):
        (tmp_path / metering).mkdir()
        shooter = Photographer(tmp_path / metering, 128, metering)
        shot = shooter.jpeg(known_lamp_spd("incandescent"), CAMERA, dslr.exif, "ordinary", 99, "cal")
        cal, _ = calibrate_like_the_cli([shot], ("incandescent",), "auto", model, shooter.preset)
        photo = shooter.jpeg(known_lamp_spd("incandescent"), CAMERA, dslr.exif, "ordinary", 5, "photo")
        read[metering] = estimate_image(photo, preset=shooter.preset, calibration=cal, model=model)
    over = read["raw"]
    assert any("has a channel at full scale" in w for w in over.warnings), over.warnings
    assert 0.5 <= over.confidence < 0.95 and over.extra["checks"]["full_scale_bins"] > 0.05
    assert not any("over-exposed" in w for w in read["rendering"].warnings), read["rendering"].warnings


def test_a_gamut_compressed_readout_comes_back_along_its_rays():
    """A camera that compresses its gamut (each out-of-gamut colour moved towards its own
    luminance until its weakest channel is 0) keeps luminance and hue and loses saturation: read
    as per-channel bounds, the native readout of CIE A is off by several per cent of its peak in
    the median bin; read along each colour's ray, to 0.1 %. A colour of no positive luminance is
    sent to black and has no ray (its channels stay bounds); no bin is lost."""
    forward = _forward()
    valid = (FEATURE_LAMBDA_NM >= 400) & (FEATURE_LAMBDA_NM <= 700)
    native = np.einsum("bcl,l->bc", forward, known_lamp_spd("incandescent"))
    display = native @ PIPE.matrix.T
    display = display * 0.9 / display[valid].max()
    native = display @ np.linalg.inv(PIPE.matrix).T
    written = compress_gamut(display)
    censored = np.where(written <= LOW_LINEAR, -1, 0).astype(np.int8)
    assert np.sum(np.any(censored < 0, axis=1) & valid) > 40  # a spectral colour is out of sRGB's gamut
    black = valid & (written @ LUMA <= 1e-9)
    assert np.any(black)  # deep violet through this matrix: no luminance, written black
    as_bounds = uncensor(_readout(written, censored, valid), PIPE.matrix, forward)
    rays = uncensor(_readout(written, censored, valid), PIPE.matrix, forward, compressed=True)
    known = uncensor(_readout(written, censored, valid), PIPE.matrix, forward, compressed=True,
                     known_spd=known_lamp_spd("incandescent"))
    peak = native[valid].max()
    lit = valid & ~black
    assert np.array_equal(rays.valid, valid) and rays.censored is None and np.all(np.isfinite(rays.values))
    assert np.median(np.abs(as_bounds.values[lit] - native[lit])) > 0.01 * peak
    assert np.median(np.abs(rays.values[lit] - native[lit])) < 0.001 * peak
    # The lamp known, its scale is set with the black colours' (wrong) bounds in: still 5× closer.
    bounds_err = np.median(np.abs(as_bounds.values[lit] - native[lit]))
    assert np.median(np.abs(known.values[lit] - native[lit])) < 0.3 * bounds_err
