"""The extension manifest, judged by Blender's own extension tool, and the build script's rules.

Blender's tool (``blender_ext.py``, shipped in the bpy wheel) is what ``blender --command extension
validate`` and extensions.blender.org run; it is a plain script, so no Blender session is needed.
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
MANIFEST_TEXT = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
MANIFEST = tomllib.loads(MANIFEST_TEXT)

sys.path.insert(0, str(ROOT))
from tools import build_extension  # noqa: E402
from tools.build_extension import ADDON_TOP  # noqa: E402

sys.path.remove(str(ROOT))


def _blender_tags_file() -> Path:
    """The tag list Blender validates against (what ``blender --command extension`` passes)."""
    return build_extension.blender_ext_script().parents[3] / "modules" / "_bpy_internal" / "extensions" / "tags.py"


@pytest.fixture(scope="module")
def blender_ext() -> ModuleType:
    spec = importlib.util.spec_from_file_location("blender_ext", build_extension.blender_ext_script())
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _errors(blender_ext: ModuleType, manifest: dict[str, Any]) -> list[str]:
    """Blender's complaints about a manifest (fields and tags), empty when it would install."""
    result = blender_ext.pkg_manifest_from_dict_and_validate_all_errros(manifest, from_repo=False, strict=True)
    errors = list(result) if isinstance(result, list) else []
    tags = blender_ext.pkg_manifest_tags_load_valid_map(str(_blender_tags_file()))
    assert isinstance(tags, dict), tags
    if (error := blender_ext.pkg_manifest_tags_valid_or_error(tags, manifest["type"], manifest.get("tags"))):
        errors.append(error)
    return errors


def _validate_cli(path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, str(build_extension.blender_ext_script()), "validate", str(path),
                           "--valid-tags", str(_blender_tags_file())], capture_output=True, text=True, timeout=120)


def test_source_manifest_passes_blenders_validator() -> None:
    proc = _validate_cli(ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize("field, value, complaint", [
    ("version", "0.1", "semantic-version"),
    ("tagline", "A lamp's spectrum from one photo of a CD.", "punctuation"),
    ("tags", ["Lighting", "Spectra"], "Spectra"),
    ("blender_version_min", "4.2", "blender_version_min"),
])
def test_blenders_validator_refuses_a_broken_copy(blender_ext: ModuleType, field: str, value: Any,
                                                  complaint: str) -> None:
    """The check above can fail: the same validator on the manifest with one field broken."""
    assert _errors(blender_ext, MANIFEST) == []
    errors = _errors(blender_ext, dict(MANIFEST, **{field: value}))
    assert any(complaint in e for e in errors), errors


def test_one_version_everywhere() -> None:
    """The manifest, pyproject and the package say the same version (a release bumps all three)."""
    import cd_spectra_addon

    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert MANIFEST["version"] == pyproject["project"]["version"] == cd_spectra_addon.__version__


def test_the_blender_we_test_with_is_in_its_builds_range(blender_ext: ModuleType) -> None:
    """bpy 4.5 (3.11) falls in the 4.2–5.0 build's range, bpy 5.2 (3.13) in the 5.1+ build's."""
    spec = build_extension.build_for_python()
    tested = tuple(int(p) for p in importlib.metadata.version("bpy").split(".")[:3])
    low = blender_ext.blender_version_parse_or_error(spec.blender_min)
    assert low <= tested, (low, tested)
    if spec.blender_max is not None:  # exclusive
        assert tested < blender_ext.blender_version_parse_or_error(spec.blender_max), (tested, spec.blender_max)


def test_build_makes_a_zip_for_every_declared_platform() -> None:
    assert {p.blender for p in build_extension.BLENDER_42.platforms} == set(MANIFEST["platforms"])


def test_a_stray_file_in_the_checkout_is_not_staged() -> None:
    """The stage copies the add-on's own files only: a clean-clone CI run once wrote its log at the
    repository's root, and the build (which copies what git would track) put it in the zip."""
    stray = [ROOT / "log", ROOT / "IMG_0001.JPG", ROOT / "notes" / "lamp.txt", ROOT / "samples" / "cd_photo.jpg",
             ROOT / "training" / "__init__.py"]
    addon = [ROOT / "__init__.py", ROOT / "blender_manifest.toml", ROOT / "README.md",
             ROOT / "cd_spectra_addon" / "__init__.py", ROOT / "models" / "cd_spectra.onnx"]
    assert build_extension.addon_files(stray + addon) == addon


def test_exactly_the_addon_ships(blender_ext: ModuleType) -> None:
    """Blender's own exclude matching over the files the build stages: the add-on and its model
    go in, whole; training, tests, tools, benches and samples stay out."""
    excluded = blender_ext.PathPatternMatch(MANIFEST["build"]["paths_exclude_pattern"])

    def ships(rel: str) -> bool:  # as blender_ext's build walks: a folder excluded prunes its files
        parts = rel.split("/")
        return not any(excluded.test_path("/".join(parts[:i]) + "/") for i in range(1, len(parts))) \
            and not excluded.test_path(rel)

    tracked = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout
    # a build straight from the checkout (Blender's tool on the repository) ships no more than the add-on
    assert {f.split("/")[0] for f in tracked.decode().split("\0") if f and ships(f)} <= ADDON_TOP
    files = [p.relative_to(ROOT).as_posix() for p in build_extension.addon_files(build_extension.source_files())]
    shipped = {f for f in files if ships(f)}
    must = {f for f in files if f.split("/")[0] in {"cd_spectra_addon", "models"} and "__pycache__" not in f}
    assert must <= shipped, sorted(must - shipped)
    assert {"__init__.py", "blender_manifest.toml", "models/cd_spectra.onnx"} <= shipped


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(v) for v in text.split("."))


