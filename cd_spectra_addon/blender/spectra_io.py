"""The Blender layer's one door to the core's spectra files and colour comparisons.

Operators and panels ask here which export formats exist, how to write or read a spectrum,
how to compare two, and what a standard lamp's SPD is, so they never depend on core function
names directly.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

# identifier → (label, extension, name of the writer in core.spectra_files, description)
_FORMATS: tuple[tuple[str, str, str, str, str], ...] = (
    ("CSV", "CSV", ".csv", "write_spd_csv", "Wavelength and relative power, one row per 5 nm"),
    ("JSON", "JSON", ".json", "write_spd_json", "The SPD with its colour metrics and provenance"),
    ("PBRT", "pbrt-v4", ".spd", "write_spd_pbrt", "pbrt-v4 spectrum file (wavelength value pairs)"),
    ("TM2714", "IES TM-27-14", ".xml", "write_spd_tm2714", "IES TM-27-14 spectral data XML"),
)


@dataclass(frozen=True)
class ExportFormat:
    identifier: str
    label: str
    extension: str
    writer: Callable[..., Any]
    description: str


def export_formats() -> list[ExportFormat]:
    """The formats the core can write (TM-27-14 only once its writer exists)."""
    try:
        from ..core import spectra_files
    except ImportError:
        return []
    found = []
    for identifier, label, ext, func, description in _FORMATS:
        writer = getattr(spectra_files, func, None)
        if callable(writer):
            found.append(ExportFormat(identifier, label, ext, writer, description))
    return found


def write_spd(fmt: ExportFormat, path: str | Path, spd: Sequence[float], meta: dict[str, Any]) -> Path:
    """Write through a temporary file in the same folder, then rename: no half-written file."""
    import tempfile

    import numpy as np

    target = Path(path)
    if target.suffix.lower() != fmt.extension:
        target = target.with_suffix(fmt.extension)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.stem}.", suffix=fmt.extension, dir=target.parent)
    os.close(fd)
    try:
        fmt.writer(tmp_name, np.asarray(spd, dtype=np.float64), name=meta.get("name") or target.stem,
                   metadata=meta)
        os.replace(tmp_name, target)
    except BaseException:
        Path(tmp_name).unlink(missing_ok=True)
        raise
    return target


def read_reference(path: str | Path) -> tuple[str, list[float]]:
    """(name, SPD on the 81-band grid) of a spectrum file; ValueError with a reason if unreadable.

    Uses the core's reader of every supported format where present, else its CSV table reader
    (first spectrum of the table).
    """
    from ..core import spectra_files

    reader = getattr(spectra_files, "read_reference_spd", None)
    if reader is not None:
        name, spd = reader(path)
        return str(name), [float(v) for v in spd]
    table = spectra_files.read_spectra_csv(path)
    return table.names[0], [float(v) for v in table.on_grid()[0]]


def compare(estimate: Sequence[float], reference: Sequence[float]) -> dict[str, float]:
    """Accuracy numbers of an estimate against a reference (MAE, Δu'v', ...)."""
    import numpy as np

    from ..core.colour import compare_spds

    result = compare_spds(np.asarray(estimate, dtype=np.float64), np.asarray(reference, dtype=np.float64))
    return {str(k): float(v) for k, v in result.items() if isinstance(v, (int, float))}


def standard_lamp(identifier: str) -> list[float]:
    """SPD of a standard illuminant (CIE A, D50, D55, D65) on the product grid."""
    from ..core import colour

    spd = colour.standard_illuminant(identifier.replace("CIE_", ""))
    return [float(v) for v in spd]
