"""A set-up described by what a person can measure (distances, angles from the disc's axis,
azimuths seen from above, counter-clockwise): the preset puts lamp and camera there, the analysis
reads it, bad numbers are refused by name, and ``setup`` / user presets carry it to the estimate."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.cli import main as cli_main
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.planning.measured import (
    MeasurementError, Measurements, measured_preset, measured_preset_data, measured_setup)
from cd_spectra_addon.core.planning.setups import analyse, angular_sigma, load_setup
from cd_spectra_addon.core.scene.capture import Scene, load_preset, preset_names, save_user_preset, user_preset_names
from cd_spectra_addon.core.user_folders import PRESET_ENV_DIR

KIM = Measurements(lamp_distance_mm=700.0, lamp_angle_deg=83.5, lamp_azimuth_deg=165.0, camera_distance_mm=230.0,
                   camera_angle_deg=38.0, camera_azimuth_deg=0.0, lamp_size_mm=5.0, name="kim")


def _angles(point: np.ndarray) -> tuple[float, float, float]:
    """Distance, angle from +z and azimuth (counter-clockwise from +x seen from +z) of a point."""
    d = float(np.linalg.norm(point))
    return d, math.degrees(math.acos(point[2] / d)), math.degrees(math.atan2(point[1], point[0])) % 360.0


@pytest.mark.parametrize("m", [KIM, Measurements(300.0, 20.0, 250.0, 180.0, 55.0, 300.0),
                               Measurements(2000.0, 5.0, 180.0, 164.0, 40.0, 0.0, disc="dvd")])
def test_lamp_and_camera_are_where_they_were_measured(m):
    preset = measured_preset(m)
    scene = Scene(preset)
    lamp, cam = scene.light_position * 1e3, scene.camera_position * 1e3
    for got, want in ((_angles(lamp), (m.lamp_distance_mm, m.lamp_angle_deg, m.lamp_azimuth_deg)),
                      (_angles(cam), (m.camera_distance_mm, m.camera_angle_deg, m.camera_azimuth_deg))):
        assert got[0] == pytest.approx(want[0], abs=1e-5) and got[1] == pytest.approx(want[1], abs=1e-6)
        assert (got[2] - want[2] + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-6)
    # aimed at the centre and upright: the image's up is the disc's axis seen from the camera
    rot = scene.camera_rotation
    forward = -rot[:, 2]
    assert np.allclose(forward, -cam / np.linalg.norm(cam), atol=1e-9)
    axis_in_image = np.array([0.0, 0.0, 1.0]) - forward[2] * forward
    assert np.allclose(rot[:, 1], axis_in_image / np.linalg.norm(axis_in_image), atol=1e-9)
    assert scene.project(np.zeros((1, 3)))[0] == pytest.approx([255.5, 255.5], abs=1e-6)  # centre in the middle


def test_the_azimuth_is_counter_clockwise_seen_from_above():
    """The lamp 90° counter-clockwise from a camera at azimuth 0 (+x) stands towards +y; seen from
    above (looking down −z) +y is a quarter turn counter-clockwise from +x."""
    scene = Scene(measured_preset(Measurements(500.0, 40.0, 90.0, 250.0, 30.0, 0.0)))
    lamp, cam = scene.light_position, scene.camera_position
    assert lamp[1] > 0 and abs(lamp[0]) < 1e-9 and cam[0] > 0 and abs(cam[1]) < 1e-12
    assert np.cross(cam[:2].tolist() + [0.0], lamp[:2].tolist() + [0.0])[2] > 0  # counter-clockwise about +z
    # Facing the disc from azimuth 0 (looking towards −x), +y is on the right: in the upright image the
    # lamp's side of the disc is the right half, as the description says for a person at the camera.
    assert scene.project(scene.light_position[None, :] * 0.05)[0][1] > 255.5


def test_a_camera_straight_above_is_the_shipped_on_axis_camera():
    preset = measured_preset(Measurements(300.0, 3.0, 0.0, 210.0, 0.0, 123.0))
    assert preset.camera.is_on_axis and preset.camera.distance_mm == 210.0
    assert Scene(preset).camera_rotation.tolist() == np.eye(3).tolist()  # image up = +y


def test_the_preset_states_the_numbers_and_the_convention_and_the_disc():
    data = measured_preset_data(KIM)
    text = data["description"]
    for piece in ("700 mm", "83.5°", "azimuth 165°", "230 mm", "38°", "azimuth 0°", "counter-clockwise",
                  "seen from above", "165° counter-clockwise from the camera", "CD (track pitch 1.6 µm)", "5 mm"):
        assert piece in text, piece
    assert data["measured"]["lamp_azimuth_deg"] == 165.0 and data["name"] == "kim"
    preset = measured_preset(KIM)
    assert preset.light.lobe_sigma == pytest.approx(angular_sigma(5.0, 700.0))
    assert preset.disc == load_preset("cd-default").disc
    dvd = measured_preset(Measurements(700.0, 60.0, 180.0, 230.0, 38.0, disc="dvd")).disc
    assert (dvd.pitch_um, dvd.groove_height_um) == (0.74, 0.06)
    assert (dvd.grating_r_min_mm, dvd.grating_r_max_mm, dvd.rim_radius_mm) == (23.0, 58.5, 60.0)


def test_a_measured_tripod_oblique_lands_where_the_shipped_one_does():
    """The shipped oblique set-up, described by its measurements (the camera at azimuth 180°, the
    lamp opposite at 0°), puts 400 / 550 / 700 nm where README's table says: 28.0 / 41.3 / 55.1 mm."""
    cam = load_preset("tripod-oblique").camera.nominal_position_mm
    d, angle, _ = _angles(np.asarray(cam))
    setup = measured_setup(Measurements(200.0, 15.0, 0.0, d, angle, 180.0, lamp_size_mm=3.0))
    report = analyse(setup, report_nm=(400.0, 550.0, 700.0))
    assert report.coplanar and report.covers_visible
    camera_side = [[abs(s) for s in report.positions_mm[lam] if s * report.read_side > 0][0]
                   for lam in (400.0, 550.0, 700.0)]
    assert camera_side == pytest.approx([28.0, 41.3, 55.1], abs=0.06)


