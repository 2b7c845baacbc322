"""How the estimate degrades when the capture is not the preset's (``make eval-poses`` →
bench/pose_errors.md).

    python -m training.evaluation.pose_errors [--lamps 12] [--size 256] [--out bench/pose_errors.md]

A person building the capture by hand puts the lamp beside the lens (not on its axis), the
camera a few mm off the disc's centre, the disc a few degrees tilted, lets some room light in,
and uses a lamp of some size. Each row renders 8-bit JPEG photos (1 % noise, EXIF focal length)
of that capture with the numpy twin of the forward model (training/simulation/render_numpy.py)
and estimates them with the product's defaults and the ``cd-default`` preset — no pose hints,
unless the row says the preset states the lamp's position. The lamps are measured LSPDD lamps
(../shared/data/spds-validation): evaluation only, nothing is tuned on them.

Only true in the simulator: the photos come from the same forward model the inverse uses.
"""

from __future__ import annotations

import argparse
import math
import re
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from cd_spectra_addon.core import colour as colour_core
from cd_spectra_addon.core.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.capture import Light, Pose, Preset, Scene, load_preset
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.estimate import estimate_image
from cd_spectra_addon.core.images import load_photo
from cd_spectra_addon.core.model import load_model

from training.evaluation.lamps import Lamp, lspdd_lamps
from training.simulation import photo
from training.simulation.render_numpy import render_cube

NOISE = 0.01
SUPERSAMPLE = 3
AMBIENT_TINT = np.array([1.0, 0.9, 0.75])  # warm room light, as a share of full scale per channel

__all__ = ["Case", "CASES", "main"]


@dataclass(frozen=True)
class Case:
    name: str
    pose: Pose = Pose()
    ambient: float = 0.0  # share of full scale added to every pixel (× AMBIENT_TINT)
    lobe_sigma: float | None = None  # the real lamp's size (default: the preset's)
    states_lamp: bool = False  # the preset given to the estimator states the true lamp position


COMBINED = Pose(camera_offset_mm=(3.3, -3.3), light_offset_mm=(12.0, 0.0), tilt_deg=(3.0, 0.0))
CASES = [
    Case("nominal"),
    *[Case(f"lamp beside the lens {d} mm", Pose(light_offset_mm=(float(d), 0.0))) for d in (5, 15, 30, 45, 60)],
    *[Case(f"lamp {d} mm, preset states it", Pose(light_offset_mm=(float(d), 0.0)), states_lamp=True)
      for d in (15, 30, 45)],
    Case("camera +5 mm (x)", Pose(camera_offset_mm=(5.0, 0.0))),
    Case("camera −5 mm (y)", Pose(camera_offset_mm=(0.0, -5.0))),
    *[Case(f"tilt {t}°", Pose(tilt_deg=(float(t), 0.0))) for t in (1, 3, 5)],
    *[Case(f"ambient {a} %", ambient=a / 100) for a in (1, 3, 5)],
    *[Case(f"lamp size σ {s}", lobe_sigma=s) for s in (0.001, 0.01)],
    Case("combined: lamp 12 + camera 4.7 mm + tilt 3°", COMBINED),
    Case("combined + ambient 1.3 %", COMBINED, ambient=0.013),
]


def _scene(base: Preset, case: Case) -> Scene:
    preset = base if case.lobe_sigma is None else replace(base, light=replace(base.light, lobe_sigma=case.lobe_sigma))
    return Scene(preset, case.pose)


def _estimator_preset(base: Preset, case: Case) -> Preset:
    """What the user hands the estimator: cd-default, or one stating where the lamp really is."""
    if not case.states_lamp:
        return base
    x, y, z = base.light.position_mm
    dx, dy = case.pose.light_offset_mm
    return replace(base, light=Light(position_mm=(x + dx, y + dy, z), lobe_sigma=base.light.lobe_sigma,
                                     intensity=base.light.intensity))


def pick_lamps(count: int) -> list[Lamp]:
    """``count`` LSPDD lamps spread evenly over the file's order (deterministic)."""
    lamps = lspdd_lamps()
    idx = np.unique(np.linspace(0, len(lamps) - 1, count).round().astype(int))
    return [lamps[i] for i in idx]


def run_case(case: Case, base: Preset, lamps: list[Lamp], model, tmp: Path) -> dict:
    scene = _scene(base, case)
    cube = render_cube(scene, supersample=SUPERSAMPLE)
    meter = photo.track_mask(scene)
    cam = load_camera(DEFAULT_CAMERA)
    c = base.camera
    exif = photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], DEFAULT_CAMERA)
    preset = _estimator_preset(base, case)
    rows, refusals, seconds = [], [], []
    for i, lamp in enumerate(lamps):
        image, _ = photo.expose(photo.linear_photo(cube, lamp.spd, cam), 1.0, meter)
        image = image + case.ambient * AMBIENT_TINT
        image = np.minimum(photo.add_noise(image, NOISE, np.random.default_rng(1000 + i)), 1.0)
        path = tmp / f"p{i}.jpg"
        photo.write_photo(path, image, "jpg", exif)
        loaded = load_photo(path, max_side=max(c.image_size_px))
        t0 = time.perf_counter()
        try:
            est = estimate_image(loaded, preset=preset, model=model)
        except CDSpectraError as exc:
            refusals.append(str(exc))
            continue
        finally:
            seconds.append(time.perf_counter() - t0)
        m = colour_core.compare_spds(est.spd, lamp.spd)
        rows.append({"mae": float(m["mae_400_700"]), "duv": float(m["delta_uv_prime"]),
                     "confidence": float(est.confidence), "warnings": list(est.warnings)})
    return {"case": case, "rows": rows, "refusals": refusals, "seconds": float(np.mean(seconds))}


