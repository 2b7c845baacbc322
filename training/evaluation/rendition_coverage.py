"""Do the colour-rendition ranges cover the truth? (``make eval-rendition`` → bench/rendition.md, .json)

    python -m training.evaluation.rendition_coverage [--quick] [--engine cycles|numpy] [--out bench/rendition.md]
    python -m training.evaluation.rendition_coverage --timing-only [--out bench/rendition_timing.md]

Photos as in ``make eval``'s real-lamp table (the nominal cd-default capture rendered through the
forward model, 8-bit JPEG q90, 1 % noise, the default camera), estimated by the product
(``estimate_image``), then:

(i)   the choice: the correlation length of the SPDs drawn from ``spd_std`` and the factor on
      ``spd_std`` (:mod:`cd_spectra_addon.core.rendition.uncertainty`) on *synthetic* photos of
      the prior's physical lamp families — of the pairs whose 90 % ranges cover the true Ra, R9,
      Rf and Rg on at least 90 % of the photos, the one with the narrowest ranges;
(ii)  the measurement: the same on the real lamps the model never saw (205 LSPDD lamps plus
      colour-science's measured sources and CIE illuminants), for every candidate, the shipped
      one marked — the real lamps choose nothing;
(iii) the time: the rendition of one estimate (its figures and those of the drawn SPDs).

Coverage counts lamps whose figures are defined both for the truth and for the estimate (a light
far from white has none); a range flagged "too wide" still counts as covering or not.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.rendition.result import DEFAULT_SAMPLES, TOO_WIDE, rendition
from cd_spectra_addon.core.rendition.uncertainty import CORRELATION_NM, STD_SCALE
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, load_preset
from cd_spectra_addon.core.spectrum.model import load_model

from training.evaluation.evaluate import RENDITION_FIGURES as FIGURES
from training.evaluation.evaluate import RENDITION_LABELS as LABELS
from training.evaluation.evaluate import Condition, Photos, rendition_scores, rendition_summary
from training.evaluation.lamps import all_lamps
from training.learning.dataset import CubeSpec
from training.learning.spd_prior import sample_spds
from training.learning.tune_fusion import TUNING_FAMILIES
from training.simulation.basis import REPO

HEADLINE = FIGURES[:4]
CANDIDATES_NM = (0.0, 10.0, 20.0, 40.0, 80.0)  # 0: independent per 5 nm sample
CANDIDATE_SCALES = (1.0, 1.25, 1.5, 2.0)
SHIPPED = (CORRELATION_NM, STD_SCALE)
GOAL = 0.90
SEED = 2024

__all__ = ["main"]


def _estimates(photos: Photos, cond: Condition, spds: list[np.ndarray], model: Any, seed: int
               ) -> list[dict[str, Any]]:
    """The product's estimate of each photo: SPD, uncertainty, its rendition and its time."""
    preset = load_preset(cond.spec.preset)
    out = []
    for i, spd in enumerate(spds):
        path = photos.write(cond, spd, seed=seed * 100_003 + i)
        image = photos.read(cond, path)
        est = estimate_image(image, preset=preset, camera=cond.camera, model=model)
        out.append({"spd": est.spd, "std": est.spd_std, "truth": spd, "rendition_ms": est.timing_ms["rendition"]})
        if (i + 1) % 25 == 0:
            print(f"  {i + 1}/{len(spds)} estimated", flush=True)
    return out


def _save_cases(path: Path, synthetic: list[dict[str, Any]], real: list[dict[str, Any]], seconds: float) -> None:
    arrays = {f"{name}_{key}": np.array([c[key] for c in cases]) for name, cases in (("synthetic", synthetic),
              ("real", real)) for key in ("spd", "std", "truth", "rendition_ms")}
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, seconds=np.array(seconds), **arrays)


def _load_cases(path: Path) -> tuple[list[dict[str, Any]], list[dict[str, Any]], float]:
    with np.load(path) as data:
        cases = [[{key: data[f"{name}_{key}"][i] for key in ("spd", "std", "truth", "rendition_ms")}
                  for i in range(data[f"{name}_spd"].shape[0])] for name in ("synthetic", "real")]
        return cases[0], cases[1], float(data["seconds"]) if "seconds" in data.files else math.nan


def coverage(cases: list[dict[str, Any]], correlation_nm: float, scale: float) -> dict[str, Any]:
    """Per figure (``evaluate.rendition_summary``): lamps scored, share covered, errors, range
    widths, share flagged — with the draws correlated over ``correlation_nm`` and ``spd_std``
    multiplied by ``scale``."""
    rows = [rendition_scores(rendition(c["spd"], c["std"], correlation_nm=correlation_nm, std_scale=scale), c["truth"])
            for c in cases]
    undefined_truth = sum(not rendition(c["truth"])["defined"] for c in cases)
    scored = sum(math.isfinite(r["covered_cri_ra"]) for r in rows)
    return {"correlation_nm": correlation_nm, "std_scale": scale, "undefined_truth": undefined_truth,
            "undefined_estimate": len(cases) - undefined_truth - scored, **rendition_summary(rows)}


