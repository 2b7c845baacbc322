"""``estimate --joint``: one result from several photos, under the command line's usual rules.

A fake ``core.inverse.joint`` stands in for the estimator (as test_cli.py does for the single
one), so the contract is tested apart from the model; one test runs the real thing.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from cli_runner import run_in_process

ROOT = Path(__file__).resolve().parents[1]

FAKE_JOINT = textwrap.dedent('''
    import sys, types
    import numpy as np
    from cd_spectra_addon.core.errors import PhotoError
    from cd_spectra_addon.core.inverse.result import DiscFit, Estimate
    from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET

    def estimate_joint(paths, *, preset=DEFAULT_PRESET, camera="auto", calibration=None, progress=None, **_):
        for k, path in enumerate(paths):
            if progress is not None:
                progress(k / len(paths), f"photo {k + 1} of {len(paths)}: {path.rsplit('/', 1)[-1]}")
        used = [p for p in paths if "bad" not in p]
        if not used:
            raise PhotoError(f"none of the {len(paths)} photos could be read: " + "; ".join(paths))
        wl = np.arange(380.0, 781.0, 5.0) * 1e-9
        spd = 1.0 / (wl**5 * (np.exp(1.4388e-2 / (wl * 3000.0)) - 1.0))
        photos = [{"source": p, "used": p in used, "refused": None if p in used else "black",
                   "coverage_nm": [[400.0, 550.0]], "held_nm": [[400.0, 552.5]], "brightness": 1.0, "weight": 1.0,
                   "residual": 0.01, "partial": "short" in p or None}
                  for p in paths]
        presets = preset if isinstance(preset, list) else [preset]
        return Estimate(spd=spd / spd.max(), spd_std=np.full(81, 0.01), xy=(0.43, 0.40), cct_k=3000.0, duv=0.0,
                        rgb_scene_linear=(1.0, 0.8, 0.6), confidence=0.9, warnings=["left out bad.jpg: black"],
                        disc=DiscFit((10.0, 10.0), 8.0), timing_ms={"total": 1.0}, source=used[0],
                        preset=", ".join(str(p) for p in presets), camera=camera, calibration=calibration,
                        model_version="fake", extra={"joint": {"given": len(paths), "used": len(used),
                                                               "photos": photos}})

    module = types.ModuleType("cd_spectra_addon.core.inverse.joint")
    module.estimate_joint = estimate_joint
    sys.modules[module.__name__] = module
''')


def run_cli(*args: str, fake: bool = True) -> subprocess.CompletedProcess[str]:
    """The command line with the fake joint estimator in this process (:mod:`cli_runner`); the
    real one in a child ``python -m cd_spectra_addon``."""
    if fake:
        return run_in_process(args, FAKE_JOINT, ROOT, blender_line=False)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "cd_spectra_addon", *args]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)


def _photos(tmp_path: Path, *names: str) -> list[str]:
    for name in names:
        (tmp_path / name).write_bytes(b"not really a photo")
    return [str(tmp_path / name) for name in names]


def test_joint_writes_one_result_with_every_photo(tmp_path: Path) -> None:
    photos = _photos(tmp_path, "a.jpg", "bad.jpg", "short.jpg")
    out = tmp_path / "out.json"
    proc = run_cli("estimate", "--joint", *photos, "--json", str(out), "--progress")
    assert proc.returncode == 0, proc.stderr
    (result,) = json.loads(out.read_text())
    assert [p["source"] for p in result["joint"]["photos"]] == photos
    assert result["joint"]["used"] == 2
    assert proc.stderr.splitlines() == ["[1/3] a.jpg", "[2/3] bad.jpg", "[3/3] short.jpg"]
    assert proc.stdout.splitlines()[0] == "joint estimate from 3 photos (2 used)"
    assert "  bad.jpg: left out" in proc.stdout.splitlines()
    assert "  a.jpg: 400–552 nm, brightness ×1.00, residual 1.0%" in proc.stdout.splitlines()
    assert "  short.jpg: 400–552 nm (too little alone), brightness ×1.00, residual 1.0%" in proc.stdout.splitlines()


def test_joint_json_to_stdout_is_one_line(tmp_path: Path) -> None:
    proc = run_cli("estimate", "--joint", *_photos(tmp_path, "a.jpg", "b.jpg"), "--json", "-")
    assert proc.returncode == 0, proc.stderr
    (line,) = proc.stdout.splitlines()
    assert json.loads(line)["joint"]["given"] == 2


def test_one_preset_per_photo_only_with_joint(tmp_path: Path) -> None:
    photos = _photos(tmp_path, "a.jpg", "b.jpg")
    proc = run_cli("estimate", "--joint", *photos, "--preset", "cd-default", "--preset", "tripod-oblique",
                   "--json", "-")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["preset"] == "cd-default, tripod-oblique"
    for args in (["--preset", "cd-default", "--preset", "tripod-oblique"],
                 ["--joint", "--preset", "cd-default", "--preset", "cd-default", "--preset", "cd-default"]):
        proc = run_cli("estimate", *photos, *args)
        assert proc.returncode == 2 and len(proc.stderr.splitlines()) == 1, proc.stderr
        assert proc.stderr.startswith("error: ") and "--preset" in proc.stderr or "presets" in proc.stderr


def test_an_animated_gif_joins_as_its_frames_with_its_preset(tmp_path: Path) -> None:
    """``--joint a.jpg sweep.gif`` is a.jpg and each of the GIF's frames, one result; with one
    --preset per PHOTO argument, the frames share the GIF's."""
    from gif_writer import Frame, gif_bytes

    (photo,) = _photos(tmp_path, "a.jpg")
    gif = tmp_path / "sweep.gif"
    gif.write_bytes(gif_bytes((70, 64), np.array([[0, 0, 0], [250, 180, 90]], np.uint8),
                              [Frame(np.full((64, 70), 1)) for _ in range(3)]))
    proc = run_cli("estimate", "--joint", photo, str(gif), "--preset", "cd-default", "--preset", "tripod-oblique",
                   "--json", "-", "--progress")
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout)
    assert [p["source"] for p in result["joint"]["photos"]] == [photo, *(f"{gif}#{i}" for i in range(3))]
    assert result["preset"] == "cd-default, tripod-oblique, tripod-oblique, tripod-oblique"
    assert proc.stderr.splitlines()[-1] == "[4/4] sweep.gif#2"


