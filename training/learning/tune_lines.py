"""Choose how far the estimate lets narrow lines stand out of the Gaussian prior, on synthetic
spectra only.

    python -m training.learning.tune_lines [--n 600] [--out bench/line_tuning.md]

The photos of :func:`training.learning.tune_tails.tail_cases` (spectra from the prior's physical
lamp families, cd-default, numpy renderer, half the cameras off their published curves), at a
seed no other choice uses. Each candidate (allowance, running-median window) of
:func:`cd_spectra_addon.core.spectrum.solve.solve_prior` re-solves the photo's rows, then the
model's blind tails are applied as the product applies them; scored as the tails tuning scores
(MAE 400–700 + MAE 380–780 + 10·Δu'v'). Allowance 0 is the solve without the line pass. The
choice is written by hand into ``solve.LINE_ALLOWANCE`` / ``LINE_WINDOW`` (a solver constant,
like ``SMOOTHNESS``), not into the model. Measured lamps play no part.
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from cd_spectra_addon.core.inverse.stages import model_prior, tail_settings
from cd_spectra_addon.core.spectrum import solve
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.spectrum.tails import with_tails

from training.learning.tune_tails import TailCase, mean_score, score_row, tail_cases
from training.simulation.basis import REPO

SEED = 4747
ALLOWANCES = (0.0, 0.03, 0.1, 0.3, 1.0)
WINDOWS = (5, 7, 9, 11)


def scores(cases: list[TailCase], allowance: float, window: int, model: Any) -> list[dict[str, Any]]:
    prior, precision = model_prior(model)
    settings = tail_settings(model)
    out = []
    for c in cases:
        x = solve.solve_prior(c.rows, prior, precision=precision, lines=allowance, window=window)[:c.rows.n]
        if not x.max() > 0:
            continue
        est = with_tails(x / x.max(), c.rows, settings)[0] if settings is not None else x
        out.append(score_row(c.family, est, c.truth))
    return out


def tune(cases: list[TailCase], model: Any) -> dict[str, Any]:
    grid, per = [], {}
    for allowance in ALLOWANCES:
        for window in (WINDOWS if allowance > 0 else WINDOWS[:1]):
            rs = scores(cases, allowance, window, model)
            per[(allowance, window)] = rs
            grid.append({"allowance": allowance, "window": window, **mean_score(rs)})
    best = min(grid, key=lambda r: r["score"])
    shipped = next((r for r in grid if r["allowance"] == solve.LINE_ALLOWANCE and r["window"] == solve.LINE_WINDOW),
                   None)
    per_family: dict[str, dict[str, dict[str, float]]] = defaultdict(dict)
    for key, cell in (("before", (0.0, WINDOWS[0])), ("after", (best["allowance"], best["window"]))):
        fam: dict[str, list] = defaultdict(list)
        for r in per[cell]:
            fam[r["family"]].append(r)
        for f, rs in fam.items():
            per_family[f][key] = {**mean_score(rs), "n": len(rs)}
    return {"n": len(cases), "grid": grid, "best": best, "shipped": shipped, "per_family": dict(per_family)}


def report(result: dict[str, Any], seconds: float) -> str:
    b, sh = result["best"], result["shipped"]
    lines = ["# How far narrow lines may stand out of the prior, chosen on synthetic spectra "
             "(`python -m training.learning.tune_lines`)", "",
             f"{result['n']} photos of spectra from the prior's physical families (seed {SEED}), cd-default, numpy "
             "renderer at 192 px, half the cameras off their published curves as in training and half exact, "
             "0.3–2 % noise, read with the true capture (`tune_tails.tail_cases`); physics + prior with the line "
             "pass of `core.spectrum.solve.solve_prior` (allowance 0: without it), then the model's blind tails. "
             "Score = MAE 400–700 + MAE 380–780 + 10·Δu'v'. No measured lamp plays a part. "
             f"{seconds / 60:.1f} min.", "",
             f"Best: allowance **{b['allowance']:g}**, window **{b['window']}** bins. "
             + (f"Shipped (`solve.LINE_ALLOWANCE`, `LINE_WINDOW`): {solve.LINE_ALLOWANCE:g}, {solve.LINE_WINDOW} "
                f"(score {sh['score']:.4f})." if sh else "The shipped setting is not in this grid."), "",
             "| allowance | window (bins) | MAE 400–700 | MAE 380–780 | Δu'v' | score |", "|---|---|---|---|---|---|"]
    for r in result["grid"]:
        mark = " **←**" if r is b else ""
        lines.append(f"| {r['allowance']:g} | {r['window']} | {r['mae_400_700']:.4f} | {r['mae_380_780']:.4f} | "
                     f"{r['delta_uv_prime']:.5f} | {r['score']:.4f}{mark} |")
    lines += ["", "Per family, without the line pass → the best:", "",
              "| family | n | MAE 400–700 | MAE 380–780 | Δu'v' |", "|---|---|---|---|---|"]
    for f in sorted(result["per_family"]):
        p = result["per_family"][f]
        lines.append(f"| {f} | {p['before']['n']} | {p['before']['mae_400_700']:.4f} → {p['after']['mae_400_700']:.4f} | "
                     f"{p['before']['mae_380_780']:.4f} → {p['after']['mae_380_780']:.4f} | "
                     f"{p['before']['delta_uv_prime']:.5f} → {p['after']['delta_uv_prime']:.5f} |")
    return "\n".join(lines + [""])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=REPO / "models" / "cd_spectra.onnx")
    parser.add_argument("--n", type=int, default=600)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "line_tuning.md")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    model = load_model(args.model)
    result = tune(tail_cases(args.n, seed=SEED, model=model), model)
    text = report(result, time.perf_counter() - t0)
    print(text)
    args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
