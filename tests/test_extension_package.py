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
    assert MANIFEST["blender_version_max"] == "5.1.0"  # 5.1 is Python 3.13: cp311 wheels fail
    assert MANIFEST["permissions"] == {"files": "Read CD photos and write spectra and calibration profiles"}
    assert set(MANIFEST["platforms"]) == {"linux-x64", "windows-x64", "macos-arm64", "macos-x64"}
    assert MANIFEST["license"] == ["SPDX:GPL-3.0-or-later"]
    assert MANIFEST["wheels"] == []  # filled only in the build copy


def test_manifest_excludes_everything_that_does_not_ship() -> None:
    patterns = set(MANIFEST["build"]["paths_exclude_pattern"])
    for required in ("/training/", "/tests/", "/bench/", "/data/", "/out/", "/samples/", "/tools/",
                     "/build/", "/dist/", "/wheels/", ".*", "__pycache__/"):
        assert required in patterns


def test_pins_never_bundle_numpy_and_keep_windows_loadable() -> None:
    assert not any(name.lower().startswith("numpy") for name in build_extension.PINS)
    assert set(build_extension.PINS) == {"onnxruntime", "pillow", "openexr"}
    for package, versions in build_extension.PINS.items():
        assert set(versions) == {p.blender for p in build_extension.PLATFORMS}, package
    windows_ort = tuple(int(v) for v in build_extension.PINS["onnxruntime"]["windows-x64"].split("."))
    assert windows_ort < (1, 19), "onnxruntime 1.19+ does not load in Blender on Windows (see README)"
    assert not build_extension.wheel_name_ok("numpy-1.26.4-cp311-cp311-win_amd64.whl")
    assert build_extension.wheel_name_ok("onnxruntime-1.18.1-cp311-cp311-win_amd64.whl")


def test_wheel_list_is_written_into_the_build_copy() -> None:
    text = (ROOT / "blender_manifest.toml").read_text(encoding="utf-8")
    names = ["onnxruntime-1.18.1-cp311-cp311-win_amd64.whl", "pillow-13.0.0-cp311-cp311-win_amd64.whl"]
    built = tomllib.loads(build_extension.manifest_with_wheels(text, names))
    assert built["wheels"] == [f"./wheels/{n}" for n in names]
    assert {k: v for k, v in built.items() if k != "wheels"} == {k: v for k, v in MANIFEST.items() if k != "wheels"}


@pytest.mark.blender
def test_source_manifest_validates_with_blenders_tool() -> None:
    script = build_extension.blender_ext_script()
    proc = subprocess.run([sys.executable, str(script), "validate", str(ROOT)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
