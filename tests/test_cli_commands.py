"""The command line's other jobs, each through a real subprocess: export, calibrate and the lists.

``export`` is given what ``estimate --json`` wrote (the fake estimator of test_cli makes it);
``calibrate`` runs the real inverse path on a photo rendered by the forward model.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from test_cli import _photos, _stderr_lines, run_cli

from cd_spectra_addon.core.spectra import spectra_files
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

READERS = {
    "csv": lambda p: spectra_files.read_spectra_csv(p).on_grid()[0],
    "json": lambda p: spectra_files.read_spd_json(p)[1],
    "pbrt": lambda p: spectra_files.read_spd_pbrt(p)[1],
    "ies": lambda p: spectra_files.read_spd_tm2714(p)[1],
    "mitsuba": lambda p: spectra_files.read_spd_mitsuba(p)[1],
}
EXTENSIONS = {"csv": ".csv", "json": ".json", "pbrt": ".spd", "ies": ".xml", "mitsuba": ".txt"}


def _assert_one_error(proc, folder: Path, before: list[str]) -> None:
    assert proc.returncode == 2, (proc.stdout, proc.stderr)
    lines = _stderr_lines(proc)
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert "Traceback" not in proc.stderr and proc.stdout == ""
    assert sorted(p.name for p in folder.iterdir()) == before


@pytest.fixture(scope="module")
def estimated(tmp_path_factory: pytest.TempPathFactory) -> str:
    """What ``estimate --json`` wrote for two photos (made once: the tests only read it)."""
    folder = tmp_path_factory.mktemp("estimated")
    photos = _photos(folder, "lamp.jpg", "other_lamp.jpg")
    out = folder / "result.json"
    proc = run_cli("estimate", *photos, "--json", str(out))
    assert proc.returncode == 0, proc.stderr
    return out.read_text()


@pytest.fixture
def result_file(tmp_path: Path, estimated: str) -> Path:
    out = tmp_path / "result.json"
    out.write_text(estimated)
    return out


@pytest.mark.parametrize("fmt", sorted(READERS))
def test_export_writes_every_result_and_reads_back(result_file: Path, fmt: str) -> None:
    results = json.loads(result_file.read_text())
    proc = run_cli("export", str(result_file), "--format", fmt)
    assert proc.returncode == 0, proc.stderr
    written = [result_file.with_name(f"result-{fmt}-{i}{EXTENSIONS[fmt]}") for i in (1, 2)]
    assert proc.stdout.strip() == "wrote " + ", ".join(str(p) for p in written)
    for path, data in zip(written, results):
        np.testing.assert_allclose(READERS[fmt](path), data["spd"], rtol=1e-9, atol=1e-12)


def test_export_of_one_result_to_a_chosen_file(tmp_path: Path, result_file: Path) -> None:
    one = tmp_path / "one.json"
    one.write_text(json.dumps(json.loads(result_file.read_text())[1]))
    target = tmp_path / "lamp.spd"
    proc = run_cli("export", str(one), "--format", "pbrt", "--out", str(target))
    assert proc.returncode == 0, proc.stderr
    text = target.read_text()
    assert text.startswith('# CD Spectra SPD "other_lamp"') and text.endswith("\n")


def test_export_reads_json_lines_from_stdout(tmp_path: Path) -> None:
    photos = _photos(tmp_path, "a.jpg", "b.jpg")
    proc = run_cli("estimate", *photos, "--json", "-")
    lines_file = tmp_path / "results.jsonl"
    lines_file.write_text(proc.stdout)
    proc = run_cli("export", str(lines_file), "--format", "mitsuba")
    assert proc.returncode == 0, proc.stderr
    pairs = (tmp_path / "results-mitsuba-1.txt").read_text().strip().split(", ")
    assert [float(p.split(":")[0]) for p in pairs] == list(WAVELENGTHS_NM)


@pytest.mark.parametrize("content", [
    "", "not json", "[]", '{"spd": [1, 2]}', '[{"spd": ' + json.dumps([0.0] * 81) + "}]",  # short, all dark
    '{"spd": ' + json.dumps([1.0] * 80 + [float("nan")]) + "}",  # Python's json writes and reads NaN
    '[{"spd": ' + json.dumps([1.0] * 81) + '}, {"spd": ' + json.dumps([-1.0] + [1.0] * 80) + "}]",  # 2nd bad
])
def test_export_refuses_a_broken_result_and_writes_nothing(tmp_path: Path, content: str) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text(content)
    proc = run_cli("export", str(bad), "--format", "csv")
    _assert_one_error(proc, tmp_path, ["bad.json"])


def test_export_never_overwrites_its_input(tmp_path: Path, result_file: Path) -> None:
    single = tmp_path / "single.json"
    single.write_text(json.dumps(json.loads(result_file.read_text())[0]))
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = run_cli("export", str(single), "--format", "json", "--out", str(single))
    _assert_one_error(proc, tmp_path, before)


def test_export_to_a_missing_folder_writes_nothing(tmp_path: Path, result_file: Path) -> None:
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = run_cli("export", str(result_file), "--format", "csv", "--out", str(tmp_path / "no" / "x.csv"))
    _assert_one_error(proc, tmp_path, before)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(spd=st.lists(st.floats(0.0, 1e6, allow_nan=False), min_size=81, max_size=81).filter(lambda v: max(v) > 0))
def test_mitsuba_pairs_round_trip_any_spd(tmp_path: Path, spd: list[float]) -> None:
    path = spectra_files.write_spd_mitsuba(tmp_path / "x.txt", spd)
    text = path.read_text(encoding="ascii")
    assert text.count("\n") == 1 and text.count(":") == 81
    np.testing.assert_array_equal(spectra_files.read_spd_mitsuba(path)[1], np.asarray(spd))


# --- lists ----------------------------------------------------------------------------------------


def test_presets_and_cameras_list_what_estimate_accepts(tmp_path: Path) -> None:
    from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, camera_names
    from cd_spectra_addon.core.scene.capture import preset_names

    env = {"CD_SPECTRA_PRESET_DIR": str(tmp_path / "no-presets-of-mine")}  # the shipped ones only
    proc = run_cli("presets", "--json", env_extra=env)
    assert [row["name"] for row in json.loads(proc.stdout)] == preset_names()
    proc = run_cli("presets", env_extra=env)
    assert [line.split()[0] for line in proc.stdout.splitlines()] == preset_names()
    proc = run_cli("cameras")
    assert [line.split()[0] for line in proc.stdout.splitlines()] == camera_names()
    (default,) = [line for line in proc.stdout.splitlines() if line.endswith("(default)")]
    assert default.split()[0] == DEFAULT_CAMERA


def test_calibrations_lists_the_calibration_folder(tmp_path: Path) -> None:
    env = {"CD_SPECTRA_CALIBRATION_DIR": str(tmp_path)}
    proc = run_cli("calibrations", env_extra=env)
    assert proc.returncode == 0 and str(tmp_path) in proc.stdout and "calibrate" in proc.stdout
    for name in ("desk", "attic"):
        (tmp_path / f"{name}.json").write_text("{}")
    proc = run_cli("calibrations", "--json", env_extra=env)
    assert json.loads(proc.stdout) == [{"name": "attic"}, {"name": "desk"}]


# --- calibrate ------------------------------------------------------------------------------------


@pytest.mark.parametrize("args", [
    ["{photo}", "--known-lamp", "A"],  # no --name
    ["{photo}", "--name", "x"],  # no lamp
    ["{photo}", "--known-lamp", "A", "--reference-spd", "{photo}", "--name", "x"],  # both
    ["{photo}", "--known-lamp", "sodium", "--name", "x"],
    ["{tmp}/missing.jpg", "--known-lamp", "A", "--name", "x"],
    ["{photo}", "--known-lamp", "A", "--name", "x"],  # not a photo
    ["{photo}", "--reference-spd", "{tmp}/missing.csv", "--name", "x"],
    ["{photo}", "{photo}", "--known-lamp", "A", "--name", "x"],  # a lamp for each photo
    ["{photo}", "{photo}", "--known-lamp", "A", "--known-lamp", "sodium", "--name", "x"],
    ["{photo}", "{tmp}/missing.jpg", "--known-lamp", "A", "--known-lamp", "D65", "--name", "x"],
    ["{photo}", "--known-lamp", "A", "{photo}", "--bogus", "--known-lamp", "D65", "--name", "x"],
])
def test_calibrate_refuses_bad_input_and_writes_no_profile(tmp_path: Path, args: list[str]) -> None:
    cal_dir = tmp_path / "calibrations"
    (photo,) = _photos(tmp_path, "photo.jpg")
    filled = [a.format(tmp=tmp_path, photo=photo) for a in args]
    proc = run_cli("calibrate", *filled, fake=False, env_extra={"CD_SPECTRA_CALIBRATION_DIR": str(cal_dir)})
    _assert_one_error(proc, tmp_path, ["photo.jpg"])


@pytest.mark.parametrize("argv, photos, lamps", [
    (["calibrate", "bulb.jpg", "window.jpg", "--known-lamp", "A", "--known-lamp", "D65", "--name", "x"],
     ["bulb.jpg", "window.jpg"], [("known", "A"), ("known", "D65")]),
    (["calibrate", "bulb.jpg", "--known-lamp", "A", "window.jpg", "--reference-spd", "sky.csv", "--name", "x"],
     ["bulb.jpg", "window.jpg"], [("known", "A"), ("file", Path("sky.csv"))]),
    (["calibrate", "--name", "x", "a.jpg", "--known-lamp", "A", "b.jpg", "--known-lamp", "D65", "c.jpg",
      "--known-lamp", "F2"], ["a.jpg", "b.jpg", "c.jpg"], [("known", "A"), ("known", "D65"), ("known", "F2")]),
])
def test_calibrate_pairs_each_photo_with_its_lamp_as_typed(argv: list[str], photos: list[str], lamps: list) -> None:
    """Each photo followed by its lamp (as people type it) pairs the same as photos-then-lamps."""
    from cd_spectra_addon.cli import parse

    args = parse(argv)
    assert [str(p) for p in args.photos] == photos and args.lamps == lamps


def test_estimate_takes_photos_between_its_options() -> None:
    from cd_spectra_addon.cli import UsageError, parse

    args = parse(["estimate", "a.jpg", "--preset", "cd-default", "b.jpg", "--preset", "tripod-oblique", "--joint"])
    assert [str(p) for p in args.photos] == ["a.jpg", "b.jpg"] and args.joint
    with pytest.raises(UsageError, match="unrecognized arguments: --nope"):
        parse(["estimate", "a.jpg", "--nope"])
    with pytest.raises(UsageError, match="unrecognized arguments: b.jpg"):
        parse(["presets", "b.jpg"])


@pytest.fixture(scope="module")
def incandescent_photo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from extension_support import render_sample_photo

    return render_sample_photo(tmp_path_factory.mktemp("calibrate"), 2856.0)


@pytest.mark.slow
def test_calibrate_then_estimate_with_the_profile(tmp_path: Path, incandescent_photo: Path) -> None:
    """A photo of CIE A calibrates; the profile is listed and used by estimate --calibration."""
    env = {"CD_SPECTRA_CALIBRATION_DIR": str(tmp_path)}
    proc = run_cli("calibrate", str(incandescent_photo), "--known-lamp", "A", "--name", "desk lamp",
                   fake=False, env_extra=env)
    assert proc.returncode == 0, proc.stderr
    profile = tmp_path / "desk_lamp.json"
    assert proc.stdout.splitlines()[0] == f"wrote calibration 'desk lamp' to {profile}"
    data = json.loads(profile.read_text())
    gains = np.asarray(data["gains"])
    assert np.all(np.isfinite(gains)) and np.all(gains > 0)
    assert data["reference"] == "Household bulb (CIE A)"  # the core's known lamp, reached by its CIE name
    assert json.loads(run_cli("calibrations", "--json", env_extra=env).stdout) == [{"name": "desk_lamp"}]
    out = tmp_path / "r.json"
    proc = run_cli("estimate", str(incandescent_photo), "--calibration", "desk_lamp", "--json", str(out),
                   fake=False, env_extra=env)
    assert proc.returncode == 0, proc.stderr
    (result,) = json.loads(out.read_text())
    assert result["calibration"] == "desk lamp"  # the profile's own name; its file is desk_lamp.json
    assert result["cct_k"] == pytest.approx(2856.0, abs=100.0)


@pytest.mark.slow
def test_calibrate_from_a_bulb_and_a_second_lamp(tmp_path: Path, incandescent_photo: Path) -> None:
    """Two photos, one lamp each in their order (a known lamp, then a measured SPD): one profile
    that names both."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from extension_support import render_sample_photo

    cool = render_sample_photo(tmp_path / "cool", 6500.0)
    env = {"CD_SPECTRA_CALIBRATION_DIR": str(tmp_path / "cal")}
    proc = run_cli("calibrate", str(incandescent_photo), str(cool), "--known-lamp", "A", "--reference-spd",
                   str(tmp_path / "cool" / "lamp.csv"), "--name", "two lamps", fake=False, env_extra=env)
    assert proc.returncode == 0, proc.stderr
    data = json.loads((tmp_path / "cal" / "two_lamps.json").read_text())
    assert [s["photo"] for s in data["shots"]] == [str(incandescent_photo), str(cool)]
    assert data["shots"][0]["reference"] == "Household bulb (CIE A)"
    assert data["shots"][1]["reference"].endswith("(lamp.csv)")
    assert np.all(np.isfinite(data["gains"])) and data["unexplained"] < 0.05
    # Each lamp read with the calibration the other gives, said on the command line and kept.
    assert [c["held_out"] for c in data["cross_check"]] == [s["reference"] for s in data["shots"]]
    assert "cross-check, each known lamp read with the calibration the others give" in proc.stdout


