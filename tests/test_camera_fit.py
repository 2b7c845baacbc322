"""A camera without a profile: its sensitivities fitted from one calibration shot of a known lamp.

Photos come from the numpy forward model of a held-out camera (never in the prior, never
trained on); the lamps are synthetic SPDs of the training prior.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.inverse.stages import read_photo
from cd_spectra_addon.core.calibration.calibration import Calibration, load_calibration, new_metadata, save_calibration
from cd_spectra_addon.core.inverse.calibration_shot import calibrate_photo, fit_calibration
from cd_spectra_addon.core.calibration.camera_fit import CameraPrior, camera_prior, fit_sensitivities
from cd_spectra_addon.core.spectra.cameras import GENERIC_CAMERA, CameraProfile, load_camera
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import camera_for, camera_prior_for, estimate_image
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.pose.result import PoseFit
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from training.learning.dataset import camera_split
from training.learning.spd_prior import sample_spds
from training.simulation import photo
from training.simulation.render_numpy import render_cube

TRAIN, HELD = camera_split()
HELD_CAMERA = "Nikon_D850"  # held out of training and of the camera prior
BAND = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
CIE_A = known_lamp_spd("incandescent")


@pytest.fixture(scope="module")
def capture():
    scene = Scene(load_preset("cd-default").with_image_size(160))
    return scene, render_cube(scene, supersample=3), photo.track_mask(scene)


def _shoot(path: Path, capture, spd, camera: CameraProfile, seed: int, exif_name: str = "Apple_iPhone 15 Pro") -> Path:
    scene, cube, meter = capture
    image, _ = photo.synthesize(cube, spd, camera, 0.9, 0.01, np.random.default_rng(seed), meter)
    c = scene.preset.camera
    photo.write_photo(path, image, "png16", photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0],
                                                           exif_name))
    return path


def test_a_calibration_shot_measures_a_camera_the_prior_never_saw(tmp_path, capture):
    assert HELD_CAMERA in HELD
    scene = capture[0]
    truth = load_camera(HELD_CAMERA).sensitivities
    prior = camera_prior(TRAIN)
    generic = prior.mean / prior.mean.max()
    image = load_photo(_shoot(tmp_path / "a.png", capture, CIE_A, load_camera(HELD_CAMERA), 1))
    analysis = read_photo(image, scene.preset, CameraProfile(GENERIC_CAMERA, generic), fit=PoseFit.of_scene(scene))
    fitted = fit_sensitivities(analysis.uncalibrated, analysis.response, CIE_A, prior)
    err_fit = np.mean(np.abs(fitted - truth)[BAND])
    err_generic = np.mean(np.abs(generic - truth)[BAND])
    assert fitted.shape == (81, 3) and fitted.min() >= 0 and fitted.max() == pytest.approx(1.0)
    assert err_fit < 0.012 and err_fit < 0.35 * err_generic, (err_fit, err_generic)
    # The known lamp's scale does not matter (to 0.1 % of the peak).
    again = fit_sensitivities(analysis.uncalibrated, analysis.response, 7.0 * CIE_A, prior)
    np.testing.assert_allclose(again, fitted, atol=1e-3)


@pytest.mark.slow  # end to end: a calibration shot and 12 estimates of 4 lamps, accuracy against the truth (~6 s)
def test_generic_profile_plus_calibration_is_as_good_as_the_cameras_own_profile(tmp_path, capture):
    """Held-out camera, EXIF unknown (→ generic): one CIE A shot brings 4 synthetic lamps within
    1.3× of the camera's own measured profile, from ~3× without it."""
    scene = capture[0]
    camera = load_camera(HELD_CAMERA)
    cal = load_calibration(calibrate_photo(_shoot(tmp_path / "cal.png", capture, CIE_A, camera, 2), CIE_A, "phone",
                                           scene.preset.name, directory=tmp_path / "cal",
                                           reference_name="incandescent"))
    assert cal.camera == GENERIC_CAMERA and cal.sensitivities is not None and cal.pipeline is None
    spds, _ = sample_spds(4, np.random.default_rng(31))
    mae = {"own": [], "generic": [], "calibrated": []}
    for i, spd in enumerate(spds):
        image = load_photo(_shoot(tmp_path / f"p{i}.png", capture, spd, camera, 10 + i))
        own = estimate_image(image, preset=scene.preset, camera=HELD_CAMERA)
        generic = estimate_image(image, preset=scene.preset)
        calibrated = estimate_image(image, preset=scene.preset, calibration=cal)
        assert generic.camera == GENERIC_CAMERA and any("not one of the 52" in w for w in generic.warnings)
        assert not any("generic" in w or "not one of" in w for w in calibrated.warnings)
        assert calibrated.confidence > generic.confidence
        for key, est in (("own", own), ("generic", generic), ("calibrated", calibrated)):
            mae[key].append(compare_spds(est.spd, spd)["mae_400_700"])
    own, generic, calibrated = (float(np.mean(mae[k])) for k in ("own", "generic", "calibrated"))
    print(f"\nown {own:.4f} generic {generic:.4f} calibrated {calibrated:.4f}")
    assert calibrated < 1.3 * own + 0.002, mae
    assert generic > 1.8 * calibrated, mae


