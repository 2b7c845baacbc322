"""Full poses in presets: a camera anywhere above the disc, the lamp anywhere, a tilted disc.

The original on-axis presets must give bit-identical scenes; a full pose must obey the pinhole
model (rays and projection invert each other) and the grating equation in the rendered image.
"""

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.scene.capture import Camera, Pose, Scene, load_preset, preset_from_dict
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.errors import CDSpectraError
from tests.ring_geometry import first_order_radius_mm_on_x_axis
from training.simulation.render_numpy import render_cube

# Keys the original presets' geometry had before full poses existed: basis-cube cache keys
# hash this dict, so it must not grow for them.
LEGACY_GEOMETRY_KEYS = {
    "preset", "pitch_um", "camera_distance_mm", "light_distance_mm", "camera_position_mm",
    "light_position_mm", "disc_normal", "image_size_px", "disc_center_px", "px_per_mm", "focal_px",
    "focal_length_mm", "sensor_width_mm", "lobe_sigma", "disc", "camera_offset_mm", "light_offset_mm",
    "tilt_deg",
}
LEGACY_CAMERA_KEYS = {"distance_mm", "focal_length_mm", "sensor_width_mm", "image_size_px"}


def _explicit(preset, position_mm, look_at_mm=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)):
    """The same preset with the camera given as a full pose (through the file format)."""
    data = preset.to_dict()
    cam = {k: v for k, v in data["camera"].items() if k != "distance_mm"}
    data["camera"] = {**cam, "position_mm": list(position_mm), "look_at_mm": list(look_at_mm), "up": list(up)}
    return preset_from_dict(data)


@pytest.mark.parametrize("name", ["cd-default", "cd-far-light", "paper"])
def test_original_presets_keep_their_geometry_and_file_form(name):
    preset = load_preset(name)
    assert preset.camera.is_on_axis and preset.disc_tilt_deg == (0.0, 0.0)
    assert set(preset.to_dict()["camera"]) == LEGACY_CAMERA_KEYS
    assert "disc_tilt_deg" not in preset.to_dict()
    assert set(Scene(preset, Pose((1.0, 2.0), (3.0, 4.0), (1.0, 0.5))).geometry_dict()) == LEGACY_GEOMETRY_KEYS
    assert np.array_equal(Scene(preset).camera_rotation, np.eye(3))


@pytest.mark.parametrize("pose", [Pose(), Pose((3.0, -2.0), (10.0, 5.0)), Pose((1.0, 2.0), (0.0, -30.0), (3.0, 1.0))])
def test_an_explicit_on_axis_pose_gives_bit_identical_rays_projections_and_renders(pose):
    legacy = load_preset("cd-default").with_image_size(40)
    explicit = _explicit(legacy, (0.0, 0.0, legacy.camera.distance_mm))
    assert not explicit.camera.is_on_axis and explicit.camera.distance_mm == legacy.camera.distance_mm
    a, b = Scene(legacy, pose), Scene(explicit, pose)
    rows, cols = (g.ravel().astype(float) for g in np.indices((40, 40)))
    assert np.array_equal(a.camera_position, b.camera_position)
    assert np.array_equal(a.pixel_rays(rows, cols), b.pixel_rays(rows, cols))
    points, _ = a.intersect_disc(a.pixel_rays(rows, cols))
    assert np.array_equal(a.project(points), b.project(points))
    assert np.array_equal(render_cube(a, supersample=2), render_cube(b, supersample=2))
    # pixel_diffraction: the on-axis fast path and the general path agree.
    pa, pb = pixel_diffraction(a), pixel_diffraction(b)
    assert np.array_equal(pa.index, pb.index)
    assert np.allclose(pa.lambda1_nm, pb.lambda1_nm, rtol=0, atol=1e-9)
    assert np.allclose(pa.gain, pb.gain, rtol=1e-9)


def test_disc_tilt_in_the_preset_equals_the_same_tilt_as_a_pose():
    base = load_preset("cd-default").with_image_size(32)
    data = base.to_dict()
    data["disc_tilt_deg"] = [4.0, -2.0]
    tilted = preset_from_dict(data)
    assert tilted.to_dict()["disc_tilt_deg"] == [4.0, -2.0]
    assert np.array_equal(Scene(tilted).disc_rotation, Scene(base, Pose(tilt_deg=(4.0, -2.0))).disc_rotation)
    assert np.allclose(Scene(tilted, Pose(tilt_deg=(-4.0, 2.0))).disc_normal, (0, 0, 1), atol=1e-15)


above_disc = st.tuples(st.floats(-400, 400), st.floats(-400, 400), st.floats(60, 2000))