# --- compare --------------------------------------------------------------------------------------


def test_compare_gives_the_cores_metrics(tmp_path: Path, result_file: Path) -> None:
    from cd_spectra_addon.core.spectra.colour import compare_spds

    results = json.loads(result_file.read_text())
    reference = tmp_path / "meter.csv"
    spd = np.asarray(results[0]["spd"])
    reference.write_text("wavelength_nm,meter\n" + "".join(f"{w},{v}\n" for w, v in zip(WAVELENGTHS_NM, spd)))
    proc = run_cli("compare", str(result_file), str(reference), "--json")
    assert proc.returncode == 0, proc.stderr
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert [r["source"] for r in rows] == [r["source"] for r in results]
    assert rows[0]["mae_400_700"] == pytest.approx(0.0, abs=1e-12)  # the same spectrum
    want = compare_spds(np.asarray(results[1]["spd"]), spd)
    assert {k: v for k, v in rows[1].items() if k in want} == pytest.approx(want)
    proc = run_cli("compare", str(result_file), str(reference))
    assert proc.stdout.splitlines()[0] == f"{results[0]['source']} vs meter"
    assert "  delta u'v': 0" in proc.stdout


def test_compare_gives_the_rendition_differences(tmp_path: Path, result_file: Path) -> None:
    """Each rendition figure against the meter's: the difference and whether the meter's value lies
    in the estimate's range; an estimate without rendition is scored on its SPD."""
    from cd_spectra_addon.core.rendition.result import compare_rendition

    results = json.loads(result_file.read_text())
    reference = tmp_path / "meter.csv"
    spd = np.asarray(results[0]["spd"])
    reference.write_text("wavelength_nm,meter\n" + "".join(f"{w},{v}\n" for w, v in zip(WAVELENGTHS_NM, spd)))
    proc = run_cli("compare", str(result_file), str(reference), "--json")
    rows = [json.loads(line) for line in proc.stdout.splitlines()]
    assert rows[0]["rendition"]["difference"]["cri_ra"] == pytest.approx(0.0, abs=1e-9)
    assert rows[0]["rendition"]["within_range"]["tm30_rf"] is True
    assert rows[1]["rendition"] == json.loads(json.dumps(compare_rendition(results[1]["rendition"], spd)))
    proc = run_cli("compare", str(result_file), str(reference))
    assert "    Ra: " in proc.stdout and "in range" in proc.stdout
    for data in results:
        del data["rendition"]
    result_file.write_text(json.dumps(results))
    proc = run_cli("compare", str(result_file), str(reference), "--json")
    assert json.loads(proc.stdout.splitlines()[0])["rendition"]["difference"]["tm30_rg"] == pytest.approx(0.0, abs=1e-9)


