"""Spectra files: every writer reads back, writes are atomic, errors are specific."""

from __future__ import annotations

import errno
import json
import os
import sys
import tempfile
from pathlib import Path

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.spectra import spectra_files as sf
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM
from training.reliability.hostile import unwritable_folder

NAME = 'Glühlampe "60 W", Küche ☀'
METADATA = {
    "source_photo": "DSC_0042 — Küche.jpg",
    "model_version": "0.1.0",
    "cct_k": np.float64(2856.4),
    "duv": None,
    "xy": np.array([0.4476, 0.4074]),
    "confidence": float("nan"),  # JSON has no NaN: stored as null
    "camera": {"profile": "Nikon D5100", "exposure": (1, 60)},
}

WRITERS = {
    "csv": (sf.write_spd_csv, False),
    "json": (sf.write_spd_json, True),
    "spd": (sf.write_spd_pbrt, False),
    "spdx": (sf.write_spd_tm2714, True),
}


@pytest.fixture
def spd(rng) -> np.ndarray:
    return rng.uniform(0.0, 1.0, N_BANDS) ** 2


def write(kind: str, path: Path, spd: np.ndarray, name: str = NAME) -> Path:
    writer, takes_metadata = WRITERS[kind]
    return writer(path, spd, name=name, **({"metadata": METADATA} if takes_metadata else {}))


# --- round trips -------------------------------------------------------------------------------


@pytest.mark.parametrize("kind", sorted(WRITERS))
def test_round_trip_through_read_reference_spd(tmp_path, spd, kind):
    path = write(kind, tmp_path / f"Lampe 日本 ☀.{kind}", spd)
    assert path == tmp_path / f"Lampe 日本 ☀.{kind}"
    name, got = sf.read_reference_spd(path)
    assert name == NAME
    if kind == "spdx":
        np.testing.assert_allclose(got, spd, rtol=1e-11)  # colour writes 12 significant digits
    else:
        np.testing.assert_array_equal(got, spd)  # lossless
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary left


def test_json_keeps_metadata(tmp_path, spd):
    path = sf.write_spd_json(tmp_path / "a.json", spd, name=NAME, metadata=METADATA)
    _, _, meta = sf.read_spd_json(path)
    assert meta == {
        "source_photo": "DSC_0042 — Küche.jpg", "model_version": "0.1.0", "cct_k": 2856.4,
        "duv": None, "xy": [0.4476, 0.4074], "confidence": None,
        "camera": {"profile": "Nikon D5100", "exposure": [1, 60]},
    }
    raw = json.loads(path.read_text(encoding="utf-8"))
    assert raw["format"] == sf.JSON_FORMAT and raw["version"] == sf.JSON_VERSION
    assert raw["wavelength_nm"] == WAVELENGTHS_NM.tolist()


def test_tm2714_file(tmp_path, spd):
    path = sf.write_spd_tm2714(tmp_path / "a.spdx", spd, name=NAME, metadata=METADATA)
    text = path.read_bytes().decode("utf-8")  # UTF-8 whatever the locale
    assert "<SpectralQuantity>relative</SpectralQuantity>" in text
    sd = colour.io.SpectralDistribution_IESTM2714(str(path)).read()
    assert sd.header.description == NAME
    assert json.loads(sd.header.comments)["source_photo"] == METADATA["source_photo"]
    np.testing.assert_allclose(sd.wavelengths, WAVELENGTHS_NM)


def test_reads_a_third_party_tm2714_file():
    path = Path(colour.__file__).parent / "io" / "tests" / "resources" / "Fluorescent.spdx"
    name, spd = sf.read_reference_spd(path)
    assert name == "Rare earth fluorescent lamp"
    assert spd.shape == (N_BANDS,) and spd.max() > 0 and np.all(spd >= 0)


def test_csv_layout(tmp_path, spd):
    path = sf.write_spd_csv(tmp_path / "a.csv", spd, name="lamp, warm")
    lines = path.read_text(encoding="utf-8").splitlines()
    assert lines[0] == 'wavelength_nm,"lamp, warm"'
    assert lines[1].startswith("380,") and lines[-1].startswith("780,") and len(lines) == N_BANDS + 1
    table = sf.read_spectra_csv(path)
    assert table.names == ["lamp, warm"]
    np.testing.assert_array_equal(table.on_grid()[0], spd)


def pbrt_read_float_file(data: bytes) -> list[float]:
    """pbrt-v4's ``ReadFloatFile`` (src/pbrt/util/file.cpp), quirks included."""
    values: list[float] = []
    number = ""
    in_number = False
    i = 0
    while i < len(data):
        c = chr(data[i])
        if in_number:
            if c.isdigit() or c in ".eE-+":
                number += c
                assert len(number) < 32, "pbrt's number buffer is 32 chars"
            else:
                values.append(float(number))
                in_number, number = False, ""
        elif c.isdigit() or c in ".-+":
            in_number, number = True, c
        elif c == "#":
            while i < len(data) and data[i] != ord("\n"):
                i += 1
        else:
            assert c.isspace(), f"pbrt stops at unexpected character {c!r}"
        i += 1
    return values  # a number still being read at EOF is dropped, as in pbrt


