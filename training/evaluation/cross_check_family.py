"""Where CROSS_CHECK_LIMIT comes from: the two-lamp cross-check over the calibration's own family.

    python -m training.evaluation.cross_check_family [--out bench/cross_check_family.md]

A CIE A and a D65 photo of the disc (the reference preset, 192 px read from a photo 2× that per
side), for the profiled Canon and a phone unlike the 52 (generic profile), as RAW and as JPEGs in
the calibration's own family of renderings (training/simulation/camera_pipelines.py: the typical
one and three sampled ones), two noise draws each, calibrated as ``calibrate`` does
(:func:`calibrate_shots`); each known lamp read with the calibration the other alone gives. The
limit is 3× the worst of the profiled camera's family JPEGs (as EXPLAIN_LIMIT is set); the phone's
are reported, not judged. No held-out rendering and no evaluation lamp is used. Simulator only.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.calibration.calibration import CROSS_CHECK_FAMILY_WORST, CROSS_CHECK_LIMIT
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.calibration_shot import Shot, calibrate_shots
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from cd_spectra_addon.core.spectrum.model import load_model
from training.evaluation.camera_files import UPSAMPLE
from training.evaluation.camera_renderings import SETTINGS, Photographer
from training.simulation import photo
from training.simulation.basis import REPO
from training.simulation.camera_pipelines import TYPICAL, pipeline_for, render_in_camera, sample_style

__all__ = ["main"]

LAMPS = (("incandescent", "CIE A"), ("daylight-d65", "D65"))
DRAWS = 2


def run() -> list[dict[str, Any]]:
    """One row per (camera, rendering, draw): each held-out lamp's MAE, or the calibration's refusal."""
    model = load_model()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        ph = Photographer(Path(tmp), 192)
        meter = photo.upsample(ph.shooter.meter, UPSAMPLE).astype(bool)
        styles = [("typical", TYPICAL)] + [(f"sampled {s}", sample_style(np.random.default_rng(s))) for s in (1, 2, 3)]
        for setting in SETTINGS:
            camera = load_camera(setting.camera)
            for name, style in [("RAW", None)] + styles:
                def render(img, cam, style=style):  # noqa: ANN001, ANN202 - a Photographer renderer
                    return render_in_camera(img, pipeline_for(cam, style), meter)

                for draw in range(DRAWS):
                    shots = []
                    for k, (lamp, _) in enumerate(LAMPS):
                        seed = 99 + k + 100 * draw
                        spd = known_lamp_spd(lamp)
                        image = (ph.raw(spd, camera, setting.exif, seed, f"c{k}") if style is None
                                 else ph.jpeg(spd, camera, setting.exif, render, seed, f"c{k}"))
                        shots.append(Shot(image, spd))
                    row: dict[str, Any] = {"camera": setting.key, "label": setting.label, "rendering": name,
                                           "draw": draw}
                    try:
                        cal, _ = calibrate_shots(shots, ph.preset, "auto", model, labels=[n for _, n in LAMPS])
                        row["checks"] = cal.metadata["cross_check"]
                        row["unexplained"] = cal.metadata.get("unexplained")
                    except CDSpectraError as exc:
                        row["refused"] = " ".join(str(exc).split())
                    print(row, flush=True)
                    rows.append(row)
    return rows


def _cell(row: dict[str, Any]) -> str:
    if "refused" in row:
        return "calibration refused"
    return ", ".join(f"{c['held_out']} {c['mae_400_700']:.3f}" if "mae_400_700" in c else f"{c['held_out']} unread"
                     for c in row["checks"])


def report(rows: list[dict[str, Any]], seconds: float) -> str:
    judged = [c["mae_400_700"] for r in rows if r["camera"] == "dslr" and r["rendering"] != "RAW"
              for c in r.get("checks", []) if "mae_400_700" in c]
    worst = max(judged) if judged else float("nan")
    lines = ["# Two-lamp cross-check over the calibration's own family (`python -m training.evaluation.cross_check_family`)",
             "", __doc__.split("\n\n", 2)[2].strip(), "", f"{seconds:.0f} s on this machine.", "",
             "| camera | file | draw | held-out lamp: MAE 400–700 | calibration unexplained |", "|---|---|---|---|---|"]
    for r in rows:
        share = r.get("unexplained")
        lines.append(f"| {r['label']} | {r['rendering']} | {r['draw']} | {_cell(r)} | "
                     f"{'–' if share is None else f'{100 * share:.1f} %'} |")
    lines += ["", f"Worst of the profiled camera's family JPEGs: {worst:.3f}; 3× that: {3 * worst:.3f}. "
              f"The product uses CROSS_CHECK_FAMILY_WORST = {CROSS_CHECK_FAMILY_WORST} → CROSS_CHECK_LIMIT = "
              f"{CROSS_CHECK_LIMIT:.3f} (core/calibration/calibration.py)."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default=str(REPO / "bench" / "cross_check_family.md"))
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    rows = run()
    Path(args.out).write_text(report(rows, time.perf_counter() - t0), encoding="utf-8")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
