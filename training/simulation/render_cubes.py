"""Render (or find in the cache) every basis cube of a training cube set.

    python -m training.simulation.render_cubes [--set buildable] [--engine cycles] [--report bench/buildable_cubes.md]

``--report`` writes each cube's geometry and render time (a cube found in the cache reports the
time it took when it was rendered) with the machine's load, so ``make model``'s cost is on record.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

from training.simulation.basis import basis_cube
from training.learning.dataset import CUBE_SETS, SHIPPED_SET, CubeSpec


def _pose(spec: CubeSpec) -> str:
    scene = spec.scene()
    parts = [f"σ {scene.preset.light.lobe_sigma:g}"]
    for label, value in (("lamp ±mm", spec.light_offset_mm), ("lamp °", spec.light_rotation_deg),
                         ("camera ±mm", spec.camera_offset_mm), ("camera °", spec.camera_rotation_deg),
                         ("tilt °", spec.tilt_deg)):
        if any(value):
            parts.append(f"{label} ({value[0]:g}, {value[1]:g})")
    return ", ".join(parts)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default=SHIPPED_SET, choices=sorted(CUBE_SETS))
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    parser.add_argument("--report", type=Path, default=None)
    args = parser.parse_args(argv)
    start = time.perf_counter()
    load0 = os.getloadavg()[1]
    rows = []
    for spec in CUBE_SETS[args.set]:
        t0 = time.perf_counter()
        cube, meta = basis_cube(spec.scene(), args.engine, log=print)
        took = time.perf_counter() - t0
        print(f"{spec.name}: {took:.1f} s", flush=True)
        rows.append((spec, cube.shape, float(meta.get("render_seconds", took)), meta.get("samples")))
    total = time.perf_counter() - start
    print(f"all cubes in {total:.0f} s")
    if args.report:
        lines = [f"# Basis cubes of the `{args.set}` set (`python -m training.simulation.render_cubes --set {args.set} "
                 f"--report ...`)", "",
                 f"{args.engine}, {os.cpu_count()} CPUs, 5-minute load average {load0:.1f} at the start and "
                 f"{os.getloadavg()[1]:.1f} at the end (the machine is shared: above ~2 the times are inflated). "
                 "Render seconds as each cube was rendered (cached cubes keep their first time).", "",
                 "| cube | preset | size | focal × | samples | pose | render s |", "|---|---|---|---|---|---|---|"]
        for spec, shape, seconds, spp in rows:
            lines.append(f"| {spec.name} | {spec.preset} | {shape[2]}×{shape[1]} | {spec.focal_multiplier:g} | {spp} | "
                         f"{_pose(spec)} | {seconds:.0f} |")
        lines += ["", f"Total render time of the set: {sum(r[2] for r in rows) / 60:.1f} min.", ""]
        args.report.write_text("\n".join(lines), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
