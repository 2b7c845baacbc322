"""Hostile inputs through the CLI, ``estimate_photo`` and the Blender operators.

Every input is generated here from one rendered capture (``training.reliability.hostile``; no binary blobs).
Each case says what the product must do -- a specific error with a message that says why, or a
result whose confidence is capped and whose warning says why -- and is checked three ways:

(a) the CLI in a child process: exit 2 and exactly one ``error:`` line (no traceback, nothing on
    stdout, no file left behind), or exit 0 with that result;
(b) ``estimate_photo`` in this process: that ``CDSpectraError`` subclass or that result, never
    another exception, never NaN;
(c) for a subset, the add-on's Estimate operator in headless Blender: ERROR + CANCELLED and not
    one data-block added, removed or renamed.

While no model is trained into models/, (a) and (b) run the estimator's physics + prior path
(``estimate_photo(model=None)``), the same pipeline minus the network; the model cases bring
their own (broken) toy model either way.
"""

from __future__ import annotations

import json
import sys
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from cd_spectra_addon.core.errors import CDSpectraError, PhotoError
from extension_support import (  # noqa: F401  (pytest fixtures for the Blender tests)
    Installed, addon, blackbody_spd, datablock_snapshot, fake_estimate, installed_addon, scene_snapshot,
)
from cd_spectra_addon.core.inverse.estimate import estimate_photo
from training.reliability import hostile
from training.reliability.hostile import CASES, CCT_TOLERANCE_K, TRUE_CCT_K, Case, Outcome

BY_NAME = {case.name: case for case in CASES}
BOMBS = ("bomb-png", "bomb-jpeg")
CLI_PEAK_RSS_MB = 150.0  # Python + numpy + Pillow is ~40 MB; decoding a bomb would be gigabytes


@dataclass
class Run:
    photo: Path | None
    model_dir: Path | None
    folder: Path
    cli: Outcome | None = None
    in_process: Outcome | None = None


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Run]:
    """Every case built once and run both ways (CLI children two at a time, in-process meanwhile)."""
    base = hostile.make_base()
    root = tmp_path_factory.mktemp("hostile")
    built: dict[str, Run] = {}
    for case in CASES:
        folder = root / case.name
        photo, model_dir = hostile.build_case(case, folder, base)
        built[case.name] = Run(photo, model_dir, folder)
    todo = [c for c in CASES if built[c.name].photo is not None]
    with ThreadPoolExecutor(2) as pool:
        futures = {c.name: pool.submit(hostile.run_cli, c, built[c.name].folder, built[c.name].photo,
                                       built[c.name].model_dir) for c in todo}
        for case in todo:
            if case.in_process:
                built[case.name].in_process = hostile.run_in_process(case, built[case.name].photo,
                                                                     built[case.name].model_dir)
        for name, future in futures.items():
            built[name].cli = future.result()
    return built


def _run(runs: dict[str, Run], case: Case) -> Run:
    run = runs[case.name]
    if run.photo is None and sys.platform == "win32":
        pytest.skip(f"{case.name}: needs POSIX (a FIFO, a folder this process cannot write)")
    assert run.photo is not None, f"{case.name}: the case could not be built"
    return run


def _warning_with(words: tuple[str, ...], warnings: list[str]) -> bool:
    return not words or any(all(w in text for w in words) for text in warnings)


def _check_result(case: Case, out: Outcome, via: str) -> None:
    e = case.expected(via)
    assert out.finite, f"{case.name}: SPD or confidence not finite / negative"
    assert len(out.spd) == 81 and max(out.spd) == 1.0
    assert out.confidence is not None and e.min_confidence <= out.confidence <= e.max_confidence, (
        case.name, out.confidence, out.warnings)
    assert _warning_with(e.words, out.warnings), (case.name, e.words, out.warnings)
    if e.cct:
        assert out.cct_k is not None and abs(out.cct_k - TRUE_CCT_K) < CCT_TOLERANCE_K, (case.name, out.cct_k)


@pytest.mark.slow  # `runs`: every case built and run through CLI children (~1 min)
@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_cli(runs: dict[str, Run], case: Case) -> None:
    out = _run(runs, case).cli
    assert out is not None
    assert not any("Traceback" in line for line in out.stderr_lines), "\n".join(out.stderr_lines)
    assert out.files_after == [], f"files left behind: {out.files_after}"
    expect = case.expected("cli")
    if expect.error is not None:
        assert out.exit_code == 2, (out.exit_code, out.stderr_lines, out.stdout[-500:])
        assert len(out.stderr_lines) == 1 and out.stderr_lines[0].startswith("error: "), out.stderr_lines
        assert all(w in out.stderr_lines[0] for w in expect.words), out.stderr_lines[0]
        assert out.stdout == ""
        photo = str(runs[case.name].photo)
        assert not out.stderr_lines[0].startswith(f"error: {photo}: {photo}"), "the path is said twice"
    else:
        assert out.exit_code == 0, out.stderr_lines
        assert out.stderr_lines == []
        assert len(out.stdout.strip().splitlines()) == 1
        _check_result(case, out, "cli")
    assert hostile.judge(case, out, "cli") == (True, "")  # the report's verdict is this test's


