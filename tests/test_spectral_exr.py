"""Spectral EXR files: Fichet et al. (2021) channel names, round trip, sidecar, render CLI."""

import json
import re

import numpy as np
import pytest

from training.simulation import render_basis
from training.simulation.spectral_exr import channel_name, read_spectral_exr, write_spectral_exr


def test_channel_names_follow_the_fichet_layout():
    from colour.io import fichet2021 as fichet

    pattern = re.compile(fichet.PATTERN_FICHET2021)
    for wl in (380.0, 552.5, 780.0):
        name = channel_name(wl)
        assert name.startswith("S0.") and name.endswith("nm")
        match = pattern.match(name[len("S0."):])
        assert match is not None
        assert fichet.match_groups_to_nm(match.group(1), match.group(3) or "n", match.group(4)) == pytest.approx(wl)


def test_round_trip_with_sidecar(tmp_path):
    cube = np.random.default_rng(0).random((4, 5, 6)).astype(np.float32)
    path = tmp_path / "cube.exr"
    write_spectral_exr(path, cube, [380.0, 385.0, 390.0, 395.0], {"preset": "x"})
    back, wl, meta = read_spectral_exr(path)
    assert np.array_equal(back, cube) and list(wl) == [380.0, 385.0, 390.0, 395.0] and meta == {"preset": "x"}
    assert not [p for p in tmp_path.iterdir() if p.suffix == ".exr" and p.name != "cube.exr"]


def test_render_basis_cli_writes_81_bands_and_geometry(tmp_path, capsys):
    out = tmp_path / "basis.exr"
    assert render_basis.main(["--engine", "numpy", "--size", "32", "--samples", "1", "--out", str(out)]) == 0
    cube, wl, meta = read_spectral_exr(out)
    assert cube.shape == (81, 32, 32) and wl[0] == 380 and wl[-1] == 780
    assert meta["pitch_um"] == 1.6 and meta["image_size_px"] == [32, 32]
    assert json.loads(out.with_suffix(".json").read_text())["engine"] == "numpy"


def test_render_basis_cli_rejects_bad_preset(tmp_path, capsys):
    assert render_basis.main(["--preset", "nope", "--out", str(tmp_path / "x.exr")]) == 2
    assert capsys.readouterr().err.startswith("error: unknown capture preset")
