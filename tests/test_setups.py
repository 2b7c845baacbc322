"""Buildable set-ups: the first order where the grating equation puts it, on the data area,
nothing in the way, and the spectral blur the lamp and lens sizes give."""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET, REFERENCE_PRESET, Scene, load_preset, preset_from_dict
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.planning.setups import Box, analyse, load_setup, setup_from_dict, setup_names

SHIPPED = ["phone-near-axis", "tripod-oblique", "phone-distant-lamp"]
REPO = Path(__file__).resolve().parents[1]


def _grating_check(scene: Scene, direction: np.ndarray, s_mm: float) -> tuple[float, float]:
    """Independent of the product code: d(sin θm − sin θi) and the tangential part v at the point
    s·ê, with sin θi = −ωi·ê and sin θm = ωo·ê (angles from the normal, positive along ê)."""
    p = s_mm * direction
    lamp = np.asarray(scene.preset.light.position_mm)
    cam = np.asarray(scene.preset.camera.nominal_position_mm)
    wi = (lamp - p) / np.linalg.norm(lamp - p)
    wo = (cam - p) / np.linalg.norm(cam - p)
    d_nm = scene.preset.disc.pitch_um * 1e3
    t = np.cross((0.0, 0.0, 1.0), direction)
    return d_nm * (wo @ direction - (-(wi @ direction))), float((wi + wo) @ t)


def test_the_shipped_set_ups_are_listed():
    assert set(SHIPPED) <= set(setup_names())
    assert "cd-default" not in setup_names()


def test_the_default_preset_can_be_built_and_the_reference_is_the_tables_coaxial_one():
    """What a photo is read as unless the user picks a preset is a set-up a person can build
    (it has build steps and covers 400–700 nm); the tables' reference geometry stays cd-default."""
    assert DEFAULT_PRESET in SHIPPED
    report = analyse(load_setup(DEFAULT_PRESET))
    assert report.covers_visible and load_setup(DEFAULT_PRESET).steps
    assert REFERENCE_PRESET == "cd-default" and REFERENCE_PRESET not in setup_names()
    reference = load_preset(REFERENCE_PRESET)
    assert reference.light.position_mm == (0.0, 0.0, reference.camera.distance_mm)  # lamp on the lens axis


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_set_up_puts_400_700_on_the_data_area_by_the_grating_equation(name):
    setup = load_setup(name)
    report = analyse(setup, report_nm=tuple(np.arange(400.0, 701.0, 25.0)))
    assert report.covers_visible and report.covered_nm == (400.0, 700.0)
    assert report.occlusions == () and report.disc_in_frame
    scene = Scene(setup.preset)
    e = np.asarray(report.line_direction)
    assert abs(e[2]) < 1e-12 and math.isclose(np.linalg.norm(e), 1.0)
    for lam, where in report.positions_mm.items():
        on_data = [s for s in where if 23.0 <= abs(s) <= 58.5]
        assert on_data, (name, lam, where)
        for s in where:
            value, v = _grating_check(scene, e, s)
            assert abs(abs(value) - lam) < 0.05, (name, lam, s, value)  # m = ±1
            assert abs(v) < 1e-12
    # One side alone shows the whole range (the planner prefers that), in order along the line.
    side = [c for c in report.sides if c.lambda_range_nm[0] <= 400 and c.lambda_range_nm[1] >= 700]
    assert side and side[0].blocked_fraction == 0.0


