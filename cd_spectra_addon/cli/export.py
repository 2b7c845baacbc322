"""``export RESULT.json --format F``: an estimate's SPD as a file another tool reads.

RESULT is what ``estimate --json`` wrote: a JSON array of results, one result object, or JSON
lines (``--json -`` saved from stdout). Every writer is the core's (core.spectra_files, the one
the panel's Export uses), atomic; with several results, one file each, and a failure removes
the files this command already wrote.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .common import UsageError, check_output

NAME = "export"
HELP = "write an estimate's SPD as CSV, JSON, pbrt-v4, IES TM-27-14 or Mitsuba spectrum"


# Command-line names for the core's export registry (core.spectra_files.EXPORT_FORMATS, the one
# the panel's Export menu is built from); a test keeps the two covering each other.
FORMATS: dict[str, str] = {"csv": "CSV", "json": "JSON", "pbrt": "PBRT", "ies": "TM2714", "mitsuba": "MITSUBA"}
META_KEYS = ("source", "model_version", "preset", "camera", "calibration", "confidence", "xy", "cct_k", "duv",
             "warnings", "spd_std", "working_space")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("result", type=Path, metavar="RESULT.json", help="what `estimate --json` wrote")
    parser.add_argument("--format", required=True, choices=sorted(FORMATS),
                        help="csv (wavelength,value rows); json (with colour metrics and provenance); pbrt "
                             "(pbrt-v4 .spd); ies (IES TM-27-14 XML, needs colour-science); mitsuba "
                             "(wavelength:value pairs for Mitsuba 3 / LuxCore)")
    parser.add_argument("--out", type=Path, metavar="FILE",
                        help="where to write (default: beside RESULT, named RESULT-FORMAT.ext; with several "
                             "results, -1, -2, ... before the extension)")


def read_results(path: Path) -> list[dict[str, Any]]:
    """The estimates in a result file, each with a usable 81-value SPD; UsageError otherwise."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UsageError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{path}: cannot read it ({getattr(exc, 'strerror', None) or exc})") from None
    try:
        data: Any = json.loads(text)
    except json.JSONDecodeError:
        try:
            data = [json.loads(line) for line in text.splitlines() if line.strip()]
        except json.JSONDecodeError as exc:
            raise UsageError(f"{path}: not a result of `estimate --json` (line {exc.lineno}: {exc.msg})") from None
    results = data if isinstance(data, list) else [data]
    if not results:
        raise UsageError(f"{path}: holds no results")
    for i, item in enumerate(results, 1):
        spd = item.get("spd") if isinstance(item, dict) else None
        try:
            values = [float(v) for v in spd] if isinstance(spd, list) else []
        except (TypeError, ValueError):
            values = []
        if len(values) != 81 or not all(math.isfinite(v) and v >= 0 for v in values) or max(values) <= 0:
            raise UsageError(f"{path}: result {i} has no usable SPD (81 finite, non-negative values)")
    return results


def targets(result_path: Path, out: Path | None, fmt: str, count: int) -> list[Path]:
    from ..core.spectra.spectra_files import export_format

    ext = export_format(FORMATS[fmt]).extension
    base = out if out is not None else result_path.with_name(f"{result_path.stem}-{fmt}{ext}")
    if count == 1:
        return [base]
    return [base.with_name(f"{base.stem}-{i}{base.suffix or ext}") for i in range(1, count + 1)]


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    import numpy as np

    from ..core.spectra import spectra_files

    fmt = spectra_files.export_format(FORMATS[args.format])
    if not fmt.available():
        raise UsageError(f"this build cannot write {args.format} ({fmt.label} needs {fmt.needs_module})")
    writer = fmt.writer
    results = read_results(args.result)
    paths = targets(args.result, args.out, args.format, len(results))
    if args.result.resolve() in {p.resolve() for p in paths}:
        raise UsageError(f"{args.result} would be overwritten: choose another --out")
    for path in paths:
        check_output(path)
    done: list[Path] = []
    try:
        for data, path in zip(results, paths):
            name = Path(str(data.get("source") or path.stem)).stem
            spd = np.asarray(data["spd"], dtype=np.float64)
            if fmt.takes_metadata:
                meta = {k: data[k] for k in META_KEYS if data.get(k) is not None}
                done.append(Path(writer(path, spd, name=name, metadata=meta)))
            else:
                done.append(Path(writer(path, spd, name=name)))
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        for path in done:
            path.unlink(missing_ok=True)
        raise UsageError(str(exc)) from exc
    out("wrote " + ", ".join(str(p) for p in done))
    return 0
