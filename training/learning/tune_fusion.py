"""Choose how strongly the final solve trusts the network, on synthetic photos only.

    python -m training.learning.tune_fusion [--model models/cd_spectra.onnx] [--set full] [--n 64] [--write]

Photos of prior spectra (a seed the training set does not use) from the training geometries,
degraded like the training data, through the product's preprocessing and model; a grid over the
fusion strength and the uncertainty floor of :func:`cd_spectra_addon.core.spectrum.solve.fused_solve`,
then per band of 380–780 nm the fused network against physics + prior alone: the network is kept
only in the bands where it wins (``fusion.band_weight``, used by ``estimate_image``).
``training.learning.train`` runs this after exporting and stores the choice in the model's
metadata; ``--write`` adds it to an existing model without retraining. The tables go to
bench/fusion_tuning.md.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.inverse.stages import Reading, fuse, model_prior, network_inputs, physics_spd, read_photo
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.spectrum.model import SpectralModel, load_model
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation import photo
from training.simulation.basis import REPO, basis_cube
from training.learning.dataset import CUBE_SETS, Degradation, perturbed_camera, camera_split
from training.learning.spd_prior import FAMILIES, sample_spds

STRENGTHS = (0.0, 0.1, 0.3, 1.0, 3.0)
FLOORS = (0.02, 0.05, 0.1)
# The choice is made for the lamps the product is for: the prior's physical families. The
# paper's artificial kinds (random smooth curves, per-sample noise, random spikes) stay in
# training for robustness, but noise and spikes finer than the spectral blur would decide the
# choice in favour of ignoring the photo's colour, which no real lamp needs.
TUNING_FAMILIES = tuple(f for f in FAMILIES if f not in ("smooth", "smooth_noise", "spiky"))
# Bands in which the network and physics + prior are compared: the blind violet tail, 50 nm
# steps where the camera sees, the red tail.
BANDS_NM = ((380, 400), (400, 450), (450, 500), (500, 550), (550, 600), (600, 650), (650, 700), (700, 780))
TRANSITION_NM = 20.0  # a chosen band hands over to its neighbour along a linear ramp this wide
# No islands: a stretch of network bands inside 400–700 nm that touches neither blind end and is
# narrower than this is given back to physics + prior. Inside the band the camera sees, physics +
# prior fits the photo's own colour; a 50 nm island of another estimate joined on by brightness
# alone shifts the colour without a clear per-band win to pay for it — on the synthetic photos
# of bench/band_choice_real.md the blend with the 550–600 nm island read Δu'v' 0.0019 against
# physics + prior's 0.0004, and 550–600 nm itself MAE 0.0240 against 0.0189.
MIN_ISLAND_NM = 100.0
SEED = 31337


@dataclass
class Case:
    """One synthetic photo as the estimator sees it (its readout stage), the network's SPD and
    uncertainty, physics + prior (the photo's units) and the truth."""

    reading: Reading
    net: NDArray[np.float64]
    std: NDArray[np.float64]
    physics: NDArray[np.float64]
    truth: NDArray[np.float64]


def fusion_cases(model: SpectralModel, cube_set: str, n: int, engine: str, seed: int = SEED,
           camera_error: bool = True, families: tuple[str, ...] = TUNING_FAMILIES) -> list[Case]:
    """Photos of ``n`` prior spectra, one geometry after another; photos the product refuses
    (an oblique geometry before the general-pose fit reads it) are left out, as in training."""
    rng = np.random.default_rng(seed)
    prior = model_prior(model)
    cams, _ = camera_split()
    deg = Degradation()
    specs = CUBE_SETS[cube_set]
    spds, _ = sample_spds(n, rng, families=families)
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, spd in enumerate(spds):
            spec = specs[i % len(specs)]
            scene = spec.scene()
            cube, _ = basis_cube(scene, engine)
            meter = photo.track_mask(scene)
            camera = load_camera(cams[int(rng.integers(len(cams)))])
            true_cam = perturbed_camera(camera, rng, deg) if camera_error else camera
            img, _ = photo.expose(photo.linear_photo(cube, spd, true_cam), float(rng.uniform(0.5, 1.2)), meter)
            img = np.minimum(photo.add_noise(photo.upsample(img, deg.upsample), float(rng.uniform(0.003, 0.02)),
                                             rng), 1.0)
            fmt = ("jpg", "png", "exr")[i % 3]
            path = Path(tmp) / f"t.{fmt}"
            c = scene.preset.camera
            photo.write_photo(path, img, fmt, photo.exif_for(c.focal_length_mm, c.sensor_width_mm,
                                                             c.image_size_px[0] * deg.upsample, camera.name))
            image = load_photo(path, max_side=max(c.image_size_px))
            try:
                analysis = read_photo(image, spec.reading_preset(), camera)
            except CDSpectraError:
                continue
            e_phys = physics_spd(analysis, prior)
            net, std = model.predict(network_inputs(analysis, e_phys))
            cases.append(Case(analysis, net, std, e_phys, spd))
    return cases


def _fused(case: Case, strength: float, floor: float, weight: NDArray[np.float64] | None = None
           ) -> NDArray[np.float64]:
    """The model operating point's SPD for this photo with candidate settings: the product's own
    fusion (:func:`cd_spectra_addon.core.inverse.stages.fuse`)."""
    est = fuse(case.reading, case.physics, case.net, case.std, strength, floor, weight)
    return est if est.max() > 0 else case.net


def _score(estimates: list[NDArray[np.float64]], cases: list[Case]) -> dict[str, float]:
    m400, m380, duv = [], [], []
    for est, case in zip(estimates, cases):
        m = compare_spds(est, case.truth)
        m400.append(m["mae_400_700"] if m["mae_400_700"] is not None else 1.0)
        m380.append(m["mae_380_780"] if m["mae_380_780"] is not None else 1.0)
        duv.append(m["delta_uv_prime"])
    return {"mae_400_700": float(np.mean(m400)), "mae_380_780": float(np.mean(m380)),
            "delta_uv_prime": float(np.mean(duv))}


def setting_grid(cases: list[Case]) -> list[dict[str, float]]:
    rows = []
    for strength, floor in itertools.product(STRENGTHS, FLOORS):
        if strength == 0 and floor != FLOORS[0]:
            continue
        rows.append({"strength": strength, "floor": floor, **_score([_fused(c, strength, floor) for c in cases],
                                                                     cases)})
    return rows


def best_setting(rows: list[dict[str, float]]) -> dict[str, float]:
    # Score: the two MAEs plus colour error scaled to comparable size (Δu'v' 0.001 ≈ MAE 0.01).
    return min(rows, key=lambda r: r["mae_400_700"] + r["mae_380_780"] + 10 * r["delta_uv_prime"])


def _peak1(spd: NDArray[np.float64]) -> NDArray[np.float64]:
    spd = np.clip(np.asarray(spd, dtype=np.float64), 0.0, None)
    return spd / spd.max() if spd.max() > 0 else spd


def band_weight(network_bands: list[bool]) -> NDArray[np.float64]:
    """w(λ) on the 81-sample grid: 1 in the bands the network won, 0 elsewhere, each change a
    linear ramp :data:`TRANSITION_NM` wide centred on the band edge (no step in the SPD): the
    band choice averaged over a window that wide (midpoint rule, exact for a step)."""
    use = np.asarray(network_bands, dtype=np.float64)
    inner_edges = np.array([lo for lo, _ in BANDS_NM[1:]], dtype=np.float64)
    n = 40
    offsets = (np.arange(n) + 0.5) / n * TRANSITION_NM - TRANSITION_NM / 2
    x = WAVELENGTHS_NM[:, None] + offsets[None, :]
    return use[np.searchsorted(inner_edges, x, side="right")].mean(axis=1).round(4)


def band_mae(estimate: NDArray[np.float64], truth: NDArray[np.float64]) -> NDArray[np.float64]:
    """MAE per band as the headline metrics score it (``compare_spds``): inside 400–700 nm both
    SPDs scaled to their peak inside 400–700 nm (MAE 400–700 is the mean of these bands), the
    tails to their peak over 380–780 nm (as MAE 380–780) — so a tail the camera cannot see does
    not decide a band it sees."""
    core = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
    out = []
    for lo, hi in BANDS_NM:
        sel = (WAVELENGTHS_NM >= lo) & (WAVELENGTHS_NM <= hi)
        norm = core if (lo >= 400 and hi <= 700) else np.ones_like(core)
        e = estimate / max(float(np.max(estimate[norm])), 1e-12)
        t = truth / max(float(np.max(truth[norm])), 1e-12)
        out.append(float(np.mean(np.abs(e[sel] - t[sel]))))
    return np.array(out)


def band_errors(cases: list[Case], strength: float, floor: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(network, physics + prior) MAE per photo and band (:func:`band_mae`): arrays (photos, bands)."""
    net = [band_mae(_peak1(_fused(c, strength, floor)), c.truth) for c in cases]
    pri = [band_mae(_peak1(c.physics), c.truth) for c in cases]
    return np.array(net), np.array(pri)


def band_rows(net: NDArray[np.float64], pri: NDArray[np.float64]) -> list[dict[str, Any]]:
    """The decision per band from paired errors: the network only where it is better by more than
    the standard error of the paired difference — physics + prior is the simpler estimate and the
    default wherever the network's win is not clear."""
    rows = []
    for k, (lo, hi) in enumerate(BANDS_NM):
        d = pri[:, k] - net[:, k]
        se = float(np.std(d, ddof=1) / math.sqrt(len(d))) if len(d) > 1 else math.inf
        rows.append({"band": [lo, hi], "mae_network": float(np.mean(net[:, k])), "mae_prior": float(np.mean(pri[:, k])),
                     "se": se, "network": bool(np.mean(d) > se)})
    return rows


def without_islands(network_bands: list[bool]) -> list[bool]:
    """The band choice with every network island removed (:data:`MIN_ISLAND_NM`): a run of
    network bands that starts after 400 nm and ends before 700 nm and spans less than that."""
    use = list(network_bands)
    k = 0
    while k < len(use):
        if not use[k]:
            k += 1
            continue
        j = k
        while j + 1 < len(use) and use[j + 1]:
            j += 1
        lo, hi = BANDS_NM[k][0], BANDS_NM[j][1]
        if lo >= 400 and hi <= 700 and hi - lo < MIN_ISLAND_NM:
            use[k:j + 1] = [False] * (j + 1 - k)
        k = j + 1
    return use


def colour_guarded(blend_duv: float, prior_duv: float) -> bool:
    """Whether the blend passes the colour guard: its mean Δu'v' on the tuning photos no worse
    than physics + prior's alone. Where it fails, :func:`choose_bands` gives every band inside
    400–700 nm (the bands that set the colour) back to physics + prior. The reference is physics
    + prior, not the better of the two parts: the network's colour on photos of its own training
    families is not evidence about lamps it never saw (the reason for the held-out-family rule;
    on the real lamps the network everywhere read Δu'v' 0.0044 against 0.0003,
    bench/band_choice_real.md), while physics + prior is the estimate the blend starts from."""
    return blend_duv <= prior_duv + 1e-12


def choose_bands(cases: list[Case], strength: float, floor: float,
                 unseen: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Per band, the MAE of the fused network SPD and of physics + prior on the same photos and
    the choice (:func:`band_rows`), the weight it makes and how the blend does. With ``unseen``
    (the pooled rows of :mod:`.heldout_families`) the network must also win the band on kinds of
    lamp it never saw."""
    rows = band_rows(*band_errors(cases, strength, floor))
    if unseen is not None:
        for row, other in zip(rows, unseen):
            row["network_unseen"] = bool(other["network"])
            row["network"] = row["network"] and row["network_unseen"]
    for row, keep in zip(rows, without_islands([r["network"] for r in rows])):
        row["island"] = row["network"] and not keep
        row["network"] = keep
    weight = band_weight([r["network"] for r in rows])
    fused = [_peak1(_fused(c, strength, floor)) for c in cases]
    prior = [_peak1(c.physics) for c in cases]
    blended = [_fused(c, strength, floor, weight) for c in cases]
    scores = {k: _score(v, cases) for k, v in (("network", fused), ("prior", prior), ("blend", blended))}
    if not colour_guarded(scores["blend"]["delta_uv_prime"], scores["prior"]["delta_uv_prime"]):
        for row in rows:
            if row["network"] and row["band"][0] >= 400 and row["band"][1] <= 700:
                row["network"], row["colour_guard"] = False, True
        weight = band_weight([r["network"] for r in rows])
        blended = [_fused(c, strength, floor, weight) for c in cases]
    blend_err = np.array([band_mae(e, c.truth) for e, c in zip(blended, cases)])
    for k, row in enumerate(rows):
        row["mae_blend"] = float(np.mean(blend_err[:, k]))
    return {"bands": rows, "weight": weight.tolist(), "network": scores["network"],
            "prior": scores["prior"], "blend": _score(blended, cases)}


def rechoose(fusion: dict[str, Any]) -> dict[str, Any]:
    """A model's stored band choice (``fusion.bands``, made on synthetic photos) with the rules
    that came after it applied (:func:`without_islands`): the weights re-derived without
    rendering the tuning photos again. The colour guard needs the photos, so it is not applied."""
    out = dict(fusion)
    out["bands"] = {}
    for key, weight_key in (("uncalibrated", "band_weight"), ("calibrated", "calibrated_band_weight")):
        rows = [dict(r) for r in fusion["bands"][key]]
        for row, keep in zip(rows, without_islands([r["network"] for r in rows])):
            row["island"] = row["network"] and not keep
            row["network"] = keep
        out["bands"][key] = rows
        out[weight_key] = band_weight([r["network"] for r in rows]).tolist()
    out["rechosen"] = f"islands under {MIN_ISLAND_NM:g} nm inside 400–700 nm removed from the stored choice"
    return out


def tune(model: SpectralModel, cube_set: str = "full", n: int = 64, engine: str = "cycles",
         unseen: list[dict[str, Any]] | None = None) -> dict[str, Any]:
    """Two choices: for photos whose camera differs from its published curves as much as the
    training data's cameras do (the normal case), and for calibrated photos, whose calibration
    shot has measured those differences away — then the photo deserves more trust. Each is a
    fusion strength and floor, then per band network or physics + prior (:func:`choose_bands`)."""
    out: dict[str, Any] = {}
    for key, camera_error in (("uncalibrated", True), ("calibrated", False)):
        cases = fusion_cases(model, cube_set, n, engine, camera_error=camera_error)
        if len(cases) < 2:
            raise RuntimeError(f"only {len(cases)} of {n} tuning photos of the {cube_set!r} geometries were read")
        rows = setting_grid(cases)
        best = best_setting(rows)
        out[key] = {"strength": best["strength"], "floor": best["floor"], "rows": rows, "n_read": len(cases),
                    **choose_bands(cases, best["strength"], best["floor"], unseen)}
    out["n_photos"] = n
    out["cube_set"] = cube_set
    out["unseen_rule"] = unseen is not None
    out["strength"], out["floor"] = out["uncalibrated"]["strength"], out["uncalibrated"]["floor"]
    return out


def _used(row: dict[str, Any]) -> str:
    if row["network"]:
        return "network"
    if row.get("island"):
        return "physics + prior (network island removed)"
    if row.get("colour_guard"):
        return "physics + prior (colour guard)"
    return "physics + prior"


def _band_lines(part: dict[str, Any]) -> list[str]:
    unseen = any("network_unseen" in r for r in part["bands"])
    lines = ["| band (nm) | network (fused) | physics + prior | paired SE | " +
             ("network wins on unseen kinds | " if unseen else "") + "used | shipped blend |",
             "|---|---|---|---|---|---|" + ("---|" if unseen else "")]
    for r in part["bands"]:
        lo, hi = r["band"]
        extra = f"{'yes' if r.get('network_unseen') else 'no'} | " if unseen else ""
        lines.append(f"| {lo}–{hi} | {r['mae_network']:.4f} | {r['mae_prior']:.4f} | {r['se']:.4f} | {extra}"
                     f"{_used(r)} | {r['mae_blend']:.4f} |")
    lines += ["", "| estimate | MAE 400–700 | MAE 380–780 | Δu'v' |", "|---|---|---|---|"]
    for key, label in (("network", "network (fused) everywhere"), ("prior", "physics + prior everywhere"),
                       ("blend", "**shipped: per-band blend**")):
        s = part[key]
        lines.append(f"| {label} | {s['mae_400_700']:.4f} | {s['mae_380_780']:.4f} | {s['delta_uv_prime']:.4f} |")
    return lines + [""]


def report(result: dict[str, Any]) -> str:
    lines = ["# Fusion of the network with the photo, chosen on synthetic photos (`python -m training.learning.tune_fusion`)",
             "", f"{result['n_photos']} photos of spectra from the prior's physical lamp families (seed {SEED}; not the "
             f"paper's artificial smooth/noisy/spiky kinds) from the `{result.get('cube_set', 'full')}` training "
             "geometries, training degradations (JPEG/PNG/EXR, 0.3–2 % noise); photos the estimator refuses are "
             "left out. Score = MAE 400–700 + MAE 380–780 + 10·Δu'v'. Strength 0 = the network's SPD as is. "
             "*Uncalibrated*: each camera differs from its published curves (±2 % gains, ±1 nm), as in training; "
             "*calibrated*: a calibration shot has removed that.", "",
             "Then, per band, the fused network SPD against physics + prior alone on the same photos (MAE on the "
             "band's samples as the headline metrics scale them: inside 400–700 nm both SPDs at peak 1 inside "
             "400–700 nm, the tails at peak 1 over 380–780 nm): the network is used only where it is better by more "
             "than the standard error of the paired difference; elsewhere the shipped estimate is physics + prior, "
             f"with linear {TRANSITION_NM:g} nm transitions (`fusion.band_weight` in the model's metadata; "
             "`core.solve.band_blend`). Real lamps play no part in any of these choices.", ""]
    if result.get("unseen_rule"):
        lines += ["The network must also win the band on *kinds of lamp it never saw*: probe networks trained "
                  "without one group of the physical families, on photos of that group, pooled "
                  "(`training.learning.heldout_families`, bench/heldout_families.md; synthetic only). A real lamp is "
                  "a new instance of a family, often of a shape no family draws; the in-family comparison alone chose "
                  "the network in every band while it lost most of 400–700 nm on the real lamps (bench/"
                  "band_choice_real.md). That knowledge, not any real-lamp number per band, is why this stricter rule "
                  "was adopted; the bands themselves are decided on synthetic photos.", ""]
    for key in ("uncalibrated", "calibrated"):
        part = result[key]
        lines += [f"## {key} ({part.get('n_read', result['n_photos'])} photos read)", "",
                  "| strength | floor | MAE 400–700 | MAE 380–780 | Δu'v' |", "|---|---|---|---|---|"]
        for r in part["rows"]:
            mark = " **←**" if (r["strength"], r["floor"]) == (part["strength"], part["floor"]) else ""
            lines.append(f"| {r['strength']:g} | {r['floor']:g} | {r['mae_400_700']:.4f} | {r['mae_380_780']:.4f} | "
                         f"{r['delta_uv_prime']:.4f}{mark} |")
        lines += ["", f"Per band at strength {part['strength']:g}, floor {part['floor']:g}:", ""]
        lines += _band_lines(part)
    return "\n".join(lines)


def fusion_metadata(result: dict[str, Any]) -> dict[str, Any]:
    u, c = result["uncalibrated"], result["calibrated"]
    return {"strength": u["strength"], "floor": u["floor"],
            "calibrated_strength": c["strength"], "calibrated_floor": c["floor"],
            "band_weight": u["weight"], "calibrated_band_weight": c["weight"],
            "bands": {"uncalibrated": u["bands"], "calibrated": c["bands"]},
            "chosen_on": f"{result['n_photos']} synthetic photos per case of the {result.get('cube_set', 'full')} "
                         "geometries (bench/fusion_tuning.md)"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=REPO / "models" / "cd_spectra.onnx")
    parser.add_argument("--n", type=int, default=64)
    parser.add_argument("--set", default=None, choices=sorted(CUBE_SETS),
                        help="geometries to tune on (default: the ones the model was trained on)")
    parser.add_argument("--engine", default="cycles")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "fusion_tuning.md")
    parser.add_argument("--write", action="store_true", help="store the choice in the model's metadata")
    parser.add_argument("--rechoose", action="store_true",
                        help="only re-apply today's band rules to the model's stored per-band rows (no photos)")
    args = parser.parse_args(argv)
    model = load_model(args.model)
    if args.rechoose:
        side = args.model.with_suffix(".json")
        meta = json.loads(side.read_text(encoding="utf-8"))
        meta["fusion"] = rechoose(meta["fusion"])
        for key in ("uncalibrated", "calibrated"):
            print(key, [("network" if r["network"] else "island → physics + prior" if r["island"] else "physics + prior",
                         r["band"]) for r in meta["fusion"]["bands"][key]])
        if args.write:
            side.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
        return 0
    cube_set = args.set or model.metadata.get("training", {}).get("cube_set", "full")
    result = tune(model, cube_set, args.n, args.engine)
    text = report(result)
    print(text)
    args.out.parent.mkdir(exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    if args.write:
        side = args.model.with_suffix(".json")
        meta = json.loads(side.read_text(encoding="utf-8"))
        meta["fusion"] = fusion_metadata(result)
        side.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
