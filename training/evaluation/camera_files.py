"""Which file to shoot: the same captures as every file a camera or phone writes (→ bench/camera_files.md).

    python -m training.evaluation.camera_files [--lamps 30] [--size 192] [--calibration-draws 3]
                                               [--out bench/camera_files.md]

Real lamps (every 7th of the 205 LSPDD lamps, evaluation only), nominal pose, 1 % sensor noise,
the numpy forward model (a small cube, so it runs in minutes on one core). Each lamp is
photographed by a camera whose pixels are twice the cube's per side and written as:

* EXR and a 16-bit linear TIFF (what a raw converter exports without processing);
* a DNG: a Bayer mosaic with noise per photosite, black level 512, white level 15000, read back
  through rawpy (LibRaw) by the product's loader;
* today's synthetic JPEG (camera-native RGB with an sRGB curve: a file no camera writes);
* an in-camera JPEG and a phone HEIC: the camera's typical rendering
  (:data:`training.simulation.camera_pipelines.TYPICAL`: fixed daylight white balance, fitted
  camera→sRGB matrix +10 % saturation, 25 % S-curve), and three random renderings sampled
  within what cameras and phones do — without calibration, with per-bin gains only, and with
  the fitted pipeline; each calibration is one shot of CIE A (a household bulb) taken the same way;
* the generic profile instead of the matched one, cameras outside the training set (held-out
  profiles; the file's EXIF names a camera we do not have, so "auto" picks generic), and four
  cameras unlike the 52 (``external_cameras/``: a phone, a phone-sized compact, a machine-vision
  CCD and a Foveon sensor; evaluation only) — each without calibration, with the old per-bin
  gains and with what ``calibrate`` now does for the generic profile: fit the camera's own
  sensitivities (:mod:`cd_spectra_addon.core.calibration.camera_fit`), then gains.

Every file is read by the product's decoders (``load_photo``: rawpy, libheif, JPEG draft) at the
rendered size → ``estimate_image`` (camera "auto" unless stated). Not through ``load_for_estimate``,
which reads any photo under 1024 px whole: these files are 2× or 4× the rendered size and under
1024 px, so read whole every rendered pixel would be a block of equal pixels whose footprint the
forward model takes for a half or a quarter (per side) of what it is
(:func:`training.simulation.photo.read_rendered`). All figures are from the simulator.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.calibration.calibration import Calibration, new_metadata
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from cd_spectra_addon.core.inverse.calibration_shot import fit_calibration
from cd_spectra_addon.core.calibration.camera_pipeline import CameraPipeline
from cd_spectra_addon.core.errors import NoDiscError
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, GENERIC_CAMERA, CameraProfile, load_camera
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Scene, load_preset
from cd_spectra_addon.core.inverse.estimate import camera_prior_for, estimate_image, resolve_camera
from cd_spectra_addon.core.photo.images import LinearImage, load_photo
from cd_spectra_addon.core.spectrum.model import load_model

from training.evaluation.evaluate import metrics, summary
from training.evaluation.lamps import Lamp, lspdd_lamps
from training.learning.dataset import camera_split
from training.simulation import photo
from training.simulation.basis import REPO
from training.simulation.camera_pipelines import (TYPICAL, InCameraStyle, in_camera_exif, pipeline_for, render_in_camera,
                                                  sample_style)
from training.simulation.dng import dng_bytes, mosaic
from training.simulation.render_numpy import render_cube

UPSAMPLE = 2
NOISE = 0.01
UNKNOWN_CAMERA = "Apple_iPhone 15 Pro"  # EXIF of a camera without a profile
# Cameras unlike the 52 (evaluation only, never trained on; licences in each file): a phone, a
# phone-sized compact sensor, a machine-vision CCD and a Foveon stacked sensor.
EXTERNAL_DIR = Path(__file__).resolve().parent / "external_cameras"
EXTERNAL_CAMERAS = [str(EXTERNAL_DIR / f"{n}.json") for n in
                    ("Nokia_N900", "Pentax_Q", "Point_Grey_Grasshopper2_14S5C", "Sigma_SD_Merrill")]

__all__ = ["main"]


@dataclass(frozen=True)
class Row:
    label: str
    fmt: str  # exr, tiff16, dng, jpg, jpg422 (4:2:2 chroma, quality 95: a DSLR's "fine" JPEG), heic
    rendering: str = "none"  # "none" (camera-native), "typical" or "random"
    # "none"; "gains": per-bin gains only; "camera": what `calibrate` does with a raw file (the
    # camera's sensitivities fitted when its profile is the generic one, then gains);
    # "pipeline": the same for an in-camera file, the camera's processing fitted first
    calibration: str = "none"
    camera: str = DEFAULT_CAMERA  # the camera that took the photo ("held-out", "external": see _camera)
    profile: str = "auto"  # what the estimate uses ("own": the camera's own profile, named by hand)
    reference: str = "dng"  # the row this one is compared with (its key)
    upsample: int = UPSAMPLE  # photo pixels per loaded pixel (per side)
    key: str = ""  # a name other rows' ``reference`` can use


SECTIONS = {
    "files": "Files a camera writes (Canon EOS 5D Mark III, its profile picked from EXIF)",
    "generic": "Cameras without a profile: the generic profile, and what one calibration shot of CIE A does",
    "large": f"The same files from a photo {2 * UPSAMPLE}× the loaded size per side (a 12 MP phone photo read at "
             "~1000 px is 4×, a 24 MP camera's 6×)",
}

ROWS: list[tuple[str, Row]] = [
    ("files", Row("EXR (linear float; camera chosen by hand, EXR has no EXIF)", "exr", profile=DEFAULT_CAMERA)),
    ("files", Row("16-bit linear TIFF", "tiff16")),
    ("files", Row("DNG (raw, via rawpy), matched profile from EXIF", "dng", key="dng")),
    ("files", Row("today's synthetic JPEG (camera-native, sRGB curve)", "jpg")),
    ("files", Row("in-camera JPEG (4:2:0, quality 90)", "jpg", "typical")),
    ("files", Row("… + CIE A calibration, gains only", "jpg", "typical", "gains")),
    ("files", Row("… + CIE A calibration, pipeline + gains", "jpg", "typical", "pipeline")),
    ("files", Row("in-camera JPEG, 3 random renderings + pipeline calibration", "jpg", "random", "pipeline")),
    ("files", Row("DSLR in-camera JPEG (4:2:2, quality 95) + CIE A calibration, pipeline + gains", "jpg422",
                  "typical", "pipeline")),
    ("files", Row("phone HEIC (8-bit)", "heic", "typical")),
    ("files", Row("… + CIE A calibration, pipeline + gains", "heic", "typical", "pipeline")),
    ("generic", Row("DNG, generic profile", "dng", profile=GENERIC_CAMERA)),
    ("generic", Row("DNG, generic profile + CIE A calibration (gains only, the old way)", "dng", calibration="gains",
                    profile=GENERIC_CAMERA)),
    ("generic", Row("DNG, generic profile + CIE A calibration (fitted camera + gains)", "dng", calibration="camera",
                    profile=GENERIC_CAMERA)),
    ("generic", Row("DNG, held-out camera, its own profile named by hand", "dng", camera="held-out", profile="own",
                    key="held")),
    ("generic", Row("DNG, held-out camera (EXIF unknown → generic)", "dng", camera="held-out", reference="held")),
    ("generic", Row("… + CIE A calibration (gains only, the old way)", "dng", calibration="gains", camera="held-out",
                    reference="held")),
    ("generic", Row("… + CIE A calibration (fitted camera + gains)", "dng", calibration="camera", camera="held-out",
                    reference="held")),
    ("generic", Row("DNG, camera unlike the 52 (phone, compact, machine vision, Foveon), its own profile by hand",
                    "dng", camera="external", profile="own", key="external")),
    ("generic", Row("DNG, camera unlike the 52 (EXIF unknown → generic)", "dng", camera="external",
                    reference="external")),
    ("generic", Row("… + CIE A calibration (fitted camera + gains)", "dng", calibration="camera", camera="external",
                    reference="external")),
    ("generic", Row("phone HEIC, camera unlike the 52 (EXIF unknown → generic) + CIE A calibration", "heic",
                    "typical", "pipeline", camera="external", reference="external")),
    ("large", Row("DNG", "dng", upsample=2 * UPSAMPLE, key="dng-large")),
    ("large", Row("in-camera JPEG (4:2:0, quality 90) + CIE A calibration", "jpg", "typical", "pipeline",
                  upsample=2 * UPSAMPLE, reference="dng-large")),
    ("large", Row("DSLR in-camera JPEG (4:2:2, quality 95) + CIE A calibration", "jpg422", "typical", "pipeline",
                  upsample=2 * UPSAMPLE, reference="dng-large")),
    ("large", Row("phone HEIC + CIE A calibration", "heic", "typical", "pipeline", upsample=2 * UPSAMPLE,
                  reference="dng-large")),
]


class Shooter:
    def __init__(self, tmp: Path, size: int):
        self.tmp = tmp
        self.scene = Scene(load_preset(REFERENCE_PRESET).with_image_size(size))
        t0 = time.perf_counter()
        self.cube = render_cube(self.scene, supersample=3)
        self.render_seconds = time.perf_counter() - t0
        self.meter = photo.track_mask(self.scene)

    def read(self, path: Path) -> LinearImage:
        """A file this shooter wrote, decoded by the product's loader at the rendered size (every
        row's file is :data:`UPSAMPLE` or 4× that per side: see :func:`photo.read_rendered`)."""
        return photo.read_rendered(path, self.scene)

    def native(self, spd: np.ndarray, camera: CameraProfile, seed: int, upsample: int, per_site: bool = False,
               exposure: float = 1.0) -> np.ndarray:
        """Exposed sensor values with noise: per pixel (H, W, 3), or per Bayer photosite (2H, 2W);
        ``exposure`` × the raw-peak metering (:func:`photo.expose`)."""
        image, _ = photo.expose(photo.linear_photo(self.cube, spd, camera), exposure, self.meter)
        image = photo.upsample(image, upsample)
        rng = np.random.default_rng(seed)
        if per_site:
            return np.minimum(photo.add_noise(mosaic(image), NOISE, rng), 1.0)
        return np.minimum(photo.add_noise(image, NOISE, rng), 1.0)

    def shoot(self, row: Row, spd: np.ndarray, camera: CameraProfile, exif_name: str,
              pipeline: CameraPipeline | None, seed: int, tag: str) -> LinearImage:
        cam = self.scene.preset.camera
        width = cam.image_size_px[0] * row.upsample
        exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, width, exif_name)
        if row.fmt == "dng":
            make, _, model = exif_name.replace("_", " ").partition(" ")
            path = self.tmp / f"{tag}.dng"
            path.write_bytes(dng_bytes(self.native(spd, camera, seed, row.upsample, per_site=True), black=512,
                                       white=15000,
                                       make=make, model=model or make, focal_length_mm=cam.focal_length_mm,
                                       focal_plane_px_per_mm=2 * width / cam.sensor_width_mm, seed=seed))  # per photosite
            return self.read(path)
        image = self.native(spd, camera, seed, row.upsample)
        if pipeline is not None:
            image = render_in_camera(image, pipeline, photo.upsample(self.meter, row.upsample).astype(bool))
            exif = in_camera_exif(exif)
        path = self.tmp / f"{tag}.{ {'tiff16': 'tif', 'jpg422': 'jpg'}.get(row.fmt, row.fmt)}"
        photo.write_photo(path, image, row.fmt, exif)
        return self.read(path)


