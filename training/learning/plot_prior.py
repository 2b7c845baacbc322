"""Eyeball the SPD prior: a few random spectra per family in one PNG (default out/spd_prior.png).

    .venv/bin/python -m training.learning.plot_prior [--per-family 6] [--seed 0] [--out out/spd_prior.png]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from training.learning.spd_prior import FAMILIES, sample_spds


def main(argv: list[str] | None = None) -> Path:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--per-family", type=int, default=6)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path("out/spd_prior.png"))
    args = ap.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(args.seed)
    cols = 4
    rows = math.ceil(len(FAMILIES) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 2.6 * rows), sharex=True, sharey=True)
    for ax, fam in zip(axes.flat, FAMILIES, strict=False):
        spds, _ = sample_spds(args.per_family, rng, families=[fam])
        for spd in spds:
            ax.plot(WAVELENGTHS_NM, spd, lw=0.9)
        ax.set_title(fam, fontsize=9)
        ax.set_ylim(0, 1.05)
    for ax in list(axes.flat)[len(FAMILIES):]:
        ax.axis("off")
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=90)
    print(args.out)
    return args.out


if __name__ == "__main__":
    main()
