"""Today's estimator on photos of the buildable set-ups (numpy twin, simulator only).

    python -m training.evaluation.setup_samples [--lamps N] [--out bench/setup_samples.md]

For each set-up preset (and cd-default as the reference row) the numpy twin renders the
capture once as a real photo frames it — at 1024 px with the focal length scaled so the disc
spans 800 px (``pose_errors.crop_preset``: a centred crop of a 12–24 MP photo, the same
perspective), written at 2048 px — then N LSPDD lamps become 8-bit JPEGs with 1 % noise per
photo pixel (the issue's test conditions) and go through ``estimate_photo(...,
preset=<set-up>)``, the product's whole path (its disc-window loader too), with no pose hints.
Prints, per set-up: photos refused (and the first message), median / mean MAE 400–700 of the
rest, and mean confidence. Numbers are from the simulator, not from real photographs.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Scene
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import estimate_photo
from cd_spectra_addon.core.planning.setups import setup_names

from training.evaluation.lamps import lspdd_lamps
from training.evaluation.pose_errors import UPSAMPLE, crop_preset
from training.simulation import photo
from training.simulation.render_numpy import render_cube

NOISE = 0.01


def evaluate(preset_name: str, lamps: list, folder: Path) -> dict:
    scene = Scene(crop_preset(preset_name)[0])
    cube = render_cube(scene, supersample=3)
    camera = load_camera(DEFAULT_CAMERA)
    cam = scene.preset.camera
    exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, cam.image_size_px[0] * UPSAMPLE, camera.name)
    meter = photo.track_mask(scene)
    rng = np.random.default_rng(0)
    maes, confidences, refusals, warned, warnings = [], [], Counter(), 0, Counter()
    for i, lamp in enumerate(lamps):
        image, _ = photo.expose(photo.linear_photo(cube, lamp.spd, camera), 1.0, meter)
        image = np.minimum(photo.add_noise(photo.upsample(image, UPSAMPLE), NOISE, rng), 1.0)
        path = folder / f"{preset_name}-{i}.jpg"
        photo.write_photo(path, image, "jpg", exif)
        try:
            result = estimate_photo(path, preset=preset_name)
        except CDSpectraError as exc:
            refusals[" ".join(str(exc).split())[:160].replace("|", "/")] += 1
            continue
        maes.append(compare_spds(result.spd, lamp.spd)["mae_400_700"])
        confidences.append(result.confidence)
        warned += bool(result.warnings)
        if result.warnings:
            warnings[result.warnings[0][:120].replace("|", "/")] += 1
    return {"preset": preset_name, "n": len(lamps), "refused": sum(refusals.values()), "reasons": refusals,
            "mae": maes, "confidence": confidences, "warned": warned,
            "warnings": warnings}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--lamps", type=int, default=12, help="how many LSPDD lamps (every k-th of the file)")
    parser.add_argument("--out", type=Path, help="also write the table here (markdown)")
    args = parser.parse_args(argv)
    every = lspdd_lamps()
    lamps = every[:: max(1, len(every) // args.lamps)][: args.lamps]
    lines = [f"# Today's estimator on the buildable set-ups ({len(lamps)} LSPDD lamps, 8-bit JPEG, 1 % noise, "
             "numpy twin, disc 800 px across in a 2048 px photo, no pose hints; simulator only)", "",
             "`python -m training.evaluation.setup_samples`", "",
             "| preset | refused | MAE 400–700 median (mean) | confidence mean | warned | commonest refusal / warning |",
             "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for name in [REFERENCE_PRESET, *setup_names()]:
            row = evaluate(name, lamps, Path(tmp))
            mae = (f"{np.median(row['mae']):.3f} ({np.mean(row['mae']):.3f})" if row["mae"] else "—")
            conf = f"{np.mean(row['confidence']):.2f}" if row["confidence"] else "—"
            common = (row["reasons"] or row["warnings"]).most_common(1)
            reason = common[0][0] if common else ""
            lines.append(f"| {name} | {row['refused']}/{row['n']} | {mae} | {conf} | {row['warned']} | {reason} |")
            print(lines[-1], flush=True)
    text = "\n".join(lines) + "\n"
    if args.out:
        args.out.write_text(text, encoding="utf-8")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