def test_pbrt_file_reads_in_pbrt(tmp_path, spd):
    path = sf.write_spd_pbrt(tmp_path / "lamp.spd", spd, name=NAME)
    data = path.read_bytes()
    data.decode("ascii")
    assert data.endswith(b"\n")
    values = pbrt_read_float_file(data)
    assert len(values) == 2 * N_BANDS  # PiecewiseLinearSpectrum::Read: pairs...
    pairs = np.array(values).reshape(-1, 2)
    assert np.all(np.diff(pairs[:, 0]) > 0)  # ... with increasing wavelengths
    np.testing.assert_array_equal(pairs[:, 0], WAVELENGTHS_NM)
    np.testing.assert_allclose(pairs[:, 1], spd, rtol=1e-15)


def test_reads_foreign_pbrt_and_whitespace_text(tmp_path):
    wl = np.arange(360.0, 831.0, 1.0)
    values = np.exp(-0.5 * ((wl - 550.0) / 40.0) ** 2)
    body = "\n".join(f"  {w:.1f}\t{v:.6e}" for w, v in zip(wl, values, strict=True))
    (tmp_path / "gauss.spd").write_text(f"# measured\n{body}\n", encoding="utf-8")
    (tmp_path / "meter.txt").write_text(body + "\n", encoding="utf-8")
    for path in (tmp_path / "gauss.spd", tmp_path / "meter.txt"):
        name, spd = sf.read_reference_spd(path)
        assert name == path.stem
        assert int(np.argmax(spd)) == (550 - 380) // 5
        assert spd.max() == pytest.approx(1.0, abs=2e-3)