def _camera(row: Row, index: int, held: list[str]) -> tuple[CameraProfile, str, str]:
    """(the camera that took the photo, the name its EXIF gives, the profile that names it)."""
    if row.camera == "held-out":
        name = held[index % len(held)]
        return load_camera(name), UNKNOWN_CAMERA, name
    if row.camera == "external":
        path = EXTERNAL_CAMERAS[index % len(EXTERNAL_CAMERAS)]
        return load_camera(path), UNKNOWN_CAMERA, path
    return load_camera(row.camera), row.camera, row.camera


def _styles(row: Row, n_lamps: int) -> list[InCameraStyle | None]:
    """One rendering per lamp group: the typical one, or three random ones (seeded)."""
    if row.rendering == "none":
        return [None] * n_lamps
    if row.rendering == "typical":
        return [TYPICAL] * n_lamps
    rng = np.random.default_rng(2024)
    styles = [sample_style(rng) for _ in range(3)]
    return [styles[i % 3] for i in range(n_lamps)]


def drawn(row: Row) -> bool:
    """Whether a row is measured over several calibration-shot noise draws: the rows whose CIE A
    shots fit an in-camera file's processing of the typical rendering (the one-shot fit issue 20
    found fragile): the Canon's one shot for every lamp, and the four cameras unlike the 52, one
    shot each. Their four shots did not average the noise out: that HEIC row read 0.043 / 0.053 /
    0.083 with the shots' seeds moved by 0 / 1000 / 2000. Rows with three random renderings stay
    one draw; raw rows fit no processing."""
    return row.calibration == "pipeline" and row.rendering == "typical" and row.camera in (DEFAULT_CAMERA, "external")