@pytest.mark.parametrize("name", SHIPPED)
def test_resolution_is_the_lamp_and_lens_angular_size_times_the_pitch(name):
    setup = load_setup(name)
    report = analyse(setup, report_nm=(550.0,))
    lamp = np.asarray(setup.preset.light.position_mm)
    cam = np.asarray(setup.preset.camera.nominal_position_mm)
    sig_i = setup.source_size_mm / (4 * np.linalg.norm(lamp))
    sig_o = setup.aperture_mm / (4 * np.linalg.norm(cam))
    e = np.asarray(report.line_direction)
    # on the half of the line that shows the whole range (the one a reader uses)
    assert report.read_side in (1, -1)
    s = [x for x in report.positions_mm[550.0] if 23 <= abs(x) <= 58.5 and x * report.read_side > 0][0]
    p = s * e
    wi, wo = (lamp - p) / np.linalg.norm(lamp - p), (cam - p) / np.linalg.norm(cam - p)
    # In the plane of diffraction, cos θ = √(1 − sin² θ) with sin θ = ω·ê.
    fwhm = 2.3548 * 1600 * math.hypot(math.sqrt(1 - (wi @ e) ** 2) * sig_i, math.sqrt(1 - (wo @ e) ** 2) * sig_o)
    assert report.resolution_nm[550.0] == pytest.approx(fwhm, rel=1e-9)
    assert 3.0 < fwhm < 25.0
    # The preset renders with the same combined angular size.
    assert setup.preset.light.lobe_sigma == pytest.approx(math.hypot(sig_i, sig_o), rel=1e-3)


def _on_axis_setup(camera_mm: float, lamp_mm: tuple[float, float, float], body=(140.0, 100.0, 150.0)):
    data = load_preset("cd-default").to_dict()
    data["camera"]["distance_mm"] = camera_mm
    data["camera"]["focal_length_mm"] = 24.0
    data["light"]["position_mm"] = list(lamp_mm)
    return setup_from_dict(preset_from_dict(data), {"kind": "oblique", "camera_body_mm": list(body),
                                                    "aperture_mm": 3.0, "source_size_mm": 3.0})


def test_a_lamp_behind_the_camera_is_shadowed_by_its_body():
    """cd-far-light as built: camera 100 mm over the disc, lamp 2 m up the axis behind it."""
    report = analyse(_on_axis_setup(100.0, (0.0, 0.0, 2000.0)))
    assert any("camera body shadows" in f for f in report.occlusions)
    assert not report.covers_visible
    # A phone-sized body (75 × 160 mm) at 100 mm shadows it too; only a tiny body would not.
    assert not analyse(_on_axis_setup(100.0, (0.0, 0.0, 2000.0), (75.0, 160.0, 9.0))).covers_visible
    assert analyse(_on_axis_setup(100.0, (0.0, 0.0, 2000.0), (2.0, 2.0, 2.0))).covers_visible


def test_a_lamp_60_mm_beside_a_58_mm_lens_cannot_put_the_spectrum_on_the_data_area():
    """The issue's finding: the visible first order on the lamp's line falls inside r < 25 mm."""
    data = load_preset("cd-default").to_dict()
    data["light"]["position_mm"] = [60.0, 0.0, 210.0]
    setup = setup_from_dict(preset_from_dict(data), {"kind": "near-axis", "camera_body_mm": [2, 2, 2],
                                                     "aperture_mm": 3.0, "source_size_mm": 3.0})
    report = analyse(setup)
    assert not report.covers_visible
    # 400-700 nm on the data area of one side only in part; the blue end is inside the hub.
    assert all(c.lambda_range_nm[0] > 400 or c.lambda_range_nm[1] < 700 for c in report.sides)