@settings(max_examples=60, deadline=None)
@given(eye=above_disc, aim=st.tuples(st.floats(-30, 30), st.floats(-30, 30)))
def test_rays_and_projection_invert_each_other_for_any_pose_above_the_disc(eye, aim):
    assume_up_ok = np.linalg.norm(np.cross(np.subtract((aim[0], aim[1], 0.0), eye), (0, 1, 0))) > 1e-2
    if not assume_up_ok:
        return
    preset = _explicit(load_preset("cd-default").with_image_size(64), eye, (aim[0], aim[1], 0.0))
    scene = Scene(preset)
    assert math.isclose(preset.camera.distance_mm, math.dist(eye, (aim[0], aim[1], 0.0)), rel_tol=1e-12)
    # The aim point is at the image centre; the image's up is the world's +y side.
    centre = scene.project(np.array([[aim[0], aim[1], 0.0]]) * 1e-3)[0]
    assert np.allclose(centre, (31.5, 31.5), atol=1e-6)
    r = scene.camera_rotation
    assert np.allclose(r.T @ r, np.eye(3), atol=1e-12) and math.isclose(np.linalg.det(r), 1.0, rel_tol=1e-12)
    assert r[:, 1] @ (0, 1, 0) >= -1e-12  # image up never points to world −y
    rows, cols = np.random.default_rng(0).uniform(0, 63, (2, 50))
    dirs = scene.pixel_rays(rows, cols)
    assert np.allclose(np.linalg.norm(dirs, axis=1), 1.0)
    assert np.all(dirs @ (-r[:, 2]) > 0)  # in front of the camera
    # A point along each ray projects back to the pixel it came from.
    back = scene.project(scene.camera_position + 0.3 * dirs)
    assert np.allclose(back, np.stack([rows, cols], axis=1), atol=1e-6)


def _oblique(size=128):
    """Camera 20° off the normal at 150 mm (24 mm lens), lamp 2 m away 15° off on the same
    side, both in the xz-plane: the first-order streak lies on the x axis, where v = 0 exactly
    (400 nm near r = 49 mm, 700 nm near r = 24 mm)."""
    base = load_preset("cd-default").with_image_size(size)
    eye = (150 * math.sin(math.radians(20)), 0.0, 150 * math.cos(math.radians(20)))
    lamp = (2000 * math.sin(math.radians(15)), 0.0, 2000 * math.cos(math.radians(15)))
    preset = _explicit(base, eye)
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=24.0))
    return replace(preset, light=replace(preset.light, position_mm=lamp, lobe_sigma=0.002, intensity=90.0))


def test_an_oblique_render_puts_each_wavelength_where_the_grating_equation_says():
    scene = Scene(_oblique(192))
    cube = render_cube(scene, supersample=3)
    row = 192 / 2 - 0.5  # the x axis projects onto the middle row (camera in the xz-plane, up +y)
    hits = 0
    for lam in (450.0, 500.0, 550.0, 600.0, 650.0):
        for side, m in ((1.0, 1), (1.0, -1), (-1.0, 1), (-1.0, -1)):
            try:
                r_mm = first_order_radius_mm_on_x_axis(lam, 1.6, scene.camera_position * 1e3,
                                                       scene.light_position * 1e3, side, m)
            except ValueError:
                continue
            if not 25.0 < r_mm < 57.0:
                continue
            target = scene.project(np.array([[side * r_mm * 1e-3, 0.0, 0.0]]))[0]
            assert abs(target[0] - row) < 1e-6
            band = cube[int((lam - 380) / 5)]
            profile = 0.5 * (band[95] + band[96])
            c0 = int(round(target[1]))
            window = np.arange(c0 - 6, c0 + 7)
            k = window[np.argmax(profile[window])]
            a, b, c = profile[k - 1], profile[k], profile[k + 1]
            found = k + 0.5 * (a - c) / (a - 2 * b + c)
            assert abs(found - target[1]) < 1.0, (lam, side, found, target)
            hits += 1
    assert hits >= 4


def test_pixel_diffraction_reads_the_oblique_streak_at_the_grating_equation_wavelength():
    scene = Scene(_oblique(160))
    pd = pixel_diffraction(scene)
    lam = 550.0
    r_mm = first_order_radius_mm_on_x_axis(lam, 1.6, scene.camera_position * 1e3, scene.light_position * 1e3, 1.0, 1)
    rc = scene.project(np.array([[r_mm * 1e-3, 0.0, 0.0]]))[0]
    rows = np.array([rc[0]])
    cols = np.array([rc[1]])
    index = np.array([int(rc[0]) * 160 + int(rc[1])])
    at = pixel_diffraction(scene, index, rows, cols)
    assert abs(at.lambda1_nm[0] - lam) < 1e-6 and at.visibility[0] > 0.999
    assert pd.lambda1_nm.size > 1000 and np.all(np.isfinite(pd.gain))


