"""Fixtures for tests of the installed extension in headless Blender (the bpy wheel).

The add-on is tested the way users get it: the zip is built with Blender's own tool (without
wheels: onnxruntime, Pillow and OpenEXR come from the venv here; Blender would install a zip's
wheels into the user's shared ``extensions/.local`` site-packages, outside the temporary
repository, and the venv's copies would shadow them anyway), validated, and installed with
``bpy.ops.extensions.package_install_files`` into a temporary user repository, so it runs as
``bl_ext.<repo>.cd_spectra`` with relative imports, exactly as in Blender. Each test starts
from a fresh startup file (MolecularNodes' tests/conftest.py does the same).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, Iterator

import pytest

ROOT = Path(__file__).resolve().parents[1]
REPO_MODULE = "cd_spectra_test"
ADDON_MODULE = f"bl_ext.{REPO_MODULE}.cd_spectra"


@dataclass(frozen=True)
class Installed:
    module: str  # the add-on's Python package name inside Blender
    package: ModuleType  # that package (the zip's root __init__.py)
    zip_path: Path
    repo_dir: Path
    report: dict[str, Any]

    def sub(self, name: str) -> ModuleType:
        """A sub-module of the installed add-on, e.g. ``cd_spectra_addon.blender.node_group``."""
        return importlib.import_module(f"{self.module}.{name}")


def build_test_zip(out_dir: Path) -> dict[str, Any]:
    sys.path.insert(0, str(ROOT))
    try:
        from tools.build_extension import build, build_for_python
    finally:
        sys.path.remove(str(ROOT))
    return build(out_dir / "dist", out_dir / "stage", wheels=False, builds=(build_for_python(),))


@pytest.fixture(scope="module")
def installed_addon(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Installed]:
    import addon_utils
    import bpy

    work = tmp_path_factory.mktemp("extension")
    report = build_test_zip(work)
    zip_path = Path(report["this_platform_zip"])
    repo_dir = work / "user_repo"
    repo_dir.mkdir()
    repos = bpy.context.preferences.extensions.repos
    repos.new(name="CD Spectra tests", module=REPO_MODULE, custom_directory=str(repo_dir), source="USER")
    try:
        result = bpy.ops.extensions.package_install_files(
            filepath=str(zip_path), repo=REPO_MODULE, enable_on_install=True)
        assert result == {"FINISHED"}, result
        assert ADDON_MODULE in bpy.context.preferences.addons
        yield Installed(ADDON_MODULE, importlib.import_module(ADDON_MODULE), zip_path, repo_dir, report)
    finally:
        if addon_utils.check(ADDON_MODULE)[1]:
            addon_utils.disable(ADDON_MODULE, default_set=True)
        # Other code may have reset the preferences (read_factory_settings): look the repo up again.
        for candidate in list(repos):
            if candidate.module == REPO_MODULE:
                repos.remove(candidate)


@pytest.fixture
def addon(installed_addon: Installed) -> Iterator[Installed]:
    """The add-on, enabled, in a fresh startup file (and the file reset again afterwards)."""
    import addon_utils
    import bpy

    if not addon_utils.check(ADDON_MODULE)[1]:
        addon_utils.enable(ADDON_MODULE, default_set=True)
    bpy.ops.wm.read_homefile(app_template="")
    yield installed_addon
    bpy.ops.wm.read_homefile(app_template="")


def blackbody_spd(temperature_k: float) -> list[float]:
    """Planck's law on the product grid, peak 1 (a test light with a known colour)."""
    import numpy as np

    wl = np.arange(380.0, 781.0, 5.0) * 1e-9
    c2 = 1.4388e-2
    spd = 1.0 / (wl**5 * (np.exp(c2 / (wl * temperature_k)) - 1.0))
    return list(spd / spd.max())