CALIBRATION_SEED = 99  # the first draw's calibration shot is seed 99 (+ lamp index), as before draws
DRAW_SEED_STEP = 10_000  # draw d: seed 99 + d × this (+ lamp index): far from the lamps' 1000 + i


def run_row(shooter: Shooter, row: Row, lamps: list[Lamp], model: Any, held: list[str], draws: int = 1
            ) -> dict[str, Any]:
    """The row's summary over the lamps estimated; ``refused`` counts the lamps the product
    refused (no rainbow found in the photo, or in the calibration shot they would use): a
    refusal is an outcome the product reports, not a crash of the table.

    ``draws`` > 1 (a calibrated row): the whole row again with each calibration shot's sensor
    noise drawn anew (the lamps' photos stay the same), the summary's figures the median over
    the draws, ``draws`` each draw's summary and ``worst`` the draw with the highest MAE."""
    if draws > 1 and row.calibration != "none":
        photos: dict[int, LinearImage] = {}
        each = [_run_draw(shooter, row, lamps, model, held, d, photos) for d in range(draws)]
        out = dict(each[0])
        for key in ("mae_400_700", "mae_400_700_median", "delta_uv_prime", "confidence"):
            out[key] = float(np.median([e[key] for e in each]))
        out["refused"] = int(max(e["refused"] for e in each))
        worst = max(each, key=lambda e: e["mae_400_700"] if np.isfinite(e["mae_400_700"]) else np.inf)
        out["worst"] = {k: worst[k] for k in ("mae_400_700", "delta_uv_prime", "confidence", "refused")}
        out["draws"] = [{k: e[k] for k in ("mae_400_700", "mae_400_700_median", "delta_uv_prime", "confidence",
                                           "refused", "calibration_checks")} for e in each]
        return out
    return _run_draw(shooter, row, lamps, model, held, 0, {})