@pytest.mark.slow
@pytest.mark.parametrize("case", [c for c in CASES if c.in_process], ids=lambda c: c.name)
def test_estimate_photo(runs: dict[str, Run], case: Case) -> None:
    out = _run(runs, case).in_process
    assert out is not None
    assert not out.unexpected, f"{case.name} raised {out.message}"
    if case.expect.error is not None:
        assert not out.ok, f"{case.name}: expected {case.expect.error.__name__}, got a result {out.warnings}"
        assert out.error_class is not None and issubclass(out.error_class, case.expect.error), out.error_type
        assert all(w in out.message for w in case.expect.words), out.message
    else:
        assert out.ok, f"{case.name}: {out.error_type}: {out.message}"
        _check_result(case, out, "api")
    assert hostile.judge(case, out, "api") == (True, "")


def test_every_category_is_covered() -> None:
    """The catalogue keeps the issue's list: files, formats, exposure, content, model, output
    (and preset files, which the CLI and the API also take from users)."""
    categories = {c.category for c in CASES}
    assert categories == {"file", "format", "exposure", "content", "model", "preset", "output"}
    assert {"empty-file", "truncated-jpeg", "text-as-png", "one-pixel", "bomb-png", "greyscale", "png-16bit",
            "cmyk-jpeg", "tiff-16bit", "exr-nan-inf-negative", "all-black", "all-white", "pure-noise", "no-disc",
            "disc-cut-by-frame", "disc-off-centre", "model-garbage-bytes", "model-layout-mismatch",
            "output-read-only", "non-ascii-path"} <= set(BY_NAME)


# --- memory ----------------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.parametrize("name", BOMBS)
def test_bomb_is_refused_before_decoding_in_bounded_memory(runs: dict[str, Run], name: str) -> None:
    run = _run(runs, BY_NAME[name])
    tracemalloc.start()
    try:
        with pytest.raises(PhotoError, match="megapixels"):
            estimate_photo(run.photo, model=None)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 5 * 2**20, f"{peak / 2**20:.1f} MB allocated for a refused header"
    if run.cli is not None and run.cli.peak_rss_mb is not None:  # Linux: the child's own VmHWM
        assert run.cli.peak_rss_mb < CLI_PEAK_RSS_MB, run.cli.peak_rss_mb


