"""Choose how strongly the final solve trusts the network, on synthetic photos only.

    python -m training.learning.tune_fusion [--model models/cd_spectra.onnx] [--n 48]

Photos of prior spectra (a seed the training set does not use) from the training geometries,
degraded like the training data, through the product's preprocessing and model; a grid over the
fusion strength and the uncertainty floor of :func:`cd_spectra_addon.core.solve.fused_solve`.
``training.learning.train`` runs this after exporting and stores the choice in the model's metadata;
the table goes to bench/fusion_tuning.md.
"""

from __future__ import annotations

import argparse
import itertools
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core import solve
from cd_spectra_addon.core.analysis import network_inputs, physics_spd, prepare
from cd_spectra_addon.core.cameras import load_camera
from cd_spectra_addon.core.capture import load_preset
from cd_spectra_addon.core.colour import compare_spds
from cd_spectra_addon.core.images import load_photo
from cd_spectra_addon.core.model import SpectralModel, load_model

from training.simulation import photo
from training.simulation.basis import REPO, basis_cube
from training.learning.dataset import CUBE_SETS, Degradation, _perturbed_camera, camera_split
from training.learning.spd_prior import FAMILIES, gaussian_prior, sample_spds

STRENGTHS = (0.0, 0.1, 0.3, 1.0, 3.0)
FLOORS = (0.02, 0.05, 0.1)
# The choice is made for the lamps the product is for: the prior's physical families. The
# paper's artificial kinds (random smooth curves, per-sample noise, random spikes) stay in
# training for robustness, but noise and spikes finer than the spectral blur would decide the
# choice in favour of ignoring the photo's colour, which no real lamp needs.
TUNING_FAMILIES = tuple(f for f in FAMILIES if f not in ("smooth", "smooth_noise", "spiky"))


def _cases(model: SpectralModel, cube_set: str, n: int, engine: str, seed: int = 31337,
           camera_error: bool = True) -> list[tuple]:
    rng = np.random.default_rng(seed)
    prior = gaussian_prior()
    precision = prior.precision()
    cams, _ = camera_split()
    deg = Degradation()
    specs = CUBE_SETS[cube_set]
    spds, _ = sample_spds(n, rng, families=TUNING_FAMILIES)
    cases = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, spd in enumerate(spds):
            spec = specs[i % len(specs)]
            scene = spec.scene()
            cube, _ = basis_cube(scene, engine)
            meter = photo.track_mask(scene)
            camera = load_camera(cams[int(rng.integers(len(cams)))])
            true_cam = _perturbed_camera(camera, rng, deg) if camera_error else camera
            img, _ = photo.expose(photo.linear_photo(cube, spd, true_cam), float(rng.uniform(0.5, 1.2)), meter)
            img = np.minimum(photo.add_noise(photo.upsample(img, deg.upsample), float(rng.uniform(0.003, 0.02)),
                                             rng), 1.0)
            fmt = ("jpg", "png", "exr")[i % 3]
            path = Path(tmp) / f"t.{fmt}"
            c = scene.preset.camera
            photo.write_photo(path, img, fmt, photo.exif_for(c.focal_length_mm, c.sensor_width_mm,
                                                             c.image_size_px[0] * deg.upsample, camera.name))
            image = load_photo(path, max_side=max(c.image_size_px))
            analysis = prepare(image, load_preset(spec.preset), camera)
            profile, matrix = analysis.readout, analysis.matrix
            net, std = model.predict(network_inputs(analysis, physics_spd(analysis, (prior, precision))))
            cases.append((profile, matrix, net, std, spd))
    return cases


def _grid(cases: list[tuple]) -> list[dict[str, float]]:
    rows = []
    for strength, floor in itertools.product(STRENGTHS, FLOORS):
        if strength == 0 and floor != FLOORS[0]:
            continue
        m400, m380, duv = [], [], []
        for profile, matrix, net, std, truth in cases:
            est = solve.fused_solve(profile, matrix, net, std, strength, floor) if strength > 0 else net
            m = compare_spds(est if est.max() > 0 else net, truth)
            m400.append(m["mae_400_700"] if m["mae_400_700"] is not None else 1.0)
            m380.append(m["mae_380_780"] if m["mae_380_780"] is not None else 1.0)
            duv.append(m["delta_uv_prime"])
        rows.append({"strength": strength, "floor": floor, "mae_400_700": float(np.mean(m400)),
                     "mae_380_780": float(np.mean(m380)), "delta_uv_prime": float(np.mean(duv))})
    return rows


