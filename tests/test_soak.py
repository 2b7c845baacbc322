"""Nothing accumulates: memory over many estimates, data-blocks over many add-on cycles.

``python -m training.reliability.soak --n 1000`` is the full soak (bench/reliability.md); here a short run
in a child process must keep its resident memory within 10 % after warm-up, and a leak the
soak is meant to catch must fail it. In headless Blender, enabling/disabling the add-on and
estimate → create-light cycles must not add a data-block, handler or decoder per cycle.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from extension_support import (  # noqa: F401  (pytest fixtures)
    ADDON_MODULE, Installed, addon, datablock_snapshot, installed_addon,
)
from training.reliability import soak
from training.simulation.photo import write_photo

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_short_soak_keeps_memory_flat(tmp_path: Path) -> None:
    out = tmp_path / "soak.json"
    proc = subprocess.run([sys.executable, "-m", "training.reliability.soak", "--n", "48", "--warmup", "12", "--json", str(out)],
                          capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)},
                          timeout=300)
    assert out.is_file(), proc.stderr[-3000:]
    report = json.loads(out.read_text())
    print(proc.stderr.strip().splitlines()[-1])
    assert report["unexpected"] == []
    assert report["outcomes"] == {"results": 30, "errors": 30}  # 3 good, 3 bad inputs, 60 runs
    assert report["growth"] < soak.GROWTH_BAR, report["rss_samples_mb"]
    assert proc.returncode == 0


@pytest.mark.slow
def test_soak_catches_a_leak(monkeypatch: pytest.MonkeyPatch) -> None:
    """An estimator that keeps 4 MB per call fails the bar (the measurement is not vacuous)."""
    from cd_spectra_addon.core.inverse import estimate
    from cd_spectra_addon.core.errors import PhotoError

    kept: list[np.ndarray] = []

    def leaky(path: object, **kw: object) -> None:
        kept.append(np.ones(2**19))  # 4 MB, touched so it is resident
        raise PhotoError("leaky stand-in")

    monkeypatch.setattr(estimate, "estimate_photo", leaky)
    report = soak.soak(n=60, warmup=5, size=64)
    assert report["growth"] > soak.GROWTH_BAR, report
    kept.clear()


# --- Blender ---------------------------------------------------------------------------------


@pytest.fixture
def blender_addon(request: pytest.FixtureRequest) -> Installed:
    import bpy  # noqa: F401  (before the add-on: addon_utils comes with it)

    return request.getfixturevalue("addon")


def _decoders(installed: Installed) -> int:
    return len(installed.sub("cd_spectra_addon.core.photo.decoders").registered_decoders())


@pytest.mark.blender
def test_enable_disable_cycles_leave_nothing_behind(blender_addon: Installed) -> None:
    import addon_utils
    import bpy

    handlers = {n: len(getattr(bpy.app.handlers, n)) for n in dir(bpy.app.handlers)
                if isinstance(getattr(bpy.app.handlers, n), list)}
    before = datablock_snapshot()
    types_before = sorted(n for n in dir(bpy.types) if n.startswith(("CDSPECTRA_", "CDSpectra")))
    assert _decoders(blender_addon) == 1
    for _ in range(10):
        addon_utils.disable(ADDON_MODULE)
        assert not hasattr(bpy.types.Scene, "cd_spectra")
        addon_utils.enable(ADDON_MODULE, default_set=True)
        assert hasattr(bpy.types.Scene, "cd_spectra")
    assert datablock_snapshot() == before
    assert sorted(n for n in dir(bpy.types) if n.startswith(("CDSPECTRA_", "CDSpectra"))) == types_before
    assert {n: len(getattr(bpy.app.handlers, n)) for n in handlers} == handlers
    assert _decoders(blender_addon) == 1  # Blender's loader registered once, not once per enable


@pytest.mark.blender
def test_estimate_and_create_light_cycles_add_only_what_they_make(blender_addon: Installed, tmp_path: Path) -> None:
    import bpy

    from training.reliability.hostile import REFERENCE_PRESET, make_base

    base = make_base(128)
    bpy.context.scene.cd_spectra.preset = REFERENCE_PRESET  # the photos' geometry; a fresh file follows
    photos = []
    for k, gain in enumerate((1.0, 0.6)):  # two photos, two SPDs: at most two node groups
        path = tmp_path / f"cd{k}.png"
        write_photo(path, base.linear * gain * (1.0, 0.8 + 0.2 * k, 1.0), "png", base.exif)
        photos.append(path)
    before = datablock_snapshot()
    cycles = 8
    for i in range(cycles):
        assert bpy.ops.cd_spectra.estimate_spd(filepath=str(photos[i % 2])) == {"FINISHED"}
        assert bpy.ops.cd_spectra.create_light(light_type="POINT") == {"FINISHED"}
    after = datablock_snapshot()
    grown = {k: len(after[k]) - len(before[k]) for k in after if len(after[k]) != len(before[k])}
    assert grown == {"objects": cycles, "lights": cycles, "node_groups": 2}, grown
    for obj in [o for o in bpy.data.objects if o.name not in before["objects"]]:
        light = obj.data
        bpy.data.objects.remove(obj)
        bpy.data.lights.remove(light)
    for group in [g for g in bpy.data.node_groups if g.name not in before["node_groups"]]:
        bpy.data.node_groups.remove(group)
    assert datablock_snapshot() == before  # nothing else was made along the way (images, trees, ...)