def _run_draw(shooter: Shooter, row: Row, lamps: list[Lamp], model: Any, held: list[str], draw: int,
              photos: dict[int, LinearImage]) -> dict[str, Any]:
    """One draw of the calibration shots (seed 99 + draw × DRAW_SEED_STEP + lamp index); the
    lamps' photos are shot once into ``photos`` and reused by the later draws."""
    preset = shooter.scene.preset
    styles = _styles(row, len(lamps))
    calibrations: dict[tuple[InCameraStyle | None, str], Calibration | None] = {}
    rows, seconds, refused = [], [], []
    ref = known_lamp_spd("incandescent")
    for i, lamp in enumerate(lamps):
        camera, exif_name, own = _camera(row, i, held)
        profile_name = own if row.profile == "own" else row.profile
        style = styles[i]
        pipeline = None if style is None else pipeline_for(camera, style)  # the camera's own colour matrix
        cal = None
        if row.calibration != "none":
            key = (style, camera.name)
            if key not in calibrations:
                seed = CALIBRATION_SEED + draw * DRAW_SEED_STEP + i
                shot = shooter.shoot(row, ref, camera, exif_name, pipeline, seed=seed, tag="calibration")
                profile, generic, name, _ = resolve_camera(profile_name, shot, model)
                prior = camera_prior_for(model) if generic and row.calibration != "gains" else None
                try:
                    calibrations[key], _ = fit_calibration(shot, ref, preset, profile, generic,
                                                           pipeline=row.calibration == "pipeline", prior=prior,
                                                           name="eval", metadata=new_metadata("eval", "CIE A"))
                except NoDiscError as exc:
                    print(f"  {camera.name}: calibration refused ({str(exc)[:60]}...)", flush=True)
                    calibrations[key] = None
            cal = calibrations[key]
            if cal is None:
                refused.append(lamp.name)
                continue
        if i not in photos:
            photos[i] = shooter.shoot(row, lamp.spd, camera, exif_name, pipeline, seed=1000 + i, tag="photo")
        image = photos[i]
        t0 = time.perf_counter()
        try:
            est = estimate_image(image, preset=preset, camera=profile_name,
                                 calibration=cal, model=model)
        except NoDiscError as exc:
            print(f"  {lamp.name} ({camera.name}): refused ({str(exc)[:60]}...)", flush=True)
            refused.append(lamp.name)
            continue
        seconds.append(time.perf_counter() - t0)
        rows.append({**metrics(est.spd, lamp.spd), "confidence": est.confidence, "lamp": lamp.name,
                     "camera": est.camera, "processed": image.processed})
    out = summary(rows)
    out["seconds_per_photo"] = float(np.mean(seconds)) if seconds else math.nan
    out["processed_share"] = float(np.mean([r["processed"] for r in rows])) if rows else math.nan
    out["cameras"] = sorted({r["camera"] for r in rows})
    out["refused"] = len(refused)
    out["calibration_checks"] = [{k: c.metadata[k] for k in ("unexplained", "processing_rms_codes")
                                  if k in c.metadata} for c in calibrations.values() if c is not None]
    return out


