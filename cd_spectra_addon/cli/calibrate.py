"""``calibrate PHOTO``: a calibration profile from a photo of a lamp whose spectrum is known.

The photo is taken like the later ones (same camera, disc and set-up) under a known lamp
(``--known-lamp``) or one whose SPD was measured (``--reference-spd FILE``). The profile is
written to the calibration folder (``$CD_SPECTRA_CALIBRATION_DIR`` or the user's config folder)
under ``--name``; ``estimate --calibration NAME`` then uses it. The same job as the panel's
Calibrate, through the same core (core.calibration_shot.calibrate_photo).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

from ..core.cameras import DEFAULT_CAMERA
from .common import UsageError
from .estimate import DEFAULT_PRESET

NAME = "calibrate"
HELP = "make a calibration profile from a photo of a known lamp"
# CIE illuminant names people know, for the core's lamps.
LAMP_ALIASES = {"A": "incandescent", "D55": "daylight", "D65": "daylight-d65"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..core.calibration import KNOWN_LAMPS

    parser.add_argument("photo", type=Path, metavar="PHOTO", help="the CD under the known lamp")
    lamp = parser.add_mutually_exclusive_group(required=True)
    lamp.add_argument("--known-lamp", choices=[*KNOWN_LAMPS, *LAMP_ALIASES],
                      help="; ".join(f"{k}: {v}" for k, v in KNOWN_LAMPS.items())
                      + "; " + ", ".join(f"{a} = {k}" for a, k in LAMP_ALIASES.items()))
    lamp.add_argument("--reference-spd", type=Path, metavar="FILE",
                      help="the lamp's measured SPD (CSV/TXT, CD Spectra JSON, pbrt .spd, TM-27-14 XML)")
    parser.add_argument("--name", required=True, help="the profile's name")
    parser.add_argument("--preset", default=DEFAULT_PRESET, help=f"capture preset (default {DEFAULT_PRESET})")
    parser.add_argument("--camera", default=DEFAULT_CAMERA, help=f"camera profile (default {DEFAULT_CAMERA})")


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.calibration import KNOWN_LAMPS, known_lamp_spd
    from ..core.calibration_shot import calibrate_photo
    from ..core.spectra_files import read_reference_spd

    if not args.name.strip():
        raise UsageError("--name must not be empty")
    if not args.photo.is_file():
        raise UsageError(f"{args.photo}: no such file")
    try:
        if args.known_lamp:
            lamp = LAMP_ALIASES.get(args.known_lamp, args.known_lamp)
            spd, reference = known_lamp_spd(lamp), KNOWN_LAMPS[lamp]
        else:
            name, spd = read_reference_spd(args.reference_spd)
            reference = f"{name} ({args.reference_spd.name})"
        path = calibrate_photo(args.photo, spd, args.name, preset=args.preset, camera=args.camera,
                               reference_name=reference)
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        message = " ".join(str(exc).split())
        raise UsageError(message if str(args.photo) in message else f"{args.photo}: {message}") from exc
    out(f"wrote calibration {args.name!r} to {path}")
    out(f"use it with: estimate PHOTO --calibration {path.stem}")
    return 0
