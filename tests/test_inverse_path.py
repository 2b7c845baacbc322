"""One inverse path: a training sample and a product estimate of the same photo see identical features.

The dataset builder and the estimator both go through ``core.analysis.prepare`` →
``physics_spd`` → ``network_inputs``; these tests run both on one written-and-reloaded photo and
compare the network's input vector bit for bit, so a product-side step (mask, grey collapse,
calibration, refusal) can no longer reach one side only.
"""

import numpy as np
import pytest

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, CameraProfile, load_camera
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.errors import NoDiscError
from cd_spectra_addon.core.inverse.estimate import camera_for, estimate_image
from cd_spectra_addon.core.inverse.stages import model_prior, physics_spd, read_photo
from cd_spectra_addon.core.spectrum.solve import LINE_ALLOWANCE, rows_for, solve_prior
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.spectrum.model import INPUT_SIZE, load_model
from cd_spectra_addon.core.pose.fit import fit_pose
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise
from training.learning.dataset import sample_features, solving_camera
from training.simulation import photo
from training.simulation.render_numpy import render_cube


class _RecordingModel:
    """The shipped model, recording every input vector it is asked to predict from."""

    def __init__(self, model):
        self._model = model
        self.seen: list[np.ndarray] = []

    def __getattr__(self, name):
        return getattr(self._model, name)

    def predict(self, inputs):
        self.seen.append(np.array(inputs, copy=True))
        return self._model.predict(inputs)


@pytest.fixture(scope="module")
def capture():
    scene = Scene(load_preset("cd-default").with_image_size(256))
    return scene, render_cube(scene, supersample=2), photo.track_mask(scene)


def _photo(tmp_path, capture, spd, grey=False):
    scene, cube, meter = capture
    img, _ = photo.expose(photo.linear_photo(cube, spd, load_camera(DEFAULT_CAMERA)), 0.9, meter)
    img = np.minimum(photo.add_noise(img, 0.01, np.random.default_rng(3)), 1.0)
    if grey:
        img = np.repeat(img.mean(axis=2, keepdims=True), 3, axis=2)
    c = scene.preset.camera
    path = tmp_path / ("grey.jpg" if grey else "photo.jpg")
    photo.write_photo(path, img, "jpg", photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0],
                                                       DEFAULT_CAMERA))
    return load_photo(path)


def _lamp():
    lam = WAVELENGTHS_NM
    return peak_normalise(0.4 * np.exp(-0.5 * ((lam - 450) / 10) ** 2) + np.exp(-0.5 * ((lam - 600) / 60) ** 2))