def load_seconds(tmp: Path) -> dict[str, float]:
    """Best of two ``load_photo(max_side=1024)`` timings of a 24 MP Bayer DNG (uncompressed,
    48 MB), a 12 MP 8-bit HEIC and 24 MP JPEGs with 4:2:2 and 4:2:0 chroma, the sizes cameras
    and phones write."""
    from training.simulation.photo import write_photo

    rng = np.random.default_rng(0)
    sites = rng.uniform(0.0, 0.8, (4000, 6000)).astype(np.float32)
    (tmp / "big.dng").write_bytes(dng_bytes(sites, seed=None))
    y, x = np.mgrid[0:3024, 0:4032]
    smooth = np.stack([0.3 + 0.25 * np.sin(x / (70.0 + 20 * c) + y / 90.0) for c in range(3)], axis=-1)
    write_photo(tmp / "big.heic", smooth, "heic")
    y, x = np.mgrid[0:4000, 0:6000]
    smooth = np.stack([0.3 + 0.25 * np.sin(x / (70.0 + 20 * c) + y / 90.0) for c in range(3)], axis=-1)
    write_photo(tmp / "big422.jpg", smooth, "jpg422")
    write_photo(tmp / "big420.jpg", smooth, "jpg", quality=95)
    out = {}
    for name in ("big.dng", "big.heic", "big422.jpg", "big420.jpg"):
        times = []
        for _ in range(2):
            t0 = time.perf_counter()
            load_photo(tmp / name, max_side=1024)
            times.append(time.perf_counter() - t0)
        out[name] = min(times)
    return out