def _corr(a: list[float], b: list[float]) -> float:
    x, y = np.asarray(a, float), np.asarray(b, float)
    if x.size < 3 or np.std(x) == 0 or np.std(y) == 0:
        return math.nan
    return float(np.corrcoef(x, y)[0, 1])


def _fmt(v: float, spec: str = ".3f") -> str:
    return "—" if not math.isfinite(v) else format(v, spec)


def report(results: list[dict], n_lamps: int, size: int, seconds: float) -> str:
    nominal = results[0]["rows"]
    nominal_mae = float(np.mean([r["mae"] for r in nominal])) if nominal else math.nan
    lines = [
        "# Estimates across capture pose errors",
        "",
        f"`python -m training.evaluation.pose_errors --lamps {n_lamps} --size {size}` (`make eval-poses`).",
        f"{n_lamps} LSPDD lamps (evaluation only), 8-bit JPEG, {100 * NOISE:.0f} % noise, {size} px, "
        "rendered by the numpy twin of the forward model; estimated by `estimate_image` with the shipped model "
        "and the `cd-default` preset (no pose hints unless the row says the preset states the lamp).",
        "Lamp offsets are beside the lens along +x at the camera's height (210 mm); camera offsets move the "
        "camera parallel to the disc (still looking straight down); tilt turns the disc about x; ambient adds "
        f"a uniform warm offset ({', '.join(f'{t:.2f}' for t in AMBIENT_TINT)} × the share of full scale). "
        "Combined: lamp (12, 0) mm, camera (3.3, −3.3) mm, tilt 3°.",
        "Only true in the simulator: photos and inverse share the forward model.",
        "",
        "| capture | MAE 400–700 mean (median) | Δu'v' mean | confidence mean | refused | MAE / nominal "
        "| r(confidence, MAE) |",
        "|---|---|---|---|---|---|---|",
    ]
    all_conf, all_mae = [], []
    for res in results:
        rows = res["rows"]
        mae = [r["mae"] for r in rows]
        conf = [r["confidence"] for r in rows]
        all_conf += conf
        all_mae += mae
        mean = float(np.mean(mae)) if mae else math.nan
        cells = [res["case"].name,
                 f"{_fmt(mean)} ({_fmt(float(np.median(mae)) if mae else math.nan)})",
                 _fmt(float(np.mean([r['duv'] for r in rows])) if rows else math.nan, ".4f"),
                 _fmt(float(np.mean(conf)) if conf else math.nan, ".2f"),
                 f"{len(res['refusals'])}/{n_lamps}",
                 _fmt(mean / nominal_mae if nominal_mae > 0 else math.nan, ".2f"),
                 _fmt(_corr(conf, mae), ".2f")]
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"Confidence vs MAE over every estimate above: r = {_fmt(_corr(all_conf, all_mae), '.2f')} "
              f"({len(all_mae)} estimates; negative is good: low confidence where the error is large).", ""]
    messages = []
    for res in results:
        for text in sorted(set(res["refusals"]))[:2]:
            messages.append(f"- {res['case'].name}: refused — {text}")
        warned: dict[str, int] = {}
        for r in res["rows"]:
            for w in r["warnings"]:
                key = re.sub(r"\d+(\.\d+)?", "N", w)
                warned[key] = warned.get(key, 0) + 1
        if warned and res["case"].name != "nominal":
            top = sorted(warned.items(), key=lambda kv: -kv[1])[:2]
            messages.append(f"- {res['case'].name}: " + "; ".join(f"{n}× “{k}”" for k, n in top))
    if messages:
        lines += ["What the user is told (first refusals, most frequent warnings):", "", *messages, ""]
    lines += [f"Total {seconds:.0f} s on this machine.", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lamps", type=int, default=12)
    parser.add_argument("--size", type=int, default=256)
    parser.add_argument("--only", default="", help="run only cases whose name contains this text")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    base = load_preset("cd-default").with_image_size(args.size)
    lamps = pick_lamps(args.lamps)
    model = load_model()
    cases = [c for c in CASES if c.name == "nominal" or args.only in c.name]
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            res = run_case(case, base, lamps, model, Path(tmp))
            mae = [r["mae"] for r in res["rows"]]
            print(f"{case.name:48s} MAE {np.mean(mae) if mae else math.nan:.3f}  refused {len(res['refusals'])}"
                  f"  {res['seconds']:.2f} s/photo", flush=True)
            results.append(res)
    text = report(results, len(lamps), args.size, time.perf_counter() - t0)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