def test_the_prior_is_the_models_training_cameras():
    model = load_model()
    prior = camera_prior_for(model)
    generic, is_generic = camera_for(GENERIC_CAMERA, model)
    assert is_generic and set(prior.names) == set(model.metadata["cameras"]["train"])
    np.testing.assert_allclose(prior.mean / prior.mean.max(), generic.sensitivities, atol=1e-6)
    assert camera_prior_for(None).names == tuple(sorted(TRAIN + HELD))


def test_calibration_profiles_keep_fitted_sensitivities_and_old_ones_still_load(tmp_path):
    sens = load_camera(HELD_CAMERA).sensitivities
    path = save_calibration(Calibration("phone", np.ones((105, 3)), "cd-default", GENERIC_CAMERA,
                                        new_metadata("x", "A"), None, sens), tmp_path)
    loaded = load_calibration(path)
    np.testing.assert_allclose(loaded.sensitivities, sens, atol=1e-6)
    data = json.loads(path.read_text())
    del data["sensitivities"]  # a profile written before fitted cameras existed
    (tmp_path / "old.json").write_text(json.dumps(data))
    assert load_calibration(tmp_path / "old.json").sensitivities is None


@settings(max_examples=60, deadline=None)
@given(value=st.one_of(st.none(), st.integers(), st.text(max_size=5), st.lists(st.floats(allow_nan=True), max_size=4),
                       st.lists(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=3, max_size=3),
                                min_size=81, max_size=81)))
def test_any_sensitivities_in_a_profile_load_or_are_refused_clearly(value):
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = save_calibration(Calibration("x", np.ones((105, 3)), "cd-default", GENERIC_CAMERA, {}), Path(tmp))
        data = json.loads(path.read_text())
        data["sensitivities"] = value
        path.write_text(json.dumps(data))
        try:
            cal = load_calibration(path)
        except CDSpectraError as exc:
            assert "sensitivities" in str(exc) and "calibrate again" in str(exc)
            return
        assert cal.sensitivities is None or (cal.sensitivities.shape == (81, 3) and np.all(np.isfinite(cal.sensitivities))
                                             and cal.sensitivities.max() == pytest.approx(1.0))


def test_bad_priors_and_dark_photos_are_refused(capture):
    with pytest.raises(CDSpectraError, match="at least two"):
        CameraPrior.from_profiles([load_camera(HELD_CAMERA).sensitivities])
    with pytest.raises(CDSpectraError, match="at least two"):
        CameraPrior.from_profiles([np.ones((80, 3)), np.ones((80, 3))])
    scene, cube, meter = capture
    image, _ = photo.synthesize(cube, CIE_A, load_camera(HELD_CAMERA), 0.9, 0.01, np.random.default_rng(0), meter)
    from cd_spectra_addon.core.readout.readout import extract_readout
    from cd_spectra_addon.core.readout.forward_matrix import bin_response

    readout = extract_readout(image, None, scene)
    response = bin_response(scene, readout)
    prior = camera_prior(TRAIN)
    dark = readout.__class__(**{**readout.__dict__, "values": np.zeros_like(readout.values)})
    with pytest.raises(CDSpectraError, match="no light"):
        fit_sensitivities(dark, response, CIE_A, prior)
    with pytest.raises(CDSpectraError, match="no light"):
        fit_sensitivities(readout, response, np.zeros(81), prior)


def test_calibrating_a_known_camera_keeps_its_profile(tmp_path, capture):
    """A camera with a profile is calibrated with per-bin gains only: its measured curves stay."""
    scene = capture[0]
    image = load_photo(_shoot(tmp_path / "k.png", capture, CIE_A, load_camera("Nikon_D850"), 3, "Nikon_D850"))
    cal, _ = fit_calibration(image, CIE_A, scene.preset, load_camera("Nikon_D850"))
    assert cal.sensitivities is None and cal.camera == "Nikon_D850"