@pytest.mark.parametrize("case", ["missing", "none-read"])
def test_joint_bad_input_exits_2_and_writes_nothing(tmp_path: Path, case: str) -> None:
    photos = _photos(tmp_path, "bad1.jpg", "bad2.jpg")
    if case == "missing":
        photos[1] = str(tmp_path / "missing.jpg")
    out, plot = tmp_path / "out.json", tmp_path / "out.png"
    proc = run_cli("estimate", "--joint", *photos, "--json", str(out), "--plot", str(plot))
    assert proc.returncode == 2, proc.stderr
    (line,) = proc.stderr.splitlines()
    assert line.startswith("error: ") and ("no such file" in line if case == "missing" else "none of the 2" in line)
    assert not out.exists() and not plot.exists() and proc.stdout == ""


def test_joint_plot_draws_the_one_spd(tmp_path: Path) -> None:
    out = tmp_path / "spd.png"
    proc = run_cli("estimate", "--joint", *_photos(tmp_path, "a.jpg", "b.jpg"), "--plot", str(out))
    assert proc.returncode == 0, proc.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_joint_end_to_end_on_rendered_photos(tmp_path: Path) -> None:
    """The real estimator: two rendered photos of one lamp and a photo of noise, one result."""
    from cd_spectra_addon.core.scene.capture import Scene, load_preset
    from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
    from training.simulation import photo
    from training.simulation.render_numpy import render_cube

    preset = load_preset("cd-default").with_image_size(256)
    scene = Scene(preset)
    cube = render_cube(scene, supersample=2)
    camera = load_camera(DEFAULT_CAMERA)
    lam = np.arange(380.0, 781.0, 5.0)
    spd = np.exp(-0.5 * ((lam - 560.0) / 80.0) ** 2)
    c = preset.camera
    exif = photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], DEFAULT_CAMERA)
    paths = []
    for k, exposure in enumerate((1.0, 0.5)):
        img, _ = photo.expose(photo.linear_photo(cube, spd, camera), exposure, photo.track_mask(scene))
        img = np.minimum(photo.add_noise(img, 0.01, np.random.default_rng(k)), 1.0)
        paths.append(tmp_path / f"shot{k}.jpg")
        photo.write_photo(paths[-1], img, "jpg", exif)
    noise = tmp_path / "noise.png"
    photo.write_photo(noise, np.random.default_rng(0).random((256, 256, 3)) * 0.5, "png")
    out = tmp_path / "out.json"
    proc = run_cli("estimate", "--joint", str(paths[0]), str(noise), str(paths[1]), "--preset", "cd-default",
                   "--json", str(out), fake=False)
    assert proc.returncode == 0, proc.stderr
    (result,) = json.loads(out.read_text())
    joint = result["joint"]
    assert (joint["given"], joint["used"], joint["refused"]) == (3, 2, 1)
    assert joint["photos"][1]["refused"] and not joint["photos"][0]["refused"]
    assert joint["photos"][2]["brightness"] == pytest.approx(0.5, rel=0.05)  # exposed at half the first's
    assert result["spd"] and max(result["spd"]) == 1.0
