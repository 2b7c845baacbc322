"""Does the network beat physics + prior on *kinds* of lamp it never saw? Synthetic only.

    python -m training.learning.heldout_families --dataset data/dataset/<set>-<key>.npz [--set buildable]
                                                 [--epochs 30] [--n 48] [--out bench/heldout_families.md]

The per-band choice (:mod:`.tune_fusion`) compares the network with physics + prior on new spectra
of the families it was trained on. A real lamp is not one of those: it is a new instance, often
of a shape no family draws. This asks the question with synthetic data alone: for each group of
the physical families, a probe network (same architecture and loss, fewer epochs) is trained on a
dataset without that group, fused with the photo as the product does, and compared per band with
physics + prior on photos of the group it never saw; the paired differences of all groups are
pooled and decided by the same rule as :func:`.tune_fusion.band_rows`. ``filtered`` (gels over any
base) stays in every probe's training, so a held-out group still leaks in through its filtered
versions: the probe is optimistic for the network, if anything. A diagnostic: the shipped weight
comes from :mod:`.tune_fusion`.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from training.learning.dataset import CUBE_SETS, SHIPPED_SET
from training.learning.spd_prior import gaussian_prior
from training.learning.train import train
from training.learning.tune_fusion import TUNING_FAMILIES, best_setting, fusion_cases, setting_grid, band_errors, band_rows
from training.simulation.basis import REPO

# Thermal and arc continua / LEDs / line sources: each group is a way of making light the probe
# trained without it has never seen.
GROUPS: tuple[tuple[str, ...], ...] = (
    ("blackbody", "incandescent", "daylight", "xenon", "xenon_flash"),
    ("led_white", "led_violet", "led_rgb", "led_grow"),
    ("fluorescent_tri", "fluorescent_halo", "metal_halide", "hps", "lps", "mercury"),
)


class TorchModel:
    """A trained torch network behind the :class:`SpectralModel` interface the tuning uses."""

    def __init__(self, net: torch.nn.Module, prior_metadata: dict[str, Any]):
        self.net = net.eval()
        self.metadata = {"prior": prior_metadata}

    def predict(self, inputs: NDArray[np.float32]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        x = np.atleast_2d(np.asarray(inputs, dtype=np.float32))
        with torch.no_grad():
            spd, log_std = self.net(torch.from_numpy(x))
        spd, std = spd.numpy().astype(np.float64), np.exp(log_std.numpy().astype(np.float64))
        return (spd[0], std[0]) if np.ndim(inputs) == 1 else (spd, std)


def run(data: dict[str, NDArray], cube_set: str, epochs: int, n: int, engine: str, log=print) -> dict[str, Any]:
    assert {f for g in GROUPS for f in g} == set(TUNING_FAMILIES) - {"filtered"}, "groups must cover the families"
    prior = gaussian_prior()
    prior_meta = {"mean": prior.mean.tolist(), "covariance": prior.covariance.tolist()}
    families = np.asarray(data["family"]).astype(str)
    nets, pris, groups = [], [], []
    for k, group in enumerate(GROUPS):
        keep = ~np.isin(families, group)
        t0 = time.perf_counter()
        net, info = train({"inputs": data["inputs"][keep], "targets": data["targets"][keep]}, epochs, seed=100 + k,
                          log=lambda *_: None)
        model = TorchModel(net, prior_meta)
        cases = fusion_cases(model, cube_set, n, engine, seed=4242 + k, families=group)
        best = best_setting(setting_grid(cases))
        a, b = band_errors(cases, best["strength"], best["floor"])
        nets.append(a)
        pris.append(b)
        groups.append({"held_out": list(group), "train_samples": int(keep.sum()), "photos": len(cases),
                       "val_mae": info["val_mae"], "strength": best["strength"], "floor": best["floor"],
                       "bands": band_rows(a, b), "seconds": time.perf_counter() - t0})
        log(f"held out {group}: {groups[-1]['train_samples']} training samples, {len(cases)} photos, "
            f"{groups[-1]['seconds']:.0f} s")
    return {"groups": groups, "pooled": band_rows(np.concatenate(nets), np.concatenate(pris)), "epochs": epochs,
            "n_photos": n, "cube_set": cube_set, "samples": int(len(families))}


def report(result: dict[str, Any], dataset: str) -> str:
    lines = ["# Held-out lamp families: network vs physics + prior per band (`python -m training.learning.heldout_families`)",
             "", f"Synthetic only. Dataset `{dataset}` ({result['samples']} samples, `{result['cube_set']}` geometries); "
             f"per group, a probe network ({result['epochs']} epochs) trained without the group, fused with the photo at "
             f"its best strength, and physics + prior, on {result['n_photos']} photos of the held-out group's spectra "
             "(refused photos left out). MAE per band as bench/fusion_tuning.md scores it (inside 400–700 nm at the 400–700 "
             "nm peak, the tails at the 380–780 nm peak); *used*: the tuning rule (network only "
             "where better by more than the paired standard error). `filtered` stays in training (its held-out bases leak "
             "in through it). A diagnostic of how the network does on kinds of lamp it never saw; the shipped weight "
             "comes from `tune_fusion` (bench/fusion_tuning.md).", ""]
    header = ["| band (nm) | network | physics + prior | paired SE | used |", "|---|---|---|---|---|"]

    def table(rows: list[dict[str, Any]]) -> list[str]:
        return header + [f"| {r['band'][0]}–{r['band'][1]} | {r['mae_network']:.4f} | {r['mae_prior']:.4f} | "
                         f"{r['se']:.4f} | {'network' if r['network'] else 'physics + prior'} |" for r in rows] + [""]

    lines += ["## Pooled over the groups", ""] + table(result["pooled"])
    for g in result["groups"]:
        lines += [f"## Held out: {', '.join(g['held_out'])}", "",
                  f"{g['train_samples']} training samples (synthetic validation MAE {g['val_mae']:.4f}), {g['photos']} "
                  f"photos read, fusion strength {g['strength']:g} floor {g['floor']:g}.", ""] + table(g["bands"])
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", type=Path, required=True)
    parser.add_argument("--set", default=SHIPPED_SET, choices=sorted(CUBE_SETS))
    parser.add_argument("--epochs", type=int, default=30)
    parser.add_argument("--n", type=int, default=48)
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "heldout_families.md")
    args = parser.parse_args(argv)
    torch.set_num_threads(args.threads)
    data = dict(np.load(args.dataset))
    result = run(data, args.set, args.epochs, args.n, args.engine)
    text = report(result, args.dataset.name)
    print(text)
    args.out.write_text(text, encoding="utf-8")
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
