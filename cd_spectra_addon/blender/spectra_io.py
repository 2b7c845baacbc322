"""The Blender layer's one door to the core's spectra files and colour comparisons.

Operators and panels ask here which export formats exist, how to write or read a spectrum,
how to compare two, and what a standard lamp's SPD is, so they never depend on core function
names directly.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Sequence

# identifier, label, extension, writer in core.spectra_files, takes metadata, description
_FORMATS: tuple[tuple[str, str, str, str, bool, str], ...] = (
    ("CSV", "CSV", ".csv", "write_spd_csv", False, "Wavelength and relative power, one row per 5 nm"),
    ("JSON", "JSON", ".json", "write_spd_json", True, "The SPD with its colour metrics and provenance"),
    ("PBRT", "pbrt-v4", ".spd", "write_spd_pbrt", False, "pbrt-v4 spectrum file (wavelength value pairs)"),
    ("TM2714", "IES TM-27-14", ".xml", "write_spd_tm2714", True, "IES TM-27-14 spectral data XML"),
    ("MITSUBA", "Mitsuba (λ:value)", ".txt", "write_spd_mitsuba", False,
     "wavelength:value pairs for Mitsuba 3's <spectrum value=...> and similar renderers"),
)


@dataclass(frozen=True)
class ExportFormat:
    identifier: str
    label: str
    extension: str
    writer: Callable[..., Any]
    takes_metadata: bool
    description: str


def _tm2714_available() -> bool:
    """TM-27-14 XML is written through colour-science, which Blender does not bundle."""
    import importlib.util

    return importlib.util.find_spec("colour") is not None


def export_formats() -> list[ExportFormat]:
    """The formats the core can write here (TM-27-14 only where colour-science is installed)."""
    from ..core import spectra_files

    found = []
    for identifier, label, ext, func, takes_metadata, description in _FORMATS:
        writer = getattr(spectra_files, func, None)
        if callable(writer) and (identifier != "TM2714" or _tm2714_available()):
            found.append(ExportFormat(identifier, label, ext, writer, takes_metadata, description))
    return found


def write_spd(fmt: ExportFormat, path: str | Path, spd: Sequence[float], meta: dict[str, Any]) -> Path:
    """Write one SPD (the core's writers are atomic: no half-written file, ever)."""
    import numpy as np

    target = Path(path)
    if target.suffix.lower() != fmt.extension:
        target = target.with_suffix(fmt.extension)
    name = str(meta.get("name") or target.stem)
    values = np.asarray(spd, dtype=np.float64)
    if fmt.takes_metadata:
        return Path(fmt.writer(target, values, name=name, metadata=meta))
    return Path(fmt.writer(target, values, name=name))


def read_reference(path: str | Path) -> tuple[str, list[float]]:
    """(name, SPD on the 81-band grid) of a spectrum file (CSV/TSV/TXT, JSON, pbrt .spd,
    TM-27-14 XML); CDSpectraError with a reason if unreadable."""
    from ..core.spectra_files import read_reference_spd

    name, spd = read_reference_spd(path)
    return str(name), [float(v) for v in spd]


def compare(estimate: Sequence[float], reference: Sequence[float]) -> dict[str, float]:
    """Accuracy numbers of an estimate against a reference (MAE, Δu'v', ...)."""
    import numpy as np

    from ..core.colour import compare_spds

    result = compare_spds(np.asarray(estimate, dtype=np.float64), np.asarray(reference, dtype=np.float64))
    return {str(k): float(v) for k, v in result.items() if isinstance(v, (int, float))}


def standard_lamp(identifier: str) -> list[float]:
    """SPD of a known calibration lamp (core.calibration.KNOWN_LAMPS) on the product grid."""
    from ..core.calibration import known_lamp_spd

    return [float(v) for v in known_lamp_spd(identifier)]
