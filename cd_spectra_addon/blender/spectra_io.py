"""The Blender layer's one door to the core's spectra files and colour comparisons.

Operators and panels ask here which export formats exist, how to write or read a spectrum,
how to compare two, and what a standard lamp's SPD is, so they never depend on core function
names directly.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

if TYPE_CHECKING:
    from ..core.spectra.spectra_files import ExportFormat


def export_formats() -> list[ExportFormat]:
    """The core's export formats this Python can write (TM-27-14 only with colour-science)."""
    from ..core.spectra.spectra_files import EXPORT_FORMATS

    return [fmt for fmt in EXPORT_FORMATS.values() if fmt.available()]


def export_format(identifier: str) -> ExportFormat:
    """The format the menu item ``identifier`` names; CDSpectraError for an unknown one."""
    from ..core.spectra.spectra_files import export_format as core_format

    return core_format(identifier)


def write_spd(fmt: ExportFormat, path: str | Path, spd: Sequence[float], meta: dict[str, Any]) -> Path:
    """Write one SPD (the core's writers are atomic: no half-written file, ever)."""
    return fmt.write(path, spd, meta)


def read_reference(path: str | Path) -> tuple[str, list[float]]:
    """(name, SPD on the 81-band grid) of a spectrum file (CSV/TSV/TXT, JSON, pbrt .spd,
    TM-27-14 XML); CDSpectraError with a reason if unreadable."""
    from ..core.spectra.spectra_files import read_reference_spd

    name, spd = read_reference_spd(path)
    return str(name), [float(v) for v in spd]


def compare(estimate: Sequence[float], reference: Sequence[float],
            rendition: dict[str, Any] | None = None) -> dict[str, float]:
    """Accuracy numbers of an estimate against a reference (MAE, Δu'v', ...), and ``delta_<figure>``
    (estimate − reference) for the headline rendition figures — from the estimate's own
    ``rendition`` JSON where it has one."""
    import numpy as np

    from ..core.rendition.result import HEADLINE, compare_rendition
    from ..core.rendition.result import rendition as rendition_of_spd
    from ..core.spectra.colour import compare_spds

    est = np.asarray(estimate, dtype=np.float64)
    ref = np.asarray(reference, dtype=np.float64)
    result: dict[str, Any] = dict(compare_spds(est, ref))
    figures = compare_rendition(rendition if isinstance(rendition, dict) else rendition_of_spd(est), ref)
    for key in HEADLINE if figures.get("defined") else ():
        result[f"delta_{key}"] = figures["difference"].get(key)
    return {str(k): float(v) for k, v in result.items() if isinstance(v, (int, float))}


def standard_lamp(identifier: str) -> list[float]:
    """SPD of a known calibration lamp (core.illuminants.KNOWN_LAMPS) on the product grid."""
    from ..core.spectra.illuminants import known_lamp_spd

    return [float(v) for v in known_lamp_spd(identifier)]