def choose(rows: list[dict[str, Any]]) -> tuple[float, float]:
    """(correlation length, factor on spd_std): of the pairs whose ranges cover Ra, R9, Rf and Rg
    on at least :data:`GOAL` of the photos, the one with the narrowest ranges (median widths, each
    relative to its "too wide" limit); failing that, the one whose worst headline coverage is
    best. Widths are not monotonic in the length: a perturbation correlated over the whole
    spectrum only rescales it, which changes no figure."""
    worst = [min(r[k]["coverage"] for k in HEADLINE) for r in rows]
    width = [sum(r[k]["median_width"] / TOO_WIDE[k] for k in HEADLINE) for r in rows]
    good = [i for i, w in enumerate(worst) if w >= GOAL]
    best = min(good, key=lambda i: width[i]) if good else int(np.argmax(worst))
    return float(rows[best]["correlation_nm"]), float(rows[best]["std_scale"])


def _white_synthetic(n: int, seed: int) -> list[np.ndarray]:
    """``n`` spectra of the prior's physical families whose rendition is defined (white-ish)."""
    rng = np.random.default_rng(seed)
    kept: list[np.ndarray] = []
    while len(kept) < n:
        spds, _ = sample_spds(4 * n, rng, families=TUNING_FAMILIES)
        kept += [s for s in spds if rendition(s)["defined"]]
    return kept[:n]


def timing(repeats: int = 30) -> dict[str, Any]:
    """ms for one estimate's rendition (the figures of the SPD and of its drawn SPDs), on a
    fluorescent estimate's SPD and uncertainty; the first call (tables loaded) apart."""
    import colour

    from cd_spectra_addon.core.spectra.grid import resample_to_grid

    sd = colour.SDS_ILLUMINANTS["FL11"]
    spd = resample_to_grid(sd.wavelengths, sd.values)
    spd = spd / spd.max()
    std = 0.01 + 0.04 * spd  # the order of the shipped model's spd_std on such a lamp
    t0 = time.perf_counter()
    rendition(spd, std)
    first = (time.perf_counter() - t0) * 1e3
    out: dict[str, Any] = {"first_call_ms": first, "threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
                           "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs",
                           "load_average": os.getloadavg()[0] if hasattr(os, "getloadavg") else math.nan}
    for samples in (0, 50, DEFAULT_SAMPLES, 200):
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            rendition(spd, std if samples else None, samples=max(samples, 10))
            times.append((time.perf_counter() - t0) * 1e3)
        out[f"samples_{samples}"] = {"median_ms": float(np.median(times)), "min_ms": float(np.min(times))}
    return out


def _fmt(v: float, digits: int = 1) -> str:
    return "–" if not isinstance(v, (int, float)) or math.isnan(v) else f"{v:.{digits}f}"


def _table(rows: list[dict[str, Any]], chosen: tuple[float, float]) -> list[str]:
    lines = ["| correlation, × spd_std | " + " | ".join(f"{LABELS[k]} covered" for k in FIGURES) + " | " +
             " | ".join(f"{LABELS[k]} median width" for k in HEADLINE) + " |",
             "|---|" + "---|" * (len(FIGURES) + len(HEADLINE))]
    for r in rows:
        pair = (r["correlation_nm"], r["std_scale"])
        name = ("independent" if pair[0] == 0 else f"{pair[0]:g} nm") + f", ×{pair[1]:g}"
        if pair == tuple(chosen):
            name = f"**{name}** (chosen)"
        if pair == SHIPPED:
            name += " (shipped)"
        lines.append(f"| {name} | " + " | ".join(f"{100 * r[k]['coverage']:.0f} %" for k in FIGURES) + " | " +
                     " | ".join(_fmt(r[k]["median_width"]) for k in HEADLINE) + " |")
    return lines


def _errors(row: dict[str, Any]) -> list[str]:
    lines = ["| figure | lamps | covered | median abs error | mean abs error | median range width | flagged too wide |",
             "|---|---|---|---|---|---|---|"]
    for k in FIGURES:
        r = row[k]
        lines.append(f"| {LABELS[k]} | {r['n']} | {100 * r['coverage']:.1f} % | {_fmt(r['median_abs_error'])} | "
                     f"{_fmt(r['mean_abs_error'])} | {_fmt(r['median_width'])} | {100 * r['too_wide']:.0f} % "
                     f"(> {TOO_WIDE[k]:g}) |")
    return lines


