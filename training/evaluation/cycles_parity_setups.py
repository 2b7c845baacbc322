"""Cycles vs the numpy twin on the buildable set-ups, per image size (simulator only).

    python -m training.evaluation.cycles_parity_setups [--out bench/cycles_parity_setups.md]

For each set-up preset (and an on-axis camera with the lamp 30 mm beside the lens, which
makes the same thin streaks with no full-pose code involved) it renders three bands with
both engines and prints the ratio of the image means (Cycles / numpy). The image mean is the
image-plane integral of radiance, so it must not depend on the pixel size; the numpy twin's
does not (converged in supersampling), so a ratio that moves with the size is a sampling
bias on the Cycles side. Needs bpy.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Pose, Scene, load_preset
from cd_spectra_addon.core.planning.setups import setup_names

from training.simulation import cycles_scene
from training.simulation.render_numpy import render_cube

BANDS_NM = (450.0, 550.0, 650.0)
SIZES = (192, 512)
SPP = 256


def ratios(scene: Scene) -> list[float]:
    lam = np.array(BANDS_NM)
    index = [int((x - 380) / 5) for x in BANDS_NM]
    ref = render_cube(scene, supersample=8)[index].astype(np.float64)
    cycles, _ = cycles_scene.render_cube(scene, lam, SPP)
    return [float(cycles[k].mean() / ref[k].mean()) for k in range(lam.size)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, help="also write the table here (markdown)")
    args = parser.parse_args(argv)
    cases = [(name, lambda n, name=name: Scene(load_preset(name).with_image_size(n))) for name in setup_names()]
    cases.append((f"{REFERENCE_PRESET}, lamp 30 mm beside the lens",
                  lambda n: Scene(load_preset(REFERENCE_PRESET).with_image_size(n), Pose(light_offset_mm=(30.0, 0.0)))))
    cases.append((f"{REFERENCE_PRESET} (coaxial rings)",
                  lambda n: Scene(load_preset(REFERENCE_PRESET).with_image_size(n))))
    lines = ["# Cycles / numpy twin image-mean ratio per band (simulator only)", "",
             f"`python -m training.evaluation.cycles_parity_setups` — Cycles {SPP} spp, numpy 8×8 per pixel", "",
             "| scene | " + " | ".join(f"{n} px: {' / '.join(f'{b:.0f}' for b in BANDS_NM)} nm" for n in SIZES) + " |",
             "|---|" + "---|" * len(SIZES)]
    for label, make in cases:
        cells = [" / ".join(f"{r:.3f}" for r in ratios(make(n))) for n in SIZES]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
        print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if args.out:
        args.out.write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
