"""The per-band choice on real lamps, measured after it was made (bench/band_choice_real.md).

    python -m training.evaluation.band_choice_real [--every 1] [--synthetic 64] [--model models/cd_spectra.onnx]

Writes the report and its figures beside it (``.json``: per band and overall, for the model card).

``training.learning.tune_fusion`` decides on synthetic photos where the network is used and where
physics + prior is (``fusion.band_weight``). This reports, for honesty and never to revise that
choice, how the three estimates do on the measured lamps of ``make eval`` (LSPDD + colour-science
sources and illuminants; cd-default, Cycles, 8-bit JPEG, 1 % noise — the rows of bench/eval.md):
the shipped per-band blend, the network everywhere (the model without its band weights) and
physics + prior alone, per band and overall. ``--every N`` takes every N-th lamp. A second table
takes the same photos of synthetic spectra (the prior's physical families): where the two
disagree, the lamps' spectra make the difference, not the capture.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.inverse.result import METHOD_MODEL, METHOD_PRIOR
from cd_spectra_addon.core.spectrum.model import load_model

from training.evaluation.evaluate import Condition, Photos, run_condition
from training.evaluation.lamps import Lamp, all_lamps
from training.learning.dataset import CubeSpec
from training.learning.spd_prior import sample_spds
from training.learning.tune_fusion import BANDS_NM, TUNING_FAMILIES, band_mae
from training.simulation.basis import REPO

METHODS = (("blend", "shipped: per-band blend"), ("network", "network (fused) everywhere"),
           ("prior", "physics + prior everywhere"))


def _without_band_weights(model):
    fusion = {k: v for k, v in (model.metadata.get("fusion") or {}).items() if "band_weight" not in k}
    return replace(model, metadata={**model.metadata, "fusion": fusion})


def synthetic_lamps(n: int, seed: int = 8080) -> list[Lamp]:
    """Spectra of the prior's physical families (a seed no choice used), as "lamps" for the same
    photos: the real-lamp test's conditions with the spectra the network was trained on."""
    spds, families = sample_spds(n, np.random.default_rng(seed), families=TUNING_FAMILIES)
    return [Lamp(f"synthetic {i}", fam, "prior", spd) for i, (spd, fam) in enumerate(zip(spds, families))]


def run(model, every: int, engine: str = "cycles", lamps: list[Lamp] | None = None) -> dict:
    lamps = all_lamps()[::every] if lamps is None else lamps
    truth = np.array([lamp.spd for lamp in lamps])
    spec = CubeSpec("eval-nominal", size=384)  # bench/eval.md's real-lamp geometry
    out: dict = {"n": len(lamps), "model_version": model.version}
    fusion = model.metadata.get("fusion") or {}
    network_everywhere = all(np.min(fusion.get(k, [1.0])) >= 1.0 for k in ("band_weight", "calibrated_band_weight"))
    with tempfile.TemporaryDirectory() as tmp:
        photos = Photos(tmp, engine)
        for key, mdl, method in (("blend", model, METHOD_MODEL), ("network", _without_band_weights(model), METHOD_MODEL),
                                 ("prior", model, METHOD_PRIOR)):
            if key == "network" and network_everywhere:  # w = 1 everywhere: the blend is the network
                out[key] = out["blend"]
                continue
            t0 = time.perf_counter()
            rows, estimates, _ = run_condition(photos, Condition("nominal", spec), lamps, mdl, method)
            est = np.array(estimates)
            out[key] = {
                "mae_400_700": float(np.nanmean([r["mae_400_700"] for r in rows])),
                "mae_380_780": float(np.nanmean([r["mae_380_780"] for r in rows])),
                "delta_uv_prime": float(np.nanmean([r["delta_uv_prime"] for r in rows])),
                "bands": np.mean([band_mae(e, t) for e, t in zip(est, truth)], axis=0).tolist(),
                "seconds": time.perf_counter() - t0,
            }
            print(key, {k: v for k, v in out[key].items() if k != "bands"}, flush=True)
    return out


def _tables(result: dict, chosen: dict) -> list[str]:
    lines = ["| band (nm) | chosen on synthetic | " + " | ".join(label for _, label in METHODS) + " |",
             "|---|---|" + "---|" * len(METHODS)]
    for i, (lo, hi) in enumerate(BANDS_NM):
        pick = chosen.get((lo, hi))
        name = "—" if pick is None else ("network" if pick else "physics + prior")
        lines.append(f"| {lo}–{hi} | {name} | " + " | ".join(f"{result[k]['bands'][i]:.4f}" for k, _ in METHODS) + " |")
    lines += ["", "| estimate | MAE 400–700 | MAE 380–780 | Δu'v' |", "|---|---|---|---|"]
    for key, label in METHODS:
        s = result[key]
        lines.append(f"| {label} | {s['mae_400_700']:.4f} | {s['mae_380_780']:.4f} | {s['delta_uv_prime']:.4f} |")
    return lines + [""]


def report(result: dict, model, synthetic: dict | None = None) -> str:
    fusion = model.metadata.get("fusion") or {}
    chosen = {tuple(r["band"]): r["network"] for r in (fusion.get("bands") or {}).get("uncalibrated", [])}
    lines = ["# The per-band choice on real lamps, measured after it was made "
             "(`python -m training.evaluation.band_choice_real`)", "",
             f"Model `{result['model_version']}`; {result['n']} measured lamps (LSPDD, colour-science sources and "
             "illuminants), cd-default, Cycles, 8-bit JPEG, 1 % noise — the real-lamp rows of `make eval`. The "
             "choice of bands (`fusion.band_weight`, bench/fusion_tuning.md) was made on synthetic photos before "
             "this was run and is not revised on these numbers. MAE per band as the headline metrics scale the SPDs "
             "(inside 400–700 nm at peak 1 inside 400–700 nm, the tails at peak 1 over 380–780 nm).", ""]
    lines += _tables(result, chosen)
    if synthetic is not None:
        lines += ["## The same photos of synthetic spectra", "",
                  f"{synthetic['n']} spectra of the prior's physical families (seed 8080) instead of the measured lamps, "
                  "everything else as above: where the two tables disagree, the difference is the lamps' spectra, "
                  "not the capture, camera or file.", ""]
        lines += _tables(synthetic, chosen)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=None)
    parser.add_argument("--every", type=int, default=1, help="every N-th lamp (1: all)")
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    parser.add_argument("--synthetic", type=int, default=64, help="synthetic spectra for the comparison table (0: none)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "band_choice_real.md")
    args = parser.parse_args(argv)
    model = load_model(args.model) if args.model else load_model()
    if not (model.metadata.get("fusion") or {}).get("band_weight"):
        raise SystemExit("the model has no per-band choice yet: run python -m training.learning.tune_fusion --write")
    real = run(model, max(1, args.every), args.engine)
    synthetic = run(model, 1, args.engine, synthetic_lamps(args.synthetic)) if args.synthetic > 0 else None
    text = report(real, model, synthetic)
    print(text)
    args.out.write_text(text, encoding="utf-8")
    bands = [list(b) for b in BANDS_NM]
    args.out.with_suffix(".json").write_text(json.dumps({"bands_nm": bands, "real": real, "synthetic": synthetic},
                                                        indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
