"""Choose when the blind tails follow a Planck curve, on synthetic spectra only.

    python -m training.learning.tune_tails [--n 400] [--write] [--out bench/tails_tuning.md]

Photos of spectra from the prior's physical lamp families (a seed no other choice uses), at the
reference geometry (cd-default, numpy renderer, 192 px), each through a camera that differs from
its published curves as the training data's do (±2 % gains, ±1 nm; half of them, the other half
with the camera exactly, as after a calibration shot) with 0.3–2 % noise, read
with the true capture (the tails do not depend on the pose fit; the evaluation,
``training.evaluation.tails``, runs the product's whole path). Physics + prior is solved once per
photo and its Planck fit once (:func:`cd_spectra_addon.core.spectrum.tails.planck_fit`); then
each candidate (``thermal_chi2``, ``other_chi2``) gives the tails of
:func:`~cd_spectra_addon.core.spectrum.tails.with_tails`, scored as the fusion tuning scores
(MAE 400–700 + MAE 380–780 + 10·Δu'v'). ``--write`` stores the best in the model's metadata
(``tails``). Measured lamps play no part.
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.inverse.stages import model_prior
from cd_spectra_addon.core.readout import forward_matrix, readout
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.spectrum import solve
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.spectrum.tails import PlanckFit, TailSettings, planck_fit, with_tails

from training.learning.dataset import Degradation, camera_split, perturbed_camera
from training.learning.spd_prior import sample_spds
from training.learning.tune_fusion import TUNING_FAMILIES
from training.simulation import photo
from training.simulation.basis import REPO
from training.simulation.render_numpy import render_cube

SEED = 4711
THERMAL = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0)
SPANS = (1.5, 2.0, 3.0, 5.0)
MAX_TEMPERATURES_K = (3500.0, 4000.0, 4500.0, 5000.0, 6000.0, float("inf"))


@dataclass
class TailCase:
    family: str
    truth: NDArray[np.float64]
    estimate: NDArray[np.float64]  # physics + prior, the rows' units
    rows: solve.Rows
    fit: PlanckFit | None


def tail_cases(n: int, seed: int = SEED, size: int = 192, families: tuple[str, ...] = TUNING_FAMILIES,
               camera_error: float = 0.5, model=None) -> list[TailCase]:
    """``camera_error``: the share of photos whose camera is off its published curves as in
    training (the uncalibrated case); the others have the camera exactly (as after a calibration
    shot, or the reference evaluation's default camera). One rule serves both."""
    model = model or load_model()
    prior = model_prior(model)
    scene = Scene(load_preset("cd-default").with_image_size(size))
    cube = render_cube(scene, supersample=3)
    meter = photo.track_mask(scene)
    cams, _ = camera_split()
    rng = np.random.default_rng(seed)
    spds, labels = sample_spds(n, rng, families=families)
    out = []
    for spd, fam in zip(spds, labels):
        cam = load_camera(cams[int(rng.integers(len(cams)))])
        true_cam = perturbed_camera(cam, rng, Degradation()) if rng.random() < camera_error else cam
        img, _ = photo.synthesize(cube, spd, true_cam, float(rng.uniform(0.5, 1.2)), float(rng.uniform(0.003, 0.02)),
                                  rng, meter)
        prof = readout.extract_readout(img, None, scene)
        matrix = forward_matrix.feature_matrix(forward_matrix.bin_response(scene, prof), cam)
        rows = solve.rows_for(prof, matrix)
        x = solve.solve_prior(rows, prior[0], precision=prior[1], lines=solve.LINE_ALLOWANCE)[:rows.n]
        if not x.max() > 0:
            continue
        out.append(TailCase(fam, np.asarray(spd, dtype=np.float64), x, rows, planck_fit(rows)))
    return out


def score_row(family: str, estimate: NDArray[np.float64], truth: NDArray[np.float64]) -> dict[str, Any]:
    """One photo's figures as the tuning scores them."""
    m = compare_spds(estimate, truth)
    return {"family": family, "mae_400_700": float(m["mae_400_700"]), "mae_380_780": float(m["mae_380_780"]),
            "delta_uv_prime": float(m["delta_uv_prime"])}


def scores(cases: list[TailCase], settings: TailSettings | None) -> list[dict[str, Any]]:
    return [score_row(c.family, with_tails(c.estimate, c.rows, settings, c.fit)[0], c.truth) for c in cases]


def mean_score(rows: list[dict[str, Any]]) -> dict[str, float]:
    """Mean figures and the score (MAE 400–700 + MAE 380–780 + 10·Δu'v', as the fusion tuning)."""
    out = {k: float(np.mean([r[k] for r in rows])) for k in ("mae_400_700", "mae_380_780", "delta_uv_prime")}
    out["score"] = out["mae_400_700"] + out["mae_380_780"] + 10 * out["delta_uv_prime"]
    return out


def tune(cases: list[TailCase]) -> dict[str, Any]:
    grid = [{"thermal_chi2": None, "other_chi2": None, "max_temperature_k": None, **mean_score(scores(cases, None))}]
    for t_max in MAX_TEMPERATURES_K:
        for lo in THERMAL:
            for span in SPANS:
                grid.append({"thermal_chi2": lo, "other_chi2": lo * span, "max_temperature_k": t_max,
                             **mean_score(scores(cases, TailSettings(lo, lo * span, t_max)))})
    best = min(grid[1:], key=lambda r: r["score"])
    chosen = TailSettings(best["thermal_chi2"], best["other_chi2"], best["max_temperature_k"])
    per_family: dict[str, dict[str, dict[str, float]]] = defaultdict(dict)
    for key, settings in (("before", None), ("after", chosen)):
        fam: dict[str, list] = defaultdict(list)
        for r in scores(cases, settings):
            fam[r["family"]].append(r)
        for f, rs in fam.items():
            per_family[f][key] = {**mean_score(rs), "n": len(rs)}
    chi = defaultdict(list)
    for c in cases:
        chi[c.family].append(c.fit.chi2_per_row if c.fit else np.nan)
    return {"n": len(cases), "grid": grid, "best": best, "per_family": dict(per_family),
            "chi2": {f: [float(np.nanmin(v)), float(np.nanmedian(v)), float(np.nanmax(v))] for f, v in chi.items()}}


def report(result: dict[str, Any]) -> str:
    b = result["best"]
    lines = ["# When the blind tails follow a Planck curve, chosen on synthetic spectra "
             "(`python -m training.learning.tune_tails`)", "",
             f"{result['n']} photos of spectra from the prior's physical families (seed {SEED}), cd-default, "
             "numpy renderer at 192 px, half the cameras off their published curves as in training (±2 % gains, "
             "±1 nm) and half exact (as after a calibration shot), "
             "0.3–2 % noise, read with the true capture; physics + prior, then the tails of "
             "`core.spectrum.tails.with_tails`. Score = MAE 400–700 + MAE 380–780 + 10·Δu'v' (as the fusion "
             "tuning). No measured lamp plays a part.", "",
             f"Chosen: fully Planck at χ²/row ≤ **{b['thermal_chi2']:g}**, fully the estimate's own tails at "
             f"≥ **{b['other_chi2']:g}**, and only for a fitted temperature ≤ **{b['max_temperature_k']:g} K**.", "",
             "Per temperature cap, the best pair of χ² thresholds:", "",
             "| hottest thermal T (K) | thermal χ²/row | other χ²/row | MAE 400–700 | MAE 380–780 | Δu'v' | score |",
             "|---|---|---|---|---|---|---|"]
    caps: dict[Any, dict[str, Any]] = {}
    for r in result["grid"]:
        key = r["max_temperature_k"]
        if key not in caps or r["score"] < caps[key]["score"]:
            caps[key] = r
    for r in caps.values():
        mark = " **←**" if r is b else ""
        cap = "never (before)" if r["thermal_chi2"] is None else f"{r['max_temperature_k']:g}"
        lo = "–" if r["thermal_chi2"] is None else f"{r['thermal_chi2']:g}"
        hi = "–" if r["other_chi2"] is None else f"{r['other_chi2']:g}"
        lines.append(f"| {cap} | {lo} | {hi} | {r['mae_400_700']:.4f} | {r['mae_380_780']:.4f} | "
                     f"{r['delta_uv_prime']:.4f} | {r['score']:.4f}{mark} |")
    lines += ["", f"At that cap, every pair tried ({len(THERMAL) * len(SPANS)}):", "",
              "| thermal χ²/row | other χ²/row | MAE 400–700 | MAE 380–780 | Δu'v' | score |", "|---|---|---|---|---|---|"]
    for r in result["grid"]:
        if r["max_temperature_k"] != b["max_temperature_k"]:
            continue
        mark = " **←**" if r is b else ""
        lines.append(f"| {r['thermal_chi2']:g} | {r['other_chi2']:g} | {r['mae_400_700']:.4f} | {r['mae_380_780']:.4f} | "
                     f"{r['delta_uv_prime']:.4f} | {r['score']:.4f}{mark} |")
    lines += ["", "Per family, before (the prior's tails) → after (the chosen rule), and the Planck fit's χ²/row "
              "(min / median / max):", "",
              "| family | n | MAE 400–700 | MAE 380–780 | Δu'v' | Planck χ²/row |", "|---|---|---|---|---|---|"]
    for f in sorted(result["per_family"]):
        p = result["per_family"][f]
        c = result["chi2"][f]
        lines.append(f"| {f} | {p['before']['n']} | {p['before']['mae_400_700']:.4f} → {p['after']['mae_400_700']:.4f} | "
                     f"{p['before']['mae_380_780']:.4f} → {p['after']['mae_380_780']:.4f} | "
                     f"{p['before']['delta_uv_prime']:.4f} → {p['after']['delta_uv_prime']:.4f} | "
                     f"{c[0]:.2f} / {c[1]:.2f} / {c[2]:.2f} |")
    return "\n".join(lines + [""])


def tails_metadata(result: dict[str, Any]) -> dict[str, Any]:
    b = result["best"]
    return {"thermal_chi2": b["thermal_chi2"], "other_chi2": b["other_chi2"],
            "max_temperature_k": b["max_temperature_k"] if np.isfinite(b["max_temperature_k"]) else None,
            "chosen_on": f"{result['n']} synthetic photos of the prior's physical families (bench/tails_tuning.md)"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=REPO / "models" / "cd_spectra.onnx")
    parser.add_argument("--n", type=int, default=400)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "tails_tuning.md")
    parser.add_argument("--write", action="store_true", help="store the choice in the model's metadata")
    args = parser.parse_args(argv)
    model = load_model(args.model)
    result = tune(tail_cases(args.n, model=model))
    text = report(result)
    print(text)
    args.out.write_text(text, encoding="utf-8")
    if args.write:
        side = args.model.with_suffix(".json")
        meta = json.loads(side.read_text(encoding="utf-8"))
        meta["tails"] = tails_metadata(result)
        side.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
