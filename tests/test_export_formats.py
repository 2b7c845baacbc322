"""The export registry: exactly these formats, each writes a file its reader takes back, an
unknown name is refused with the choices (no writer looked up by string, none silently dropped)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cd_spectra_addon.core.spectra import spectra_files as sf
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.grid import N_BANDS


def test_the_registry_is_pinned():
    got = [(f.identifier, f.label, f.extension, f.writer, f.takes_metadata, f.needs_module)
           for f in sf.EXPORT_FORMATS.values()]
    assert got == [
        ("CSV", "CSV", ".csv", sf.write_spd_csv, False, None),
        ("JSON", "JSON", ".json", sf.write_spd_json, True, None),
        ("PBRT", "pbrt-v4", ".spd", sf.write_spd_pbrt, False, None),
        ("TM2714", "IES TM-27-14", ".xml", sf.write_spd_tm2714, True, "colour"),
        ("MITSUBA", "Mitsuba (λ:value)", ".txt", sf.write_spd_mitsuba, False, None),
    ]


def test_the_command_line_offers_every_registered_format():
    from cd_spectra_addon.cli.export import FORMATS

    assert sorted(FORMATS.values()) == sorted(sf.EXPORT_FORMATS)
    assert all(key == fmt.identifier and fmt.description for key, fmt in sf.EXPORT_FORMATS.items())


@pytest.mark.parametrize("identifier", list(sf.EXPORT_FORMATS))
def test_every_format_writes_what_the_reader_reads(identifier, tmp_path: Path):
    fmt = sf.export_format(identifier)
    assert fmt.available()  # colour-science is pinned: every format is writable here
    spd = np.linspace(0.1, 1.0, N_BANDS) ** 2
    path = fmt.write(tmp_path / "lamp.txt", spd, {"name": "warm lamp", "cct_k": 2856.0})
    assert path == tmp_path / f"lamp{fmt.extension}" and path.is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]
    name, back = sf.read_reference_spd(path)
    assert np.allclose(back / back.max(), spd / spd.max(), atol=1e-6)
    # Mitsuba's pair list has no room for a name (it is pasted into scene files): the file's stem
    assert name == ("lamp" if identifier == "MITSUBA" else "warm lamp")


def test_a_format_needing_a_missing_package_is_unavailable():
    fmt = sf.ExportFormat("X", "X", ".x", sf.write_spd_csv, False, "test", needs_module="no_such_package_cd")
    assert not fmt.available()
    assert sf.EXPORT_FORMATS["CSV"].available()


@given(st.text(max_size=12).filter(lambda s: s not in sf.EXPORT_FORMATS))
def test_an_unknown_format_names_the_choices(identifier):
    with pytest.raises(CDSpectraError, match="choose one of CSV, JSON, PBRT, TM2714, MITSUBA"):
        sf.export_format(identifier)
