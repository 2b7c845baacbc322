"""Soak: many estimates in one process, and whether its memory stays flat.

    python -m training.reliability.soak --n 1000 [--warmup 50] [--size 128] [--json OUT.json]

The photos cycle through a small set written once to a temporary folder: three lamps in three
encodings (8-bit PNG, JPEG, EXR) plus one input of each kind that must fail (no disc, an empty
file, a truncated JPEG), so the error paths run as often as the happy ones. Resident memory
(RSS, from /proc/self/statm after ``gc.collect()`` and glibc's ``malloc_trim``; peak RSS from
``resource`` where /proc is missing) is read after
``--warmup`` estimates, when caches (onnxruntime session, colour tables, LUTs) have filled, and
again at the end; ``growth`` is (end − warm) / warm. The bar is < 10 %.

While no model is trained into models/, the estimator runs its physics + prior path
(``estimate_photo(model=None)``); the report says which.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectrum.model import MODEL_DIR, MODEL_NAME

GROWTH_BAR = 0.10

__all__ = ["rss_mb", "write_photos", "soak", "main", "GROWTH_BAR"]


def _release_free_heap() -> None:
    """Give freed heap pages back to the OS (glibc's malloc_trim) so RSS measures what is still
    held, not what the allocator keeps cached: without it, readings one estimate apart swung
    56 → 71 → 56 MB, more than the leak bar."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc (macOS, musl, Windows): read RSS as it is
        pass


def rss_mb() -> float:
    """Resident set size now (MB), after a garbage collection and a heap trim. /proc/self/statm
    where there is one (Linux), else the peak."""
    gc.collect()
    _release_free_heap()
    statm = Path("/proc/self/statm")
    if statm.is_file():
        pages = int(statm.read_text().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 2**20
    import resource  # macOS: ru_maxrss is the peak, in bytes

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024


def write_photos(folder: Path, size: int = 128) -> list[tuple[Path, bool]]:
    """(path, should succeed) for the soak's cycle of inputs."""
    from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
    from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Scene, load_preset
    from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
    from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise
    from training.simulation import photo
    from training.simulation.render_numpy import render_cube

    scene = Scene(load_preset(REFERENCE_PRESET).with_image_size(size))
    cube = render_cube(scene, supersample=2)
    cam = load_camera(DEFAULT_CAMERA)
    meter = photo.track_mask(scene)
    c = scene.preset.camera
    exif = photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], DEFAULT_CAMERA)
    lam = WAVELENGTHS_NM
    lamps = {
        "incandescent": known_lamp_spd("incandescent"),
        "led": peak_normalise(0.35 * np.exp(-0.5 * ((lam - 452) / 9) ** 2) + np.exp(-0.5 * ((lam - 590) / 55) ** 2)),
        "daylight": peak_normalise(1.0 + 0.3 * np.cos((lam - 460.0) / 60.0)),
    }
    out: list[tuple[Path, bool]] = []
    rng = np.random.default_rng(0)
    for (name, spd), fmt in zip(lamps.items(), ("png", "jpg", "exr")):
        image, _ = photo.synthesize(cube, spd, cam, noise=0.01, rng=rng, meter=meter)
        path = folder / f"{name}.{fmt}"
        photo.write_photo(path, image, fmt, exif if fmt != "exr" else None)
        out.append((path, True))
    noise = folder / "noise.png"
    photo.write_photo(noise, rng.random((size, size, 3)), "png")
    empty = folder / "empty.jpg"
    empty.write_bytes(b"")
    cut = folder / "cut.jpg"
    cut.write_bytes(photo.encode_photo(image, "jpg")[:2000])
    out += [(noise, False), (empty, False), (cut, False)]
    return out


