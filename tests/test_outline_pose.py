"""The disc's outline as a constraint of the pose fit: every capture must draw its rim where the
photo shows the outline, which the rainbow alone does not pin (tripod-oblique's near-symmetry),
and a dark disc on a lit table is judged on the disc, not on the table around it or through its
hole."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.inverse.load import load_for_estimate
from cd_spectra_addon.core.inverse.stages import pose_photo
from cd_spectra_addon.core.pose import fit as pose_fit
from cd_spectra_addon.core.pose.rim_ellipse import Ellipse, outline_mismatch, project_circle
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.scene.relative_pose import apply_params, nominal_scene, relative_pose
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.evaluation import pose_errors
from training.simulation.render_numpy import render_cube

RIM_MM = 60.0


def _tripod_truth() -> tuple[Scene, Ellipse]:
    preset, _ = pose_errors.crop_preset("tripod-oblique")
    scene = Scene(preset, Pose(tilt_deg=(1.0, -2.0), camera_rotation_deg=(1.0, 1.5)))
    rel = relative_pose(scene)
    cam = preset.camera
    return scene, project_circle(rel.disc_centre_mm, rel.disc_normal, RIM_MM, cam.focal_px, cam.image_size_px)


def test_the_mismatch_is_free_of_the_discs_size_and_of_the_axis_angles_wrap():
    _, rim = _tripod_truth()
    assert np.allclose(outline_mismatch(rim, rim), 0.0)
    # a photo taken nearer: the same pose, a bigger disc
    nearer = replace(rim, major_px=rim.major_px * 1.2, minor_px=rim.minor_px * 1.2)
    assert np.allclose(outline_mismatch(rim, nearer), 0.0)
    # the major axis's angle is defined up to π
    assert np.allclose(outline_mismatch(rim, replace(rim, angle=rim.angle + math.pi)), 0.0, atol=1e-12)
    # a circle has no axis: any angle is the same outline
    circle = Ellipse((100.0, 120.0), 50.0, 50.0, 0.3)
    assert np.allclose(outline_mismatch(circle, replace(circle, angle=1.4)), 0.0)
    # a centre 4 px off on a 400 px semi-axis: 0.01 in that measure
    moved = replace(rim, centre_px=(rim.centre_px[0], rim.centre_px[1] + 4.0))
    assert outline_mismatch(rim, moved)[1] == pytest.approx(4.0 / rim.major_px)


def test_the_rim_rows_cost_a_disc_turned_off_its_outline():
    """At the true capture the rows cost nothing; the disc turned 5° about its centre (the
    rainbow's near-symmetry keeps the glint) costs more than a fit that explains a photo may."""
    scene, rim = _tripod_truth()
    cam = scene.preset.camera
    rows = pose_fit._OutlineRows(rim, RIM_MM, cam.focal_px, cam.image_size_px)
    truth = relative_pose(scene)
    assert float(rows(truth) @ rows(truth)) < 1e-12
    turned = apply_params(truth, np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert float(rows(turned) @ rows(turned)) > pose_fit.GOOD_COST
    # within the outline's own error (OUTLINE_DEAD) a rim costs nothing: the rows never pull a
    # capture the rainbow pins by less than an outline is found to
    nudged = apply_params(truth, np.array([0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0]))
    assert float(rows(nudged) @ rows(nudged)) == 0.0
    # the Jacobian (forward differences) where the rows act, against central differences
    x = np.array([0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    free = pose_fit.FREE
    jac = rows.jacobian(truth, x, free)
    assert np.any(jac != 0.0)
    for j, k in enumerate(free):
        step = np.zeros(8)
        step[k] = 1e-4
        central = (rows(apply_params(truth, x + step)) - rows(apply_params(truth, x - step))) / 2e-4
        assert np.allclose(jac[:, j], central, rtol=0.02, atol=0.02 * float(np.max(np.abs(jac))))


def test_a_dark_disc_is_judged_without_the_table_around_it_or_through_its_hole():
    outline = Ellipse((50.0, 50.0), 40.0, 40.0, 0.0, lit=False)
    level = pose_fit._Level.of(np.zeros((101, 101, 3)), None, 1, 500.0)
    mask = level.within(outline, 0.35).reshape(101, 101)
    assert mask[50, 50 + 30]  # on the tracks
    assert not mask[50, 50]  # the hole: the table shows through
    assert not mask[50, 50 + 10]
    assert not mask[50, 50 + 40]  # the rim itself: the table's edge is an outline's error away
    lit = level.within(replace(outline, lit=True), 0.35).reshape(101, 101)
    assert lit[50, 50] and lit[50, 50 + 43]  # a lit disc on a dark surround: all of it, and a margin


def test_an_outline_far_from_the_discs_size_is_not_the_disc():
    """A greyscale photo's rings made edges that read as a dark disc 0.45 of the preset's size;
    held to it, the fit refused a readable photo (tests/test_hostile_inputs.py, greyscale)."""
    preset = load_preset("cd-default")
    size, focal = (256, 256), 412.4
    # the rim's size with the preset's camera distance (210 mm: the disc nominally seen square on)
    expected = focal * preset.disc.rim_radius_mm / relative_pose(nominal_scene(preset, size, focal)).distance_mm
    for share, taken in ((1.0, True), (1.5, True), (0.7, True), (0.45, False), (1.7, False)):
        outline = Ellipse((128.0, 128.0), share * expected, 0.98 * share * expected, 0.0, lit=False)
        assert pose_fit.disc_sized(outline, preset, focal) is taken, share


@pytest.mark.slow
def test_a_tripod_photo_on_a_lit_table_is_read_at_its_capture(tmp_path):
    """One of pose_errors' combined tripod captures (camera 9.5° and lamp 20.3° from the disc's
    axis, preset 12.5° and 15°), on a lit table: before the outline held the fit it read camera
    15.1°, lamp 17.3° on the camera's side (λ₁ 312 nm off, MAE 0.59); the outline pins the disc,
    the lamp is then sought about it."""
    preset, _ = pose_errors.crop_preset("tripod-oblique")
    pose = Pose(camera_offset_mm=(2.394, -0.314), light_offset_mm=(0.657, 3.306), tilt_deg=(-1.268, -2.676),
                camera_rotation_deg=(-0.882, 2.046), light_rotation_deg=(-0.052, 2.454))
    scene = Scene(preset, pose)
    lam = np.arange(380, 781, 5)
    spd = np.exp(-0.5 * ((lam - 580) / 110.0) ** 2)
    path = tmp_path / "tripod.jpg"
    pose_errors.write_capture(path, scene, render_cube(scene, supersample=pose_errors.SUPERSAMPLE), spd, 0.015, 0.2,
                              seed=1)
    user = load_preset("tripod-oblique")
    loaded = load_for_estimate(path, user)
    fit = pose_photo(loaded, user, load_camera(DEFAULT_CAMERA)).fit
    height, width = loaded.rgb.shape[:2]
    truth = pose_errors.pose_numbers(Scene(preset.with_image_size(width, height), pose))
    got = pose_errors.pose_numbers(fit.known_scene)
    assert got[1] == pytest.approx(truth[1], abs=0.5)  # the camera's angle from the disc's axis
    assert got[2] == pytest.approx(truth[2], abs=1.0)  # the lamp's
    assert abs((got[3] - truth[3] + 180.0) % 360.0 - 180.0) < 3.0  # the lamp's azimuth from the camera's side
