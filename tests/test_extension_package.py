"""The extension manifest and the build script's rules (no Blender session needed)."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MANIFEST = tomllib.loads((ROOT / "blender_manifest.toml").read_text(encoding="utf-8"))

sys.path.insert(0, str(ROOT))
from tools import build_extension  # noqa: E402

sys.path.remove(str(ROOT))


def test_manifest_fields_follow_blenders_rules() -> None:
    import cd_spectra_addon

    assert MANIFEST["schema_version"] == "1.0.0"
    assert MANIFEST["id"] == "cd_spectra"
    assert MANIFEST["name"] == "CD Spectra"
    assert MANIFEST["type"] == "add-on"
    assert MANIFEST["version"] == cd_spectra_addon.__version__
    tagline = MANIFEST["tagline"]
    assert len(tagline) <= 64 and (tagline[-1].isalnum() or tagline[-1] in ")]}")
    assert re.fullmatch(r"\d+\.\d+\.\d+", MANIFEST["blender_version_min"])
    assert MANIFEST["blender_version_min"] == "4.2.0"
    assert MANIFEST["permissions"] == {"files": "Read CD photos and write spectra and calibration profiles"}
    assert MANIFEST["license"] == ["SPDX:GPL-3.0-or-later"]
    assert MANIFEST["wheels"] == []  # filled only in the build copy


def test_manifest_excludes_everything_that_does_not_ship() -> None:
    patterns = set(MANIFEST["build"]["paths_exclude_pattern"])
    for required in ("/training/", "/tests/", "/bench/", "/data/", "/out/", "/samples/", "/tools/",
                     "/build/", "/dist/", "/wheels/", ".*", "__pycache__/"):
        assert required in patterns


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
    text = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
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


@pytest.mark.blender
def test_source_manifest_validates_with_blenders_tool() -> None:
    script = build_extension.blender_ext_script()
    proc = subprocess.run([sys.executable, str(script), "validate", str(ROOT)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
