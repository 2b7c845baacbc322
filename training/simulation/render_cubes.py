"""Render (or find in the cache) every basis cube of a training cube set.

    python -m training.simulation.render_cubes [--set full] [--engine cycles]
"""

from __future__ import annotations

import argparse
import time

from training.simulation.basis import basis_cube
from training.learning.dataset import CUBE_SETS


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", default="full", choices=sorted(CUBE_SETS))
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    args = parser.parse_args(argv)
    start = time.perf_counter()
    for spec in CUBE_SETS[args.set]:
        t0 = time.perf_counter()
        basis_cube(spec.scene(), args.engine, log=print)
        print(f"{spec.name}: {time.perf_counter() - t0:.1f} s", flush=True)
    print(f"all cubes in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
