"""``calibrations``: the calibration profiles in the calibration folder
(``$CD_SPECTRA_CALIBRATION_DIR`` or the user's config folder), for ``estimate --calibration``."""

from __future__ import annotations

import argparse
from collections.abc import Callable

from . import listing

NAME = "calibrations"
HELP = "list the saved calibration profiles"
add_arguments = listing.add_arguments


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.calibration.calibration import list_calibrations
    from ..core.user_folders import calibration_dir

    folder = calibration_dir()
    rows = [{"name": name} for name in list_calibrations(folder)]
    return listing.show(rows, args, out, f"no calibration profiles in {folder} (make one with `calibrate`)")
