"""``presets``: the capture set-ups an estimate can assume (``estimate --preset NAME``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from . import listing

NAME = "presets"
HELP = "list the capture presets"
add_arguments = listing.add_arguments


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.scene.capture import load_preset, preset_names

    rows = [{"name": name, "description": load_preset(name).description} for name in preset_names()]
    return listing.show(rows, args, out, "no presets in this build")
