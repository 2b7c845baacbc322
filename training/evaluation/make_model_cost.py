"""What `make model` costs on this machine, step by step, projected from short timed runs.

    python -m training.evaluation.make_model_cost [--photos 120] [--out bench/make_model_cost.md]

Times one Cycles cube of the buildable set (rendered afresh into a temporary cache) and ``--photos``
training photos of one near-axis cube through the dataset's own per-cube job in one process, then
projects the whole build (17 cubes; 1000 photos per geometry read by 2 workers; 60 epochs and the
fusion tuning at the pilot's measured rates). Run it on an otherwise idle machine: the load
average is printed with the numbers.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from training.learning import dataset as ds
from training.simulation.basis import REPO, basis_cube

N_PER_CUBE = 1000
READ_NOW, ALL = 11, 17  # geometries the estimator reads today / once oblique photos are read
EPOCHS = 60
TUNE_S = 2 * 139.0  # the pilot's fusion tuning at 48 photos per case, ×2 for 96 (bench/buildable_pilot.md)
# Training per sample and epoch (2 threads): the pilot's 30 s for 2970 samples × 30 epochs. Timing a
# few epochs here swung 0.02–3 ms with the machine's other jobs; the full runs agree (the `full`
# build: 4.8 min for 18 720 × 60, 0.26 ms).
EPOCH_S = 30.0 / (2970 * 30)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--photos", type=int, default=120)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "make_model_cost.md")
    args = parser.parse_args(argv)
    spec = ds.CUBE_SETS["buildable"][0]
    load = [os.getloadavg()[0]]
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        basis_cube(spec.scene(), "cycles", cache_dir=Path(tmp))
        cube_s = time.perf_counter() - t0
    load.append(os.getloadavg()[0])
    job = ds.CubeJob(spec, args.photos, 0, ds.camera_split()[0], ds.Degradation(), "cycles", None, 3)
    t0 = time.perf_counter()
    part = ds.run_cube(job)
    photo_s = (time.perf_counter() - t0) / max(1, len(part["inputs"]))
    load.append(os.getloadavg()[0])
    rows = []
    for label, n_read in (("now (11 geometries read)", READ_NOW), ("once oblique photos are read (17)", ALL)):
        samples = n_read * N_PER_CUBE
        steps = {"Cycles cubes": ALL * cube_s, "dataset (2 workers)": samples * photo_s / 2,
                 "training": samples * 0.9 * EPOCHS * EPOCH_S, "fusion + per-band choice": TUNE_S}
        rows.append((label, samples, steps))
    lines = ["# What `make model` costs (`python -m training.evaluation.make_model_cost`)", "",
             f"{os.cpu_count()} CPUs; 1-minute load average {', '.join(f'{v:.1f}' for v in load)} at the start and "
             "after each timed step (this job adds 1–2; more means another job shared the machine).", "",
             "| timed here | seconds |", "|---|---|",
             f"| one Cycles cube, `{spec.name}` (512 px, {ds.BUILDABLE_SPP} spp) | {cube_s:.0f} |",
             f"| one training photo through the dataset's job, 1 process ({len(part['inputs'])} photos) | {photo_s:.2f} |",
             f"| (one training sample-epoch, 2 threads: the pilot's {EPOCH_S * 1e3:.2f} ms, not timed here) | |", "",
             "| projection | samples | Cycles | dataset | training | tuning | total |", "|---|---|---|---|---|---|---|"]
    for label, samples, steps in rows:
        cells = " | ".join(f"{v / 60:.0f} min" for v in steps.values())
        lines.append(f"| {label} | {samples} | {cells} | **{sum(steps.values()) / 60:.0f} min** |")
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
