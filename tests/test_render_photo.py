"""The photo synthesis CLI end to end (numpy engine, small images), and its failure modes."""

import json

import numpy as np
import pytest
from PIL import Image

from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET, load_preset
from training.simulation import render_photo

CSV = "wavelength_nm,warm,cool\n" + "\n".join(
    f"{w},{(w - 350) / 430:.4f},{np.exp(-((w - 450) / 30) ** 2):.4f}" for w in range(360, 831, 2))


@pytest.fixture
def spd_csv(tmp_path):
    path = tmp_path / "spd.csv"
    path.write_text(CSV)
    return path


def _run(args, capsys):
    code = render_photo.main([str(a) for a in args])
    return code, capsys.readouterr()


@pytest.mark.parametrize("fmt,ext", [("jpg", "jpg"), ("png", "png"), ("png16", "png"), ("exr", "exr")])
def test_writes_one_photo_per_column(tmp_path, spd_csv, capsys, fmt, ext):
    out = tmp_path / "out"
    code, cap = _run(["--spd", spd_csv, "--out", out, "--engine", "numpy", "--size", "64", "--format", fmt,
                      "--noise", "0.01", "--cache-dir", tmp_path / "cache"], capsys)
    assert code == 0, cap.err
    assert sorted(p.name for p in out.iterdir()) == sorted([f"warm.{ext}", f"cool.{ext}", "render_photo.json"])
    manifest = json.loads((out / "render_photo.json").read_text())
    assert [p["spd"] for p in manifest["photos"]] == ["warm", "cool"]
    if ext in ("jpg", "png"):
        with Image.open(out / f"warm.{ext}") as im:
            assert im.size == (64, 64)


def test_jpeg_carries_the_focal_length_in_exif(tmp_path, spd_csv, capsys):
    out = tmp_path / "out"
    assert _run(["--spd", spd_csv, "--out", out, "--engine", "numpy", "--size", "64",
                 "--cache-dir", tmp_path / "c"], capsys)[0] == 0
    with Image.open(out / "warm.jpg") as im:
        exif = im.getexif().get_ifd(0x8769)
    # render_photo's default preset (the estimator's): its lens's focal length in EXIF FocalLength
    assert float(exif[0x920A]) == pytest.approx(load_preset(DEFAULT_PRESET).camera.focal_length_mm)


def test_print_geometry(capsys):
    code, cap = _run(["--print-geometry", "--preset", "cd-default"], capsys)
    assert code == 0
    geo = json.loads(cap.out)
    for key in ("pitch_um", "camera_distance_mm", "light_distance_mm", "image_size_px", "disc_center_px", "px_per_mm"):
        assert key in geo
    assert geo["pitch_um"] == 1.6 and geo["image_size_px"] == [512, 512]
    assert geo["disc_center_px"] == [255.5, 255.5]
    assert geo["px_per_mm"] == pytest.approx(58.0 / 36.0 * 512 / 210.0)


def test_full_pose_flags_move_camera_and_lamp_and_keep_the_offsets(capsys):
    code, cap = _run(["--print-geometry", "--preset", "cd-default", "--camera-position-mm", "-120", "0", "250",
                      "--light-position-mm", "300", "0", "1500", "--camera-offset-mm", "2", "1"], capsys)
    assert code == 0, cap.err
    geo = json.loads(cap.out)
    assert geo["camera_position_mm"] == pytest.approx([-118.0, 1.0, 250.0])
    assert geo["light_position_mm"] == pytest.approx([300.0, 0.0, 1500.0])
    assert geo["camera_distance_mm"] == pytest.approx(np.hypot(120.0, 250.0))
    forward = -np.asarray(geo["camera_rotation"])[:, 2]
    assert forward == pytest.approx(np.array([120.0, 0.0, -250.0]) / np.hypot(120.0, 250.0))
    # The offset moves the camera (and its aim) 2 mm towards +x and 1 mm towards +y without
    # turning it: the disc centre appears left of and below the image centre.
    col, row = geo["disc_center_px"]
    assert col < 255.5 - 1.0 and row > 255.5 + 0.5


def test_a_camera_below_the_disc_is_refused(capsys):
    code, cap = _run(["--print-geometry", "--camera-position-mm", "0", "0", "-5"], capsys)
    assert code == 2 and "above the disc" in cap.err and "Traceback" not in cap.err


@pytest.mark.parametrize("content,needle", [
    ("", "fewer than two rows"),
    ("wavelength,a\n400,1\n500,x\n", "not a number"),
    ("wavelength,a\n1,1\n2,1\n", "not wavelengths"),
    ("wavelength,a\n400,0\n500,0\n", "zero everywhere"),
])
def test_bad_spd_files_exit_2_with_one_error_line(tmp_path, capsys, content, needle):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    code, cap = _run(["--spd", path, "--out", tmp_path / "o", "--engine", "numpy", "--size", "32",
                      "--cache-dir", tmp_path / "c"], capsys)
    assert code == 2
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error:") and needle in lines[0]
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_unknown_preset_and_camera(tmp_path, spd_csv, capsys):
    code, cap = _run(["--spd", spd_csv, "--out", tmp_path, "--preset", "nope"], capsys)
    assert code == 2 and "unknown capture preset" in cap.err
    code, cap = _run(["--spd", spd_csv, "--out", tmp_path, "--camera", "Leica_X"], capsys)
    assert code == 2 and "unknown camera" in cap.err