@pytest.mark.parametrize("change,words", [
    ({"lamp_distance_mm": 0.0}, "lamp distance from the disc centre (mm) must be a number > 0"),
    ({"camera_distance_mm": -5.0}, "camera distance from the disc centre (mm) must be a number > 0"),
    ({"camera_distance_mm": 0.5}, "hangs over the disc"),
    ({"lamp_distance_mm": 4.0}, "at least 50 mm"),
    ({"lamp_distance_mm": math.nan}, "lamp distance from the disc centre (mm) must be a number > 0, not nan"),
    ({"lamp_distance_mm": "700"}, "lamp distance from the disc centre (mm) must be a number > 0, not '700'"),
    ({"lamp_distance_mm": 2e5}, "more than 100 m"),
    ({"camera_angle_deg": 95.0}, "a camera 95° from the disc's axis is below the disc's plane"),
    ({"lamp_angle_deg": 90.0}, "a lamp 90° from the disc's axis is in the disc's plane"),
    ({"lamp_angle_deg": 89.7}, "lamp angle from the disc's axis (degrees) must be a number between 0 and 89.5"),
    ({"camera_angle_deg": -10.0}, "add 180° to the azimuth"),
    ({"lamp_azimuth_deg": 400.0}, "lamp azimuth (degrees) must be a number between -360 and 360"),
    ({"disc": "bluray"}, "disc must be 'cd' or 'dvd'"),
    ({"lamp_size_mm": 800.0}, "not a small source"),
    ({"lamp_size_mm": 0.0}, "lamp size (mm) must be a number > 0"),
    ({"focal_mm": math.inf}, "lens focal length (mm)"),
    ({"image_size_px": (0, 512)}, "image size (pixels)[0]"),
    ({"lamp_distance_mm": 230.0, "lamp_angle_deg": 38.0, "lamp_azimuth_deg": 0.0}, "cannot be in the same place"),
])
def test_bad_numbers_are_refused_by_name(change, words):
    values = {**KIM.__dict__, **change}
    with pytest.raises(MeasurementError) as caught:
        measured_preset(Measurements(**values))
    assert words in str(caught.value) and "\n" not in str(caught.value)


_MEASURED = st.builds(
    Measurements, lamp_distance_mm=st.floats(1.0, 5000.0), lamp_angle_deg=st.floats(0.0, 89.5),
    lamp_azimuth_deg=st.floats(-360.0, 360.0), camera_distance_mm=st.floats(1.0, 5000.0),
    camera_angle_deg=st.floats(0.0, 89.5), camera_azimuth_deg=st.floats(-360.0, 360.0),
    disc=st.sampled_from(["cd", "dvd", "DVD"]), lamp_size_mm=st.one_of(st.none(), st.floats(0.1, 50.0)))
# One field replaced by what a form or a typo can give, in a third of the examples.
_BROKEN = st.one_of(st.none(), st.none(), st.tuples(
    st.sampled_from(["lamp_distance_mm", "lamp_angle_deg", "lamp_azimuth_deg", "camera_distance_mm",
                     "camera_angle_deg", "camera_azimuth_deg", "lamp_size_mm", "disc", "focal_mm"]),
    st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=3), st.integers(-1000, 1000))))


@settings(max_examples=40, deadline=None)
@given(measured=_MEASURED, broken=_BROKEN)
def test_any_measured_set_up_gives_a_finite_report_or_a_clear_refusal(measured, broken):
    if broken is not None:
        measured = Measurements(**{**measured.__dict__, broken[0]: broken[1]})
    try:
        setup = measured_setup(measured)
    except MeasurementError as exc:
        assert str(exc).strip() and "\n" not in str(exc)
        return
    report = analyse(setup)
    for cov in report.sides:
        assert all(np.isfinite(cov.lambda_range_nm)) and cov.lambda_range_nm[0] >= 0.0
        assert all(np.isfinite(cov.azimuth_deg)) and 0.0 <= cov.blocked_fraction <= 1.0
    assert all(np.isfinite(list(report.resolution_nm.values())))
    assert all(np.isfinite(list(report.nm_per_px.values())))
    assert report.covered_nm is None or 400.0 <= report.covered_nm[0] <= report.covered_nm[1] <= 700.0


