"""Write bench/reliability.md: what the reliability suite tried and what each input produced.

    python -m training.reliability.report [--out bench/reliability.md] [--soak-n 1000]

Every number in the file comes from this command: the hostile-input catalogue
(``training.reliability.hostile``, the one ``tests/test_hostile_inputs.py`` asserts) run through the CLI and
``estimate_photo``; sweeps that calibrated the confidence checks for off-centre and very dark
photos, and one that shows what is still wrong (ambient light); the soak
(``training.reliability.soak``); and the forward-model extremes, Cycles against the numpy twin
(``training.reliability.stress``; skipped without bpy).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectrum.model import MODEL_DIR, MODEL_NAME

from training.reliability import hostile, soak

ROOT = Path(__file__).resolve().parents[2]


def _short(text: str, folder: Path, limit: int = 170) -> str:
    text = " ".join(text.replace(str(folder) + os.sep, "").replace(str(folder), ".").split())
    text = text.replace("|", "\\|")
    return text if len(text) <= limit else text[: limit - 1] + "…"


def _expected(case: hostile.Case) -> str:
    if case.cli_expect is not None:
        return f"CLI: {_expectation(case.cli_expect)}; API: {_expectation(case.expect)}"
    return _expectation(case.expect)


def _expectation(e: hostile.Expect) -> str:
    if e.error is not None:
        return f"{e.error.__name__}: " + ", ".join(f"“{w}”" for w in e.words)
    parts = [f"result, confidence ≤ {e.max_confidence:g}" if e.max_confidence < 1 else "result"]
    if e.min_confidence > 0:
        parts.append(f"≥ {e.min_confidence:g}")
    if e.words:
        parts.append("warning “" + " … ".join(e.words) + "”")
    if e.cct:
        parts.append(f"CCT ±{hostile.CCT_TOLERANCE_K:.0f} K")
    return ", ".join(parts)


def _cli_cell(out: hostile.Outcome | None, folder: Path) -> str:
    if out is None:
        return "—"
    if out.exit_code == 0:
        return f"exit 0, confidence {out.confidence:.2f}" + (f", CCT {out.cct_k:.0f} K" if out.cct_k else "")
    return f"exit {out.exit_code}: `{_short(out.message, folder)}`"


def _api_cell(out: hostile.Outcome | None, folder: Path) -> str:
    if out is None:
        return "— (CLI only)"
    if out.ok:
        warn = "; ".join(_short(w, folder, 90) for w in out.warnings) or "no warning"
        return f"confidence {out.confidence:.2f}" + (f", CCT {out.cct_k:.0f} K" if out.cct_k else "") + f" — {warn}"
    return f"{out.error_type}"


def run_hostile() -> tuple[list[str], list[str]]:
    """(markdown lines, failures) for the whole catalogue."""
    base = hostile.make_base()
    lines: list[str] = []
    failures: list[str] = []
    with tempfile.TemporaryDirectory(prefix="cd_spectra_hostile_") as tmp:
        root = Path(tmp)
        built = {}
        for case in hostile.CASES:
            folder = root / case.name
            built[case.name] = (folder, *hostile.build_case(case, folder, base))
        runnable = [c for c in hostile.CASES if built[c.name][1] is not None]
        with ThreadPoolExecutor(2) as pool:
            futures = {c.name: pool.submit(hostile.run_cli, c, *built[c.name]) for c in runnable}
            api = {c.name: hostile.run_in_process(c, built[c.name][1], built[c.name][2])
                   for c in runnable if c.in_process}
            cli = {name: f.result() for name, f in futures.items()}
        counts: dict[str, dict[str, int]] = {}
        rows = []
        for case in hostile.CASES:
            folder = built[case.name][0]
            tally = counts.setdefault(case.category, {"cases": 0, "errors": 0, "results": 0, "met": 0, "skipped": 0})
            tally["cases"] += 1
            if case.name not in cli:
                tally["skipped"] += 1
                rows.append(f"| {case.category} | {case.name} | {case.what} | {_expected(case)} | skipped here | — | — |")
                continue
            verdicts = [hostile.judge(case, cli[case.name], "cli")]
            if case.name in api:
                verdicts.append(hostile.judge(case, api[case.name], "api"))
            ok = all(v[0] for v in verdicts)
            tally["met"] += ok
            tally["errors" if case.expected("cli").error is not None else "results"] += 1
            if not ok:
                failures.append(f"{case.name}: " + "; ".join(v[1] for v in verdicts if not v[0]))
            rows.append(f"| {case.category} | {case.name} | {case.what} | {_expected(case)} | "
                        f"{_cli_cell(cli[case.name], folder)} | {_api_cell(api.get(case.name), folder)} | "
                        f"{'yes' if ok else '**no**'} |")
        lines += ["| category | inputs | refused (error) | estimated (result) | as expected |", "|---|---|---|---|---|"]
        for cat, t in counts.items():
            lines.append(f"| {cat} | {t['cases']} | {t['errors']} | {t['results']} | {t['met']}/{t['cases'] - t['skipped']}"
                         + (f" ({t['skipped']} not buildable here)" if t["skipped"] else "") + " |")
        total = sum(t["cases"] for t in counts.values())
        met = sum(t["met"] for t in counts.values())
        lines.append(f"| **all** | {total} | {sum(t['errors'] for t in counts.values())} | "
                     f"{sum(t['results'] for t in counts.values())} | {met}/{total - sum(t['skipped'] for t in counts.values())} |")
        lines += ["", "| category | case | input | expected | CLI (`python -m cd_spectra_addon estimate`) | "
                  "`estimate_photo` | as expected |", "|---|---|---|---|---|---|---|", *rows]
        peaks = [o.peak_rss_mb for n, o in cli.items() if n.startswith("bomb") and o.peak_rss_mb]
        if peaks:
            lines += ["", f"Decompression bombs (50 000 × 50 000 headers): refused from the header; the CLI "
                          f"process peaked at {max(peaks):.0f} MB resident (Python + numpy + Pillow alone ≈ 40 MB; "
                          f"decoding would need ≈ 7.5 GB)."]
    return lines, failures


def _warm_led() -> np.ndarray:
    from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise

    lam = WAVELENGTHS_NM
    return peak_normalise(0.35 * np.exp(-0.5 * ((lam - 452) / 9) ** 2) + np.exp(-0.5 * ((lam - 590) / 55) ** 2))


def _sweep(rows: list[tuple[str, str, Any, np.ndarray]], header: str) -> list[str]:
    """Estimate each (lamp, setting, make(folder) -> photo path, true SPD) and tabulate."""
    from cd_spectra_addon.core.spectra.colour import compare_spds
    from cd_spectra_addon.core.inverse.estimate import estimate_photo
    from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET
    from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA

    lines = [f"| lamp | {header} | MAE 400–700 | Δu′v′ | confidence | warnings |", "|---|---|---|---|---|---|"]
    with tempfile.TemporaryDirectory() as tmp:
        for lamp, setting, make, spd in rows:
            path = make(Path(tmp))
            try:
                # the sweeps' photos' geometry and camera (an EXR names none: "auto" would read it
                # with the generic profile, whose error would hide the offset's)
                result = estimate_photo(path, preset=REFERENCE_PRESET, camera=DEFAULT_CAMERA, model=_model())
            except CDSpectraError as exc:
                lines.append(f"| {lamp} | {setting} | — | — | — | {type(exc).__name__}: {_short(str(exc), Path(tmp), 90)} |")
                continue
            m = compare_spds(result.spd, spd)
            warn = "; ".join(w.split(" — ")[0].split(":")[0] for w in result.warnings) or "—"
            lines.append(f"| {lamp} | {setting} | {m['mae_400_700']:.3f} | {m['delta_uv_prime']:.4f} | "
                         f"{result.confidence:.2f} | {warn} |")
    return lines


def _model() -> Any:
    return "shipped" if (MODEL_DIR / f"{MODEL_NAME}.onnx").is_file() else None


def run_sweeps() -> list[str]:
    from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, load_preset
    from training.simulation import photo

    base = hostile.make_base()
    lamps = {"CIE A": base.spd, "warm LED": _warm_led()}
    shots = {name: base.shoot(spd) for name, spd in lamps.items()}
    cam = load_preset(REFERENCE_PRESET).camera
    px_per_mm = cam.focal_length_mm / cam.sensor_width_mm * base.linear.shape[1] / cam.distance_mm

    def png(image: np.ndarray, name: str, exif: bytes | None = base.exif) -> Any:
        return lambda folder: hostile._write(folder, name, image, "png", exif)

    def exr(image: np.ndarray, name: str) -> Any:
        def make(folder: Path) -> Path:
            photo.write_photo(folder / name, image, "exr")
            return folder / name
        return make

    crops = [(lamp, f"{k / 2 / px_per_mm:.1f} mm", png(shots[lamp][:, k:], f"crop{k}.png"), spd)
             for lamp, spd in lamps.items() for k in (0, 8, 16, 24, 32, 48, 64, 96)]
    dims = [(lamp, f"{level:g}×", png(base.shoot(spd, exposure=level), f"dim{level:g}.png"), spd)
            for lamp, spd in lamps.items() for level in (1.0, 0.05, 0.01, 0.005, 0.003)]
    ambient = [("CIE A", f"{level:+g}", exr(shots["CIE A"] + level, f"ambient{level:g}.exr"), base.spd)
               for level in (-0.02, -0.01, 0.0, 0.01, 0.03, 0.1)]
    return [
        "### Disc off the middle of the photo", "",
        "Columns cropped from the left of the 256 px capture move the disc's centre off the image centre "
        f"({px_per_mm:.2f} px per mm in the disc plane). The check warns above 5 mm and reaches its floor "
        "at 15 mm; before it, every row here had confidence 1.00.", "",
        *_sweep(crops, "disc centre off the middle"),
        "", "### Very dark 8-bit photos", "",
        "Exposure × level with the same camera noise (8-bit PNG). The check warns below 1 % of full scale.", "",
        *_sweep(dims, "exposure"),
        "", "### A constant offset (ambient light or a black level) in an EXR", "",
        "The offset is measured on the disc's dark part and subtracted; from 1 % of full scale the estimate "
        "says so (`AMBIENT_WARN`). The EXR carries no EXIF: its camera is named, and the missing focal "
        "length costs 0.2 of the confidence.", "",
        *_sweep(ambient, "offset (full scale 1)"),
    ]


def run_soak(n: int) -> tuple[list[str], dict[str, Any]]:
    """The soak in a child process of its own, so its RSS is the estimator's alone."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "soak.json"
        subprocess.run([sys.executable, "-m", "training.reliability.soak", "--n", str(n), "--json", str(out)], cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, capture_output=True, text=True, timeout=7200)
        report = json.loads(out.read_text())
    ms = report["ms_per_estimate"]
    lines = [f"`python -m training.reliability.soak --n {n}` ({report['estimator']}): {len(report['inputs'])} inputs in turn "
             f"({', '.join(report['inputs'])}), {report['outcomes']['results']} results and "
             f"{report['outcomes']['errors']} refusals, in one process:", "",
             "| | RSS |", "|---|---|",
             f"| start (photos written, nothing estimated) | {report['rss_start_mb']:.1f} MB |",
             f"| after {report['warmup']} warm-up estimates | {report['rss_after_warmup_mb']:.1f} MB |",
             *[f"| after {k} more | {v:.1f} MB |" for k, v in report["rss_samples_mb"]],
             f"| end | {report['rss_end_mb']:.1f} MB |",
             f"| growth after warm-up | {100 * report['growth']:+.2f} % (bar {100 * soak.GROWTH_BAR:.0f} %) |", "",
             f"Time per estimate ({report['photo_size_px']} px photos, refusals included): mean {ms['mean']:.0f} ms, "
             f"median {ms['median']:.0f} ms, p95 {ms['p95']:.0f} ms, max {ms['max']:.0f} ms. Median by input: "
             + ", ".join(f"{k} {v:.0f} ms" for k, v in report["median_ms_by_input"].items()) + ".",
             "" if not report["unexpected"] else "Unexpected: " + "; ".join(report["unexpected"])]
    return lines, report