def test_box_hits_segments_through_it_not_beside_or_touching():
    box = Box("b", (0.0, 0.0, 0.0), (2.0, 2.0, 2.0))
    a = np.array([[-5.0, 0.0, 0.0], [-5.0, 3.0, 0.0], [-5.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    b = np.array([[5.0, 0.0, 0.0], [5.0, 3.0, 0.0], [-2.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    assert box.hits(a, b).tolist() == [True, False, False, False]
    turned = Box.facing("t", (0, 0, 0), (10.0, 0.5, 10.0), facing=(0, 1, 0), up=(0, 0, 1))
    # a thin card in the xz-plane... faced along +y it is thin along y: a ray along y crosses it
    assert turned.hits(np.array([[0.0, -5.0, 0.0]]), np.array([[0.0, 5.0, 0.0]]))[0]


def test_boxes_that_share_volume_overlap_and_separate_ones_do_not():
    a = Box("a", (0.0, 0.0, 0.0), (2.0, 2.0, 2.0))
    assert a.overlaps(Box("b", (1.5, 0.0, 0.0), (2.0, 2.0, 2.0)))
    assert not a.overlaps(Box("c", (2.0, 0.0, 0.0), (2.0, 2.0, 2.0)))  # touching faces only
    # a box turned 45° about z: its corner reaches 1.414·1 from its centre along x
    turned = Box.facing("d", (2.3, 0.0, 0.0), (2.0, 2.0, 2.0), facing=(0, 0, 1), up=(1, 1, 0))
    assert turned.overlaps(a)
    assert not Box.facing("e", (2.5, 0.0, 0.0), (2.0, 2.0, 2.0), facing=(0, 0, 1), up=(1, 1, 0)).overlaps(a)


def test_a_lamp_housing_inside_the_camera_body_is_reported():
    setup = _on_axis_setup(300.0, (20.0, 0.0, 300.0))
    crowded = setup_from_dict(setup.preset, {"kind": "oblique", "camera_body_mm": [140, 100, 150],
                                             "aperture_mm": 3.0, "source_size_mm": 3.0,
                                             "bodies": [{"name": "lamp housing", "center_mm": [20, 0, 340],
                                                         "size_mm": [80, 80, 80], "passes_source": True}]})
    assert any("same place" in f for f in analyse(crowded).occlusions)


def test_a_preset_without_a_set_up_is_refused_with_the_list():
    with pytest.raises(CDSpectraError, match="no buildable set-up.*phone-near-axis"):
        load_setup("cd-default")


@settings(max_examples=60, deadline=None)
@given(st.dictionaries(st.sampled_from(["kind", "camera_body_mm", "aperture_mm", "source_size_mm", "bodies",
                                        "lens_offset_mm", "emitter"]),
                       st.one_of(st.none(), st.floats(allow_nan=True), st.text(max_size=4),
                                 st.lists(st.floats(allow_nan=True), max_size=4))))
def test_junk_set_up_sections_are_refused_with_a_clear_message(tmp_path_factory, section):
    import json

    data = {**load_preset("cd-default").to_dict(), "setup": section}
    path = tmp_path_factory.mktemp("s") / "s.json"
    path.write_text(json.dumps(data))
    try:
        setup = load_setup(path)
    except CDSpectraError as exc:
        assert "invalid setup section" in str(exc) and "setup" in str(exc)
        return
    assert setup.aperture_mm > 0 and setup.source_size_mm > 0 and setup.kind in ("near-axis", "oblique")


@pytest.mark.slow  # re-plans every shipped set-up (10 s): make test only
def test_shipped_presets_are_what_the_planner_designs_now():
    done = subprocess.run([sys.executable, str(REPO / "tools" / "design_setups.py"), "--check"],
                          capture_output=True, text=True, cwd=REPO)
    assert done.returncode == 0, done.stderr


# --- lamp and camera anywhere: the first order on the curve v = 0 ---------------------------------


def _v_by_hand(scene: Scene, points: np.ndarray) -> np.ndarray:
    """(ωi + ωo)·t̂ at disc points, written out here (not the kernel): t̂ = n × r̂."""
    lamp = np.asarray(scene.light_position) * 1e3
    cam = np.asarray(scene.camera_position) * 1e3
    n = scene.disc_normal
    wi = (lamp - points) / np.linalg.norm(lamp - points, axis=-1, keepdims=True)
    wo = (cam - points) / np.linalg.norm(cam - points, axis=-1, keepdims=True)
    r_hat = points / np.linalg.norm(points, axis=-1, keepdims=True)
    return np.sum((wi + wo) * np.cross(n, r_hat), axis=-1)


def _measured_scene(lamp, camera, lamp_azimuth):
    from cd_spectra_addon.core.planning.measured import Measurements, measured_setup

    setup = measured_setup(Measurements(lamp[0], lamp[1], lamp_azimuth, camera[0], camera[1], 0.0, lamp_size_mm=3.0))
    return setup, Scene(setup.preset)


@pytest.mark.parametrize("name", SHIPPED)
def test_for_coplanar_set_ups_the_curve_is_the_incidence_line_and_lambda_the_grating_equations(name):
    """The root finder, run where lamp, camera and axis share a plane, finds the straight line."""
    from cd_spectra_addon.core.planning.setups import first_order_curve, incidence_line

    scene = Scene(load_setup(name).preset)
    e = incidence_line(scene)
    radii = np.linspace(1.0, 60.0, 119)
    curve = first_order_curve(scene, radii)
    for arm, sign in ((0, 1.0), (1, -1.0)):
        points = curve.points_mm[arm]
        assert np.allclose(points, sign * radii[:, None] * e[None, :], atol=1e-9), (name, arm)
        lam = np.array([_grating_check(scene, e, sign * r)[0] for r in radii])
        kernel_lam = _kernel_lambda1(scene, points)
        assert np.allclose(np.abs(lam), kernel_lam, atol=1e-9)


def _kernel_lambda1(scene: Scene, points: np.ndarray) -> np.ndarray:
    from cd_spectra_addon.core.scene.kernel import diffraction_at

    cam = np.asarray(scene.camera_position) * 1e3
    view = (cam - points) / np.linalg.norm(cam - points, axis=-1, keepdims=True)
    geo = diffraction_at(points, view, np.zeros(3), scene.disc_normal, np.asarray(scene.light_position) * 1e3)
    return geo.lambda1_nm(scene.preset.disc.pitch_um)


@pytest.mark.parametrize("lamp,camera,azimuth", [
    ((700.0, 83.5), (230.0, 38.0), 165.0),  # Kim 2023's case 1: a grazing lamp, 15° out of the camera's plane
    ((300.0, 35.0), (200.0, 30.0), 160.0),  # the mirror glint on the data area
    ((400.0, 20.0), (250.0, 45.0), 90.0),
])
def test_off_plane_the_first_order_lies_on_the_curve_v_0_and_shows_the_kernels_lambda(lamp, camera, azimuth):
    from cd_spectra_addon.core.planning.setups import first_order_curve, incidence_line

    setup, scene = _measured_scene(lamp, camera, azimuth)
    with pytest.raises(CDSpectraError, match="one plane"):
        incidence_line(scene)
    radii = np.linspace(0.5, 60.0, 120)
    curve = first_order_curve(scene, radii)
    points = curve.points_mm.reshape(-1, 3)
    assert np.allclose(np.linalg.norm(points, axis=1), np.tile(radii, 2), atol=1e-9)
    assert np.max(np.abs(points[:, 2])) < 1e-12  # on the disc plane
    assert np.max(np.abs(_v_by_hand(scene, points))) < 1e-9
    # The arms leave the centre in opposite directions and bend: it is a curve, not a line.
    assert abs((curve.azimuth_deg[1, 0] - curve.azimuth_deg[0, 0]) % 360.0 - 180.0) < 1.0
    assert np.ptp(curve.azimuth_deg[0]) > 1.0
    report = analyse(setup, report_nm=tuple(np.arange(400.0, 1001.0, 50.0)))
    assert not report.coplanar
    for lam, where in report.positions_mm.items():
        for s in where:
            arm = 0 if s > 0 else 1
            point = first_order_curve(scene, [abs(s)]).points_mm[arm]
            assert _kernel_lambda1(scene, point)[0] == pytest.approx(lam, abs=0.05), (lam, s)
    # Per arm, the first order's range on the data area is the kernel's there.
    for cov, arm in zip(report.sides, (0, 1)):
        on_data = first_order_curve(scene, np.linspace(23.0, 58.5, 200)).points_mm[arm]
        lam = _kernel_lambda1(scene, on_data)
        assert cov.lambda_range_nm == pytest.approx((lam.min(), lam.max()), abs=0.5)
        for m, lo, hi in cov.orders_nm:  # other orders show λ₁/m: only where that is visible
            assert 400.0 <= lo <= hi <= 700.0 and lam.min() / m <= hi + 1e-9 and lam.max() / m >= lo - 1e-9


def test_off_plane_glint_is_the_lamps_mirror_point():
    """Zero order: where the disc mirrors the lamp into the lens — on the segment between their feet,
    split in the ratio of their heights — and it lies on the curve (u = v = 0 there)."""
    from cd_spectra_addon.core.planning.setups import first_order_curve

    setup, scene = _measured_scene((300.0, 35.0), (200.0, 30.0), 160.0)
    report = analyse(setup)
    lamp = np.asarray(setup.preset.light.position_mm)
    cam = np.asarray(setup.preset.camera.nominal_position_mm)
    mirror = (cam[:2] * lamp[2] + lamp[:2] * cam[2]) / (lamp[2] + cam[2])
    (glint,) = report.glint_mm
    assert abs(glint) == pytest.approx(np.hypot(*mirror), abs=2e-3)
    on_curve = first_order_curve(scene, [abs(glint)]).points_mm[0 if glint > 0 else 1][0]
    assert np.allclose(on_curve[:2], mirror, atol=2e-3)
    assert any("mirror glint" in note for note in report.notes)


def test_a_grazing_lamp_out_of_the_cameras_plane_reports_each_arm():
    """Kim 2023's case 1 (lamp 700 mm at 83.5°, camera 230 mm at 38°, 165° apart): one arm shows
    the blue–green first order, the other the near infrared, whose second order is visible there."""
    setup, _ = _measured_scene((700.0, 83.5), (230.0, 38.0), 165.0)
    report = analyse(setup)
    plus, minus = report.sides
    assert 400.0 < plus.lambda_range_nm[0] < 500.0 < plus.lambda_range_nm[1] < 700.0
    assert minus.lambda_range_nm[0] > 700.0 and minus.orders_nm and minus.orders_nm[0][0] == 2
    assert not report.covers_visible and report.covered_nm is not None
    assert all(np.isfinite(list(report.resolution_nm.values())))
    assert any("curve through the centre" in note for note in report.notes)


def _lambda_by_grating_equation(scene: Scene, direction: np.ndarray, tilt_rad: float, s_mm: float) -> float:
    """Independent of the product code: λ₁ at the point s along the incidence line ê (level disc)
    of the disc turned by ``tilt_rad`` about y, the axis across that line: d·|(ωi + ωo)·R ê|."""
    lamp = np.asarray(scene.preset.light.position_mm)
    cam = np.asarray(scene.preset.camera.nominal_position_mm)
    c, s = math.cos(tilt_rad), math.sin(tilt_rad)
    e = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) @ direction  # the line on the tilted disc
    p = s_mm * e
    wi, wo = (lamp - p) / np.linalg.norm(lamp - p), (cam - p) / np.linalg.norm(cam - p)
    return scene.preset.disc.pitch_um * 1e3 * abs(float((wi + wo) @ e))


@pytest.mark.parametrize("name", ["tripod-oblique", "phone-distant-lamp"])
def test_a_tilt_in_the_plane_of_lamp_and_camera_moves_every_wavelength_by_d_cos_sum(name):
    """d·(cos θi + cos θo)·δ to first order — 35–56 nm per degree for lamp and camera within 45° of
    the axis, on whichever side — which is why an oblique set-up needs a wide margin (or a level
    disc); and the product's streak moves so."""
    from cd_spectra_addon.core.planning.setups import first_order_positions
    from cd_spectra_addon.core.scene.capture import Pose

    scene = Scene(load_preset(name))
    e = np.asarray(analyse(load_setup(name)).line_direction)
    lamp = np.asarray(scene.preset.light.position_mm)
    cam = np.asarray(scene.preset.camera.nominal_position_mm)
    d_nm = scene.preset.disc.pitch_um * 1e3
    one = math.radians(1.0)
    for s_mm in (-40.0, 30.0, 50.0):
        p = s_mm * e
        cos_sum = (lamp - p)[2] / np.linalg.norm(lamp - p) + (cam - p)[2] / np.linalg.norm(cam - p)
        shift = _lambda_by_grating_equation(scene, e, one, s_mm) - _lambda_by_grating_equation(scene, e, 0.0, s_mm)
        assert abs(abs(shift) - d_nm * cos_sum * one) < 0.15 * d_nm * cos_sum * one, (s_mm, shift)  # + the point lifting (camera 127 mm: 11 %)
        assert 30.0 < abs(shift) < 60.0
    # the product's first order: where 550 nm lies on the tilted disc, the level disc shows 550 ∓ shift
    for tilt in (1.0, -1.0):
        tilted = Scene(scene.preset, Pose(tilt_deg=(0.0, tilt)))
        for s_mm in first_order_positions(tilted, [550.0])[0]:
            if 23.0 <= abs(s_mm) <= 58.5:
                expect = _lambda_by_grating_equation(scene, e, 0.0, s_mm)
                assert abs(abs(expect - 550.0) - 50.0) < 8.0, (tilt, s_mm, expect)


def test_the_tilt_tolerance_is_where_400_700_leaves_the_tracks():
    """The shipped tripod set-up keeps 400–700 nm on the tracks with the disc tilted 3° any way;
    version 2's (lamp 300 mm at 7.5°, camera 27.5° on its side) lost a third of it at 1°; the
    near-axis capture only slides its first order along the line."""
    from cd_spectra_addon.core.planning.setups import TILT_COVERAGE, tilt_tolerance_deg, visible_share
    from cd_spectra_addon.core.scene.capture import Pose

    tripod = load_preset("tripod-oblique")
    assert tilt_tolerance_deg(tripod) >= 3.0
    for tilt in ((3.0, 0.0), (-3.0, 0.0), (0.0, 3.0), (0.0, -3.0)):
        assert visible_share(Scene(tripod, Pose(tilt_deg=tilt))) >= TILT_COVERAGE
    old = load_preset(REPO / "tests" / "tripod_oblique_v2.json")
    assert visible_share(Scene(old)) == 1.0
    assert tilt_tolerance_deg(old) <= 1.0
    assert visible_share(Scene(old, Pose(tilt_deg=(0.0, 3.0)))) < 0.6
    assert tilt_tolerance_deg(load_preset("phone-near-axis")) >= 3.0


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.floats(300.0, 800.0), st.booleans()), min_size=2, max_size=60))
def test_the_steps_a_streak_shows_are_those_some_joined_segment_reaches(samples):
    """Coverage (the planner's, the analysis's, first_order_visible's) marks the 1 nm steps of
    400–700 nm each segment between neighbouring samples reaches, widened by half a step: marked
    at the segments' ends and summed, it is exactly the step-by-step definition; its runs are
    the maximal stretches of marked steps."""
    from cd_spectra_addon.core.planning.setups import _GRID_NM, _runs, _seen_nm

    lam = np.array([v for v, _ in samples])
    joined = np.array([j for _, j in samples[:-1]], dtype=bool)
    expected = np.zeros(_GRID_NM.size, dtype=bool)
    for i in np.flatnonzero(joined):
        lo, hi = sorted((lam[i], lam[i + 1]))
        expected |= (_GRID_NM >= lo - 0.5) & (_GRID_NM <= hi + 0.5)
    seen = _seen_nm(lam, joined)
    assert np.array_equal(seen, expected)
    runs = _runs(seen)
    assert sum(b - a for a, b in runs) == int(seen.sum())
    for a, b in runs:
        assert seen[a:b].all() and (a == 0 or not seen[a - 1]) and (b == seen.size or not seen[b])
