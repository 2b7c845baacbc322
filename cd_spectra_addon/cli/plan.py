"""``python -m cd_spectra_addon plan``: where to put the lamp and the camera.

    python -m cd_spectra_addon plan --lamp-distance-mm D --lamp-size-mm S --focal-mm F
        [--phone | --camera] [--sensor-width-mm W] [--f-number N] [--min-focus-mm M]
        [--lamp-housing-mm H] [--json] [--write-preset OUT.json]

Searches lamp and camera positions with the forward model (core.planner) and prints the steps
(distances, angles), the wavelength range the first order puts on the disc's data area and the
spectral resolution. A phone's focal length is its 35 mm-equivalent unless --sensor-width-mm
gives the real sensor. Impossible equipment exits with status 2 and one ``error:`` line that
says what to change. ``--write-preset`` saves the plan as a capture preset (for rendering and
for ``estimate --preset``); the file appears whole or not at all.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from pathlib import Path

from ..core.errors import CDSpectraError
from .common import UsageError, check_preset_path, write_preset_file

NAME = "plan"
HELP = "where to put the lamp and the camera for the equipment you have"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--lamp-distance-mm", type=float, required=True, help="how far from the disc the lamp can be")
    p.add_argument("--lamp-size-mm", type=float, required=True,
                   help="size of the glowing part (filament, LED, or the hole of a card in front of it)")
    p.add_argument("--focal-mm", type=float, required=True, help="lens focal length (phone: 35 mm-equivalent)")
    kind = p.add_mutually_exclusive_group()
    kind.add_argument("--phone", action="store_true", help="a phone (small lens, small body)")
    kind.add_argument("--camera", action="store_true", help="a camera with a lens (default)")
    p.add_argument("--sensor-width-mm", type=float, default=36.0, help="sensor width (default 36: full frame)")
    p.add_argument("--f-number", type=float, help="aperture (default f/1.8 phone, f/8 camera)")
    p.add_argument("--min-focus-mm", type=float, help="closest focus distance (default 80 phone, 250 camera)")
    p.add_argument("--lamp-housing-mm", type=float, default=80.0, help="size of the lamp's housing (default 80)")
    p.add_argument("--json", action="store_true", help="print the plan as JSON instead of text")
    p.add_argument("--write-preset", type=Path, metavar="OUT.json", help="save the plan as a capture preset")


def _equipment(args: argparse.Namespace) -> "Equipment":
    from ..core.planning.planner import Equipment

    return Equipment(lamp_distance_mm=args.lamp_distance_mm, lamp_size_mm=args.lamp_size_mm,
                     focal_mm=args.focal_mm, sensor_width_mm=args.sensor_width_mm, phone=bool(args.phone),
                     f_number=args.f_number, lamp_housing_mm=args.lamp_housing_mm, min_focus_mm=args.min_focus_mm)


def _text(plan: object) -> str:
    from ..core.planning.planner import Plan, setup_summary as _summary

    assert isinstance(plan, Plan)
    lines = [f"Set-up: {plan.family}"]
    lines += [f"  {i}. {step}" for i, step in enumerate(plan.instructions(), 1)]
    lines.append("Expected:")
    lines += [f"  {line}" for line in _summary(plan.report)]
    where = ", ".join(f"{lam:g} nm at r = {abs(s[0]):.1f} mm" for lam, s in plan.report.positions_mm.items()
                      if s and 23.0 <= abs(s[0]) <= 58.5)
    if where:
        lines.append(f"  along the streak: {where}")
    lines.append(f"  the disc may tip up to {plan.tilt_tolerance_deg:g}° any way before 400–700 nm leaves its tracks")
    return "\n".join(lines)


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    """Plan, print the steps (or the plan as JSON) and write the preset when asked."""
    from ..core.planning.planner import plan_capture

    if args.write_preset is not None:
        check_preset_path(args.write_preset)
    try:
        plan = plan_capture(_equipment(args), name=args.write_preset.stem if args.write_preset else "planned")
        if args.write_preset is not None:
            preset = plan.setup.preset.to_dict()
            preset["description"] = "Planned by python -m cd_spectra_addon plan. " + " ".join(plan.instructions())
            preset["setup"] = {
                "kind": plan.family, "camera_body_mm": list(plan.setup.camera_body_mm),
                "lens_offset_mm": list(plan.setup.lens_offset_mm), "aperture_mm": plan.setup.aperture_mm,
                "source_size_mm": plan.setup.source_size_mm,
                "bodies": [{"name": b.name, "center_mm": list(b.center_mm), "size_mm": list(b.size_mm),
                            "facing": list(b.axes[2]), "passes_source": b.passes_source} for b in plan.setup.bodies],
                "steps": plan.instructions(),
            }
            write_preset_file(args.write_preset, preset)
    except CDSpectraError as exc:
        raise UsageError(str(exc)) from exc
    out(json.dumps(plan.to_dict(), indent=2, ensure_ascii=False) if args.json else _text(plan))
    return 0