def test_reference_from_a_table_with_several_spectra(tmp_path):
    path = tmp_path / "meter.csv"
    rows = ["nm;lamp A;lamp B"] + [f"{w:g};{1 + i % 3};0,5" for i, w in enumerate(WAVELENGTHS_NM)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(CDSpectraError, match=r"2 spectra \(lamp A, lamp B\); choose one"):
        sf.read_reference_spd(path)
    name, spd = sf.read_reference_spd(path, column="lamp B")
    assert name == "lamp B"
    np.testing.assert_allclose(spd, 0.5)  # decimal comma with ';' separators
    with pytest.raises(CDSpectraError, match="no spectrum 'lamp C'"):
        sf.read_reference_spd(path, column="lamp C")


@settings(max_examples=25, deadline=None)
@given(values=arrays(np.float64, N_BANDS, elements=st.floats(0.0, 1e30, allow_subnormal=False)).filter(
    lambda a: a.max() > 0), kind=st.sampled_from(["csv", "json", "spd"]))
def test_round_trip_is_lossless(values, kind):
    with tempfile.TemporaryDirectory() as folder:
        path = WRITERS[kind][0](Path(folder) / f"x.{kind}", values, name="x")
        name, got = sf.read_reference_spd(path)
    assert name == "x"
    np.testing.assert_array_equal(got, values)


def test_names_are_one_clean_line(tmp_path, spd):
    for kind in ("csv", "json", "spd"):
        path = write(kind, tmp_path / f"n.{kind}", spd, name="  two\nlines\tand\x00nul  ")
        assert sf.read_reference_spd(path)[0] == "two lines and nul"
        path = write(kind, tmp_path / f"e.{kind}", spd, name="")
        assert sf.read_reference_spd(path)[0] == "spd"


# --- atomic writes --------------------------------------------------------------------------------


class Boom(Exception):
    pass


@pytest.mark.parametrize("kind", sorted(WRITERS))
@pytest.mark.parametrize("fail_at", ["fsync", "replace"])
def test_failure_mid_write_keeps_the_previous_file(tmp_path, monkeypatch, spd, kind, fail_at):
    target = write(kind, tmp_path / f"lamp.{kind}", spd)
    before = target.read_bytes()

    def fail(*args, **kwargs):
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(sf.os, fail_at, fail)
    with pytest.raises(CDSpectraError, match="Input/output error"):
        write(kind, target, 2 * spd + 1)
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


def test_interrupt_mid_write_leaves_no_partial_file(tmp_path, monkeypatch, spd):
    """Half the bytes are in the temporary file when the write dies (not an OSError)."""
    real_write = sf._write_bytes

    def half_then_die(data: bytes):
        def inner(temp: Path) -> None:
            real_write(data[: len(data) // 2])(temp)
            assert temp.stat().st_size > 0
            raise Boom("killed")

        return inner

    target = sf.write_spd_json(tmp_path / "lamp.json", spd)
    before = target.read_bytes()
    monkeypatch.setattr(sf, "_write_bytes", half_then_die)
    with pytest.raises(Boom):
        sf.write_spd_json(target, 2 * spd)
    with pytest.raises(Boom):
        sf.write_spd_json(tmp_path / "new.json", spd)
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


def test_unwritable_paths(tmp_path, spd):
    with pytest.raises(CDSpectraError, match="does not exist"):
        sf.write_spd_csv(tmp_path / "missing" / "a.csv", spd)
    with pytest.raises(CDSpectraError, match="is a folder"):
        sf.write_spd_csv(tmp_path, spd)
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    with pytest.raises(CDSpectraError, match="does not exist"):
        sf.write_spd_json(blocker / "a.json", spd)  # a file where a folder should be
    with pytest.raises(CDSpectraError, match="cannot write"):
        sf.write_spd_pbrt(tmp_path / ("x" * 300 + ".spd"), spd)  # name too long for the OS
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file.txt"]


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX permission bits")
def test_read_only_folder(tmp_path, spd):
    """A folder the OS refuses: read-only, or for root (who ignores permission bits) /sys."""
    folder = unwritable_folder(tmp_path)
    assert folder is not None
    listing = sorted(os.listdir(folder))
    try:
        with pytest.raises(CDSpectraError, match=r"[Pp]ermission denied"):
            sf.write_spd_csv(folder / "a.csv", spd)
        assert sorted(os.listdir(folder)) == listing
    finally:
        (tmp_path / "read-only").chmod(0o700)


def test_permission_denied_is_a_clear_error(tmp_path, monkeypatch, spd):
    """The same path as a read-only folder, for runs as root (which ignores permission bits)."""
    def deny(*args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied")

    monkeypatch.setattr(sf.os, "open", deny)
    with pytest.raises(CDSpectraError, match=r"cannot write in .*: Permission denied"):
        sf.write_spd_csv(tmp_path / "a.csv", spd)


@pytest.mark.parametrize("bad, match", [
    (np.full(N_BANDS, np.nan), "NaN"),
    (-np.ones(N_BANDS), "negative"),
    (np.zeros(N_BANDS), "zero everywhere"),
    (np.ones(10), "81 values"),
])
def test_writers_refuse_bad_spds(tmp_path, bad, match):
    for kind in ("csv", "json", "spd"):
        with pytest.raises(CDSpectraError, match=match):
            WRITERS[kind][0](tmp_path / f"a.{kind}", bad)
    assert list(tmp_path.iterdir()) == []


def test_metadata_that_json_cannot_hold(tmp_path, spd):
    with pytest.raises(CDSpectraError, match=r"metadata\.when.*datetime"):
        from datetime import datetime

        sf.write_spd_json(tmp_path / "a.json", spd, metadata={"when": datetime.now()})
    assert list(tmp_path.iterdir()) == []


# --- reading errors --------------------------------------------------------------------------------


def test_reference_errors(tmp_path):
    with pytest.raises(CDSpectraError, match="does not exist"):
        sf.read_reference_spd(tmp_path / "nope.csv")
    cases = {
        "other.json": ('{"wavelengths": [1, 2]}', "not a CD Spectra SPD file"),
        "newer.json": ('{"format": "cd-spectra-spd", "version": 99}', "version 99"),
        "broken.json": ('{"format": ', "not valid JSON"),
        "zero.csv": ("nm,a\n380,0\n780,0\n", "zero everywhere"),
        "ir.csv": ("nm,a\n800,1\n900,1\n", "miss 380–780"),
        "odd.spd": ("380 1\n385\n", "odd count"),
        "down.spd": ("500 1\n400 1\n", "must increase"),
        "words.txt": ("hello world\n", "fewer than two rows"),
        "one.csv": ("380\n385\n390\n", "need a wavelength column"),
    }
    for file_name, (text, match) in cases.items():
        (tmp_path / file_name).write_text(text, encoding="utf-8")
        with pytest.raises(CDSpectraError, match=match):
            sf.read_reference_spd(tmp_path / file_name)


def test_tm2714_errors(tmp_path):
    reflectance = tmp_path / "r.spdx"
    reflectance.write_text(
        '<?xml version="1.0"?><IESTM2714 xmlns="iestm2714" version="1.0"><Header/>'
        "<SpectralDistribution><SpectralQuantity>reflectance</SpectralQuantity>"
        '<SpectralData wavelength="400">0.5</SpectralData><SpectralData wavelength="700">0.5'
        "</SpectralData></SpectralDistribution></IESTM2714>", encoding="utf-8")
    with pytest.raises(CDSpectraError, match="reflectance spectrum, not a light's"):
        sf.read_reference_spd(reflectance)
    broken = tmp_path / "b.xml"
    broken.write_text("<IESTM2714", encoding="utf-8")
    with pytest.raises(CDSpectraError, match="not a readable IES TM-27-14 file"):
        sf.read_reference_spd(broken)


def test_tm2714_without_colour_science(tmp_path, monkeypatch, spd):
    monkeypatch.setitem(sys.modules, "colour.io", None)  # as inside Blender: not importable
    with pytest.raises(CDSpectraError, match="needs the colour-science package"):
        sf.write_spd_tm2714(tmp_path / "a.spdx", spd)
    (tmp_path / "b.spdx").write_text("<IESTM2714/>", encoding="utf-8")
    with pytest.raises(CDSpectraError, match="needs the colour-science package"):
        sf.read_reference_spd(tmp_path / "b.spdx")
    assert [p.name for p in tmp_path.iterdir()] == ["b.spdx"]
