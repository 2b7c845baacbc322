"""Write models/MODEL_CARD.md from the model's metadata and the latest evaluation (bench/eval.json).

    python -m training.evaluation.model_card

Sections follow the Hugging Face model card template (details, uses, limitations, training,
evaluation, technical specifications). Numbers are copied from the files, never typed in.
"""

from __future__ import annotations

import json
import math
from typing import Any

from cd_spectra_addon.core.inverse.result import METHOD_MODEL, METHOD_PHYSICS, METHOD_PRIOR
from cd_spectra_addon.core.scene.capture import preset_digests
from cd_spectra_addon.core.spectrum.model import MODEL_DIR, MODEL_NAME

from training.learning.spd_prior import FAMILIES
from training.simulation.basis import REPO

EVAL = REPO / "bench" / "eval.json"
BAND_CHOICE = REPO / "bench" / "band_choice_real.json"


def _tails_lines(tails: dict[str, Any] | None) -> list[str]:
    """When the blind tails (380–410, 680–780 nm) follow a Planck curve: chosen on synthetic photos."""
    if not tails:
        return []
    return [f"- **Blind tails:** a Planck curve continues the estimate into 380–410 and 680–780 nm where one explains"
            f" the photo's features (χ² per feature row ≤ {tails['thermal_chi2']:g}, none at ≥ {tails['other_chi2']:g},"
            " linear between); the solve's own tails otherwise; spd_std widened there. Chosen on synthetic photos"
            " of the prior's physical lamp families (`bench/tails_tuning.md`)."]


def _fusion_lines(fusion: dict[str, Any] | None) -> list[str]:
    """How far the final solve trusts the network vs the photo: chosen on synthetic photos."""
    if not fusion:
        return []
    lines = [f"- **Fusion with the photo:** strength {fusion['strength']:g} (floor {fusion['floor']:g}) uncalibrated,"
             f" {fusion.get('calibrated_strength', fusion['strength']):g} (floor"
             f" {fusion.get('calibrated_floor', fusion['floor']):g}) after a calibration shot; chosen on"
             " synthetic photos of the prior's physical lamp families (`bench/fusion_tuning.md`)."]
    bands = (fusion.get("bands") or {}).get("uncalibrated")
    if bands:
        used = [f"{r['band'][0]}–{r['band'][1]}" for r in bands if r["network"]]
        lines.append("- **Where the network is used:** " + (", ".join(used) + " nm" if used else "nowhere") +
                     "; physics + prior elsewhere (per band, where the network did not beat it clearly on the same"
                     " synthetic photos, and never as an island narrower than 100 nm inside 400–700 nm;"
                     " `fusion.band_weight`, 20 nm transitions).")
    return lines


def _wins_lines(fusion: dict[str, Any] | None, real: dict[str, Any] | None) -> list[str]:
    """What the network wins where it is used: on the synthetic photos that chose the bands (the
    model's metadata), then on the measured lamps (bench/band_choice_real.json, run afterwards)."""
    rows = ((fusion or {}).get("bands") or {}).get("uncalibrated") or []
    used = [r for r in rows if r["network"]]
    if not used:
        return []
    parts = [f"{r['band'][0]}–{r['band'][1]} nm: MAE {r['mae_network']:.4f} against physics + prior's "
             f"{r['mae_prior']:.4f} (± {r['se']:.4f})"
             + (", and ahead on families its probes never saw (`bench/heldout_families.md`)" if r.get("network_unseen")
                else "") for r in used]
    lines = ["- **What the network wins** (MAE per band, peak-normalised as the fusion tuning scores): on the"
             " synthetic photos that chose the bands (physics + prior as it was then), " + "; ".join(parts) + "."]
    if real is not None:
        bands = [tuple(b) for b in real["bands_nm"]]
        rl = real["real"]
        per = []
        for r in used:
            i = bands.index(tuple(r["band"]))
            per.append(f"{r['band'][0]}–{r['band'][1]} nm {rl['blend']['bands'][i]:.4f} against "
                       f"{rl['prior']['bands'][i]:.4f}")
        b, p = rl["blend"], rl["prior"]
        lines.append(f"  On the {rl['n']} measured lamps afterwards (`bench/band_choice_real.md`, never used to choose): "
                     + "; ".join(per) + f"; over the whole SPD MAE 400–700 {b['mae_400_700']:.4f} against "
                     f"{p['mae_400_700']:.4f}, 380–780 {b['mae_380_780']:.4f} against {p['mae_380_780']:.4f}, "
                     f"Δu'v' {b['delta_uv_prime']:.4f} against {p['delta_uv_prime']:.4f}.")
    return lines