def run_stress() -> list[str]:
    try:
        import bpy  # noqa: F401
    except ImportError:
        return ["Skipped: bpy (headless Blender) is not importable here."]
    from training.reliability.stress import EDGE_BANDS, EXTREMES, compare_extreme

    lines = ["Cycles (OSL, CPU) at pixel centres (1 sample, filter 0.01 px) against the numpy twin's "
             "band radiance at the same rays, 48 px, bands " + ", ".join(f"{b:.0f}" for b in EDGE_BANDS) + " nm "
             "(bands with signal only):", "",
             "| capture | finite, ≥ 0 | PSNR (dB), worst band | band sums Cycles/twin |", "|---|---|---|---|"]
    for name in EXTREMES:
        r = compare_extreme(name)
        psnr = r["psnr_db"]
        worst = min(psnr.values()) if psnr else None
        sums = r["sum_ratio"]
        span = f"{min(sums.values()):.4f}–{max(sums.values()):.4f}" if sums else "all zero"
        lines.append(f"| {name} | {'yes' if r['finite'] and r['non_negative'] else '**no**'} | "
                     f"{'—' if worst is None else f'{worst:.1f} (of {len(psnr)} bands)'} | {span} |")
    return lines


def run_antialias() -> list[str]:
    try:
        import bpy  # noqa: F401
    except ImportError:
        return []
    from training.reliability.stress import antialiasing_comparison

    r = antialiasing_comparison()
    pairs = lambda key: ", ".join(f"{w:.0f} nm {v:.3f}" for w, v in zip(r["wavelength_nm"], r[key]))  # noqa: E731
    return ["Anti-aliased renders agree less well where rings are far thinner than a pixel (a 28 mm lens at "
            "100 mm, 48 px). Band sums, Cycles / twin: with Cycles' 1 px box filter at 1024 spp against the "
            f"twin's 16×16 stratified box, {pairs('anti_aliased')}; with Cycles point-sampled at 4× resolution "
            f"and averaged 4×4 against the twin's 4×4 samples (the same positions), {pairs('point_sampled')}. "
            "So the BRDFs agree and the difference is in how the two integrate a pixel; at the shipped capture "
            "(58 mm lens, 210 mm, 128 px) tests/test_cycles_render.py holds it under 1 %. Left alone: it "
            "concerns the renderers' anti-aliasing, not this issue."]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "bench" / "reliability.md")
    parser.add_argument("--soak-n", type=int, default=1000)
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
    estimator = ("the shipped model" if _model() else
                 "the physics + prior path (`estimate_photo(model=None)`: no model in models/ yet); "
                 "the model cases bring their own broken toy models")
    print("hostile inputs…", file=sys.stderr)
    hostile_lines, failures = run_hostile()
    print("sweeps…", file=sys.stderr)
    sweep_lines = run_sweeps()
    print(f"soak ({args.soak_n})…", file=sys.stderr)
    soak_lines, soak_report = run_soak(args.soak_n)
    if soak_report["growth"] >= soak.GROWTH_BAR or soak_report["unexpected"]:
        failures.append(f"soak: growth {100 * soak_report['growth']:+.1f} %, {soak_report['unexpected']}")
    print("forward-model extremes…", file=sys.stderr)
    stress_lines = run_stress()
    antialias_lines = run_antialias()
    failures += [f"forward stress: {ln}" for ln in stress_lines if "**no**" in ln]
    doc = [
        "# Reliability: bad input, numerical stress, nothing lost",
        "",
        f"Written by `python -m training.reliability.report --soak-n {args.soak_n}` "
        f"({dt.date.today().isoformat()}, commit {commit or '?'}, {os.cpu_count()} CPUs, "
        f"{platform.platform()}, Python {platform.python_version()}) in "
        f"{(time.perf_counter() - t0) / 60:.1f} min. The estimator is {estimator}.",
        "",
        "## Hostile inputs",
        "",
        "Each input is generated from one rendered capture of a CIE A lamp (`training/hostile.py`; the same "
        "catalogue `tests/test_hostile_inputs.py` asserts, where a subset also runs through the add-on's "
        "Estimate operator in headless Blender: ERROR, CANCELLED, no data-block changed). The CLI runs in a "
        "child process; *as expected* means exit 2 with exactly one `error:` line (no traceback, nothing on "
        "stdout, no file left) or exit 0 with a result meeting the expectation, and the same from "
        "`estimate_photo` (that `CDSpectraError` subclass, or a finite result).",
        "",
        *hostile_lines,
        "",
        "## Confidence checks, calibrated",
        "",
        *sweep_lines,
        "",
        "## Soak",
        "",
        *soak_lines,
        "",
        "Headless Blender (tests/test_soak.py): 10 enable/disable cycles and 8 estimate → create-light cycles "
        "add no data-block, handler, RNA type or image decoder beyond one light object + light per light and "
        "one node group per distinct SPD.",
        "",
        "## Forward model at its extremes",
        "",
        *stress_lines,
        "",
        *antialias_lines,
        "",
        "## What still fails",
        "",
        *([f"- {f}" for f in failures] or ["- Nothing in the catalogue, the soak or the extremes above."]),
        "- A disc far off the image centre is now flagged and its confidence capped, but not estimated well: "
        "the inverse assumes the camera looks at the disc's centre (fitting the principal point would fix it).",
        "- A 32-bit float TIFF needs Blender's image loader: the CLI and the add-on read it through Blender, "
        "the bare Python API (`estimate_photo` without Blender) refuses it with a clear message.",
    ]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(doc) + "\n", encoding="utf-8")
    print(f"wrote {args.out} ({len(failures)} failures)", file=sys.stderr)
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main())
