"""Render one basis cube (per-band radiance, 380–780 nm / 5 nm) to a spectral OpenEXR.

    python -m training.simulation.render_basis --preset cd-default --out data/basis/cd-default.exr
        [--size W [H]] [--samples N] [--engine cycles|numpy] [--seed N]
        [--camera-offset-mm X Y] [--light-offset-mm X Y] [--tilt-deg X Y]
        [--camera-rotation-deg X Y] [--light-rotation-deg X Y]

Channels follow Fichet et al. (2021) (``S0.380,0nm`` …); the capture geometry goes to a JSON
sidecar next to the file. Cycles renders three bands per render with the OSL grating shader.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation.basis import ENGINES, render_basis
from training.simulation.render_photo import add_pose_arguments, scene_from_args
from training.simulation.spectral_exr import write_spectral_exr


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m training.simulation.render_basis", description=__doc__.splitlines()[0])
    p.add_argument("--preset", default=DEFAULT_PRESET)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--size", type=int, nargs="+", metavar="PX")
    p.add_argument("--samples", type=int, help="Cycles samples per pixel (default: preset)")
    p.add_argument("--engine", choices=ENGINES, default="cycles")
    p.add_argument("--seed", type=int, default=0)
    add_pose_arguments(p)
    args = p.parse_args(argv)
    try:
        scene = scene_from_args(args)
        cube, meta = render_basis(scene, args.engine, args.samples, args.seed)
        write_spectral_exr(args.out, cube, WAVELENGTHS_NM, meta)
    except (ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.out} ({meta['render_seconds']:.1f} s, {args.engine}, {meta['samples']} samples)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
