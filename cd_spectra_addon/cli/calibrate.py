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

from ..core.spectra.cameras import DEFAULT_CAMERA
from ..core.scene.capture import DEFAULT_PRESET
from .common import UsageError

NAME = "calibrate"
HELP = "make a calibration profile from a photo of a known lamp"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..core.spectra.illuminants import KNOWN_LAMPS, LAMP_ALIASES

    parser.add_argument("photo", type=Path, metavar="PHOTO", help="the CD under the known lamp")
    lamp = parser.add_mutually_exclusive_group(required=True)
    lamp.add_argument("--known-lamp", metavar="LAMP",
                      help="; ".join(f"{k}: {v.description}" for k, v in KNOWN_LAMPS.items())
                      + "; or by CIE name: " + ", ".join(f"{a.upper()} = {k}" for a, k in LAMP_ALIASES.items()))
    lamp.add_argument("--reference-spd", type=Path, metavar="FILE",
                      help="the lamp's measured SPD (CSV/TXT, CD Spectra JSON, pbrt .spd, TM-27-14 XML)")
    parser.add_argument("--name", required=True, help="the profile's name")
    parser.add_argument("--preset", default=DEFAULT_PRESET, help=f"capture preset (default {DEFAULT_PRESET})")
    parser.add_argument("--camera", default="auto",
                        help="camera profile (default: from the photo's EXIF Make/Model, else the generic profile; "
                             f"e.g. {DEFAULT_CAMERA})")


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.spectra.illuminants import KNOWN_LAMPS, LAMP_ALIASES, known_lamp_spd
    from ..core.calibration.calibration import calibration_warning, load_calibration
    from ..core.inverse.calibration_shot import calibrate_photo
    from ..core.spectra.spectra_files import read_reference_spd
    from ..core.photo.frames import split_frame

    if not args.name.strip():
        raise UsageError("--name must not be empty")
    try:
        file, _ = split_frame(args.photo)  # a GIF's frame is named FILE.gif#N
    except ValueError as exc:
        raise UsageError(str(exc)) from exc
    if not Path(file).is_file():
        raise UsageError(f"{args.photo}: no such file")
    try:
        if args.known_lamp:
            spd = known_lamp_spd(args.known_lamp)  # a key or a CIE name; CDSpectraError names the choices
            key = args.known_lamp if args.known_lamp in KNOWN_LAMPS else LAMP_ALIASES[args.known_lamp.strip().lower()]
            reference = KNOWN_LAMPS[key].label
        else:
            name, spd = read_reference_spd(args.reference_spd)
            reference = f"{name} ({args.reference_spd.name})"
        path = calibrate_photo(args.photo, spd, args.name, preset=args.preset, camera=args.camera,
                               reference_name=reference)
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        message = " ".join(str(exc).split())
        raise UsageError(message if str(args.photo) in message else f"{args.photo}: {message}") from exc
    out(f"wrote calibration {args.name!r} to {path}")
    poor = calibration_warning(load_calibration(path))
    if poor:
        out(f"warning: {poor}")
    out(f"use it with: estimate PHOTO --calibration {path.stem}")
    return 0