def fake_estimate(spd: list[float], **extra: Any) -> dict[str, Any]:
    """An estimate as Estimate.to_json() gives it, for tests of everything after the estimator
    (its colour rendition computed by the core from the SPD and a 0.01 uncertainty; none for an
    SPD the core refuses, as the tests of bad estimates hand the add-on)."""
    from cd_spectra_addon.core.errors import CDSpectraError
    from cd_spectra_addon.core.rendition.result import rendition

    try:
        figures = rendition(list(spd), [0.01] * 81)
    except CDSpectraError:
        figures = None

    return {
        "source": "/photos/cd_under_lamp.jpg",
        "wavelength_nm": [380.0 + 5.0 * i for i in range(81)],
        "spd": list(spd),
        "spd_std": [0.01] * 81,
        "xy": [0.4476, 0.4074],
        "cct_k": 2856.0,
        "duv": 0.0,
        "rgb_scene_linear": [1.0, 0.7, 0.4],
        "working_space": "Linear Rec.709",
        "confidence": 0.83,
        "warnings": ["Some highlights were over-exposed and ignored; a shorter exposure would help."],
        "disc": {"center_px": [256.0, 256.0], "radius_px": 200.0, "hole_radius_px": 25.0,
                 "axis_ratio": 1.0, "angle_deg": 0.0, "px_per_mm": 3.3},
        "timing_ms": {"total": 12.0},
        "preset": "cd-default",
        "camera": "Canon_EOS_5D_Mark_III",
        "calibration": None,
        "model_version": "test-model",
        "rendition": figures,
        **extra,
    }


def scene_snapshot() -> dict[str, Any]:
    """What an operator that failed must not have changed."""
    import bpy

    settings = bpy.context.scene.cd_spectra
    return {
        "objects": sorted(o.name for o in bpy.data.objects),
        "lights": sorted(light.name for light in bpy.data.lights),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "estimate_json": settings.estimate_json,
        "reference_json": settings.reference_json,
        "light_colours": sorted(tuple(round(c, 6) for c in light.color) for light in bpy.data.lights),
    }


def datablock_snapshot() -> dict[str, list[str]]:
    """Every data-block in the file by collection (objects, lights, node groups, images, ...):
    a failed operator must leave this exactly as it was, and a repeated one must not grow it."""
    import bpy

    out: dict[str, list[str]] = {}
    for name in dir(bpy.data):
        if name.startswith("_"):
            continue
        try:
            value = getattr(bpy.data, name)
        except (AttributeError, RuntimeError):
            continue
        if isinstance(value, bpy.types.bpy_prop_collection) and name != "window_managers":
            out[name] = sorted(getattr(item, "name_full", getattr(item, "name", "")) for item in value)
    return out


def run_blender_script(script: str, *args: str, timeout: float = 120.0) -> subprocess.CompletedProcess[str]:
    """Run Python with the bpy wheel in a fresh process (for what must not share this one)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    with tempfile.NamedTemporaryFile("w", suffix=".py", delete=False) as fh:
        fh.write(script)
        path = fh.name
    try:
        return subprocess.run([sys.executable, path, *args], capture_output=True, text=True,
                              timeout=timeout, env=env)
    finally:
        os.unlink(path)


def last_json_line(text: str) -> dict[str, Any]:
    for line in reversed(text.strip().splitlines()):
        if line.startswith("{"):
            return json.loads(line)
    raise AssertionError(f"no JSON line in output:\n{text[-3000:]}")


def render_sample_photo(out_dir: Path, temperature_k: float = 2856.0) -> Path:
    """A synthetic CD photo of a blackbody lamp by ``training.simulation.render_photo`` (numpy engine, 256 px)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    table = out_dir / "lamp.csv"
    wl = [380.0 + 5.0 * i for i in range(81)]
    table.write_text("wavelength_nm,lamp\n" + "".join(
        f"{w},{v}\n" for w, v in zip(wl, blackbody_spd(temperature_k))), encoding="utf-8")
    subprocess.run([sys.executable, "-m", "training.simulation.render_photo", "--spd", str(table), "--out",
                    str(out_dir / "photos"), "--engine", "numpy", "--size", "256", "--format", "png",
                    "--cache-dir", str(out_dir / "cache")], cwd=ROOT, check=True, capture_output=True, timeout=600)
    return out_dir / "photos" / "lamp.png"