def test_compare_picks_one_spectrum_of_a_table(tmp_path: Path, result_file: Path) -> None:
    """A table of several spectra (samples/demo_lamps.csv holds three): --spectrum picks one by its
    column name; without it, or with a name it lacks, the error says what to give."""
    from cd_spectra_addon.core.spectra.colour import compare_spds

    results = json.loads(result_file.read_text())
    spd = np.asarray(results[0]["spd"])
    table = tmp_path / "lamps.csv"
    table.write_text("wavelength_nm,flat,meter\n" + "".join(f"{w},1,{v}\n" for w, v in zip(WAVELENGTHS_NM, spd)))
    proc = run_cli("compare", str(result_file), str(table), "--spectrum", "meter", "--json")
    assert proc.returncode == 0, proc.stderr
    row = json.loads(proc.stdout.splitlines()[0])
    assert row["reference"] == "meter" and row["mae_400_700"] == pytest.approx(0.0, abs=1e-12)
    flat = json.loads(run_cli("compare", str(result_file), str(table), "--spectrum", "flat", "--json").stdout.splitlines()[0])
    assert flat["mae_400_700"] == pytest.approx(compare_spds(spd, np.ones(spd.size))["mae_400_700"])
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = run_cli("compare", str(result_file), str(table))
    _assert_one_error(proc, tmp_path, before)
    assert "flat, meter" in proc.stderr and "--spectrum NAME" in proc.stderr
    proc = run_cli("compare", str(result_file), str(table), "--spectrum", "lamp")
    _assert_one_error(proc, tmp_path, before)
    assert "no spectrum 'lamp'" in proc.stderr


def test_compare_refuses_an_unreadable_reference(tmp_path: Path, result_file: Path) -> None:
    bad = tmp_path / "meter.csv"
    bad.write_text("this is not a table\n")
    before = sorted(p.name for p in tmp_path.iterdir())
    proc = run_cli("compare", str(result_file), str(bad))
    _assert_one_error(proc, tmp_path, before)
    proc = run_cli("compare", str(result_file), str(tmp_path / "missing.csv"))
    _assert_one_error(proc, tmp_path, before)


def test_every_command_is_listed_and_documented() -> None:
    from cd_spectra_addon import cli

    assert [c.NAME for c in cli.COMMANDS] == list(cli.COMMAND_NAMES)
    proc = run_cli("--help")
    for command in cli.COMMANDS:
        assert command.NAME in proc.stdout and command.HELP[:20] in " ".join(proc.stdout.split())