def soak(n: int, warmup: int = 50, size: int = 128, progress: bool = False) -> dict[str, Any]:
    """Run ``n`` estimates (after ``warmup`` more) and report memory and time."""
    from cd_spectra_addon.core.inverse.estimate import estimate_photo
    from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET

    shipped = (MODEL_DIR / f"{MODEL_NAME}.onnx").is_file()
    model: Any = "shipped" if shipped else None
    with tempfile.TemporaryDirectory(prefix="cd_spectra_soak_") as tmp:
        inputs = write_photos(Path(tmp), size)
        start_mb = rss_mb()
        times: list[float] = []
        by_input: dict[str, list[float]] = {p.name: [] for p, _ in inputs}
        outcomes = {"results": 0, "errors": 0}
        unexpected: list[str] = []
        samples: list[tuple[int, float]] = []
        warm_mb = start_mb
        for i in range(warmup + n):
            path, should_succeed = inputs[i % len(inputs)]
            t0 = time.perf_counter()
            try:
                result = estimate_photo(path, model=model, preset=REFERENCE_PRESET)  # the photos' geometry
                if not (np.all(np.isfinite(result.spd)) and result.spd.max() == 1.0):
                    unexpected.append(f"{path.name}: SPD not finite / not peak 1")
                outcomes["results"] += 1
                if not should_succeed:
                    unexpected.append(f"{path.name}: a result where an error was expected")
            except CDSpectraError:
                outcomes["errors"] += 1
                if should_succeed:
                    unexpected.append(f"{path.name}: an error where a result was expected")
            times.append((time.perf_counter() - t0) * 1e3)
            if i >= warmup:
                by_input[path.name].append(times[-1])
            if i + 1 == warmup:
                warm_mb = rss_mb()
            if i + 1 > warmup and (i + 1 - warmup) % max(1, n // 10) == 0:
                samples.append((i + 1 - warmup, rss_mb()))
                if progress:
                    print(f"  {i + 1 - warmup}/{n}: RSS {samples[-1][1]:.1f} MB", file=sys.stderr)
        end_mb = rss_mb()
    timed = times[warmup:] or times
    return {
        "n": n,
        "warmup": warmup,
        "photo_size_px": size,
        "inputs": [p.name for p, _ in inputs],
        "estimator": "shipped model" if shipped else "physics + prior (estimate_photo(model=None); no shipped model)",
        "rss_start_mb": start_mb,
        "rss_after_warmup_mb": warm_mb,
        "rss_end_mb": end_mb,
        "rss_samples_mb": samples,
        "growth": (end_mb - warm_mb) / warm_mb,
        "growth_bar": GROWTH_BAR,
        "ms_per_estimate": {"mean": statistics.fmean(timed), "median": statistics.median(timed),
                            "p95": float(np.percentile(timed, 95)), "max": max(timed)},
        "median_ms_by_input": {k: statistics.median(v) for k, v in by_input.items() if v},
        "outcomes": outcomes,
        "unexpected": unexpected,
        "python": sys.version.split()[0],
        "platform": sys.platform,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=1000, help="estimates after the warm-up (default 1000)")
    parser.add_argument("--warmup", type=int, default=50)
    parser.add_argument("--size", type=int, default=128, help="photo size in pixels (default 128)")
    parser.add_argument("--json", type=Path, help="also write the report as JSON")
    args = parser.parse_args(argv)
    report = soak(args.n, args.warmup, args.size, progress=True)
    text = json.dumps(report, indent=1)
    if args.json:
        args.json.write_text(text + "\n", encoding="utf-8")
    print(text)
    ok = report["growth"] < GROWTH_BAR and not report["unexpected"]
    print(f"RSS {report['rss_after_warmup_mb']:.1f} MB after {args.warmup} warm-up estimates -> "
          f"{report['rss_end_mb']:.1f} MB after {args.n} more ({100 * report['growth']:+.1f} %, bar "
          f"{100 * GROWTH_BAR:.0f} %); {report['ms_per_estimate']['mean']:.0f} ms per estimate: "
          f"{'PASS' if ok else 'FAIL'}", file=sys.stderr)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
