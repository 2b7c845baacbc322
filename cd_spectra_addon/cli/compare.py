"""``compare RESULT.json REFERENCE``: an estimate against a measured spectrum (the panel's Load
reference): MAE and RMSE in 400–700 and 380–780 nm, correlation, Δu'v', ΔCCT, ΔDuv.

REFERENCE is any spectrum file the panel reads (CSV/TSV/TXT, CD Spectra JSON, pbrt ``.spd``,
TM-27-14 XML). With several results, one block each, in order.
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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("result", type=Path, metavar="RESULT.json", help="what `estimate --json` wrote")
    parser.add_argument("reference", type=Path, metavar="REFERENCE", help="the measured spectrum")
    parser.add_argument("--json", action="store_true", help="print one JSON object per result instead")


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    import numpy as np

    from ..core.spectra.colour import compare_spds
    from ..core.spectra.spectra_files import read_reference_spd
    from .common import UsageError

    results = read_results(args.result)
    if not args.reference.is_file():
        raise UsageError(f"{args.reference}: no such file")
    try:
        name, reference = read_reference_spd(args.reference)
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        message = " ".join(str(exc).split())
        raise UsageError(message if str(args.reference.name) in message else f"{args.reference}: {message}") from exc
    for data in results:
        metrics = compare_spds(np.asarray(data["spd"], dtype=np.float64), reference)
        if args.json:
            out(json.dumps({"source": data.get("source"), "reference": str(name), **metrics}))
            continue
        out(f"{data.get('source') or '?'} vs {name}")
        for key, label in LABELS.items():
            value = metrics.get(key)
            out(f"  {label}: " + ("undefined" if value is None else f"{value:.4g}"))
    return 0