def _fmt(v: float, digits: int = 4) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def _worst(summary: dict[str, Any]) -> str:
    """The worst calibration draw's cell: '–' for a row measured once."""
    worst, draws = summary.get("worst"), summary.get("draws") or []
    if not worst:
        return "–"
    return (f"{_fmt(worst['mae_400_700'])} / {_fmt(worst['delta_uv_prime'])} / {_fmt(worst['confidence'], 2)} "
            f"(of {len(draws)})")


def report(results: list[tuple[str, Row, dict[str, Any]]], lamps: int, size: int, seconds: float,
           loads: dict[str, float], synthetic: bool, draws: int = 1) -> str:
    by_key = {row.key: summary for _, row, summary in results if row.key}
    names = {"dng": "DNG", "dng-large": "DNG", "held": "own profile", "external": "own profile"}
    source = ("synthetic SPDs of the training prior (`--synthetic`: what settings were chosen on)" if synthetic
              else "LSPDD lamps (evaluation only)")
    lines = [
        "# Which file to shoot (simulated" + (", synthetic lamps)" if synthetic else ", real lamps)"),
        "",
        f"`{'python -m training.evaluation.camera_files --synthetic' if synthetic else 'make eval-camera-files'}` — "
        f"{lamps} {source}, nominal pose, numpy forward model at {size}×{size} px (the photo {UPSAMPLE}× that per "
        f"side unless stated, read back at {size}×{size} by the product's decoders), 1 % sensor noise, the "
        "shipped model, camera \"auto\" (from EXIF) unless stated. "
        f"{seconds:.0f} s on one core. Calibrations are one shot of CIE A taken the same way (same camera, file "
        "type and settings). Rows calibrated from in-camera CIE A shots of the typical rendering (the Canon's, and the "
        "cameras unlike the 52's HEIC) are "
        f"measured over {draws} draws of that shot's sensor noise (`--calibration-draws {draws}`; the lamps' photos "
        "stay the same): their figures are the median over the draws, the last column the draw with the highest "
        "MAE; other rows are one draw (seed 99). **All figures are from the simulator.**",
    ]
    for section, title in SECTIONS.items():
        rows = [(row, summary) for sec, row, summary in results if sec == section]
        if not rows:
            continue
        lines += ["", f"## {title}", "", "| file | MAE 400–700 (median) | × reference | Δu'v' | confidence | "
                  "flagged processed | worst calibration draw: MAE / Δu'v' / confidence |",
                  "|---|---|---|---|---|---|---|"]
        for row, summary in rows:
            ref = by_key.get(row.reference)
            ratio = f"{summary['mae_400_700'] / ref['mae_400_700']:.2f} ({names[row.reference]})" if ref else "–"
            note = f"; {summary['refused']} of {lamps} refused (no rainbow)" if summary.get("refused") else ""
            mae = f"{_fmt(summary['mae_400_700'])} ({_fmt(summary['mae_400_700_median'])}){note}"
            lines.append(f"| {row.label} | {mae} | "
                         f"{ratio} | {_fmt(summary['delta_uv_prime'])} | {_fmt(summary['confidence'], 2)} | "
                         f"{_fmt(100 * summary['processed_share'], 0)}% | {_worst(summary)} |")
    lines += ["", "Goals (issue 11): DNG as good as EXR; in-camera JPEG + one CIE A calibration within 1.3× of DNG; "
              "generic profile + calibration within 1.3× of the matched profile (here: the camera's own profile).",
              "Cameras unlike the 52 (`training/evaluation/external_cameras/`, evaluation only): Nokia N900 (a "
              "phone), Pentax Q (a phone-sized 1/2.3\" sensor), Point Grey Grasshopper2 14S5C (a machine-vision "
              "CCD) — Jiang et al. 2013, CC BY-NC-SA — and the Sigma SD Merrill (Foveon; Darrodi et al. 2015 via "
              "colour-science), one per lamp in turn.", ""]
    if loads:
        lines += [f"Loading (`load_photo(max_side=1024)`, best of 2, this machine): 24 MP Bayer DNG (48 MB, "
                  f"uncompressed) {loads['big.dng']:.2f} s — rawpy unpack, 2×2 binning, 3×3 box; 12 MP 8-bit HEIC "
                  f"{loads['big.heic']:.2f} s — libheif decode, 4×4 box; 24 MP DSLR JPEG (4:2:2, q95) "
                  f"{loads['big422.jpg']:.2f} s — full-size YCbCr decode, 8×8 box in YCbCr (4:2:0 JPEGs take the "
                  f"1/4 DCT-scaled decode: {loads['big420.jpg']:.2f} s).", ""]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--lamps", type=int, default=30)
    parser.add_argument("--size", type=int, default=192)
    parser.add_argument("--out", default="", help="default bench/camera_files.md (--synthetic: "
                        "bench/camera_files_synthetic.md)")
    parser.add_argument("--rows", default="", help="comma-separated row numbers (1-based) to run; default all")
    parser.add_argument("--calibration-draws", type=int, default=3,
                        help="noise draws of the calibration shot for the rows calibrated from one in-camera CIE A "
                             "shot (median and worst reported; default 3; 1: seed 99 only, as before)")
    parser.add_argument("--synthetic", action="store_true",
                        help="synthetic SPDs from the training prior instead of real lamps: for choosing settings "
                             "(never on the evaluation lamps)")
    args = parser.parse_args(argv)
    if args.calibration_draws < 1:
        parser.error("--calibration-draws must be at least 1")
    draws = args.calibration_draws
    t0 = time.perf_counter()
    if args.synthetic:
        from training.learning.spd_prior import sample_spds

        spds, families = sample_spds(args.lamps, np.random.default_rng(777))
        lamps = [Lamp(f"synthetic-{i}", fam, "synthetic", spd) for i, (spd, fam) in enumerate(zip(spds, families))]
    else:
        everything = lspdd_lamps()
        lamps = everything[:: max(1, len(everything) // args.lamps)][: args.lamps]
    model = load_model()
    _, held = camera_split()
    rows = ROWS if not args.rows else [ROWS[int(i) - 1] for i in args.rows.split(",")]
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        shooter = Shooter(Path(tmp), args.size)
        for section, row in rows:
            t1 = time.perf_counter()
            summary = run_row(shooter, row, lamps, model, held, draws if drawn(row) else 1)
            results.append((section, row, summary))
            worst = "" if "worst" not in summary else (
                f"; worst of {draws} draws MAE {summary['worst']['mae_400_700']:.4f} "
                "(draws " + ", ".join(f"{d['mae_400_700']:.4f}" for d in summary["draws"]) + ")")
            print(f"{row.label}: MAE {summary['mae_400_700']:.4f} (median {summary['mae_400_700_median']:.4f}) "
                  f"Δu'v' {summary['delta_uv_prime']:.4f} conf {summary['confidence']:.2f}{worst} "
                  f"[{time.perf_counter() - t1:.0f} s]", flush=True)
        seconds = time.perf_counter() - t0
        loads = load_seconds(Path(tmp)) if not args.rows and not args.synthetic else {}
    out = Path(args.out or REPO / "bench" / ("camera_files_synthetic.md" if args.synthetic else "camera_files.md"))
    if not args.rows:
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(report(results, len(lamps), args.size, seconds, loads, args.synthetic, draws), encoding="utf-8")
        out.with_suffix(".json").write_text(json.dumps([{"section": sec, "row": r.label, **s} for sec, r, s in results],
                                                       indent=1), encoding="utf-8")
        print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