def test_pins_never_bundle_numpy_and_keep_windows_loadable() -> None:
    for spec in build_extension.BUILDS:
        assert not any(name.lower().startswith("numpy") for name in spec.pins), spec.name
        assert set(spec.pins) == {"onnxruntime", "pillow", "openexr", "rawpy", "pillow-heif"}, spec.name
        for package, versions in spec.pins.items():
            assert set(versions) == {p.blender for p in spec.platforms}, (spec.name, package)
    # Blender 4.2-5.0 on Windows bundle a VC++ runtime that onnxruntime 1.19+ cannot load with.
    assert _version(build_extension.BLENDER_42.pins["onnxruntime"]["windows-x64"]) < (1, 19)
    assert not build_extension.wheel_name_ok("numpy-1.26.4-cp311-cp311-win_amd64.whl")
    assert build_extension.wheel_name_ok("onnxruntime-1.18.1-cp311-cp311-win_amd64.whl")


def test_builds_split_blender_by_python_without_overlap() -> None:
    old, new = build_extension.BLENDER_42, build_extension.BLENDER_51
    assert (old.python, new.python) == ("3.11", "3.13")
    assert old.blender_min == MANIFEST["blender_version_min"] == "4.2.0"
    assert old.blender_max == new.blender_min == "5.1.0"  # max is exclusive: 5.1.0 is the new build's
    assert new.blender_max is None
    assert "macos-x64" not in {p.blender for p in new.platforms}  # no Intel-Mac Blender since 5.0
    assert build_extension.build_for_python("3.11") is old
    assert build_extension.build_for_python("3.13") is new
    with pytest.raises(SystemExit):
        build_extension.build_for_python("3.12")


def test_committed_manifest_is_the_first_builds() -> None:
    assert MANIFEST["blender_version_max"] == "5.1.0"  # 5.1 is Python 3.13: cp311 wheels fail
    assert set(MANIFEST["platforms"]) == {p.blender for p in build_extension.BLENDER_42.platforms}


@pytest.mark.parametrize("spec", build_extension.BUILDS, ids=lambda b: b.name)
def test_build_copy_gets_its_range_platforms_and_wheels(spec: build_extension.Build) -> None:
    text = MANIFEST_TEXT
    tag = "cp" + spec.python.replace(".", "")
    names = [f"onnxruntime-1.0.0-{tag}-{tag}-win_amd64.whl", f"pillow-13.0.0-{tag}-{tag}-win_amd64.whl"]
    built = tomllib.loads(build_extension.manifest_for(text, spec, names))
    assert built["wheels"] == [f"./wheels/{n}" for n in names]
    assert built["blender_version_min"] == spec.blender_min
    assert built.get("blender_version_max") == spec.blender_max
    assert built["platforms"] == [p.blender for p in spec.platforms]
    changed = {"wheels", "blender_version_min", "blender_version_max", "platforms"}
    assert {k: v for k, v in built.items() if k not in changed} == {
        k: v for k, v in MANIFEST.items() if k not in changed}


@pytest.mark.parametrize("spec", build_extension.BUILDS, ids=lambda b: b.name)
def test_each_build_copy_passes_blenders_validator(spec: build_extension.Build, blender_ext: ModuleType) -> None:
    """The committed manifest lists no wheels (they are not in git; the build writes them in)."""
    assert MANIFEST["wheels"] == []
    tag = "cp" + spec.python.replace(".", "")
    built = tomllib.loads(build_extension.manifest_for(MANIFEST_TEXT, spec, [f"onnxruntime-1.0.0-{tag}-{tag}-win_amd64.whl"]))
    assert _errors(blender_ext, built) == []


SPEC = build_extension.build_for_python()  # this Python's build: its tool validates, its tag fits
TAG = build_extension.python_tag(SPEC)
LINUX = build_extension.LINUX.blender


def _fake_wheel(folder: Path, name: str) -> Path:
    """A tiny wheel-named zip: Blender's tool and the check read wheel names, not their code."""
    path = folder / name
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr(name.split("-")[0] + "/__init__.py", "")
    return path


def _zip(path: Path, manifest: str, held: list[str]) -> Path:
    """A built zip in miniature: the manifest and the wheels it holds."""
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("blender_manifest.toml", manifest)
        zf.writestr("__init__.py", "")
        for name in held:
            zf.writestr(f"wheels/{name}", b"")
    return path


