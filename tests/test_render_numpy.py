"""The numpy twin's images obey the grating equation; photos are linear in the SPD."""


import numpy as np
import pytest

from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from tests.ring_geometry import (
    coaxial_first_order_radius_px,
    first_order_radius_mm_on_x_axis,
    line_peak_px,
    radial_peak_px,
)
from training.simulation import photo
from training.simulation.render_numpy import render_cube

pytestmark = pytest.mark.slow  # full-resolution supersampled renders (~15 s)

RING_WAVELENGTHS = (400.0, 450.0, 550.0, 650.0, 750.0)


@pytest.fixture(scope="module")
def default_cube():
    scene = Scene(load_preset("cd-default").with_image_size(256))
    return scene, render_cube(scene, supersample=4)


def _band(lam):
    return int(round((lam - 380) / 5))


def test_ring_radii_follow_the_grating_equation_coaxial(default_cube):
    scene, cube = default_cube
    cam = scene.preset.camera
    centre = scene.project(np.zeros((1, 3)))[0]
    for lam in RING_WAVELENGTHS:
        expected = coaxial_first_order_radius_px(lam, scene.preset.disc.pitch_um, cam.focal_px)
        found = radial_peak_px(cube[_band(lam)], centre, expected - 8, expected + 8)
        assert abs(found - expected) < 1.0, (lam, found, expected)


@pytest.mark.parametrize("preset,wavelengths", [
    ("cd-far-light", RING_WAVELENGTHS),
    ("paper", (400.0, 450.0, 500.0, 600.0, 680.0)),
])
def test_ring_radii_follow_the_grating_equation_other_presets(preset, wavelengths):
    scene = Scene(load_preset(preset).with_image_size(256))
    cube = render_cube(scene, supersample=3, wavelengths_nm=WAVELENGTHS_NM)
    px_per_mm = scene.preset.camera.focal_px / scene.preset.camera.distance_mm
    centre = scene.project(np.zeros((1, 3)))[0]
    for lam in wavelengths:
        r_mm = first_order_radius_mm_on_x_axis(lam, scene.preset.disc.pitch_um,
                                               scene.camera_position * 1e3, scene.light_position * 1e3, 1.0)
        expected = r_mm * px_per_mm
        found = radial_peak_px(cube[_band(lam)], centre, expected - 8, expected + 8)
        assert abs(found - expected) < 1.0, (preset, lam, found, expected)


def test_an_off_axis_camera_moves_the_rings_as_the_grating_equation_says():
    pose = Pose(camera_offset_mm=(6.0, 0.0))
    scene = Scene(load_preset("cd-default").with_image_size(256), pose)
    cube = render_cube(scene, supersample=4)
    centre = scene.project(np.zeros((1, 3)))[0]
    for lam in (450.0, 550.0, 650.0):
        radii, predicted = [], []
        for side in (1.0, -1.0):
            r_mm = first_order_radius_mm_on_x_axis(lam, 1.6, scene.camera_position * 1e3,
                                                   scene.light_position * 1e3, side)
            target = scene.project(np.array([[side * r_mm * 1e-3, 0.0, 0.0]]))[0]
            expected = abs(target[1] - centre[1])
            found = line_peak_px(cube[_band(lam)], centre, np.array([0.0, side]), expected - 6, expected + 6)
            assert abs(found - expected) < 1.0, (lam, side, found, expected)
            radii.append(found)
            predicted.append(expected)
        # The shift is real (several pixels between the two sides) and reproduced within 1 px.
        assert abs(predicted[0] - predicted[1]) > 3.0
        assert abs((radii[0] - radii[1]) - (predicted[0] - predicted[1])) < 1.0


def test_photos_are_linear_in_the_spd(default_cube, rng):
    _, cube = default_cube
    cam = load_camera("Nikon_D5100")
    s1, s2 = rng.random(81), rng.random(81) * (WAVELENGTHS_NM > 600)
    both = photo.linear_photo(cube, s1 + s2, cam)
    summed = photo.linear_photo(cube, s1, cam) + photo.linear_photo(cube, s2, cam)
    assert np.allclose(both, summed, rtol=1e-5, atol=1e-6 * both.max())  # float32 synthesis


def test_zero_power_bands_give_black_rings_and_no_nan(default_cube):
    scene, cube = default_cube
    cam = load_camera("Nikon_D5100")
    spd = np.zeros(81)
    spd[_band(550)] = 1.0
    image = photo.linear_photo(cube, spd, cam)
    assert np.all(np.isfinite(image)) and np.all(image >= 0)
    centre = scene.project(np.zeros((1, 3)))[0]
    rows, cols = np.indices(image.shape[:2])
    radius = np.hypot(rows - centre[0], cols - centre[1])
    r550 = coaxial_first_order_radius_px(550, 1.6, scene.preset.camera.focal_px)
    r450 = coaxial_first_order_radius_px(450, 1.6, scene.preset.camera.focal_px)
    ring = image[np.abs(radius - r550) < 1].sum(-1).mean()
    elsewhere = image[np.abs(radius - r450) < 1].sum(-1).mean()
    assert elsewhere < 1e-3 * ring  # only the diffuse base is left where no power is


def test_cube_is_finite_and_non_negative_everywhere(default_cube):
    _, cube = default_cube
    assert cube.dtype == np.float32
    assert np.all(np.isfinite(cube)) and cube.min() >= 0


def test_tilted_and_grazing_poses_stay_finite():
    for tilt in [(3.0, 0.0), (0.0, 60.0), (85.0, 0.0)]:
        scene = Scene(load_preset("cd-default").with_image_size(64), Pose(tilt_deg=tilt))
        cube = render_cube(scene, supersample=2)
        assert np.all(np.isfinite(cube)) and cube.min() >= 0
