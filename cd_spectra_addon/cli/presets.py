"""``presets``: the capture set-ups an estimate can assume (``estimate --preset NAME``): the
shipped ones, then your own (``setup --save``, Blender's set-up form) from your presets folder
(``$CD_SPECTRA_PRESET_DIR`` or the user's config folder)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from . import listing

NAME = "presets"
HELP = "list the capture presets (shipped, then your own)"
add_arguments = listing.add_arguments


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.errors import CDSpectraError
    from ..core.scene.capture import load_preset, preset_names, user_preset_names
    from ..core.user_folders import preset_dir

    rows = [{"name": name, "description": load_preset(name).description} for name in preset_names()]
    for name in user_preset_names():
        try:
            description = load_preset(name).description
        except CDSpectraError as exc:  # a broken file of the user's: listed with why it cannot be used
            description = f"(cannot be used: {exc})"
        rows.append({"name": name, "description": f"(yours, in {preset_dir()}) {description}".strip()})
    return listing.show(rows, args, out, "no presets in this build")
