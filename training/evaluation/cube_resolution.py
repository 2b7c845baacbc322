"""How many basis-cube pixels a training photo needs (bench/cube_resolution.md).

    python -m training.evaluation.cube_resolution [--n 12] [--out bench/cube_resolution.md]
    python -m training.evaluation.cube_resolution --cycles [--n 12]   # appends the Cycles spp table

The product reads a centred crop of the photo with the disc about 800–1000 px across. A training
photo is a basis cube (one geometry, rendered once) upsampled to that size and read back by the
product's loader; the cube is rendered with the preset's focal length × a multiplier, so the disc
fills the cube as it fills that crop. For one near-axis geometry and spectra drawn from the
prior's physical families (synthetic only), per (cube side, side read):

- the readout features against a cube rendered and read at the product's size (noise-free EXR:
  what the coarser cube and the coarser read change),
- the physics + prior MAE 400–700 nm (16-bit PNG, 1 % noise, true pose),
- the seconds each step costs per photo and the numpy twin's render time per cube.

Cycles' cost per cube is measured by ``render_cubes`` (bench/buildable_cubes.md).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.inverse.stages import physics_spd, read_photo
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import NEAR_AXIS_PRESET
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.pose.result import PoseFit

from training.learning.dataset import CubeSpec, disc_fill_multiplier
from training.learning.spd_prior import gaussian_prior, sample_spds
from training.learning.tune_fusion import TUNING_FAMILIES
from training.simulation import photo
from training.simulation.basis import REPO
from training.simulation.render_numpy import render_cube

READ_SIDE = 1024  # the product's crop: the disc ≈ 0.9 × this across
VARIANTS = ((256, 256), (512, 512), (256, 1024), (512, 1024), (1024, 1024))  # (cube side, side read)
CAMERA = DEFAULT_CAMERA
GEOMETRIES = ((f"{NEAR_AXIS_PRESET}, σ 0.0043 (preset)", None), (f"{NEAR_AXIS_PRESET}, σ 0.001 (thinnest streaks)", 0.001))


def _spec(size: int, sigma: float | None) -> CubeSpec:
    return CubeSpec("probe", preset=NEAR_AXIS_PRESET, size=size, lobe_sigma=sigma,
                    focal_multiplier=disc_fill_multiplier(NEAR_AXIS_PRESET))


class _Reader:
    """The dataset's path at one read size: known pose, cached per-pixel geometry."""

    def __init__(self, side: int, sigma: float | None, camera, prior):
        self.spec = _spec(side, sigma)
        scene = self.spec.scene()
        self.side, self.fit, self.pixels = side, PoseFit.of_scene(scene), pixel_diffraction(scene)
        self.camera, self.prior = camera, prior

    def __call__(self, path: Path):
        image = load_photo(path, max_side=self.side)
        analysis = read_photo(image, self.spec.reading_preset(), self.camera, fit=self.fit, pixels=self.pixels)
        return analysis.readout, physics_spd(analysis, self.prior)


