"""``cameras``: the camera sensitivity profiles shipped (``estimate --camera NAME``)."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from . import listing

NAME = "cameras"
HELP = "list the camera profiles"
add_arguments = listing.add_arguments


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.spectra.cameras import DEFAULT_CAMERA, camera_names

    rows = [{"name": name, "description": "(default)" if name == DEFAULT_CAMERA else ""}
            for name in camera_names()]
    return listing.show(rows, args, out, "no camera profiles in this build")
