"""In-camera files: the pipeline model, its fit from one calibration shot, processed-file detection.

Photos are rendered by the numpy forward model, rendered "in camera" by the sampler in
training/simulation/camera_pipelines.py (a different curve family from the fitted model), written
as real JPEG/HEIC files and read back through load_photo and the estimator.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.calibration.calibration import Calibration, load_calibration, new_metadata, save_calibration
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from cd_spectra_addon.core.inverse.calibration_shot import calibrate_photo, fit_calibration
from cd_spectra_addon.core.calibration.camera_pipeline import CameraPipeline, fit_pipeline
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.photo.processed import BRIGHT, CLIPPED_RATIO, gamut_clipped_share
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise
from training.simulation import photo
from training.simulation.camera_pipelines import (
    TYPICAL, InCameraStyle, in_camera_exif, pipeline_for, render_in_camera, sample_pipeline,
)
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)


@pytest.fixture(scope="module")
def capture():
    scene = Scene(load_preset("cd-default").with_image_size(160))
    return scene, render_cube(scene, supersample=3), photo.track_mask(scene)


def _shoot(tmp_path: Path, capture, spd, name: str, pipeline: CameraPipeline | None, fmt: str = "jpg",
           seed: int = 0, exif: bool = True) -> Path:
    scene, cube, meter = capture
    img, _ = photo.expose(photo.linear_photo(cube, spd, CAMERA), 1.0, meter)
    img = np.minimum(photo.add_noise(img, 0.01, np.random.default_rng(seed)), 1.0)
    c = scene.preset.camera
    tags = photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], DEFAULT_CAMERA)
    if pipeline is not None:
        img = render_in_camera(img, pipeline, meter)
        tags = in_camera_exif(tags) if exif else None
    path = tmp_path / f"{name}.{'heic' if fmt.startswith('heic') else fmt}"
    photo.write_photo(path, img, fmt, tags)
    return path


def _led() -> np.ndarray:
    lam = WAVELENGTHS_NM
    return peak_normalise(0.35 * np.exp(-0.5 * ((lam - 452) / 9) ** 2) + np.exp(-0.5 * ((lam - 590) / 55) ** 2))


# --- the model ---------------------------------------------------------------------------------


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**20), wb=st.floats(2800, 7500), sat=st.floats(0, 0.3), contrast=st.floats(0, 0.5),
       gamma=st.floats(0.85, 1.1))
def test_pipeline_inverse_undoes_everything_but_clipping(seed, wb, sat, contrast, gamma):
    pipe = pipeline_for(CAMERA, InCameraStyle(wb, sat, contrast, gamma))
    native = np.random.default_rng(seed).uniform(0.0, 0.3, (500, 3))
    display = native @ pipe.matrix.T
    inside = np.all((display > 1e-3) & (display < 0.999), axis=1)
    back = pipe.to_native(pipe.to_file(native))
    # to_display is a table on a √ grid (agrees to ~2e-6; wb=2800, contrast=0.5 reach 2.03e-6)
    np.testing.assert_allclose(back[inside], native[inside], rtol=1e-5, atol=1e-9)
    assert np.all(np.isfinite(back))


def test_pipeline_json_round_trip_and_bad_pipelines_are_refused():
    pipe = pipeline_for(CAMERA, TYPICAL)
    again = CameraPipeline.from_json(json.loads(json.dumps(pipe.to_json())))
    x = np.random.default_rng(1).uniform(0, 1, (50, 3))
    np.testing.assert_allclose(again.to_file(x), pipe.to_file(x), atol=1e-5)
    with pytest.raises(CDSpectraError, match="increasing"):
        CameraPipeline(np.eye(3), np.array([0.0, 0.5, 1.0]), np.array([0.0, 0.6, 0.5]))
    with pytest.raises(CDSpectraError, match="invertible"):
        CameraPipeline(np.zeros((3, 3)), np.array([0.0, 1.0]), np.array([0.0, 1.0]))


def test_fit_recovers_a_sampled_pipeline_from_spectral_colours():
    """Monochromatic-like pixels of many intensities, 8-bit codes: the fitted inverse matches the
    true camera-native values where the rendering did not clip (up to the unknown exposure)."""
    rng = np.random.default_rng(3)
    pipe = sample_pipeline(CAMERA, rng)
    band = CAMERA.sensitivities[(WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)]
    white = CAMERA.sensitivities.sum(axis=0) / CAMERA.sensitivities.sum()
    a = rng.uniform(0.02, 0.25, 6000)[:, None]
    native = band[rng.integers(0, band.shape[0], 6000)] * a + white * a * rng.uniform(0, 1, 6000)[:, None]
    observed = srgb_decode(np.round(srgb_encode(pipe.to_file(native)) * 255) / 255)
    fitted = fit_pipeline(observed, native * 7.0)
    back = fitted.to_native(observed)
    display = native @ pipe.matrix.T
    inside = np.all((display > 0.01) & (display < 0.99), axis=1)
    assert inside.sum() > 1000
    scale = np.sum(back[inside] * native[inside]) / np.sum(native[inside] ** 2)
    assert np.median(np.abs(back[inside] / scale - native[inside])) < 0.01 * native.mean()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_fit_is_not_bent_by_the_sensors_noise(seed):
    """The sensor's noise comes before the camera's curve: between encoded values it is biased
    (the curve is concave), and a fit there bends the curve to follow it — reading every
    brighter value 2–8 % off (pixels of many colours and levels, noise 0.004 of full scale,
    8-bit codes). Refitted between linear values, weighted by the noise it measures, the values
    the noise does not swamp (display ≥ 0.03) come back within 1.5 %."""
    rng = np.random.default_rng(seed)
    pipe = pipeline_for(CAMERA, TYPICAL) if seed == 0 else sample_pipeline(CAMERA, rng)
    band = CAMERA.sensitivities[(WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)]
    white = CAMERA.sensitivities.sum(axis=0) / CAMERA.sensitivities.sum()
    a = np.exp(rng.uniform(np.log(0.005), np.log(0.3), 6000))[:, None]
    native = band[rng.integers(0, band.shape[0], 6000)] / band.max() * a + white * a * rng.uniform(0, 1, 6000)[:, None]
    native = native / np.max(native @ pipe.matrix.T)
    noisy = native + rng.normal(0.0, 0.004, native.shape)
    observed = srgb_decode(np.round(srgb_encode(pipe.to_file(noisy)) * 255) / 255)
    fitted = fit_pipeline(observed, native)
    display = native @ pipe.matrix.T
    back = fitted.to_native(pipe.to_file(native))
    inside = np.all((display > 0.002) & (display < 0.98), axis=1)
    bright = inside & np.all(display > 0.1, axis=1)
    scale = np.sum(back[bright] * native[bright]) / np.sum(native[bright] ** 2)  # the unknown exposure
    read = (back[inside] / scale) @ pipe.matrix.T
    for lo, hi in ((0.03, 0.1), (0.1, 1.0)):
        sel = (display[inside] > lo) & (display[inside] < hi)
        assert sel.sum() > 1000
        assert abs(np.median(read[sel] / display[inside][sel] - 1.0)) < 0.015, (lo, hi)


def test_fit_refuses_too_few_pixels():
    with pytest.raises(CDSpectraError, match="rainbow pixels"):
        fit_pipeline(np.full((50, 3), 0.3), np.full((50, 3), 0.2))


def test_calibration_files_keep_the_pipeline_and_old_files_still_load(tmp_path):
    pipe = pipeline_for(CAMERA, TYPICAL)
    gains = np.ones((105, 3))
    path = save_calibration(Calibration("jpeg", gains, "cd-default", DEFAULT_CAMERA, new_metadata("x", "A"), pipe),
                            tmp_path)
    loaded = load_calibration(path)
    assert loaded.pipeline is not None
    np.testing.assert_allclose(loaded.pipeline.matrix, pipe.matrix, atol=1e-7)
    data = json.loads(path.read_text())
    del data["pipeline"]  # a profile written before pipelines existed
    (tmp_path / "old.json").write_text(json.dumps(data))
    assert load_calibration(tmp_path / "old.json").pipeline is None
    data["pipeline"] = {"matrix": [[1, 0], [0, 1]], "curve_in": [0, 1], "curve_out": [0, 1]}
    (tmp_path / "bad.json").write_text(json.dumps(data))
    with pytest.raises(CDSpectraError, match="bad.json"):
        load_calibration(tmp_path / "bad.json")


# --- processed files -----------------------------------------------------------------------------


def test_in_camera_files_are_detected_and_camera_native_ones_are_not(tmp_path, capture):
    pipe = pipeline_for(CAMERA, TYPICAL)
    spd = known_lamp_spd("incandescent")
    native = load_photo(_shoot(tmp_path, capture, spd, "native", None))
    assert not native.processed and native.processed_reason == ""
    jpeg = load_photo(_shoot(tmp_path, capture, spd, "camera", pipe))
    assert jpeg.processed and "WhiteBalance" in jpeg.processed_reason and "ColorSpace" in jpeg.processed_reason
    heic = load_photo(_shoot(tmp_path, capture, spd, "phone", pipe, fmt="heic"))
    assert heic.processed and "HEIC" in heic.processed_reason
    stripped = load_photo(_shoot(tmp_path, capture, spd, "stripped", pipe, exif=False))
    assert stripped.processed and "clipped to zero" in stripped.processed_reason
    native_heic = load_photo(_shoot(tmp_path, capture, spd, "native-heic", None, fmt="heic"))
    assert native_heic.processed  # a HEIC is a phone's rendering whatever its pixels say


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_gamut_clipped_share_is_the_plain_float64_count(dtype):
    """The fast share (channel max in the image's precision, float64 for bright pixels only)
    equals the straightforward one, also at the threshold and with NaN, ±inf and clipped pixels."""
    rng = np.random.default_rng(5)
    rgb = (rng.random((120, 150, 3)) * 0.3).astype(dtype)
    rgb[::7, ::5, 1] = 0.0
    rgb[::3, ::3] = dtype(BRIGHT)  # exactly at the float32/float64 threshold
    rgb[5, 5, 0], rgb[6, 6, 1], rgb[7, 7, 2], rgb[8, 8] = np.nan, np.inf, -np.inf, np.inf
    saturated = rng.random((120, 150)) < 0.1
    flat = rgb.astype(np.float64).reshape(-1, 3)
    flat = flat[~saturated.reshape(-1) & np.all(np.isfinite(flat), axis=1)]
    bright = flat[flat.max(axis=1) > BRIGHT]
    plain = float(np.mean(bright.min(axis=1) < CLIPPED_RATIO * bright.max(axis=1)))
    assert gamut_clipped_share(rgb, saturated) == plain
    assert gamut_clipped_share(rgb[:5, :5], saturated[:5, :5]) == 0.0  # fewer than 100 bright pixels


def test_icc_profile_marks_a_file_processed(tmp_path):
    from PIL import Image, ImageCms

    icc = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    Image.new("RGB", (96, 96), (120, 60, 30)).save(tmp_path / "icc.jpg", icc_profile=icc)
    image = load_photo(tmp_path / "icc.jpg")
    assert image.processed and "ICC profile" in image.processed_reason


# --- the calibration shot fits the pipeline, the estimator uses it ---------------------------------


@pytest.mark.slow  # end to end: two calibration fits and 4 estimates, accuracy against the truth (~4 s)
def test_calibration_shot_undoes_an_in_camera_jpeg(tmp_path, capture):
    """One in-camera JPEG of CIE A, fixed white balance: the pipeline calibration brings a warm
    LED's in-camera JPEG within 2× of a camera-native 8-bit file (the quantisation floor of any
    JPEG); per-bin gains alone cannot."""
    scene = capture[0]
    pipe = pipeline_for(CAMERA, TYPICAL)
    ref = known_lamp_spd("incandescent")
    cal_path = _shoot(tmp_path, capture, ref, "cal", pipe, seed=5)
    saved = calibrate_photo(cal_path, ref, "camera-jpeg", scene.preset.name, directory=tmp_path / "cal",
                            reference_name="incandescent")
    cal = load_calibration(saved)
    assert cal.pipeline is not None and "WhiteBalance" in cal.metadata["processed"]
    image = load_photo(cal_path)
    gains_only_cal, _ = fit_calibration(image, ref, scene.preset, CAMERA, pipeline=False)
    assert gains_only_cal.pipeline is None and gains_only_cal.sensitivities is None
    gains_only = gains_only_cal.gains
    target = _led()
    raw = load_photo(_shoot(tmp_path, capture, target, "raw", None, fmt="exr", seed=3))
    native8 = load_photo(_shoot(tmp_path, capture, target, "native8", None, seed=3))
    jpeg = load_photo(_shoot(tmp_path, capture, target, "jpeg", pipe, seed=3))

    def mae(image, calibration):
        est = estimate_image(image, preset=scene.preset, camera=DEFAULT_CAMERA, calibration=calibration, model=None,
                             method="physics")
        return compare_spds(est.spd, target)["mae_400_700"], est

    native_mae, _ = mae(native8, None)
    plain, plain_est = mae(jpeg, None)
    gains, gains_est = mae(jpeg, Calibration("g", gains_only, scene.preset.name, DEFAULT_CAMERA, {}))
    piped, piped_est = mae(jpeg, cal)
    assert any("processed by the camera" in w for w in plain_est.warnings)
    assert any("gains only" in w for w in gains_est.warnings)
    assert not any("processed" in w for w in piped_est.warnings)
    assert piped < 0.3 * min(plain, gains)
    assert piped < 2.0 * native_mae
    _, mixed = mae(raw, cal)  # a JPEG calibration on a raw photo is flagged, not silently trusted
    assert any("unprocessed" in w for w in mixed.warnings) and mixed.confidence <= 0.5


# --- the camera from EXIF ------------------------------------------------------------------------


@pytest.mark.parametrize("make,model,profile", [
    ("Canon", "Canon EOS 5D Mark III", "Canon_EOS_5D_Mark_III"), ("NIKON CORPORATION", "NIKON D850", "Nikon_D850"),
    ("NIKON CORPORATION", "NIKON Z f", "Nikon_Z_f"), ("SONY", "ILCE-7M3", "Sony_ILCE-7M3"),
    ("FUJIFILM", "GFX 100", "Fujifilm_GFX_100"), ("Panasonic", "DC-GX9", "Panasonic_DC-GX9"),
    ("Canon", "Canon EOS DIGITAL REBEL XTi", "Canon_Digital_Rebel_XTi"), ("Canon", "Canon EOS 250D", "Canon_EOS_200D_II"),
    ("Arashi Vision", "Insta360 X5", "Arashi_Vision_Insta360_X5"), ("  canon ", "canon eos-1d x mark ii\x00",
                                                                    "Canon_EOS-1D_X_Mark_II"),
    ("Apple", "iPhone 15 Pro", None), ("Canon", "Canon EOS 5D Mark V", None), (None, None, None), ("", "", None),
])
def test_camera_from_exif_normalises_names(make, model, profile):
    from cd_spectra_addon.core.spectra.cameras import camera_from_exif

    assert camera_from_exif(make, model.replace("\x00", "") if model else model) == profile


@settings(max_examples=200, deadline=None)
@given(make=st.one_of(st.none(), st.text(max_size=40)), model=st.one_of(st.none(), st.text(max_size=60)))
def test_camera_from_exif_never_fails_on_any_text(make, model):
    from cd_spectra_addon.core.spectra.cameras import camera_from_exif, camera_names

    assert camera_from_exif(make, model) in (None, *camera_names())


def test_auto_camera_uses_exif_and_says_so_when_it_cannot(tmp_path, capture):
    scene = capture[0]
    spd = known_lamp_spd("incandescent")
    matched = load_photo(_shoot(tmp_path, capture, spd, "canon", None, fmt="png"))
    est = estimate_image(matched, preset=scene.preset, model=None, method="physics")
    assert est.camera == DEFAULT_CAMERA and not any("camera profiles" in w for w in est.warnings)
    scene_cam = scene.preset.camera
    tags = photo.exif_for(scene_cam.focal_length_mm, scene_cam.sensor_width_mm, scene_cam.image_size_px[0],
                          "Apple_iPhone 15 Pro")
    img, _ = photo.expose(photo.linear_photo(capture[1], spd, CAMERA), 1.0, capture[2])
    photo.write_photo(tmp_path / "phone.png", img, "png", tags)
    phone = load_photo(tmp_path / "phone.png")
    est = estimate_image(phone, preset=scene.preset, model="shipped", method="model")
    assert est.camera == "generic"
    assert any("Apple iPhone 15 Pro" in w and "not one of the 52" in w for w in est.warnings)
    assert not any(w.startswith("generic camera profile") for w in est.warnings)
    forced = estimate_image(phone, preset=scene.preset, camera="Nikon_D850", model=None, method="physics")
    assert forced.camera == "Nikon_D850"
    other = Calibration("canon-cal", np.ones((105, 3)), scene.preset.name, DEFAULT_CAMERA, {})
    mixed = estimate_image(phone, preset=scene.preset, camera="Nikon_D850", calibration=other, model=None,
                           method="physics")
    assert any("made with the Canon_EOS_5D_Mark_III profile" in w for w in mixed.warnings)
    assert mixed.confidence < forced.confidence


def test_a_processed_files_colour_blur_does_not_size_the_lamp(tmp_path, capture, monkeypatch):
    """A rendering's gamut clipping and saturation blur the rainbow's colours as a larger lamp
    does, so the lamp's size is judged on its colour blur (by the pose fit, or for a near-axis
    set-up by the readout) only in camera-native files: an in-camera JPEG keeps the size its
    capture was fitted at (a held-out rendering's LED was read at 3× the lamp's size, blur 15 nm
    for 5, and the solve deconvolved that blur into one-bin spikes)."""
    from cd_spectra_addon.core.inverse import stages

    judged: list[str] = []
    real_fit, real_sized = stages.fit_pose, stages.sized_by_readout

    def fit_spy(*args, **kwargs):
        if kwargs["judge_size"]:
            judged.append("pose fit")
        return real_fit(*args, **kwargs)

    def sized_spy(posed):
        judged.append("readout")
        return real_sized(posed)

    monkeypatch.setattr(stages, "fit_pose", fit_spy)
    monkeypatch.setattr(stages, "sized_by_readout", sized_spy)
    scene = capture[0]
    jpeg = load_photo(_shoot(tmp_path, capture, _led(), "jpeg", pipeline_for(CAMERA, TYPICAL), seed=3))
    native = load_photo(_shoot(tmp_path, capture, _led(), "native", None, fmt="exr", seed=3))
    assert jpeg.processed and not native.processed
    stages.pose_photo(jpeg, scene.preset, CAMERA)
    assert judged == []
    stages.pose_photo(native, scene.preset, CAMERA)
    assert judged == ["readout"]