def run(n: int, log=print) -> list[dict]:
    prior = gaussian_prior()
    prior_pair = (prior, prior.precision())
    camera = load_camera(CAMERA)
    rows = []
    spds, _ = sample_spds(n, np.random.default_rng(777), families=TUNING_FAMILIES)
    with tempfile.TemporaryDirectory() as tmp:
        exr, png = Path(tmp) / "a.exr", Path(tmp) / "b.png"
        for label, sigma in GEOMETRIES:
            cubes, render_s = {}, {}
            for size in sorted({c for c, _ in VARIANTS}):
                t0 = time.perf_counter()
                cubes[size] = render_cube(_spec(size, sigma).scene(), supersample=4 if size <= 512 else 2)
                render_s[size] = time.perf_counter() - t0
            readers = {side: _Reader(side, sigma, camera, prior_pair) for side in sorted({r for _, r in VARIANTS})}
            meters = {size: photo.track_mask(_spec(size, sigma).scene()) for size in cubes}
            cam = _spec(READ_SIDE, sigma).scene().preset.camera
            exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, READ_SIDE, CAMERA)
            refs = []
            for spd in spds:  # the reference: a cube rendered at the product's read size, noise-free
                img, _ = photo.expose(photo.linear_photo(cubes[READ_SIDE], spd, camera), 0.9, meters[READ_SIDE])
                photo.write_photo(exr, np.minimum(img, 1.0), "exr", exif)
                refs.append(readers[READ_SIDE](exr)[0])
            for size, side in VARIANTS:
                k = READ_SIDE // size  # every photo is written at the product's size, then read at `side`
                diffs, maes, t_make, t_read = [], [], [], []
                for i, spd in enumerate(spds):
                    img, _ = photo.expose(photo.linear_photo(cubes[size], spd, camera), 0.9, meters[size])
                    photo.write_photo(exr, np.minimum(photo.upsample(img, k), 1.0), "exr", exif)
                    readout, _ = readers[side](exr)
                    both = readout.valid & refs[i].valid
                    scale = float(np.max(refs[i].values[both]))
                    diffs.append(float(np.sqrt(np.mean((readout.values[both] - refs[i].values[both]) ** 2))) / scale)
                    t0 = time.perf_counter()
                    noisy = photo.add_noise(photo.upsample(img, k), 0.01, np.random.default_rng(i))
                    photo.write_photo(png, np.minimum(noisy, 1.0), "png16", exif)
                    t1 = time.perf_counter()
                    try:
                        _, e = readers[side](png)
                    except CDSpectraError:
                        maes.append(np.nan)
                        continue
                    finally:
                        t_make.append(t1 - t0)
                        t_read.append(time.perf_counter() - t1)
                    maes.append(compare_spds(e / e.max(), spd)["mae_400_700"])
                rows.append({"geometry": label, "cube": size, "read": side, "feature_rms": float(np.mean(diffs)),
                             "mae": float(np.nanmean(maes)) if not np.all(np.isnan(maes)) else float("nan"),
                             "refused": int(np.sum(np.isnan(maes))), "render_s": render_s[size],
                             "make_s": float(np.mean(t_make)), "read_s": float(np.mean(t_read))})
                log(rows[-1])
    return rows


def report(rows: list[dict], n: int) -> str:
    lines = ["# Basis-cube resolution for training photos (`python -m training.evaluation.cube_resolution`)", "",
             f"Synthetic only: {n} spectra of the prior's physical families, camera {CAMERA}, numpy twin, the "
             "near-axis phone set-up rendered with its focal length × the disc-filling multiplier (the disc spans "
             f"0.9 of the image: a centred crop). Every photo is written at {READ_SIDE} px, the size the product "
             f"reads (disc ≈ {int(0.9 * READ_SIDE)} px), from a cube of side N upsampled {READ_SIDE}/N×, and read "
             "back by the product's loader at the side given (box-reduced). *Feature RMS*: the λ₁ readout "
             f"(noise-free EXR, true pose) against a cube rendered and read at {READ_SIDE} px, share of the "
             "peak. *MAE*: physics + prior, 400–700 nm, 16-bit PNG, 1 % noise, true pose. Times on this "
             "machine (shared 2-core CPU): numpy render of the cube; per photo, synthesize + encode, then "
             "load + readout + solve (the dataset's path: pose known, per-pixel geometry cached).", "",
             "| geometry | cube N | read at | feature RMS | MAE 400–700 | refused | numpy render s | "
             "make s/photo | read s/photo |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['geometry']} | {r['cube']} | {r['read']} | {r['feature_rms']:.4f} | {r['mae']:.4f} | "
                     f"{r['refused']} | {r['render_s']:.1f} | {r['make_s']:.2f} | {r['read_s']:.2f} |")
    return "\n".join(lines) + "\n"