def _best(rows: list[dict[str, float]]) -> dict[str, float]:
    # Score: the two MAEs plus colour error scaled to comparable size (Δu'v' 0.001 ≈ MAE 0.01).
    return min(rows, key=lambda r: r["mae_400_700"] + r["mae_380_780"] + 10 * r["delta_uv_prime"])


def tune(model: SpectralModel, cube_set: str = "full", n: int = 48, engine: str = "cycles") -> dict[str, Any]:
    """Two choices: for photos whose camera differs from its published curves as much as the
    training data's cameras do (the normal case), and for calibrated photos, whose calibration
    shot has measured those differences away — then the photo deserves more trust."""
    out: dict[str, Any] = {}
    for key, camera_error in (("uncalibrated", True), ("calibrated", False)):
        rows = _grid(_cases(model, cube_set, n, engine, camera_error=camera_error))
        best = _best(rows)
        out[key] = {"strength": best["strength"], "floor": best["floor"], "rows": rows}
    out["n_photos"] = n
    out["strength"], out["floor"] = out["uncalibrated"]["strength"], out["uncalibrated"]["floor"]
    return out


def report(result: dict[str, Any]) -> str:
    lines = ["# Fusion of the network with the photo, chosen on synthetic photos (`python -m training.learning.tune_fusion`)",
             "", f"{result['n_photos']} photos of spectra from the prior's physical lamp families (seed 31337; not the "
             "paper's artificial smooth/noisy/spiky kinds) from the training geometries, training "
             "degradations (JPEG/PNG/EXR, 0.3–2 % noise). Score = MAE 400–700 + MAE 380–780 + 10·Δu'v'. "
             "Strength 0 = the network's SPD as is. *Uncalibrated*: each camera differs from its published "
             "curves (±2 % gains, ±1 nm), as in training; *calibrated*: a calibration shot has removed that.", ""]
    for key in ("uncalibrated", "calibrated"):
        part = result[key]
        lines += [f"## {key}", "", "| strength | floor | MAE 400–700 | MAE 380–780 | Δu'v' |", "|---|---|---|---|---|"]
        for r in part["rows"]:
            mark = " **←**" if (r["strength"], r["floor"]) == (part["strength"], part["floor"]) else ""
            lines.append(f"| {r['strength']:g} | {r['floor']:g} | {r['mae_400_700']:.4f} | {r['mae_380_780']:.4f} | "
                         f"{r['delta_uv_prime']:.4f}{mark} |")
        lines.append("")
    return "\n".join(lines)


def fusion_metadata(result: dict[str, Any]) -> dict[str, Any]:
    return {"strength": result["uncalibrated"]["strength"], "floor": result["uncalibrated"]["floor"],
            "calibrated_strength": result["calibrated"]["strength"],
            "calibrated_floor": result["calibrated"]["floor"],
            "chosen_on": f"{result['n_photos']} synthetic photos per case (bench/fusion_tuning.md)"}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", type=Path, default=REPO / "models" / "cd_spectra.onnx")
    parser.add_argument("--n", type=int, default=48)
    parser.add_argument("--set", default="full")
    parser.add_argument("--engine", default="cycles")
    parser.add_argument("--write", action="store_true", help="store the choice in the model's metadata")
    args = parser.parse_args(argv)
    model = load_model(args.model)
    result = tune(model, args.set, args.n, args.engine)
    text = report(result)
    print(text)
    (REPO / "bench").mkdir(exist_ok=True)
    (REPO / "bench" / "fusion_tuning.md").write_text(text, encoding="utf-8")
    if args.write:
        side = args.model.with_suffix(".json")
        meta = json.loads(side.read_text(encoding="utf-8"))
        meta["fusion"] = fusion_metadata(result)
        side.write_text(json.dumps(meta, indent=1) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
