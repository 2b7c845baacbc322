"""``python -m cd_spectra_addon setup``: a set-up you measured, as a preset, and what it delivers.

    python -m cd_spectra_addon setup --lamp-distance-mm D --lamp-angle-deg A --lamp-azimuth-deg Z
        --camera-distance-mm D --camera-angle-deg A [--camera-azimuth-deg Z] [--disc cd|dvd]
        [--lamp-size-mm S] [--focal-mm F] [--sensor-width-mm W] [--aperture-mm P]
        [--image-size W H] [--name NAME] [--write-preset OUT.json] [--save] [--json]

Lamp and camera wherever they were: each by its distance from the disc centre (mm), its angle
from the disc's axis (degrees: 0 straight above the disc, 90 in its plane) and its azimuth
around the axis (degrees, seen from above the disc, counter-clockwise; the lamp's minus the
camera's is how far counter-clockwise the lamp stands from the camera). The camera is taken as
aimed at the disc centre and held upright. Prints where the first order lands on the data area
(per arm of its curve), which wavelengths, which other orders show visible light there, the
mirror glint and the spectral blur. ``--write-preset`` saves the preset as a file, ``--save``
into your presets folder so ``estimate --preset NAME`` and Blender's preset menu find it; each
file appears whole or not at all. Bad numbers exit with status 2 and one ``error:`` line.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core.errors import CDSpectraError
from .common import UsageError, check_preset_path, write_preset_file

NAME = "setup"
HELP = "a set-up you measured (lamp and camera anywhere) as a preset, and what it delivers"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--lamp-distance-mm", type=float, required=True, help="lamp's distance from the disc centre")
    p.add_argument("--lamp-angle-deg", type=float, required=True,
                   help="lamp's angle from the disc's axis (0: straight above the disc, 90: in its plane)")
    p.add_argument("--lamp-azimuth-deg", type=float, required=True,
                   help="lamp's azimuth around the axis, seen from above the disc, counter-clockwise")
    p.add_argument("--camera-distance-mm", type=float, required=True, help="lens's distance from the disc centre")
    p.add_argument("--camera-angle-deg", type=float, required=True, help="camera's angle from the disc's axis")
    p.add_argument("--camera-azimuth-deg", type=float, default=0.0,
                   help="camera's azimuth, measured like the lamp's (default 0)")
    p.add_argument("--disc", choices=("cd", "dvd"), default="cd", help="cd (pitch 1.6 µm, default) or dvd (0.74 µm)")
    p.add_argument("--lamp-size-mm", type=float, help="size of the glowing part (filament, LED, a card's hole)")
    p.add_argument("--focal-mm", type=float, default=26.0,
                   help="lens focal length (default 26: a phone's main camera, 35 mm-equivalent)")
    p.add_argument("--sensor-width-mm", type=float, default=36.0,
                   help="sensor width the focal length is for (default 36: 35 mm-equivalent)")
    p.add_argument("--aperture-mm", type=float, default=3.0,
                   help="lens entrance pupil, focal length / f-number (default 3: a phone's, or 24 mm at f/8)")
    p.add_argument("--image-size", type=int, nargs=2, metavar=("W", "H"), default=(512, 512),
                   help="image size of the preset in pixels (default 512 512)")
    p.add_argument("--name", help="the preset's name (default: the --write-preset file's name, else 'measured')")
    p.add_argument("--write-preset", type=Path, metavar="OUT.json", help="save the preset as this file")
    p.add_argument("--save", action="store_true",
                   help="save the preset in your presets folder (estimate --preset NAME finds it)")
    p.add_argument("--json", action="store_true", help="print the set-up and its analysis as JSON instead of text")


def _measurements(args: argparse.Namespace) -> Any:
    from ..core.planning.measured import Measurements

    name = args.name or (args.write_preset.stem if args.write_preset else "measured")
    return Measurements(
        lamp_distance_mm=args.lamp_distance_mm, lamp_angle_deg=args.lamp_angle_deg,
        lamp_azimuth_deg=args.lamp_azimuth_deg, camera_distance_mm=args.camera_distance_mm,
        camera_angle_deg=args.camera_angle_deg, camera_azimuth_deg=args.camera_azimuth_deg, disc=args.disc,
        lamp_size_mm=args.lamp_size_mm, focal_mm=args.focal_mm, sensor_width_mm=args.sensor_width_mm,
        image_size_px=tuple(args.image_size), aperture_mm=args.aperture_mm, name=name)


def _along(report: Any) -> list[str]:
    """Where 400, 450, …, 700 nm land, per arm (or side) on the data area."""
    lines = []
    word = "side" if report.coplanar else "arm"
    for side in (1, -1):
        where = [f"{lam:g} nm at r = {abs(x):.1f} mm" for lam, xs in report.positions_mm.items() for x in xs
                 if x * side > 0 and 23.0 <= abs(x) <= 58.5]
        if where:
            lines.append(f"  along {word} {'+' if side > 0 else '−'}: {', '.join(where)}")
    return lines


def _text(data: dict[str, Any], report: Any, written: list[str]) -> str:
    from ..core.planning.planner import setup_summary

    lines = [f"Set-up '{data['name']}': {data['description']}"]
    lines += [f"  {i}. {step}" for i, step in enumerate(data["setup"]["steps"], 1)]
    lines.append("Expected:")
    lines += [f"  {line.strip()}" if not line.startswith("  ") else f"  {line}" for line in setup_summary(report)]
    lines += _along(report)
    if report.glint_mm:
        lines.append("  mirror glint (zero order) on the streak at r = "
                     + ", ".join(f"{abs(g):.1f} mm ({'+' if g > 0 else '−'})" for g in report.glint_mm))
    else:
        lines.append("  no mirror glint on the streak")
    lines += written
    return "\n".join(lines)


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """Check the numbers, analyse the set-up, write the preset where asked, print what it gives."""
    from ..core.planning.measured import measured_preset_data
    from ..core.planning.setups import analyse, setup_from_dict
    from ..core.scene.capture import preset_from_dict, save_user_preset, user_preset_name

    if args.write_preset is not None:
        check_preset_path(args.write_preset)  # before the analysis, as plan does
    try:
        measurements = _measurements(args)
        if args.save:
            user_preset_name(measurements.name)  # refuse a name that cannot be saved before anything is written
        data = measured_preset_data(measurements)
        report = analyse(setup_from_dict(preset_from_dict(data), data["setup"]))
        written = []
        if args.write_preset is not None:
            write_preset_file(args.write_preset, data)
            written.append(f"wrote {args.write_preset}")
        if args.save:
            path = save_user_preset(data)
            written.append(f"saved as preset '{path.stem}' in {path.parent} (estimate --preset {path.stem})")
    except CDSpectraError as exc:
        raise UsageError(str(exc)) from exc
    if args.json:
        out(json.dumps({"preset": data, "report": report.to_dict(), "written": written}, indent=2, ensure_ascii=False))
    else:
        out(_text(data, report, written))
    return 0
