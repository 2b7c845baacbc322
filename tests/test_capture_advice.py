"""What the estimate tells a person to move for an oblique or measured set-up: the preset's and the
photo's angles and azimuths, which part of 400–700 nm lands on the tracks, and moves that help."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.planning.capture_advice import (
    capture_angles, coverage_advice, lamp_azimuth_deg, oblique_advice)
from cd_spectra_addon.core.planning.measured import Measurements, measured_preset
from cd_spectra_addon.core.planning.setups import first_order_visible
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset

KIM = Measurements(700.0, 83.5, 165.0, 230.0, 38.0, 0.0, lamp_size_mm=5.0, name="kim")


@pytest.mark.parametrize("camera_azimuth,lamp_azimuth,expected", [(0.0, 165.0, 165.0), (30.0, 10.0, 340.0),
                                                                  (200.0, 20.0, 180.0), (90.0, 90.0, 0.0)])
def test_the_lamps_azimuth_is_counted_counter_clockwise_from_the_camera(camera_azimuth, lamp_azimuth, expected):
    scene = Scene(measured_preset(Measurements(500.0, 40.0, lamp_azimuth, 250.0, 30.0, camera_azimuth)))
    assert lamp_azimuth_deg(scene) == pytest.approx(expected, abs=1e-6)
    # capture_angles' unsigned angle between them is the same turn folded onto 0–180
    assert capture_angles(scene)[2] == pytest.approx(min(expected, 360.0 - expected), abs=1e-6)


def test_without_a_fit_the_advice_names_the_presets_angles_and_azimuth():
    text = oblique_advice(measured_preset(KIM), None)
    assert "camera 38° and lamp 83.5° from the disc's axis" in text
    assert "the lamp 165° counter-clockwise from the camera, seen from above the disc" in text
    assert "one vertical plane through the disc's centre" not in text
    tripod = oblique_advice(load_preset("tripod-oblique"), None)
    assert "camera 12.5° and lamp 15° from the disc's axis, the lamp opposite the camera, in its vertical plane" in tripod


def test_a_capture_off_the_presets_angles_is_told_each_move_and_what_lands():
    """The photo's lamp stands 20° short of the preset's azimuth and the camera 7° lower: the advice
    names both captures and the moves, with the part of 400–700 nm the photo's capture shows."""
    preset = measured_preset(KIM)
    photo = Scene(measured_preset(Measurements(700.0, 83.5, 145.0, 230.0, 45.0, 0.0, lamp_size_mm=5.0)))
    text = coverage_advice(preset, photo)
    (lo, hi), = first_order_visible(photo)
    assert f"only {lo:.0f}–{hi:.0f} nm of 400–700 nm lands on the disc's tracks" in text
    assert "the photo shows the camera 45° and lamp 83.5° from the disc's axis, the lamp 145° counter-clockwise" in text
    assert "raise the camera 7° (to 38° from the disc's axis)" in text
    assert "move the lamp 20° counter-clockwise around the disc, seen from above (to 165° counter-clockwise" in text
    assert "lamp 83.5" in text and "lower the lamp" not in text and "raise the lamp" not in text


def test_a_tilted_disc_is_offered_as_the_other_explanation():
    preset = load_preset("tripod-oblique")
    # the set-up keeps 400–700 nm to 3° of tilt (planner.TILT_GOAL_DEG); at 5° it does not
    text = oblique_advice(preset, Scene(preset, Pose(tilt_deg=(0.0, -5.0))))
    assert "lay the disc flat (it is tilted 5°)" in text
    assert re.search(r"only \d+–700 nm of 400–700 nm lands", text)  # the blue end slides off the tracks


def test_when_the_preset_itself_misses_part_the_advice_names_a_move_that_shows_more():
    """Kim's case 1 on a CD shows only 436–571 nm on the tracks as measured; the suggested move,
    made, shows more of 400–700 nm."""
    preset = measured_preset(KIM)
    text = oblique_advice(preset, Scene(preset))
    assert "only 436–571 nm of 400–700 nm lands on the disc's tracks with the set-up as preset 'kim' places it" in text
    shown = sum(b - a for a, b in first_order_visible(Scene(preset)))
    moves = {"move the lamp 15° clockwise around the disc": {"lamp_azimuth_deg": 150.0},
             "move the lamp 15° counter-clockwise around the disc": {"lamp_azimuth_deg": 180.0},
             "raise the lamp 5°": {"lamp_angle_deg": 78.5}, "lower the lamp 5°": {"lamp_angle_deg": 88.5},
             "raise the camera 5°": {"camera_angle_deg": 33.0}, "lower the camera 5°": {"camera_angle_deg": 43.0}}
    (said,) = [move for move in moves if move in text]
    moved = Scene(measured_preset(Measurements(**{**KIM.__dict__, **moves[said]})))
    after = first_order_visible(moved)
    assert sum(b - a for a, b in after) >= shown + 10.0
    assert f"then only {after[0][0]:.0f}–" in text or "then all of 400–700 nm would land" in text


def test_a_capture_as_the_preset_says_with_the_range_on_the_tracks_points_at_the_frame():
    preset = load_preset("phone-distant-lamp")
    text = oblique_advice(preset, Scene(preset))
    assert text.startswith("all of 400–700 nm lands on the disc's tracks with the capture the photo shows")
    assert "cut off by the frame" in text and np.isfinite(capture_angles(Scene(preset))).all()


@pytest.mark.parametrize("distance_mm,way", [(150.0, "further from"), (300.0, "closer to")])
def test_a_near_axis_camera_too_near_or_too_far_is_told_which_way(distance_mm, way):
    """cd-default's camera and lamp moved to 150 / 300 mm (tests/test_joint_estimate.py): even a
    lamp at the lens leaves the short / long end of 400–700 nm off the tracks, so no lamp offset
    helps (it said "within about 0 mm of the lens"); the advice names the end and the way to go."""
    base = load_preset("cd-default")
    preset = replace(base, camera=replace(base.camera, distance_mm=distance_mm, focal_length_mm=base.camera.focal_length_mm
                                          * distance_mm / base.camera.distance_mm),
                     light=replace(base.light, position_mm=(0.0, 0.0, distance_mm)))
    text = coverage_advice(preset, Scene(preset))
    assert f"move camera and lamp {way} the disc" in text and "within about 0 mm" not in text
    lo, hi = (int(v) for v in re.search(r"leaves (\d+)–(\d+) nm", text).groups())
    assert (lo == 400) == (way == "further from") and (hi == 700) == (way == "closer to")
