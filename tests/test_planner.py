"""The capture planner and ``python -m cd_spectra_addon plan``: plans that work by the grating
equation, and impossible equipment refused with a message that says what to change."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.planning.planner import Equipment, PlanError, plan_capture
from cd_spectra_addon.core.planning.setups import analyse, load_setup
from cd_spectra_addon.cli import main as cli_main


def run_plan(argv):
    return cli_main(["plan", *argv])

DISTANT = Equipment(lamp_distance_mm=2000.0, lamp_size_mm=10.0, focal_mm=26.0, phone=True)


@pytest.fixture(scope="module")
def distant_plan():
    return plan_capture(DISTANT)


def _lambda_at(plan, s_mm: float) -> float:
    """First-order λ at the signed position s on the streak line: d·|sin θm − sin θi|."""
    e = np.asarray(plan.report.line_direction)
    p = s_mm * e
    lamp = np.asarray(plan.setup.preset.light.position_mm)
    cam = np.asarray(plan.setup.preset.camera.nominal_position_mm)
    wi, wo = (lamp - p) / np.linalg.norm(lamp - p), (cam - p) / np.linalg.norm(cam - p)
    return 1600.0 * abs(wo @ e + wi @ e)


def test_a_plan_places_lamp_and_camera_where_it_says(distant_plan):
    plan = distant_plan
    lamp = np.asarray(plan.setup.preset.light.position_mm)
    cam = np.asarray(plan.setup.preset.camera.nominal_position_mm)
    assert np.linalg.norm(lamp) == pytest.approx(DISTANT.lamp_distance_mm)
    assert math.degrees(math.acos(lamp[2] / np.linalg.norm(lamp))) == pytest.approx(abs(plan.lamp_angle_deg))
    assert np.linalg.norm(cam) == pytest.approx(plan.camera_distance_mm)
    assert math.degrees(math.acos(cam[2] / np.linalg.norm(cam))) == pytest.approx(plan.camera_angle_deg)
    assert abs(cam[1]) < 1e-9 and abs(lamp[1]) < 1e-9  # one vertical plane through the disc axis
    text = " ".join(plan.instructions())
    assert f"{plan.camera_distance_mm:.0f} mm" in text and f"{plan.lamp_distance_mm:.0f} mm" in text


def test_the_plan_covers_400_700_on_the_data_area_by_the_grating_equation(distant_plan):
    plan = distant_plan
    assert plan.report.covers_visible and not plan.report.occlusions and plan.report.disc_in_frame
    # The data area's two ends on the side to read show ≤ 400 and ≥ 700 nm (λ is continuous between).
    ends = []
    for side in (1, -1):
        lo, hi = sorted((_lambda_at(plan, side * 23.0), _lambda_at(plan, side * 58.5)))
        ends.append((lo, hi))
    assert any(lo <= 400.0 + 1 and hi >= 700.0 - 1 for lo, hi in ends), ends
    for lam, where in plan.report.positions_mm.items():
        for s in where:
            assert _lambda_at(plan, s) == pytest.approx(lam, abs=0.05)


def test_a_phone_with_a_pinhole_at_its_distance_gets_the_near_axis_set_up():
    plan = plan_capture(Equipment(210.0, 2.0, 26.0, phone=True), families=("near-axis",))
    assert plan.family == "near-axis" and 10.0 < abs(plan.lamp_offset_mm) <= 15.0
    assert plan.report.covers_visible and not plan.report.occlusions


def test_a_camera_is_never_offered_the_near_axis_set_up():
    with pytest.raises(PlanError, match="needs a phone"):
        plan_capture(Equipment(210.0, 2.0, 24.0, phone=False), families=("near-axis",))


@pytest.mark.parametrize("equipment,message", [
    (Equipment(50.0, 2.0, 26.0, phone=True), "too close"),
    (Equipment(300.0, 60.0, 24.0), "blurs the spectrum"),
    (Equipment(2000.0, 10.0, 800.0, sensor_width_mm=36.0), "too narrow"),
    (Equipment(float("nan"), 2.0, 26.0), "lamp distance"),
    (Equipment(300.0, -1.0, 26.0), "lamp size"),
    # the planner searching every lamp distance to 2 m: the slowest case (14 s loaded), in make test only
    pytest.param(Equipment(2000.0, 10.0, 50.0), "a lamp at .* mm works", marks=pytest.mark.slow),
])
def test_impossible_equipment_is_refused_with_what_to_change(equipment, message):
    with pytest.raises(PlanError, match=message):
        plan_capture(equipment)


@settings(max_examples=12, deadline=None, derandomize=True)
@given(distance=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(100, 5000)),
       size=st.one_of(st.floats(allow_nan=True), st.floats(0.5, 20)),
       focal=st.one_of(st.floats(allow_nan=True), st.floats(12, 60)), phone=st.booleans())
def test_any_equipment_gives_a_working_plan_or_a_plan_error(distance, size, focal, phone):
    try:
        plan = plan_capture(Equipment(distance, size, focal, phone=phone), max_analysed=15)
    except PlanError as exc:
        assert str(exc).strip() and "\n" not in str(exc)  # one plain line
        return
    assert plan.report.covers_visible and not plan.report.occlusions
    assert all(np.isfinite(list(plan.report.resolution_nm.values())))


def test_cli_prints_the_steps_and_writes_a_preset_that_loads(tmp_path, capsys):
    out = tmp_path / "mine.json"
    assert run_plan(["--lamp-distance-mm", "2000", "--lamp-size-mm", "10", "--focal-mm", "26", "--phone",
                     "--write-preset", str(out)]) == 0
    text = capsys.readouterr().out
    assert "Camera on a tripod" in text and "400–700 covered" in text and "nm FWHM" in text
    assert "level to within 1.5°" in text and "may tip up to 1.5° any way" in text
    setup = load_setup(out)
    assert setup.preset.name == "mine" and analyse(setup).covers_visible


def test_cli_json_output_is_the_plan(capsys):
    assert run_plan(["--lamp-distance-mm", "2000", "--lamp-size-mm", "10", "--focal-mm", "26", "--phone",
                     "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["report"]["covers_400_700"] is True and data["camera_distance_mm"] > 0


@pytest.mark.parametrize("argv,message", [
    (["--lamp-distance-mm", "50", "--lamp-size-mm", "2", "--focal-mm", "26"], "too close"),
    (["--lamp-distance-mm", "x", "--lamp-size-mm", "2", "--focal-mm", "26"], "invalid float"),
    (["--lamp-size-mm", "2", "--focal-mm", "26"], "required"),
    (["--lamp-distance-mm", "300", "--lamp-size-mm", "2", "--focal-mm", "26", "--phone", "--camera"], "not allowed"),
    (["--lamp-distance-mm", "2000", "--lamp-size-mm", "10", "--focal-mm", "26", "--phone",
      "--write-preset", "/nonexistent-folder/x.json"], "does not exist"),
])
def test_cli_refuses_bad_input_with_one_error_line(argv, message, capsys):
    assert run_plan(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0]


@pytest.mark.parametrize("target,message", [("/nonexistent-folder/x.json", "does not exist"),
                                            ("plan.txt", "needs a .json file name")])
def test_a_preset_that_cannot_be_written_is_refused_before_the_plan(target, message, monkeypatch, capsys):
    """A plan takes ~2 s; a --write-preset that cannot be written is said at once, in one line."""
    def no_plan(*_args, **_kwargs):
        raise AssertionError("planned before checking where the preset goes")

    monkeypatch.setattr("cd_spectra_addon.core.planning.planner.plan_capture", no_plan)
    assert run_plan(["--lamp-distance-mm", "2000", "--lamp-size-mm", "10", "--focal-mm", "26", "--phone",
                     "--write-preset", target]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error:") and message in err[0]


def test_plan_is_reachable_from_python_dash_m():
    done = subprocess.run([sys.executable, "-m", "cd_spectra_addon", "plan", "--lamp-distance-mm", "40",
                           "--lamp-size-mm", "2", "--focal-mm", "26"], capture_output=True, text=True)
    assert done.returncode == 2 and done.stderr.startswith("error: a lamp 40 mm") and "Traceback" not in done.stderr


@pytest.mark.slow  # ~4 s of CPU: the in-plane search, then up to 45 off-plane analyses
def test_where_every_position_in_the_cameras_plane_is_blocked_the_lamp_is_turned_out_of_it():
    """A 250 mm lamp housing 300 mm from the disc collides with the camera, or shades the streak,
    wherever the planner puts the lamp in the camera's plane; turned around the disc's axis it
    stands aside, and the curved first order still puts 400–700 nm on the data area."""
    from cd_spectra_addon.core.planning.setups import first_order_curve, setup_from_dict
    from cd_spectra_addon.core.scene.capture import Scene, preset_from_dict

    plan = plan_capture(Equipment(300.0, 3.0, 24.0, lamp_housing_mm=250.0), max_analysed=20)
    assert plan.lamp_turn_deg in (30.0, -30.0, 60.0, -60.0, 90.0, -90.0)
    report = plan.report
    assert not report.coplanar and report.covers_visible and not report.occlusions and report.disc_in_frame
    lamp = np.asarray(plan.setup.preset.light.position_mm)
    cam = np.asarray(plan.setup.preset.camera.nominal_position_mm)
    assert np.linalg.norm(lamp) == pytest.approx(300.0)
    turn = math.degrees(math.atan2(lamp[1], lamp[0]) - math.atan2(cam[1], cam[0])) % 360.0
    assert turn == pytest.approx(plan.lamp_azimuth_from_camera_deg)
    text = " ".join(plan.instructions())
    assert f"{plan.lamp_azimuth_from_camera_deg:g}° counter-clockwise from the camera" in text
    # The same lamp turned back into the camera's plane is no plan (blocked, or 400–700 nm not all on the
    # data area): the turn is what made it work.
    back = np.array([np.hypot(lamp[0], lamp[1]) * (1.0 if plan.lamp_angle_deg > 0 else -1.0), 0.0, lamp[2]])
    data = plan.setup.preset.to_dict()
    data["light"]["position_mm"] = back.tolist()
    housing = {"name": "lamp housing", "center_mm": (back + back / 300.0 * 125.0).tolist(),
               "size_mm": [250.0] * 3, "facing": (-back / 300.0).tolist(), "passes_source": True}
    in_plane = setup_from_dict(preset_from_dict(data), {
        "kind": "oblique", "camera_body_mm": list(plan.setup.camera_body_mm),
        "lens_offset_mm": list(plan.setup.lens_offset_mm), "aperture_mm": plan.setup.aperture_mm,
        "source_size_mm": 3.0, "bodies": [housing]})
    back_report = analyse(in_plane)
    assert back_report.occlusions or not back_report.covers_visible
    # 400 and 700 nm lie where the kernel's λ₁ on the curve says.
    scene = Scene(plan.setup.preset)
    for lam in (400.0, 700.0):
        for s in report.positions_mm[lam]:
            assert _kernel_lambda1(scene, first_order_curve(scene, [abs(s)]).points_mm[0 if s > 0 else 1]) \
                == pytest.approx(lam, abs=0.05)


def _kernel_lambda1(scene, points):
    from cd_spectra_addon.core.scene.kernel import diffraction_at

    cam = np.asarray(scene.camera_position) * 1e3
    view = (cam - points) / np.linalg.norm(cam - points, axis=-1, keepdims=True)
    geo = diffraction_at(points, view, np.zeros(3), scene.disc_normal, np.asarray(scene.light_position) * 1e3)
    return float(geo.lambda1_nm(scene.preset.disc.pitch_um)[0])


@pytest.mark.slow
def test_plans_prefer_a_disc_that_may_tip_and_say_how_level_it_must_be():
    """A tilt in the plane of lamp and camera moves every wavelength along the disc (~50 nm per
    degree): the planner ranks how far the disc may tip before 400–700 nm leaves the tracks ahead
    of the blur, and where that is under 3° the first step says how level to lay it. A tripod
    camera with the lamp 300 mm away cannot be made to tolerate more than 1°; at 200 mm it can."""
    from cd_spectra_addon.core.planning.planner import TILT_GOAL_DEG
    from cd_spectra_addon.core.planning.setups import TILT_COVERAGE, visible_share
    from cd_spectra_addon.core.scene.capture import Pose, Scene

    near = plan_capture(Equipment(lamp_distance_mm=200.0, lamp_size_mm=3.0, focal_mm=24.0))
    far = plan_capture(Equipment(lamp_distance_mm=300.0, lamp_size_mm=3.0, focal_mm=24.0))
    assert near.tilt_tolerance_deg >= TILT_GOAL_DEG > far.tilt_tolerance_deg
    for plan in (near, far):
        tilt = plan.tilt_tolerance_deg
        for about in ((tilt, 0.0), (0.0, tilt), (-tilt, 0.0), (0.0, -tilt)):
            assert visible_share(Scene(plan.setup.preset, Pose(tilt_deg=about))) >= TILT_COVERAGE
        worse = tilt + 1.0
        assert min(visible_share(Scene(plan.setup.preset, Pose(tilt_deg=about)))
                   for about in ((worse, 0.0), (0.0, worse), (-worse, 0.0), (0.0, -worse))) < TILT_COVERAGE
    assert f"level to within {far.tilt_tolerance_deg:g}°" in far.instructions()[0]
    assert "level" not in near.instructions()[0]
    assert plan_capture(DISTANT).to_dict()["tilt_tolerance_deg"] == pytest.approx(1.5)