CYCLES_SPP = (4, 8, 16)


def run_cycles(n: int, log=print) -> list[dict]:
    """Cycles samples per pixel at the buildable cubes' size: the readout of a Cycles cube against
    the numpy twin's (8×8 supersampling, noise-free), and physics + prior MAE (1 % noise)."""
    from training.simulation.basis import basis_cube

    prior = gaussian_prior()
    prior_pair = (prior, prior.precision())
    camera = load_camera(CAMERA)
    spds, _ = sample_spds(n, np.random.default_rng(777), families=TUNING_FAMILIES)
    spec = _spec(512, None)
    reader = _Reader(512, None, camera, prior_pair)
    meter = photo.track_mask(spec.scene())
    cam = spec.scene().preset.camera
    exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, READ_SIDE, CAMERA)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        exr, png = Path(tmp) / "a.exr", Path(tmp) / "b.png"

        def readouts(cube):
            out, maes = [], []
            for i, spd in enumerate(spds):
                img, _ = photo.expose(photo.linear_photo(cube, spd, camera), 0.9, meter)
                photo.write_photo(exr, np.minimum(photo.upsample(img, 2), 1.0), "exr", exif)
                out.append(reader(exr)[0])
                noisy = photo.add_noise(photo.upsample(img, 2), 0.01, np.random.default_rng(i))
                photo.write_photo(png, np.minimum(noisy, 1.0), "png16", exif)
                _, e = reader(png)
                maes.append(compare_spds(e / e.max(), spd)["mae_400_700"])
            return out, float(np.mean(maes))

        ref, ref_mae = readouts(render_cube(spec.scene(), supersample=8))
        rows.append({"spp": "numpy twin 8×8", "seconds": float("nan"), "feature_rms": 0.0, "mae": ref_mae})
        for spp in CYCLES_SPP:
            t0 = time.perf_counter()
            cube, meta = basis_cube(replace(spec, samples=spp).scene(), "cycles")
            got, mae = readouts(cube)
            rms = []
            for a, b in zip(got, ref):
                both = a.valid & b.valid
                rms.append(float(np.sqrt(np.mean((a.values[both] - b.values[both]) ** 2)) / np.max(b.values[both])))
            rows.append({"spp": str(spp), "seconds": float(meta.get("render_seconds", time.perf_counter() - t0)),
                         "feature_rms": float(np.mean(rms)), "mae": mae})
            log(rows[-1])
    return rows


def report_cycles(rows: list[dict], n: int) -> str:
    lines = ["", "## Cycles samples per pixel at 512 px", "",
             f"The same geometry (σ of the preset), Cycles cubes at 512 px against the numpy twin's (8×8 stratified "
             f"samples per pixel); {n} spectra, read at 512 px, true pose. *Feature RMS*: noise-free readout against "
             "the twin's, share of the peak (includes the renderers' own ~35–60 dB difference). *MAE*: physics + "
             "prior, 400–700 nm, 1 % noise. Seconds: the Cycles render of the whole cube (81 bands) on this "
             "machine, as cached (a cube rendered earlier keeps its first time).", "",
             "| samples per pixel | cube render s | feature RMS | MAE 400–700 |", "|---|---|---|---|"]
    for r in rows:
        sec = "—" if not np.isfinite(r["seconds"]) else f"{r['seconds']:.0f}"
        lines.append(f"| {r['spp']} | {sec} | {r['feature_rms']:.4f} | {r['mae']:.4f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=12)
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "cube_resolution.md")
    parser.add_argument("--cycles", action="store_true", help="only the Cycles samples-per-pixel table (appended)")
    args = parser.parse_args(argv)
    if args.cycles:
        text = report_cycles(run_cycles(args.n), args.n)
        print(text)
        with open(args.out, "a", encoding="utf-8") as handle:
            handle.write(text)
        return 0
    text = report(run(args.n), args.n)
    print(text)
    args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