def render_markdown(r: dict[str, Any]) -> str:
    shipped = next(row for row in r["real"] if (row["correlation_nm"], row["std_scale"]) == SHIPPED)
    chosen = tuple(r["chosen"])
    t = r.get("timing") or {}
    lines = [
        "# Colour rendition: do the ranges cover the truth? (`make eval-rendition`)", "",
        f"Model `{r['model_version']}`; {r['engine']} captures of the nominal `{REFERENCE_PRESET}` set-up, "
        "8-bit JPEG q90, "
        "1 % noise, the default camera — the photos of `make eval`'s real-lamp table — estimated by the product. "
        f"Ranges: 5–95 % of {DEFAULT_SAMPLES} SPDs drawn from `spd` ± k · `spd_std`, correlated over a length, both "
        "chosen below, widened to include the estimate's own value and, for Ra, R9 and Rf near 100, up to 100 "
        "(`core/rendition/result.py`). Figures: CIE 13.3 Ra "
        "and R9, TM-30 Rf and Rg, dominant wavelength λd (from illuminant E) and peak wavelength λpeak. "
        f"Run time {r['seconds'] / 60:.1f} min.", "",
        f"## (i) The choice, on {r['n_synthetic']} synthetic photos (the prior's physical lamp families, white-ish)", "",
        f"Of the (correlation length, k) pairs whose ranges cover Ra, R9, Rf and Rg on ≥ {100 * GOAL:.0f} % of photos, "
        "the one with the narrowest ranges (or, if none does, the best worst coverage): "
        f"**{chosen[0]:g} nm, k = {chosen[1]:g}** (the product ships {SHIPPED[0]:g} nm, k = {SHIPPED[1]:g}"
        + ("" if chosen == SHIPPED else " — **not the choice made here: update it**") + ").", "",
        *_table(r["synthetic"], chosen), "",
        f"## (ii) Real lamps ({r['n_real']} lamps; the model never saw them, and they chose nothing)", "",
        *_table(r["real"], chosen), "",
        f"As shipped ({SHIPPED[0]:g} nm, k = {SHIPPED[1]:g}): {shipped['undefined_truth']} lamps have no rendition "
        f"(too far from white, or outside 1000–25 000 K), {shipped['undefined_estimate']} more lose it in the "
        "estimate.", "",
        *_errors(shipped), "",
        "## (iii) Time per estimate", "",
        f"`rendition(spd, spd_std)` on {t.get('machine', '?')} (load average {_fmt(t.get('load_average'))} while "
        f"measuring, OPENBLAS_NUM_THREADS={t.get('threads', '?')}); median and fastest of 30 calls:", "",
        "| SPDs drawn | median ms | min ms |", "|---|---|---|"]
    for samples in (0, 50, DEFAULT_SAMPLES, 200):
        row = t.get(f"samples_{samples}") or {}
        lines.append(f"| {samples or 'none (figures only)'}{' (shipped)' if samples == DEFAULT_SAMPLES else ''} | "
                     f"{_fmt(row.get('median_ms'))} | {_fmt(row.get('min_ms'))} |")
    lines += ["", f"First call in a process (loading the tables): {_fmt(t.get('first_call_ms'))} ms. Inside the "
              f"estimates above (`timing_ms.rendition`): median {_fmt(r.get('estimate_rendition_ms'))} ms.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "rendition.md")
    parser.add_argument("--quick", action="store_true", help="few lamps (a smoke run)")
    parser.add_argument("--engine", default="cycles", choices=("cycles", "numpy"))
    parser.add_argument("--synthetic", type=int, default=120, help="synthetic photos for the choice")
    parser.add_argument("--timing-only", action="store_true", help="only (iii), printed and written to --out")
    parser.add_argument("--cache", type=Path, default=None,
                        help="keep the estimates in this .npz and reuse them (re-running the analysis only)")
    args = parser.parse_args(argv)
    if args.timing_only:
        t = timing()
        text = json.dumps(t, indent=1)
        args.out.write_text(f"# Rendition time per estimate\n\n```\n{text}\n```\n", encoding="utf-8")
        print(text)
        return 0
    start = time.perf_counter()
    model = load_model()
    lamps = all_lamps()
    n_syn = args.synthetic
    if args.quick:
        lamps, n_syn = lamps[::30], 12
    cond = Condition("nominal", CubeSpec("eval-nominal", size=128 if args.quick else 384))
    if args.cache is not None and args.cache.is_file():
        synthetic, real, estimating = _load_cases(args.cache)
        start -= estimating if math.isfinite(estimating) else 0.0  # the run time of the estimates, once
    else:
        with tempfile.TemporaryDirectory() as tmp:
            photos = Photos(tmp, args.engine)
            print(f"synthetic: {n_syn} photos", flush=True)
            synthetic = _estimates(photos, cond, _white_synthetic(n_syn, SEED), model, seed=1)
            print(f"real lamps: {len(lamps)} photos", flush=True)
            real = _estimates(photos, cond, [lamp.spd for lamp in lamps], model, seed=0)
        if args.cache is not None:
            _save_cases(args.cache, synthetic, real, time.perf_counter() - start)
    grid = [(c, k) for k in CANDIDATE_SCALES for c in CANDIDATES_NM]
    syn_rows = [coverage(synthetic, c, k) for c, k in grid]
    real_rows = [coverage(real, c, k) for c, k in grid]
    result = {"model_version": model.version, "engine": args.engine, "n_synthetic": len(synthetic),
              "n_real": len(real), "chosen": choose(syn_rows), "synthetic": syn_rows, "real": real_rows,
              "estimate_rendition_ms": float(np.median([c["rendition_ms"] for c in synthetic + real])),
              "timing": timing()}
    result["seconds"] = time.perf_counter() - start
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    args.out.write_text(render_markdown(result), encoding="utf-8")
    print(args.out.read_text(encoding="utf-8"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