# --- the command line and the user's presets folder ------------------------------------------------------

KIM_ARGS = ["setup", "--lamp-distance-mm", "700", "--lamp-angle-deg", "83.5", "--lamp-azimuth-deg", "165",
            "--camera-distance-mm", "230", "--camera-angle-deg", "38", "--camera-azimuth-deg", "0", "--disc", "cd",
            "--lamp-size-mm", "5"]


@pytest.fixture
def preset_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    folder = tmp_path / "my-presets"
    monkeypatch.setenv(PRESET_ENV_DIR, str(folder))
    return folder


def test_setup_writes_the_preset_and_says_what_it_delivers(tmp_path, preset_folder, capsys):
    out = tmp_path / "kim.json"
    assert cli_main([*KIM_ARGS, "--write-preset", str(out)]) == 0
    text = capsys.readouterr().out
    assert "arm + (azimuth 147° to 151°): 436–571 nm" in text
    assert "order 2 shows" in text and "nm FWHM" in text and "along arm +: 450 nm at r = 54.2 mm" in text
    assert f"wrote {out}" in text and not preset_folder.exists()  # --save was not asked for
    setup = load_setup(out)
    assert setup.preset.name == "kim" and not analyse(setup).coplanar
    assert json.loads(out.read_text())["measured"]["lamp_angle_deg"] == 83.5


def test_setup_save_makes_a_preset_the_estimate_and_the_lists_find(preset_folder, capsys):
    assert cli_main([*KIM_ARGS, "--name", "kitchen lamp", "--save"]) == 0
    assert "saved as preset 'kitchen_lamp'" in capsys.readouterr().out
    assert (preset_folder / "kitchen_lamp.json").is_file()
    assert user_preset_names() == ["kitchen_lamp"] and "kitchen_lamp" not in preset_names()
    assert load_preset("kitchen_lamp").light.position_mm[2] == pytest.approx(700.0 * math.cos(math.radians(83.5)))
    assert load_setup("kitchen_lamp").steps[2].startswith("Lamp 700 mm")
    assert cli_main(["presets", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in rows] == preset_names() + ["kitchen_lamp"] and "yours" in rows[-1]["description"]


def test_setup_json_is_the_preset_and_its_analysis(capsys):
    assert cli_main([*KIM_ARGS, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["preset"]["setup"]["kind"] == "oblique" and data["report"]["coplanar"] is False
    assert data["report"]["sides"][1]["orders_nm"][0]["order"] == 2 and data["written"] == []


@pytest.mark.parametrize("extra,message", [
    (["--lamp-angle-deg", "93.5"], "below the disc's plane"),
    (["--camera-distance-mm", "nan"], "camera distance from the disc centre (mm) must be a number > 0, not nan"),
    (["--lamp-azimuth-deg", "x"], "invalid float value"),
    (["--disc", "bluray"], "invalid choice"),
    (["--write-preset", "kim.txt"], "needs a .json file name"),
    (["--write-preset", "/nonexistent-folder/kim.json"], "does not exist"),
    (["--name", "cd-default", "--save"], "ships with CD Spectra"),
    (["--name", "...", "--save"], "a preset needs a name"),
])
def test_setup_refuses_bad_input_with_one_error_line_and_writes_nothing(extra, message, preset_folder, capsys):
    assert cli_main([*KIM_ARGS, *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0], err
    assert not preset_folder.exists()


def test_a_user_preset_never_shadows_a_shipped_one(preset_folder):
    preset_folder.mkdir()
    data = load_preset("tripod-oblique").to_dict()
    (preset_folder / "cd-default.json").write_text(json.dumps({**data, "name": "cd-default"}))
    assert load_preset("cd-default").camera.is_on_axis  # still the shipped one
    assert user_preset_names() == []
    with pytest.raises(CDSpectraError, match="ships with CD Spectra"):
        save_user_preset({**data, "name": "cd-default"})
    assert sorted(p.name for p in preset_folder.iterdir()) == ["cd-default.json"]  # nothing written


def test_estimate_accepts_a_user_preset_by_name(tmp_path, preset_folder):
    """Through the real estimator: an unknown name is refused before the photo is read; the saved
    preset gets past that to the photo (here a black one, refused for that)."""
    from PIL import Image

    from test_cli import run_cli

    photo = tmp_path / "black.png"
    Image.new("RGB", (64, 64)).save(photo)
    env = {PRESET_ENV_DIR: str(preset_folder)}
    proc = run_cli("estimate", str(photo), "--preset", "kim", fake=False, env_extra=env)
    assert proc.returncode == 2 and "unknown capture preset 'kim'" in proc.stderr
    assert run_cli(*KIM_ARGS, "--name", "kim", "--save", fake=False, env_extra=env).returncode == 0
    proc = run_cli("estimate", str(photo), "--preset", "kim", fake=False, env_extra=env)
    assert proc.returncode == 2 and "black" in proc.stderr and "preset" not in proc.stderr