@pytest.mark.parametrize("camera,message", [
    ({"position_mm": [0, 0, -100]}, "above the disc"),
    ({"position_mm": [0, 0, 100], "look_at_mm": [0, 0, 100]}, "must differ"),
    ({"position_mm": [0, 300, 100], "up": [0, 300, 100]}, "line of sight"),
    ({"position_mm": [0, 0, 100], "distance_mm": 50}, "disagrees"),
    ({"position_mm": [0, 0]}, "3 numbers"),
    ({"position_mm": [0, "a", 3]}, "position_mm[1]"),
    ({"position_mm": [0, 0, 100], "look_at_mm": [0, 0, 200]}, "below the camera"),
])
def test_impossible_full_poses_are_refused_with_the_field_named(tmp_path, camera, message):
    data = load_preset("cd-default").to_dict()
    data["camera"] = {**{k: v for k, v in data["camera"].items() if k != "distance_mm"}, **camera}
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(CDSpectraError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_preset(path)


@settings(max_examples=40, deadline=None)
@given(tilt=st.lists(st.one_of(st.floats(allow_nan=True), st.text(max_size=3), st.none()), min_size=0, max_size=3))
def test_junk_disc_tilt_is_refused_not_rendered(tmp_path_factory, tilt):
    data = load_preset("cd-default").to_dict()
    data["disc_tilt_deg"] = tilt
    path = tmp_path_factory.mktemp("p") / "p.json"
    path.write_text(json.dumps(data))
    try:
        preset = load_preset(path)
    except CDSpectraError:
        return
    assert all(math.isfinite(a) and abs(a) <= 80 for a in preset.disc_tilt_deg) and len(preset.disc_tilt_deg) == 2


def test_camera_defaults_are_the_original_on_axis_camera():
    assert Camera().is_on_axis and Camera().nominal_position_mm == (0.0, 0.0, 210.0)
    moved = Camera(position_mm=(10.0, -20.0, 200.0), distance_mm=math.dist((10, -20, 200), (0, 0, 0)))
    assert not moved.is_on_axis
    assert np.allclose(moved.rotation()[:, 2], np.array([10.0, -20.0, 200.0]) / moved.distance_mm)


@settings(max_examples=40, deadline=None)
@given(turn=st.tuples(st.floats(-8, 8), st.floats(-8, 8)), offset=st.tuples(st.floats(-10, 10), st.floats(-10, 10)))
def test_a_turned_camera_keeps_its_place_and_only_re_aims_its_rays(turn, offset):
    """Pose.camera_rotation_deg turns the camera about its own centre: the same world rays reach
    it (a point's direction from the camera is unchanged), only their pixels move; the image
    centre now looks along the turned axis, and rays and projection still invert each other."""
    preset = load_preset("cd-default").with_image_size(64)
    straight, turned = Scene(preset, Pose(camera_offset_mm=offset)), Scene(preset, Pose(camera_offset_mm=offset,
                                                                                         camera_rotation_deg=turn))
    assert np.array_equal(straight.camera_position, turned.camera_position)
    assert turned.looks_straight_down == (turn == (0.0, 0.0))
    rows, cols = np.random.default_rng(1).uniform(0, 63, (2, 30))
    dirs = turned.pixel_rays(rows, cols)
    back = turned.project(turned.camera_position + 0.2 * dirs)
    assert np.allclose(back, np.stack([rows, cols], axis=1), atol=1e-6)
    forward = -turned.camera_rotation[:, 2]
    ax, ay = (math.radians(a) for a in turn)
    assert math.isclose(forward @ (0, 0, -1), math.cos(ax) * math.cos(ay), abs_tol=1e-12)
    # The optical axis meets the disc plane at camera_look_at.
    aim = turned.camera_look_at
    assert abs(aim[2]) < 1e-12 and np.allclose(np.cross(aim - turned.camera_position, forward), 0, atol=1e-12)


def test_a_camera_turned_by_a_small_angle_moves_the_disc_centre_by_f_tan_angle():
    preset = load_preset("cd-default").with_image_size(200)
    scene = Scene(preset, Pose(camera_rotation_deg=(0.0, 2.0)))  # about image up: the disc moves sideways
    row, col = scene.project(np.zeros((1, 3)))[0]
    f = preset.camera.focal_px
    assert math.isclose(row, 99.5, abs_tol=1e-9)
    assert math.isclose(abs(col - 99.5), f * math.tan(math.radians(2.0)), rel_tol=1e-9)
    # pixel_diffraction takes the general path for a turned camera and sees the same disc points
    # the straight camera sees (rays through the same world points give the same λ₁).
    straight = Scene(preset)
    px = pixel_diffraction(scene)
    points = px.points[:200]
    rc = straight.project(points)
    ref = pixel_diffraction(straight, np.zeros(len(rc), np.int64), rc[:, 0], rc[:, 1])
    assert np.allclose(ref.lambda1_nm, px.lambda1_nm[:200], atol=1e-6)


def test_a_lamp_swung_about_the_disc_keeps_its_distance():
    preset = load_preset("phone-distant-lamp")
    scene = Scene(preset, Pose(light_rotation_deg=(3.0, -2.0)))
    base = np.asarray(preset.light.position_mm) * 1e-3
    moved = scene.light_position
    assert math.isclose(np.linalg.norm(moved), np.linalg.norm(base), rel_tol=1e-12)
    angle = math.degrees(math.acos(moved @ base / np.linalg.norm(base) ** 2))
    assert 2.0 < angle < 5.0