def _drift_lines(meta: dict[str, Any], now: dict[str, str]) -> list[str]:
    """The shipped set-ups whose preset file changed after the model was trained (digests in the
    model's metadata against ``now``): its photos of those came from the earlier geometry."""
    trained = meta.get("presets") or {}
    changed = ", ".join(f"`{n}`" for n in sorted(n for n in trained if n in now and now[n] != trained[n]))
    added = ", ".join(f"`{n}`" for n in sorted(n for n in now if n not in trained))
    parts = [f"{changed} (the preset file — its geometry or only its text — differs from the one the model "
             "recorded: its synthetic photos of it came from the earlier file)"] if changed else []
    parts += [f"{added} (new)"] if added else []
    if not parts:
        return []
    return ["- **Set-ups changed since training:** " + "; ".join(parts)
            + ". `make model` re-renders their cubes and retrains."]


def _f(v: Any, digits: int = 4) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def render(meta: dict[str, Any], ev: dict[str, Any] | None, band_choice: dict[str, Any] | None = None) -> str:
    t = meta["training"]
    lines = [
        f"# Model card: {MODEL_NAME} `{meta['version']}`",
        "",
        "## Model details",
        "",
        "- **What:** maps the spectral profile of a photo of a CD (camera RGB binned by the first-order diffraction",
        "  wavelength λ₁, plus validity/noise/saturation per bin, the camera's sensitivities, the physics-only",
        "  solution and the fitted lamp size) to the lamp's spectral power distribution on 380–780 nm in 5 nm steps,",
        "  peak-normalised, with a per-wavelength standard deviation.",
        f"- **Architecture:** MLP {' → '.join(str(h) for h in t['hidden'])} (GELU), softplus output with a skip path from",
        "  the physics solution, peak normalisation inside the graph; Laplace likelihood head for the uncertainty.",
        "- **Format:** ONNX opset 17 (`cd_spectra.onnx`), metadata in `metadata_props` and the JSON sidecar",
        f"  (`cd_spectra.json`: wavelength grid, feature grid, input layout hash `{meta['layout_hash']}`, preprocessing",
        "  parameters, presets, cameras, Gaussian prior, data hash, metrics).",
        f"- **onnxruntime vs torch:** max |Δ| {meta.get('onnx_parity_max_abs_diff', float('nan')):.1e} (must be ≤ 1e-5).",
        "",
        "## Uses",
        "",
        "Estimating a lamp's SPD from one photo of an unwritten CD, lit by the lamp in one of the capture set-ups",
        "(README: 'Capture set-ups you can build'), for lighting artists (a matched light in Blender) and inverse-rendering",
        "work (a measured SPD for a spectral renderer). Not a replacement for a calibrated spectroradiometer where",
        "absolute radiometry or UV/IR content matters.",
        "",
        "## Bias, risks and limitations",
        "",
        "- Consumer cameras see little outside ~400–690 nm: the tails (380–400, 700–780 nm) come mostly from the prior",
        "  learnt from synthetic spectra; they are reported separately and should not be trusted like the middle.",
        "- Trained only on synthetic spectra (physics-based lamp families) rendered through a physical CD model; a",
        "  real disc's groove depth and a real camera's curves differ from the model: the calibration shot corrects it.",
        "- Camera JPEGs apply white balance and a colour matrix the model does not know; raw/linear files are better.",
        "- Lamp size sets the spectral resolution: a bulb close to the disc blurs narrow lines (see README).",
        "",
        "## Training details",
        "",
        f"- **Data:** {t['train_samples'] + t['val_samples']} synthetic photos ({t['n_per_cube']} per capture geometry ×"
        f" {len(t['cubes'])} geometries: {', '.join(t['cubes'])}), basis cubes rendered by Cycles ({t['engine']});",
        f"  SPDs from `training/learning/spd_prior/` ({len(FAMILIES)} lamp families, no measured spectra), random training",
        "  cameras with ±2 % gain and ±1 nm shift errors, exposure 0.3–2× (clipping), 0.2–3 % noise, ambient",
        "  light, EXR / 16-bit PNG / 8-bit PNG / JPEG q75–98, read back through the product's loader; profiles taken",
        "  at geometries the pose fit produced. Data hash `" + meta["data_hash"] + "`.",
        f"- **Cameras:** {len(meta['cameras']['train'])} for training; held out (never trained on): "
        + ", ".join(meta["cameras"]["held_out"]) + ".",
        f"- **Procedure:** AdamW, one-cycle LR, {t['epochs']} epochs, seed {t['seed']}; loss: band-weighted L1 +"
        f" Laplace likelihood, u'v' colour weight {t.get('colour_weight', 0.0):g} (`bench/model_choice.md` says why);"
        f" 10 % synthetic validation (MAE {_f(t['val_mae'])}). The network's fit took {t['seconds'] / 60:.1f} min;"
        f" dataset + fit + export + fusion tuning {(t.get('total_seconds') or 0) / 60:.1f} min on this machine with"
        f" the basis cubes already rendered (rendering the {len(t['cubes'])} cubes comes on top: `bench/render.md`,"
        " `bench/buildable_cubes.md`).",
        *_drift_lines(meta, preset_digests()),
        *_fusion_lines(meta.get("fusion")),
        *_wins_lines(meta.get("fusion"), band_choice),
        *_tails_lines(meta.get("tails")),
        "- **Never used for training, tuning or selection:** the LSPDD lamps and colour-science's measured sources and",
        "  CIE illuminants.",
        "",
        "## Evaluation",
        "",
    ]
    if ev is None:
        lines += ["Not evaluated yet: run `make eval`.", ""]
    else:
        real = ev["real_lamps"]
        pp = ev["paper_protocol"]
        lines += [
            f"From `bench/eval.md` (model `{ev['model_version']}`):",
            "",
            "| test | MAE 400–700 | MAE 380–780 | r | Δu'v' |",
            "|---|---|---|---|---|",
        ]
        for method, label in ((METHOD_MODEL, "real lamps, JPEG 1 % noise (model)"), (METHOD_PRIOR, "… physics + prior"),
                              (METHOD_PHYSICS, "… physics only")):
            s = real[method]["all"]
            lines.append(f"| {label} | {_f(s['mae_400_700'])} | {_f(s['mae_380_780'])} | {_f(s['pearson_r'], 3)} | "
                         f"{_f(s['delta_uv_prime'])} |")
        lines += ["", f"Paper's protocol (MAE / RMSE / r over 380–780 nm): paper {pp['paper']['mae']} / – / "
                  f"{pp['paper']['r']}; ours {_f(pp['protocol_model']['mae'])} / {_f(pp['protocol_model']['rmse'])} / "
                  f"{_f(pp['protocol_model']['r'], 3)} (trained on {pp['n_train']}), shipped model "
                  f"{_f(pp['shipped_model']['mae'])} / {_f(pp['shipped_model']['rmse'])} / {_f(pp['shipped_model']['r'], 3)}.",
                  "", "Robustness, per-family and per-camera tables: `bench/eval.md`.", ""]
    lines += [
        "## Technical specifications",
        "",
        f"- Input: float32 [batch, {sum(n for _, n in meta['input_layout'])}] (`inputs`); outputs `spd` [batch, 81]"
        " (peak exactly 1) and `log_std` [batch, 81].",
        "- Runtime: onnxruntime, CPU execution provider, one thread; session created lazily on first use.",
        "- Rebuild: `make model` (seeded; renders missing basis cubes, builds the dataset, trains, exports).",
        "",
    ]
    return "\n".join(lines)


def main() -> int:
    meta = json.loads((MODEL_DIR / f"{MODEL_NAME}.json").read_text(encoding="utf-8"))
    ev = json.loads(EVAL.read_text(encoding="utf-8")) if EVAL.is_file() else None
    if ev is not None and ev.get("model_version") != meta["version"]:
        ev = None  # the evaluation is of another model
    band_choice = json.loads(BAND_CHOICE.read_text(encoding="utf-8")) if BAND_CHOICE.is_file() else None
    if band_choice is not None and band_choice["real"].get("model_version") != meta["version"]:
        band_choice = None  # measured for another model
    out = MODEL_DIR / "MODEL_CARD.md"
    out.write_text(render(meta, ev, band_choice), encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
