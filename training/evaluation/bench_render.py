"""Benchmark the forward renderer: basis cubes vs one render per sample, and samples vs error.

    python -m training.evaluation.bench_render [--out bench/render.md] [--quick]

Prints and writes a Markdown table plus JSON (same stem). All timings in one run on this
machine; compare them as ratios.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import time
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Scene, load_preset
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation import cycles_scene, photo
from training.simulation.render_numpy import render_cube as numpy_cube

PAPER_SAMPLES = 5000  # the paper rendered one image per training SPD


def psnr(test: np.ndarray, ref: np.ndarray) -> float:
    mse = float(np.mean((np.asarray(test, np.float64) - ref) ** 2))
    return float("inf") if mse == 0 else 10 * math.log10(float(ref.max()) ** 2 / mse)


def radial_profile(image: np.ndarray, centre: np.ndarray, step: float = 1.0) -> np.ndarray:
    rows, cols = np.indices(image.shape)
    idx = (np.hypot(rows - centre[0], cols - centre[1]) / step).astype(int).ravel()
    sums = np.bincount(idx, weights=image.ravel())
    counts = np.bincount(idx)
    return sums / np.maximum(counts, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("bench/render.md"))
    parser.add_argument("--quick", action="store_true", help="small sizes (smoke run)")
    args = parser.parse_args()
    size = 96 if args.quick else 256
    cube_sizes = (96,) if args.quick else (256, 512)
    spps = (1, 4, 16) if args.quick else (1, 2, 4, 8, 16, 32, 64, 128)
    converged_spp = 64 if args.quick else 1024
    preset = load_preset(REFERENCE_PRESET)
    shipped_spp = preset.samples
    probe = np.array([400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0, 750.0, 780.0])  # 3 renders

    result: dict = {"machine": {"cpus": os.cpu_count(), "platform": platform.platform()},
                    "preset": preset.name, "shipped_spp": shipped_spp}
    # 1) Basis cube vs one render per training sample.
    cubes = []
    for s in cube_sizes:
        scene = Scene(preset.with_image_size(s))
        cube, seconds = cycles_scene.render_cube(scene, WAVELENGTHS_NM, shipped_spp)
        t0 = time.perf_counter()
        numpy_cube(scene, supersample=4)
        numpy_seconds = time.perf_counter() - t0
        cam = load_camera(DEFAULT_CAMERA)
        spd = np.linspace(0.2, 1.0, 81)
        t0 = time.perf_counter()
        n_photo = 20
        for _ in range(n_photo):
            photo.linear_photo(cube, spd, cam)
        photo_seconds = (time.perf_counter() - t0) / n_photo
        cubes.append({"size": s, "cycles_cube_s": seconds, "renders": int(math.ceil(81 / 3)),
                      "numpy_cube_s": numpy_seconds, "photo_from_cube_ms": photo_seconds * 1e3,
                      "paper_way_s": PAPER_SAMPLES * seconds,
                      "basis_way_s": seconds + PAPER_SAMPLES * photo_seconds})
    result["cubes"] = cubes

    # 2) Samples per pixel vs error against a converged render.
    scene = Scene(preset.with_image_size(size))
    centre = scene.project(np.zeros((1, 3)))[0]
    reference, ref_seconds = cycles_scene.render_cube(scene, probe, converged_spp, seed=7)
    twin = numpy_cube(scene, supersample=16)[[int((x - 380) / 5) for x in probe]]
    rows = []
    for spp in spps:
        test, seconds = cycles_scene.render_cube(scene, probe, spp, seed=1)
        per_band = [psnr(test[k], reference[k]) for k in range(probe.size)]
        profile_err = max(
            float(np.max(np.abs(radial_profile(test[k], centre) - radial_profile(reference[k], centre)))
                  / radial_profile(reference[k], centre).max())
            for k in range(probe.size))
        rows.append({"spp": spp, "seconds_3_renders": seconds,
                     "cube_seconds_est": seconds * 27 / 3, "psnr_min": min(per_band),
                     "psnr_median": float(np.median(per_band)), "radial_profile_max_err": profile_err})
    result["spp_sweep"] = {"size": size, "converged_spp": converged_spp, "rows": rows,
                           "converged_vs_numpy_psnr_min": min(psnr(reference[k], twin[k]) for k in range(probe.size))}

    lines = [
        "# Forward renderer benchmark (`make bench-render`)",
        "",
        f"Machine: {result['machine']['cpus']} CPUs, {result['machine']['platform']}. Preset `{result['preset']}`,",
        f"Cycles on the CPU with the OSL shader, {shipped_spp} samples per pixel (shipped), three bands per render.",
        "",
        "## Basis cube vs one render per training sample",
        "",
        "The paper rendered one image per training SPD. With an RGB renderer a photo of an arbitrary",
        "SPD needs every band's radiance at every pixel, i.e. the same work as one basis cube, so the",
        f"paper's way costs one cube per sample ({PAPER_SAMPLES} samples). The basis way renders the cube",
        "once and makes each photo by a matrix product.",
        "",
        "| image | Cycles cube (27 renders) | numpy twin cube | photo from cube | 5000 photos, paper's way | 5000 photos, basis way | speed-up |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in cubes:
        lines.append(f"| {c['size']}² | {c['cycles_cube_s']:.1f} s | {c['numpy_cube_s']:.1f} s | "
                     f"{c['photo_from_cube_ms']:.1f} ms | {c['paper_way_s'] / 3600:.1f} h | "
                     f"{c['basis_way_s']:.0f} s | {c['paper_way_s'] / c['basis_way_s']:.0f}× |")
    sweep = result["spp_sweep"]
    lines += [
        "",
        f"## Samples per pixel vs error ({sweep['size']}², 9 bands, against {converged_spp} spp)",
        "",
        "PSNR is per band image against the converged Cycles render (peak signal); the radial-profile",
        "error is the largest deviation of the azimuthal mean profile (what the inverse reads), as a",
        "fraction of its peak.",
        "",
        "| spp | seconds (3 renders) | cube seconds (est.) | PSNR min | PSNR median | radial profile max error |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['spp']} | {r['seconds_3_renders']:.2f} | {r['cube_seconds_est']:.1f} | "
                     f"{r['psnr_min']:.1f} dB | {r['psnr_median']:.1f} dB | {100 * r['radial_profile_max_err']:.3f} % |")
    lines += [
        "",
        f"Converged Cycles vs numpy twin (16×16 supersampling): PSNR min {sweep['converged_vs_numpy_psnr_min']:.1f} dB.",
        "",
    ]
    text = "\n".join(lines)
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(text, encoding="utf-8")
    args.out.with_suffix(".json").write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