ONNX = f"onnxruntime-1.0.0-{TAG}-{TAG}-manylinux_2_28_x86_64.whl"
PILLOW = f"pillow-13.0.0-{TAG}-{TAG}-manylinux_2_28_x86_64.whl"
PILLOW_WIN = f"pillow-13.0.0-{TAG}-{TAG}-win_amd64.whl"
# What `blender_ext.py build --split-platforms` made before (issue 18): every platform's wheels in
# `wheels`, this zip's only in the [build.generated] table it appends.
SPLIT_TAIL = f'\n[build.generated]\nplatforms = ["{LINUX}"]\nwheels = ["./wheels/{ONNX}", "./wheels/{PILLOW}"]\n'


def _manifest(wheels: list[str], platforms: tuple[build_extension.Platform, ...] = (build_extension.LINUX,)) -> str:
    return build_extension.manifest_for(MANIFEST_TEXT, SPEC, wheels, platforms)


@pytest.mark.parametrize("manifest, held, complaint", [
    (_manifest([ONNX, PILLOW, PILLOW_WIN]), [ONNX, PILLOW], "wheels the zip lacks: ['wheels/" + PILLOW_WIN),
    (_manifest([ONNX]), [ONNX, PILLOW], "does not list: ['wheels/" + PILLOW),
    (_manifest([ONNX, PILLOW, PILLOW_WIN], SPEC.platforms) + SPLIT_TAIL, [ONNX, PILLOW],
     "wheels the zip lacks: ['wheels/" + PILLOW_WIN),
    (_manifest([ONNX, PILLOW], SPEC.platforms), [ONNX, PILLOW], "platforms is ["),
    (_manifest([ONNX, f"numpy-2.0.0-{TAG}-{TAG}-manylinux_2_28_x86_64.whl"]),
     [ONNX, f"numpy-2.0.0-{TAG}-{TAG}-manylinux_2_28_x86_64.whl"], "bundles numpy"),
    (_manifest([ONNX, "pillow-13.0.0-cp310-cp310-win_amd64.whl"]), [ONNX, "pillow-13.0.0-cp310-cp310-win_amd64.whl"],
     f"not for {TAG}"),
], ids=["lists-a-wheel-it-lacks", "holds-an-unlisted-wheel", "split-platforms-manifest", "other-platforms",
        "numpy", "other-python"])
def test_the_build_check_refuses_a_zip_that_misleads_blender(tmp_path: Path, manifest: str, held: list[str],
                                                             complaint: str) -> None:
    good = _zip(tmp_path / "good.zip", _manifest([ONNX, PILLOW]), [ONNX, PILLOW])
    assert build_extension.zip_problems(good, TAG, LINUX) == []
    build_extension.check_zip(good, TAG, LINUX)
    bad = _zip(tmp_path / "bad.zip", manifest, held)
    problems = build_extension.zip_problems(bad, TAG, LINUX)
    assert any(complaint in p for p in problems), problems
    with pytest.raises(SystemExit, match="bad.zip"):
        build_extension.check_zip(bad, TAG, LINUX)


def test_a_built_zip_lists_exactly_the_wheels_it_holds(tmp_path: Path) -> None:
    """Stage, Blender's build and the check, as `make extension` runs them for one platform (issue 18:
    a zip's manifest listed 14 wheels of other platforms), from tiny wheels: no network."""
    wheels = [_fake_wheel(tmp_path, n) for n in (ONNX, PILLOW)]
    tool = [(build_extension.blender_ext_script(), None)]
    out = build_extension.build_platform_zip(tool, wheels, SPEC, build_extension.LINUX, tmp_path / "stage",
                                             tmp_path / "linux.zip")
    with zipfile.ZipFile(out) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
        held = sorted(n for n in zf.namelist() if n.endswith(".whl"))
        tops = {n.split("/")[0] for n in zf.namelist()}
    assert held == [f"wheels/{ONNX}", f"wheels/{PILLOW}"]
    assert tops <= ADDON_TOP | {"wheels"}, sorted(tops)  # whatever else lies in the checkout
    assert manifest["wheels"] == [f"./{n}" for n in held]
    assert manifest["platforms"] == [LINUX] and "generated" not in manifest["build"]
    assert build_extension.zip_problems(out, TAG, LINUX) == []


def test_the_build_stops_on_a_zip_it_must_not_ship(tmp_path: Path) -> None:
    """The check runs inside the build: a numpy wheel gets into Blender's zip, and the build fails."""
    numpy = _fake_wheel(tmp_path, f"numpy-2.0.0-{TAG}-{TAG}-manylinux_2_28_x86_64.whl")
    tool = [(build_extension.blender_ext_script(), None)]
    with pytest.raises(SystemExit, match="bundles numpy"):
        build_extension.build_platform_zip(tool, [numpy], SPEC, build_extension.LINUX, tmp_path / "stage",
                                           tmp_path / "linux.zip")
