"""Design the shipped capture set-ups with the planner and write them as presets.

    python tools/design_setups.py [--check]

Each set-up starts from equipment a person has (stated below); the planner
(cd_spectra_addon.core.planning.planner) searches lamp and camera positions with the forward model's
geometry and the result, with what it delivers, is written to
cd_spectra_addon/presets/<name>.json. ``--check`` only compares with the committed files
(exit 1 if they differ), so a change to the physics that moves a set-up is noticed.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from cd_spectra_addon.core.scene.capture import DISTANT_LAMP_PRESET, NEAR_AXIS_PRESET, OBLIQUE_PRESET, PRESET_DIR  # noqa: E402
from cd_spectra_addon.core.planning.planner import Equipment, Plan, plan_capture, setup_summary  # noqa: E402
from cd_spectra_addon.core.planning.setups import NEAR_AXIS, OBLIQUE, TILT_COVERAGE, analyse, setup_from_dict  # noqa: E402

# name → (equipment, families, what it is)
DESIGNS: dict[str, tuple[Equipment, tuple[str, ...], str]] = {
    NEAR_AXIS_PRESET: (
        Equipment(lamp_distance_mm=210.0, lamp_size_mm=2.0, focal_mm=26.0, sensor_width_mm=36.0, phone=True),
        (NEAR_AXIS,),
        "Phone held level over the disc; the source is a 2 mm hole in a card taped beside the lens, the lamp "
        "right behind the card.",
    ),
    OBLIQUE_PRESET: (
        # 200 mm, not version 2's 300 mm: at 300 mm no position tolerates more than 1° of disc tilt
        # (planner.TILT_GOAL_DEG); at 200 mm one tolerates 3° for 13 -> 15.5 nm of blur.
        Equipment(lamp_distance_mm=200.0, lamp_size_mm=3.0, focal_mm=24.0, sensor_width_mm=36.0, phone=False),
        (OBLIQUE,),
        "Full-frame camera with a 24 mm lens at f/8 on a tripod, tilted towards the disc; a small lamp (an LED, "
        "or any lamp behind a card with a 3 mm hole) 200 mm from the disc at an angle.",
    ),
    DISTANT_LAMP_PRESET: (
        Equipment(lamp_distance_mm=2000.0, lamp_size_mm=10.0, focal_mm=26.0, sensor_width_mm=36.0, phone=True),
        (OBLIQUE,),
        "A lamp 2 m away (a bulb of ~10 mm filament or LED cluster: small because it is far); the phone on a "
        "small tripod close to the disc, tilted towards it.",
    ),
}


def _pinhole_parts(plan: Plan) -> dict[str, Any]:
    """The card with the hole and the lamp behind it, for the near-axis set-up."""
    hx, hy, hz = plan.setup.preset.light.position_mm
    out = 1.0 if hx > 0 else -1.0  # the card reaches out past the phone's edge
    return {
        "bodies": [{"name": "card with the hole", "center_mm": [hx + out * 18.0, hy, hz], "size_mm": [40.0, 40.0, 0.5],
                    "facing": [0, 0, -1], "passes_source": True},
                   {"name": "lamp housing", "center_mm": [hx, hy, hz + 70.0], "size_mm": [80.0, 80.0, 80.0],
                    "facing": [0, 0, -1], "passes_source": True}],
        "emitter": {"center_mm": [hx, hy, hz + 30.0], "diameter_mm": 50.0, "facing": [0, 0, -1]},
    }


def design(name: str) -> dict[str, Any]:
    equipment, families, what = DESIGNS[name]
    plan = plan_capture(equipment, name=name, families=families)
    preset = plan.setup.preset.to_dict()
    setup = {
        "kind": plan.family,
        "camera_body_mm": list(plan.setup.camera_body_mm),
        "lens_offset_mm": list(plan.setup.lens_offset_mm),
        "aperture_mm": round(plan.setup.aperture_mm, 3),
        "source_size_mm": plan.setup.source_size_mm,
        "bodies": [{"name": b.name, "center_mm": [round(v, 3) for v in b.center_mm], "size_mm": list(b.size_mm),
                    "facing": [round(v, 6) for v in b.axes[2]], "passes_source": b.passes_source}
                   for b in plan.setup.bodies],
        "equipment": {k: v for k, v in equipment.__dict__.items() if v is not None},
        "steps": plan.instructions(),
    }
    if plan.family == NEAR_AXIS:
        setup.update(_pinhole_parts(plan))
    final = setup_from_dict(plan.setup.preset, setup)
    report = analyse(final)
    if not report.covers_visible or report.occlusions:
        raise SystemExit(f"{name}: the finished set-up fails its own check: {setup_summary(report)}")
    lo, hi = report.covered_nm or (0, 0)
    worst = max(report.resolution_nm.values())
    preset["description"] = (f"{what} First order covers {lo:.0f}-{hi:.0f} nm on the data area "
                             f"({plan.read_side}), and keeps {100 * TILT_COVERAGE:.0f} % of it with the disc "
                             f"tilted up to {plan.tilt_tolerance_deg:g} deg; spectral blur <= {worst:.0f} nm FWHM. "
                             "Designed by tools/design_setups.py with the capture planner.")
    preset["light"] = {k: (round(v, 6) if isinstance(v, float) else [round(x, 3) for x in v])
                       for k, v in preset["light"].items()}
    if "position_mm" in preset["camera"]:
        preset["camera"]["position_mm"] = [round(v, 3) for v in preset["camera"]["position_mm"]]
        preset["camera"].pop("distance_mm", None)  # derived from the position
    preset["setup"] = setup
    return preset


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="compare with the committed presets only")
    args = parser.parse_args(argv)
    status = 0
    for name in DESIGNS:
        text = json.dumps(design(name), indent=2, ensure_ascii=False) + "\n"
        path = PRESET_DIR / f"{name}.json"
        if args.check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                print(f"{path.name} differs from what the planner designs now", file=sys.stderr)
                status = 1
        else:
            path.write_text(text, encoding="utf-8")
            print(path)
    return status


if __name__ == "__main__":
    sys.exit(main())
