"""Shared output of the listing commands: one name a line for people, a JSON list for machines."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable, Sequence


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print a JSON list instead")


def show(rows: Sequence[dict[str, str]], args: argparse.Namespace, out: Callable[[str], None],
         empty: str) -> int:
    """Rows are {"name": ..., optional "description": ...}; ``empty`` is said when there are none."""
    if args.json:
        out(json.dumps(list(rows)))
        return 0
    if not rows:
        out(empty)
    width = max((len(r["name"]) for r in rows), default=0)
    for row in rows:
        text = row.get("description", "")
        out(f"{row['name']:<{width}}  {text}".rstrip())
    return 0