def _same_physics(result, physics, image, preset, cam, generic, fit, model, calibration=None):
    """The network's physics input is the plain prior solve (as it was trained); the estimate's
    own physics + prior is the same solve of the same rows with the line pass."""
    cam, generic = solving_camera(cam, generic, calibration)
    reading = read_photo(image, preset, cam, generic_camera=generic, fit=fit, calibration=calibration)
    prior = model_prior(model)
    assert np.array_equal(physics_spd(reading, prior), physics)
    lined = solve_prior(rows_for(reading.readout, reading.matrix), prior[0], precision=prior[1],
                        lines=LINE_ALLOWANCE)[:physics.size]
    assert np.allclose(result.extra["physics_spd"], lined / lined.max(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("camera", [DEFAULT_CAMERA, "generic"])
@pytest.mark.parametrize("grey", [False, True], ids=["colour", "grey"])
def test_dataset_sample_and_estimate_see_identical_features(tmp_path, capture, camera, grey):
    image = _photo(tmp_path, capture, _lamp(), grey)
    preset = load_preset("cd-default").with_image_size(256)
    model = _RecordingModel(load_model())
    cam, generic = camera_for(camera, model)
    focal = capture[0].preset.camera.focal_px
    fit = fit_pose(np.asarray(image.rgb, dtype=np.float64), preset, focal)

    features = sample_features(image, preset, cam, generic, fit, None, model_prior(model))
    result = estimate_image(image, preset=preset, camera=camera, model=model, fit=fit)

    assert features is not None and len(model.seen) == 1
    inputs, physics = features
    assert inputs.shape == (INPUT_SIZE,) and np.all(np.isfinite(inputs))
    assert np.array_equal(model.seen[0], inputs)
    _same_physics(result, physics, image, preset, cam, generic, fit, model)


def test_a_photo_the_product_refuses_is_not_a_training_sample(tmp_path, capture):

    scene = capture[0]
    dark = np.clip(0.3 + 0.02 * np.random.default_rng(0).standard_normal((256, 256, 3)), 0, 1)  # lit, no rainbow
    path = tmp_path / "blank.png"
    photo.write_photo(path, dark, "png16")
    image = load_photo(path)
    preset = load_preset("cd-default").with_image_size(256)
    cam = load_camera(DEFAULT_CAMERA)
    fit = fit_pose(dark, preset, scene.preset.camera.focal_px)
    with pytest.raises(NoDiscError):
        estimate_image(image, preset=preset, fit=fit)
    assert sample_features(image, preset, CameraProfile(cam.name, cam.sensitivities), False, fit, None,
                           model_prior(load_model())) is None


# make test only (5 s, the slowest check of make test-fast; test_dataset_sample_and_estimate_see_identical_features
# keeps the uncalibrated parity there); the generic camera repeats it with a fitted profile
@pytest.mark.slow
@pytest.mark.parametrize("camera", [DEFAULT_CAMERA, "generic"])
def test_calibrated_in_camera_photo_gives_training_and_product_the_same_features(tmp_path, capture, camera):
    """An in-camera JPEG read with a CIE A calibration (its processing, and for the generic
    profile the camera's fitted sensitivities): the dataset and the estimator agree bit for bit."""
    from cd_spectra_addon.core.inverse.calibration_shot import fit_calibration
    from cd_spectra_addon.core.inverse.estimate import camera_prior_for
    from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
    from training.simulation.camera_pipelines import TYPICAL, in_camera_exif, pipeline_for, render_in_camera

    scene, cube, meter = capture
    pipe = pipeline_for(load_camera(DEFAULT_CAMERA), TYPICAL)

    def shoot(spd, name):
        img, _ = photo.expose(photo.linear_photo(cube, spd, load_camera(DEFAULT_CAMERA)), 0.9, meter)
        img = render_in_camera(np.minimum(photo.add_noise(img, 0.01, np.random.default_rng(5)), 1.0), pipe, meter)
        c = scene.preset.camera
        path = tmp_path / f"{name}.jpg"
        photo.write_photo(path, img, "jpg", in_camera_exif(photo.exif_for(
            c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], "Apple_iPhone 15 Pro")))
        return load_photo(path)

    preset = load_preset("cd-default").with_image_size(256)
    model = _RecordingModel(load_model())
    cam, generic = camera_for(camera, model)
    ref = known_lamp_spd("incandescent")
    cal, _ = fit_calibration(shoot(ref, "cal"), ref, preset, cam, generic,
                             prior=camera_prior_for(model) if generic else None)
    assert cal.pipeline is not None and (cal.sensitivities is not None) == generic
    image = shoot(_lamp(), "photo")
    assert image.processed
    fit = fit_pose(np.asarray(image.rgb, dtype=np.float64), preset, scene.preset.camera.focal_px)
    features = sample_features(image, preset, cam, generic, fit, None, model_prior(model), cal)
    result = estimate_image(image, preset=preset, camera=camera, calibration=cal, model=model, fit=fit)
    assert features is not None and len(model.seen) == 1
    assert np.array_equal(model.seen[0], features[0])
    _same_physics(result, features[1], image, preset, cam, generic, fit, model, cal)
    assert features[0][INPUT_SIZE - 2] == 0.0  # calibrated: the network is told the camera is known
