"""``calibrate PHOTO... --known-lamp LAMP...``: a calibration profile from photos of known lamps.

The photos are taken like the later ones (same camera, disc and set-up) under a known lamp
(``--known-lamp``) or one whose SPD was measured (``--reference-spd FILE``): one photo, or
several under lamps of different colours — a bulb and daylight — whose second colour measures
the camera where the first cannot. One lamp option per photo, the n-th for the n-th photo,
either after all the photos or each after its photo:

    calibrate bulb.jpg --known-lamp A --name mine
    calibrate bulb.jpg window.jpg --known-lamp A --known-lamp D65 --name mine
    calibrate bulb.jpg --known-lamp A window.jpg --known-lamp D65 --name mine

The profile is written to the calibration folder (``$CD_SPECTRA_CALIBRATION_DIR`` or the user's
config folder) under ``--name``; ``estimate --calibration NAME`` then uses it. The same job as
the panel's Calibrate, through the same core (core.inverse.calibration_shot.calibrate_photos).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core.spectra.cameras import DEFAULT_CAMERA
from ..core.scene.capture import DEFAULT_PRESET
from .common import UsageError

NAME = "calibrate"
HELP = "make a calibration profile from photos of known lamps"
INTERMIXED, INTERMIXED_TYPE = "photos", Path  # a photo may follow the lamp option of the one before


class _Lamp(argparse.Action):
    """``--known-lamp`` and ``--reference-spd`` into one list, ``args.lamps``, in the order given:
    ("known", NAME) or ("file", PATH), the n-th for the n-th photo."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        kind = "known" if option_string == "--known-lamp" else "file"
        namespace.lamps = [*(getattr(namespace, "lamps", None) or []), (kind, values)]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..core.spectra.illuminants import KNOWN_LAMPS, LAMP_ALIASES

    parser.add_argument("photos", nargs="+", type=Path, metavar="PHOTO",
                        help="the CD under a known lamp; several: one lamp each, of different colours")
    parser.add_argument("--known-lamp", metavar="LAMP", action=_Lamp,
                        help="once per PHOTO, in order: "
                        + "; ".join(f"{k}: {v.description}" for k, v in KNOWN_LAMPS.items())
                        + "; or by CIE name: " + ", ".join(f"{a.upper()} = {k}" for a, k in LAMP_ALIASES.items()))
    parser.add_argument("--reference-spd", type=Path, metavar="FILE", action=_Lamp,
                        help="instead of --known-lamp for a photo: the lamp's measured SPD (CSV/TXT, CD Spectra "
                             "JSON, pbrt .spd, TM-27-14 XML)")
    parser.set_defaults(lamps=None)
    parser.add_argument("--name", required=True, help="the profile's name")
    parser.add_argument("--preset", default=DEFAULT_PRESET, help=f"capture preset (default {DEFAULT_PRESET})")
    parser.add_argument("--camera", default="auto",
                        help="camera profile (default: from the photo's EXIF Make/Model, else the generic profile; "
                             f"e.g. {DEFAULT_CAMERA})")


def _lamp(kind: str, value: Any) -> tuple[Any, str]:
    """(SPD, name for the profile) of one lamp option; CDSpectraError/OSError for a bad one."""
    from ..core.spectra.illuminants import KNOWN_LAMPS, LAMP_ALIASES, known_lamp_spd
    from ..core.spectra.spectra_files import read_reference_spd

    if kind == "known":
        spd = known_lamp_spd(value)  # a key or a CIE name; CDSpectraError names the choices
        key = value if value in KNOWN_LAMPS else LAMP_ALIASES[value.strip().lower()]
        return spd, KNOWN_LAMPS[key].label
    name, spd = read_reference_spd(value)
    return spd, f"{name} ({Path(value).name})"


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    from ..core.calibration.calibration import calibration_warning, cross_check_summary, load_calibration
    from ..core.inverse.calibration_shot import LampPhoto, calibrate_photos
    from ..core.photo.frames import split_frame

    if not args.name.strip():
        raise UsageError("--name must not be empty")
    lamps = args.lamps or []
    if len(lamps) != len(args.photos):
        raise UsageError(f"{len(lamps)} known lamps for {len(args.photos)} photo{'s' * (len(args.photos) > 1)}: "
                         "give one --known-lamp or --reference-spd per photo, in the photos' order")
    for photo in args.photos:
        try:
            file, _ = split_frame(photo)  # a GIF's frame is named FILE.gif#N
        except ValueError as exc:
            raise UsageError(str(exc)) from exc
        if not Path(file).is_file():
            raise UsageError(f"{photo}: no such file")
    shots = []
    for photo, (kind, value) in zip(args.photos, lamps):
        try:
            spd, reference = _lamp(kind, value)
        except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
            raise UsageError(_about(photo, exc)) from exc
        shots.append(LampPhoto(photo, spd, reference))
    try:
        path = calibrate_photos(shots, args.name, preset=args.preset, camera=args.camera)
    except (ValueError, OSError) as exc:
        message = " ".join(str(exc).split())
        named = any(str(p) in message for p in args.photos)
        raise UsageError(message if named or len(args.photos) > 1 else _about(args.photos[0], exc)) from exc
    out(f"wrote calibration {args.name!r} to {path}")
    made = load_calibration(path)
    checked = cross_check_summary(made)
    if checked:
        out(checked)
    poor = calibration_warning(made)
    if poor:
        out(f"warning: {poor}")
    out(f"use it with: estimate PHOTO --calibration {path.stem}")
    return 0


def _about(photo: Path, exc: BaseException) -> str:
    """One line about ``photo``: the message, led by the photo's name unless it names it."""
    message = " ".join(str(exc).split())
    return message if str(photo) in message else f"{photo}: {message}"