def test_unexpected_exceptions_are_recorded_not_hidden(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The harness would notice a non-CDSpectraError (it is not vacuous)."""
    from cd_spectra_addon.core.inverse import estimate

    def broken(*args: object, **kw: object) -> None:
        raise IndexError("boom")

    monkeypatch.setattr(estimate, "estimate_photo", broken)
    out = hostile.run_in_process(BY_NAME["all-black"], tmp_path / "x.jpg", None)
    assert out.unexpected and "IndexError" in out.error_type


# --- Blender: the operators change nothing on failure ---------------------------------------

BLENDER_CASES = [c for c in CASES if c.blender]


@pytest.fixture
def blender_addon(request: pytest.FixtureRequest) -> Installed:
    """The installed add-on (bpy imported first: addon_utils comes with it)."""
    import bpy  # noqa: F401
    return request.getfixturevalue("addon")


def _blender_case(case: Case, run: Run, installed: Installed, monkeypatch: pytest.MonkeyPatch) -> None:
    """Point the installed add-on's estimator at what the case needs, and its Preset at the
    geometry the photos are rendered in (the panel's default is a buildable set-up, not it; the
    ``addon`` fixture's fresh startup file puts the default back afterwards)."""
    import bpy

    bpy.context.scene.cd_spectra.preset = hostile.REFERENCE_PRESET
    model = installed.sub("cd_spectra_addon.core.spectrum.model")
    monkeypatch.setattr(model, "_CACHE", {})
    if run.model_dir is not None:
        monkeypatch.setattr(model, "MODEL_DIR", run.model_dir)


@pytest.mark.blender
@pytest.mark.parametrize("case", BLENDER_CASES, ids=lambda c: c.name)
def test_blender_estimate_operator(blender_addon: Installed, runs: dict[str, Run], case: Case,
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import bpy

    run = _run(runs, case)
    _blender_case(case, run, blender_addon, monkeypatch)
    before, settings_before = datablock_snapshot(), scene_snapshot()
    if case.expect.error is not None:
        with pytest.raises(RuntimeError) as info:  # what bpy.ops raises for a reported ERROR
            bpy.ops.cd_spectra.estimate_spd(filepath=str(run.photo))
        assert all(w in str(info.value) for w in case.expect.words), str(info.value)
        assert "Traceback" not in str(info.value)
        assert datablock_snapshot() == before
        assert scene_snapshot() == settings_before
        assert bpy.context.scene.cd_spectra.photo_path == ""
    else:
        assert bpy.ops.cd_spectra.estimate_spd(filepath=str(run.photo)) == {"FINISHED"}
        after = datablock_snapshot()
        assert {k: v for k, v in after.items() if k != "node_groups"} == \
            {k: v for k, v in before.items() if k != "node_groups"}
        assert len(after["node_groups"]) == len(before["node_groups"]) + 1  # the estimate's group only
        data = json.loads(bpy.context.scene.cd_spectra.estimate_json)
        assert data["source"] == str(run.photo) and np.all(np.isfinite(data["spd"]))


@pytest.mark.blender
def test_blender_float_tiff_goes_through_blenders_loader(blender_addon: Installed, runs: dict[str, Run],
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """The case the CLI must refuse (Pillow cannot read float TIFF) works inside Blender, and the
    loader's temporary image data-block is gone afterwards."""
    import bpy

    case = BY_NAME["tiff-float"]
    run = _run(runs, case)
    _blender_case(case, run, blender_addon, monkeypatch)
    before = datablock_snapshot()
    assert bpy.ops.cd_spectra.estimate_spd(filepath=str(run.photo)) == {"FINISHED"}
    after = datablock_snapshot()
    assert after["images"] == before["images"]
    assert len(after["node_groups"]) == len(before["node_groups"]) + 1


@pytest.mark.blender
def test_blender_export_to_unwritable_folder_writes_nothing(blender_addon: Installed, tmp_path: Path) -> None:
    import bpy

    formats = blender_addon.sub("cd_spectra_addon.blender.spectra_io").export_formats()
    folder = hostile.unwritable_folder(tmp_path)
    assert formats, "the add-on offers no export format"
    assert folder is not None, "no folder this process cannot write (as root: /sys)"
    blender_addon.sub("cd_spectra_addon.blender.state").store_estimate(bpy.context.scene.cd_spectra,
                                                              fake_estimate(blackbody_spd(3000.0)))
    before = datablock_snapshot()
    listing = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    for fmt in formats:
        with pytest.raises(RuntimeError):
            bpy.ops.cd_spectra.export_spd(filepath=str(folder / f"lamp{fmt.extension}"), file_format=fmt.identifier)
    assert datablock_snapshot() == before
    assert sorted(p.name for p in folder.iterdir()) == listing


def test_cli_error_line_without_the_harness(tmp_path: Path) -> None:
    """One real `python -m cd_spectra_addon` run (no stand-ins) on a hostile file."""
    import subprocess

    bad = tmp_path / "notes.png"
    bad.write_text("not a photo\n" * 10)
    proc = subprocess.run([sys.executable, "-m", "cd_spectra_addon", "estimate", str(bad), "--json",
                           str(tmp_path / "out.json")], capture_output=True, text=True, cwd=hostile.ROOT,
                          env={"PYTHONPATH": str(hostile.ROOT), "PATH": "/usr/bin:/bin"}, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.splitlines() == [f"error: {bad}: not an image, the file contains text "
                                        "(supported: JPEG, HEIC/HEIF, PNG, TIFF, OpenEXR, GIF and camera raw (CR2, CR3, NEF, "
                                        "ARW, RAF, ORF, RW2, DNG, ...))"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.png"]


def test_cdspectra_error_is_the_only_kind_users_see() -> None:
    assert all(issubclass(c.expect.error, CDSpectraError) for c in CASES if c.expect.error is not None)


@pytest.mark.blender
@pytest.mark.parametrize("operator", ["create_light", "apply_to_light"])
@pytest.mark.parametrize("where", ["wiring the light", "filling the node group"])
def test_blender_failure_half_way_leaves_nothing(blender_addon: Installed, monkeypatch: pytest.MonkeyPatch,
                                                 operator: str, where: str) -> None:
    """An exception inside Blender half-way through (not bad input: a bpy error) leaves no light,
    object or node group behind and does not change the selected light."""
    import bpy

    light_mod = blender_addon.sub("cd_spectra_addon.blender.light")
    group_mod = blender_addon.sub("cd_spectra_addon.blender.node_group")
    blender_addon.sub("cd_spectra_addon.blender.state").store_estimate(bpy.context.scene.cd_spectra,
                                                                      fake_estimate(blackbody_spd(3300.0)))
    if operator == "apply_to_light":
        bpy.ops.object.light_add(type="POINT")
    target = bpy.context.object
    colour = tuple(target.data.color) if operator == "apply_to_light" else None

    def boom(*args: object, **kw: object) -> None:
        raise RuntimeError("injected failure")

    monkeypatch.setattr(light_mod if where == "wiring the light" else group_mod,
                        "_wire" if where == "wiring the light" else "_fill", boom)
    before = datablock_snapshot()
    with pytest.raises(RuntimeError, match="injected failure"):
        getattr(bpy.ops.cd_spectra, operator)()
    assert datablock_snapshot() == before
    if colour is not None:
        assert tuple(target.data.color) == colour
        assert not [k for k in target.data.keys() if k.startswith("cd_spectra")]
