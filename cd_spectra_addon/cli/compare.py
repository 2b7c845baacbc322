"""``compare RESULT.json REFERENCE``: an estimate against a measured spectrum (the panel's Load
reference): MAE and RMSE in 400–700 and 380–780 nm, correlation, Δu'v', ΔCCT, ΔDuv, and the
colour-rendition figures a meter shows (Ra, R9, Rf, Rg, peak and dominant wavelength): the
reference's value, the difference, and whether the reference lies in the estimate's 90 % range.

REFERENCE is any spectrum file the panel reads (CSV/TSV/TXT, CD Spectra JSON, pbrt ``.spd``,
TM-27-14 XML); of a table with several spectra, ``--spectrum NAME`` picks one. With several
results, one block each, in order.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

from .export import read_results

NAME = "compare"
HELP = "compare estimates with a measured reference spectrum"
LABELS = {
    "mae_400_700": "MAE 400-700 nm", "rmse_400_700": "RMSE 400-700 nm", "mae_380_780": "MAE 380-780 nm",
    "rmse_380_780": "RMSE 380-780 nm", "pearson_r": "correlation r", "pearson_r_400_700": "correlation r 400-700",
    "delta_uv_prime": "delta u'v'", "delta_cct_k": "delta CCT (K)", "delta_duv": "delta Duv",
}
RENDITION_LABELS = {"cri_ra": "Ra", "cri_r9": "R9", "tm30_rf": "Rf", "tm30_rg": "Rg",
                    "peak_wavelength_nm": "peak (nm)", "dominant_wavelength_nm": "dominant wavelength (nm)"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("result", type=Path, metavar="RESULT.json", help="what `estimate --json` wrote")
    parser.add_argument("reference", type=Path, metavar="REFERENCE", help="the measured spectrum")
    parser.add_argument("--spectrum", metavar="NAME",
                        help="where REFERENCE holds several spectra (a table's columns), the one to compare with")
    parser.add_argument("--json", action="store_true", help="print one JSON object per result instead")


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    import numpy as np

    from ..core.rendition.result import compare_rendition, rendition
    from ..core.spectra.colour import compare_spds
    from ..core.spectra.spectra_files import read_reference_spd
    from .common import UsageError

    results = read_results(args.result)
    if not args.reference.is_file():
        raise UsageError(f"{args.reference}: no such file")
    try:
        name, reference = read_reference_spd(args.reference, args.spectrum)
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        message = " ".join(str(exc).split())
        if args.spectrum is None and message.endswith("choose one"):
            message += " with --spectrum NAME"
        raise UsageError(message if str(args.reference.name) in message else f"{args.reference}: {message}") from exc
    for data in results:
        spd = np.asarray(data["spd"], dtype=np.float64)
        metrics = compare_spds(spd, reference)
        # An estimate made with --no-rendition (or before rendition existed) is scored on its SPD alone.
        own = data.get("rendition") if isinstance(data.get("rendition"), dict) else rendition(spd)
        figures = compare_rendition(own, reference)
        if args.json:
            out(json.dumps({"source": data.get("source"), "reference": str(name), **metrics, "rendition": figures}))
            continue
        out(f"{data.get('source') or '?'} vs {name}")
        for key, label in LABELS.items():
            value = metrics.get(key)
            out(f"  {label}: " + ("undefined" if value is None else f"{value:.4g}"))
        for line in _rendition_lines(own, figures):
            out(line)
    return 0


def _rendition_lines(estimate: dict, figures: dict) -> list[str]:
    """The rendition block of the text output: estimate vs reference per figure."""
    if not figures.get("defined"):
        return [f"  colour rendition: not compared ({figures.get('reason')})"]
    lines = ["  colour rendition (estimate vs reference; in range = the reference lies in the estimate's 90 % range):"]
    for key, label in RENDITION_LABELS.items():
        est, ref, diff = estimate.get(key), figures["reference"].get(key), figures["difference"].get(key)
        if not all(isinstance(v, (int, float)) for v in (est, ref, diff)):
            lines.append(f"    {label}: undefined")
            continue
        inside = figures["within_range"].get(key)
        where = "" if inside is None else ("  in range" if inside else "  outside the range")
        lines.append(f"    {label}: {est:.1f} vs {ref:.1f} ({diff:+.1f}){where}")
    return lines
