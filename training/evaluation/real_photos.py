"""Real photographs: Kim 2023's CD and DVD series read through the product's own path.

Kim, "Diffraction on Optical Disks" (2023; github.com/yongwookkkkim/Diffraction-on-Optical-Disks,
``unwritten/cd1.gif`` and ``unwritten/dvd1.gif``): 34 frames each of a plain disc under a small
filament lamp, frame i at θ = 15° + 5° i, the azimuth between the lamp's and the camera's
vertical planes. The paper states the geometry (Figs. 3–4, case 1): lamp 700 mm from the disc
centre at 83.5° from the disc's axis, camera 230 mm at 38°. The lamp was not measured; a small
filament lamp is near Planck at 2400–3400 K, which is what the figures below are judged against.

The GIFs carry no licence: they are read from a folder the user gives (``--kim-dir`` or
``KIM_DIR``), never fetched and never committed; the contact sheet, which shows the frames, is
written under ``build/`` (git-ignored). Nothing here tunes anything: the frames check the
product, they do not train it.

Each frame goes through what a user's ``estimate`` of ``cd1.gif#N`` does, with a preset written
from the stated numbers by :func:`~cd_spectra_addon.core.planning.measured.measured_preset` (the
lamp's azimuth −θ from the camera's: the lines the geometry predicts match the frames that way
round), the generic camera (no EXIF) and the focal length from the disc's outline where it
shows. Refusals are reported with their message.

    python -m training.evaluation.real_photos --kim-dir DIR --out bench/real_photos.md
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import AUTO, estimate_image, resolve_camera, resolved_model
from cd_spectra_addon.core.inverse.joint import estimate_joint
from cd_spectra_addon.core.inverse.load import load_for_estimate
from cd_spectra_addon.core.inverse.batch import series_lenses
from cd_spectra_addon.core.inverse.stages import MIN_COVERAGE_NM, pose_photo
from cd_spectra_addon.core.photo.frames import frame_count, with_frame
from cd_spectra_addon.core.planning.measured import Measurements, measured_preset
from cd_spectra_addon.core.scene.capture import Preset, Scene
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.spectra.cameras import GENERIC_CAMERA
from cd_spectra_addon.core.spectrum.model import SpectralModel
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from cd_spectra_addon.core.spectra.illuminants import planck_spd

LAMP_MM, LAMP_ANGLE = 700.0, 83.5  # the paper's case 1
CAMERA_MM, CAMERA_ANGLE = 230.0, 38.0
FRAME_SIZE = (750, 625)
PLANCK_BAND = (450.0, 650.0)  # the band for r against the best Planck curve
PLANCK_GRID_K = np.arange(1000.0, 10001.0, 25.0)
TARGET_CCT_K = (2400.0, 3400.0)
TARGET_R = 0.95
SERIES = {"cd1.gif": "cd", "dvd1.gif": "dvd"}


def theta_deg(frame: int) -> float:
    """Kim's azimuth between the lamp's and the camera's vertical planes for frame ``frame``."""
    return 15.0 + 5.0 * frame


def kim_preset(disc: str, frame: int) -> Preset:
    """The preset a user writes from the paper's numbers (``cd_spectra setup``)."""
    return measured_preset(Measurements(
        lamp_distance_mm=LAMP_MM, lamp_angle_deg=LAMP_ANGLE, lamp_azimuth_deg=-theta_deg(frame),
        camera_distance_mm=CAMERA_MM, camera_angle_deg=CAMERA_ANGLE, camera_azimuth_deg=0.0,
        disc=disc, image_size_px=FRAME_SIZE, name=f"kim-{disc}-theta{theta_deg(frame):g}"))


def first_order_nm(scene: Scene) -> float:
    """How much of 400–700 nm (5 nm bins) the geometry puts in the first order on the tracks,
    where the lamp's lobe is seen (visibility > 0.3): the frames the issue says must be read."""
    px = pixel_diffraction(scene)
    lam = px.lambda1_nm[px.on_tracks & (px.visibility > 0.3)]
    return 5.0 * np.unique(np.floor(lam[(lam >= 400.0) & (lam < 700.0)] / 5.0)).size


def best_planck(spd: np.ndarray) -> tuple[float, float]:
    """(r, T): the Planck curve whose shape over PLANCK_BAND correlates best with ``spd``."""
    band = (WAVELENGTHS_NM >= PLANCK_BAND[0]) & (WAVELENGTHS_NM <= PLANCK_BAND[1])
    best = (-1.0, math.nan)
    for t in PLANCK_GRID_K:
        r = float(np.corrcoef(spd[band], planck_spd(float(t))[band])[0, 1])
        if r > best[0]:
            best = (r, float(t))
    return best


@dataclass
class FrameResult:
    series: str
    frame: int
    theta: float
    stated_first_order_nm: float
    refused: str = ""
    cct_k: float | None = None
    planck_r: float = math.nan
    planck_t: float = math.nan
    confidence: float = math.nan
    line_offset_px: float = math.nan
    line_share: float = math.nan
    focal_source: str = ""
    focal_px: float = math.nan
    strategy: str = ""
    seconds: float = 0.0
    spd: np.ndarray | None = None
    scene: Scene | None = field(default=None, repr=False)
    image: Any = field(default=None, repr=False)  # the loaded frame and its pose fit, for the joint
    fit: Any = field(default=None, repr=False)

    @property
    def read(self) -> bool:
        return not self.refused


def series_focal(path: Path, disc: str, frames: list[int]) -> float | None:
    """The series' lens (file pixels) from the disc outlines of its frames (one camera and zoom),
    as ``estimate`` of the GIF finds it (:func:`~cd_spectra_addon.core.inverse.batch.series_lenses`)."""
    lenses = series_lenses([with_frame(path, f) for f in frames], [kim_preset(disc, f) for f in frames])
    return lenses.get(str(path))


@functools.lru_cache(maxsize=1)
def _model() -> SpectralModel | None:
    return resolved_model("shipped")


def read_frame(path: Path, disc: str, frame: int, focal_file_px: float | None = None) -> FrameResult:
    """One frame through the product's loader, pose stage and estimate; ``focal_file_px`` the
    series' focal length where its outlines gave one (else the frame's own, as ``estimate``)."""
    return read_source(with_frame(path, frame), path.name, disc, frame, focal_file_px)


def read_source(source: str, series: str, disc: str, frame: int, focal_file_px: float | None = None) -> FrameResult:
    """:func:`read_frame` of the photo ``source`` (a file, or a GIF's frame) taken as Kim's
    frame ``frame``: the simulated control's photos go the same way."""
    preset = kim_preset(disc, frame)
    out = FrameResult(series, frame, theta_deg(frame), first_order_nm(Scene(preset)))
    t0 = time.perf_counter()
    try:
        image = load_for_estimate(source, preset)
        focal = None if focal_file_px is None else focal_file_px / image.scale
        # The profile estimate picks for this file (no EXIF: the generic one) poses it, as in
        # estimate_image: the pose fit's colour model and its size-from-colour depend on it.
        camera, generic, _, _ = resolve_camera(AUTO, image, _model())
        posed = pose_photo(image, preset, camera, generic_camera=generic, focal_px=focal)
        out.focal_source = "series outline" if focal is not None else posed.focal_source
        out.focal_px = float(posed.focal_px)
        out.image, out.fit = image, posed.fit
        out.scene = posed.fit.known_scene
        out.line_offset_px, out.line_share = posed.fit.line_offset_px, posed.fit.line_share
        out.strategy = posed.fit.strategy
        est = estimate_image(image, preset=preset, fit=posed.fit, focal_px=posed.focal_px)
    except CDSpectraError as exc:
        out.refused = str(exc)
        out.seconds = time.perf_counter() - t0
        return out
    out.seconds = time.perf_counter() - t0
    out.spd, out.cct_k, out.confidence = est.spd, est.cct_k, est.confidence
    out.planck_r, out.planck_t = best_planck(est.spd)
    return out


@dataclass
class JointResult:
    series: str
    used: list[int]
    partial: list[int]
    held_nm: float
    refused: str = ""
    cct_k: float | None = None
    planck_r: float = math.nan
    planck_t: float = math.nan
    confidence: float = math.nan


def read_joint(results: list[FrameResult], disc: str) -> JointResult:
    """``estimate --joint`` of every frame whose rainbow the pose stage found (each with its own
    fit and preset): the frames together may cover what no one frame does."""
    frames = [r for r in results if r.fit is not None]
    out = JointResult(results[0].series if results else "", [], [], 0.0)
    if not frames:
        out.refused = "no frame was posed"
        return out
    try:
        est = estimate_joint([r.image for r in frames], preset=[kim_preset(disc, r.frame) for r in frames],
                             fits=[r.fit for r in frames])
    except CDSpectraError as exc:
        out.refused = str(exc)
        return out
    joint = est.extra.get("joint", {})
    for r, entry in zip(frames, joint.get("photos", [])):
        if not entry.get("refused"):
            out.used.append(r.frame)
            if entry.get("partial"):
                out.partial.append(r.frame)
    out.held_nm = float(sum(b - a for a, b in joint.get("held_nm", [])))
    out.cct_k, out.confidence = est.cct_k, est.confidence
    out.planck_r, out.planck_t = best_planck(est.spd)
    return out


def contact_sheet(path: Path, results: list[FrameResult], out: Path) -> None:
    """The frames with the fitted first-order line drawn over them (λ₁ colours; the 2nd and 3rd
    orders white and grey) and each read SPD beside its frame with its best Planck curve."""
    from PIL import Image, ImageDraw

    thumbs = []
    for res in results:
        with Image.open(path) as im:
            im.seek(res.frame)
            frame = im.convert("RGB")
        draw = ImageDraw.Draw(frame)
        if res.scene is not None:
            px = pixel_diffraction(res.scene)
            width = frame.size[0]
            for m, colour in ((1, None), (2, (255, 255, 255)), (3, (140, 140, 140))):
                lam = px.lambda1_nm / m
                keep = px.on_tracks & (px.visibility > 0.6) & (lam >= 400) & (lam <= 700)
                for k in np.flatnonzero(keep)[::3]:
                    row, col = divmod(int(px.index[k]), width)
                    draw.point((col, row), fill=colour or _wavelength_rgb(float(lam[k])))
        label = f"{res.series}#{res.frame} θ={res.theta:g}°"
        label += " refused" if res.refused else f" {res.cct_k and round(res.cct_k)} K r={res.planck_r:.2f}"
        draw.rectangle((0, 0, frame.size[0], 18), fill=(0, 0, 0))
        draw.text((4, 3), label, fill=(255, 255, 255))
        tile = Image.new("RGB", (frame.size[0] + 260, frame.size[1]), (20, 20, 20))
        tile.paste(frame, (0, 0))
        if res.spd is not None:
            _plot_spd(ImageDraw.Draw(tile), res, frame.size[0] + 10, 30, 240, 200)
        thumbs.append(tile.resize((tile.size[0] // 2, tile.size[1] // 2)))
    cols = 3
    rows = math.ceil(len(thumbs) / cols)
    w, h = thumbs[0].size
    sheet = Image.new("RGB", (cols * w, rows * h), (0, 0, 0))
    for i, t in enumerate(thumbs):
        sheet.paste(t, ((i % cols) * w, (i // cols) * h))
    out.parent.mkdir(parents=True, exist_ok=True)
    sheet.save(out)


def _plot_spd(draw, res: FrameResult, x0: int, y0: int, w: int, h: int) -> None:
    wl = WAVELENGTHS_NM
    draw.rectangle((x0, y0, x0 + w, y0 + h), outline=(90, 90, 90))
    planck = planck_spd(res.planck_t)
    band = (wl >= 400) & (wl <= 700)
    planck = planck / planck[band].max()

    def pts(curve):
        return [(x0 + (l - 380) / 400 * w, y0 + h - float(np.clip(v, 0, 1.2)) / 1.2 * h) for l, v in zip(wl, curve)]
    draw.line(pts(planck), fill=(160, 160, 160), width=1)
    draw.line(pts(res.spd), fill=(255, 200, 60), width=2)
    draw.text((x0, y0 + h + 4), f"SPD (orange) vs Planck {res.planck_t:.0f} K", fill=(200, 200, 200))


def _wavelength_rgb(lam: float) -> tuple[int, int, int]:
    """A rough display colour for a wavelength (for drawing only)."""
    if lam < 440:
        return int(255 * (440 - lam) / 60), 0, 255
    if lam < 490:
        return 0, int(255 * (lam - 440) / 50), 255
    if lam < 510:
        return 0, 255, int(255 * (510 - lam) / 20)
    if lam < 580:
        return int(255 * (lam - 510) / 70), 255, 0
    if lam < 645:
        return 255, int(255 * (645 - lam) / 65), 0
    return 255, 0, 0


# --------------------------------------------------------------------------- the simulated control

CONTROL_FRAMES = tuple(range(24, 34))  # θ 135–180°: the frames where the stated geometry has first order
CONTROL_LAMP_K = 2900.0  # a filament lamp
CONTROL_FOCAL_PX = 916.0  # cd1's lens from its outlines
CONTROL_NOISE = 0.01  # per photo pixel, as the simulated benches
# An in-camera rendering: white balance set to the lamp (what a camera's auto white balance does
# under a filament lamp), a DSLR's standard saturation and contrast (camera_pipelines.TYPICAL's).
CONTROL_STYLE = (CONTROL_LAMP_K, 0.1, 0.25, 1.0)
CONTROL_VARIANTS = ("native PNG", "native GIF", "in-camera PNG", "in-camera GIF")


def control_images(frame: int, rng: np.random.Generator) -> dict[str, Any]:
    """Kim's frame ``frame`` as the simulator renders the stated geometry (750×625 px, focal
    CONTROL_FOCAL_PX, a CONTROL_LAMP_K Planck lamp, the generic camera, 1 % noise), in each of
    CONTROL_VARIANTS: the camera-native values as 8-bit sRGB codes (what the product's benches
    read), those quantised to a 256-colour palette (median cut, Floyd–Steinberg dither, as a GIF
    converter does), and an in-camera rendering of them (CONTROL_STYLE) as PNG and as GIF.
    Returns Pillow images."""
    from PIL import Image

    from cd_spectra_addon.core.inverse.estimate import camera_for
    from cd_spectra_addon.core.photo.srgb import srgb_encode
    from training.simulation import photo
    from training.simulation.camera_pipelines import InCameraStyle, pipeline_for, render_in_camera
    from training.simulation.render_numpy import render_cube

    preset = kim_preset("cd", frame)
    cam = preset.camera
    preset = replace(preset, camera=replace(
        cam, focal_length_mm=CONTROL_FOCAL_PX * cam.sensor_width_mm / cam.image_size_px[0]))
    scene = Scene(preset)
    camera, _ = camera_for(GENERIC_CAMERA, _model())
    meter = photo.track_mask(scene)
    native, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=3), planck_spd(CONTROL_LAMP_K), camera),
                             1.0, meter)
    native = np.minimum(photo.add_noise(native, CONTROL_NOISE, rng), 1.0)
    rendered = render_in_camera(native, pipeline_for(camera, InCameraStyle(*CONTROL_STYLE)), meter)
    out = {}
    for name, linear in (("native", native), ("in-camera", rendered)):
        codes = np.rint(srgb_encode(np.clip(linear, 0.0, 1.0)) * 255.0).astype(np.uint8)
        png = Image.fromarray(codes, "RGB")
        out[f"{name} PNG"] = png
        out[f"{name} GIF"] = png.quantize(colors=256, method=Image.Quantize.MEDIANCUT,
                                          dither=Image.Dither.FLOYDSTEINBERG)
    return out


def simulated_control(frames: tuple[int, ...] = CONTROL_FRAMES) -> tuple[list[FrameResult], dict[str, JointResult]]:
    """Each CONTROL_VARIANTS photo of ``frames`` read as Kim's frames are (:func:`read_source`,
    the same preset, focal length and camera), and each variant's joint estimate: what the
    product makes of this geometry when the colours are camera-native, and what a palette and
    an in-camera rendering cost — the real frames differ from the model in both."""
    import tempfile

    rng = np.random.default_rng(0)
    results: list[FrameResult] = []
    joints: dict[str, JointResult] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for frame in frames:
            for variant, im in control_images(frame, rng).items():
                path = Path(tmp) / f"{variant.replace(' ', '-')}-{frame}.{variant[-3:].lower()}"
                im.save(path)
                results.append(read_source(str(path), variant, "cd", frame, CONTROL_FOCAL_PX))
        for variant in CONTROL_VARIANTS:
            joints[variant] = read_joint([r for r in results if r.series == variant], "cd")
    return results, joints


def control_report(results: list[FrameResult], joints: dict[str, JointResult]) -> list[str]:
    lines = ["## Simulated control (the simulator, not photographs)", "",
             f"Kim's stated geometry for frames {CONTROL_FRAMES[0]}–{CONTROL_FRAMES[-1]} rendered by the numpy twin "
             f"at 750×625 px (focal {CONTROL_FOCAL_PX:.0f} px) with a {CONTROL_LAMP_K:.0f} K Planck lamp, the generic "
             f"camera and {100 * CONTROL_NOISE:.0f} % noise, then read as the real frames are (same preset, focal "
             "length and camera): *native* — the camera-native values as 8-bit sRGB codes, what the simulated "
             "benches read; *GIF* — quantised to a 256-colour palette (median cut, Floyd–Steinberg); *in-camera* — "
             f"white balance set to the lamp, saturation +{100 * CONTROL_STYLE[1]:.0f} %, contrast "
             f"{100 * CONTROL_STYLE[2]:.0f} % (`training.simulation.camera_pipelines`). Frames not listed were "
             "refused.", "",
             "| variant | frames read | frame: CCT, r vs Planck (T), confidence | within target | joint: CCT, r (T), confidence; held |",
             "|---|---|---|---|---|"]
    for variant in CONTROL_VARIANTS:
        rows = [r for r in results if r.series == variant]
        read = [r for r in rows if r.read]
        good = [r for r in read if r.cct_k is not None and TARGET_CCT_K[0] <= r.cct_k <= TARGET_CCT_K[1]
                and r.planck_r >= TARGET_R]
        per = "; ".join(f"{r.frame}: {'—' if r.cct_k is None else f'{r.cct_k:.0f} K'}, {r.planck_r:.2f} "
                        f"({r.planck_t:.0f} K), {r.confidence:.2f}" for r in read) or "—"
        j = joints.get(variant)
        if j is None or j.refused:
            joint = "refused" + (f": {j.refused[:100]}" if j is not None else "")
        else:
            joint = (f"{'—' if j.cct_k is None else f'{j.cct_k:.0f} K'}, {j.planck_r:.2f} ({j.planck_t:.0f} K), "
                     f"{j.confidence:.2f}; {j.held_nm:.0f} nm")
        lines.append(f"| {variant} | {len(read)} of {len(rows)} | {per} | {len(good)} | {joint} |")
    return lines + [""]


def report(results: list[FrameResult], joints: dict[str, JointResult], seconds: float) -> str:
    lines = ["# Real photographs: Kim 2023 (`make eval-real KIM_DIR=…`)", "",
             "`python -m training.evaluation.real_photos --kim-dir DIR`: every frame of Kim's `unwritten/cd1.gif` "
             "and `unwritten/dvd1.gif` (not in the repo: no licence) through the product's loader, pose fit and "
             "estimate, with a preset written from the paper's stated geometry (lamp 700 mm at 83.5° from the "
             "axis and azimuth −θ, camera 230 mm at 38°), the generic camera and no EXIF. The lamp was not "
             f"measured: the target is a filament lamp's Planck curve, CCT {TARGET_CCT_K[0]:.0f}–{TARGET_CCT_K[1]:.0f} K "
             f"and r ≥ {TARGET_R} against the best Planck curve over {PLANCK_BAND[0]:.0f}–{PLANCK_BAND[1]:.0f} nm. "
             f"*First order (stated)*: how much of 400–700 nm the stated geometry puts in the first order on the "
             f"tracks (the issue's frames to read: ≥ {MIN_COVERAGE_NM:.0f} nm). *Lines*: the photo's thin lines' "
             f"median distance from the fitted curve (px) and their share on it. {seconds:.0f} s.", ""]
    for series in SERIES:
        rows = [r for r in results if r.series == series]
        if not rows:
            continue
        must = [r for r in rows if r.stated_first_order_nm >= MIN_COVERAGE_NM]
        read = [r for r in rows if r.read]
        good = [r for r in read if r.cct_k is not None and TARGET_CCT_K[0] <= r.cct_k <= TARGET_CCT_K[1]
                and r.planck_r >= TARGET_R]
        ccts = [r.cct_k for r in read if r.cct_k is not None]
        lines += [f"## {series}", "",
                  f"- frames whose stated geometry holds ≥ {MIN_COVERAGE_NM:.0f} nm of first order: "
                  f"{', '.join(str(r.frame) for r in must) or 'none'}; read: "
                  f"{', '.join(str(r.frame) for r in must if r.read) or 'none'}",
                  f"- frames read: {len(read)} of {len(rows)}; within {TARGET_CCT_K[0]:.0f}–{TARGET_CCT_K[1]:.0f} K "
                  f"and r ≥ {TARGET_R}: {len(good)}; CCT spread of the frames read: "
                  + (f"{max(ccts) - min(ccts):.0f} K" if len(ccts) > 1 else "—"),
                  f"- refused: {len(rows) - len(read)} (every refusal says which range the frame holds "
                  "or what is missing; messages below)", "",
                  "| frame | θ | first order (stated) | result | CCT | r vs Planck (T) | confidence | lines px (share) | focal | s |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in rows:
            result = "refused" if r.refused else "read"
            cct = "—" if r.cct_k is None else f"{r.cct_k:.0f}"
            planck = "—" if r.refused else f"{r.planck_r:.2f} ({r.planck_t:.0f} K)"
            conf = "—" if r.refused else f"{r.confidence:.2f}"
            ln = "—" if not math.isfinite(r.line_offset_px) else f"{r.line_offset_px:.1f} ({r.line_share:.2f})"
            focal = "—" if not r.focal_source else f"{r.focal_px:.0f} ({r.focal_source})"
            lines.append(f"| {r.frame} | {r.theta:g}° | {r.stated_first_order_nm:.0f} nm | {result} | {cct} | "
                         f"{planck} | {conf} | {ln} | {focal} | {r.seconds:.1f} |")
        joint = joints.get(series)
        if joint is not None:
            if joint.refused:
                lines += ["", f"**Joint estimate** (`estimate --joint` of every posed frame): refused — {joint.refused[:300]}"]
            else:
                lines += ["", f"**Joint estimate** (`estimate --joint` of every frame the pose stage posed, each "
                          f"with its own fit): frames used {', '.join(map(str, joint.used))} "
                          f"({len(joint.partial)} of them too short alone, used for their stretch); together "
                          f"{joint.held_nm:.0f} nm of 400–700; CCT "
                          f"{'—' if joint.cct_k is None else f'{joint.cct_k:.0f} K'}, r {joint.planck_r:.2f} "
                          f"against Planck {joint.planck_t:.0f} K, confidence {joint.confidence:.2f}."]
        lines += ["", "Refusals (first 200 characters):", ""]
        seen: dict[str, list[int]] = {}
        for r in rows:
            if r.refused:
                name = f"{r.series}#{r.frame}"
                key = r.refused[len(name) + 2:] if r.refused.startswith(name + ": ") else r.refused.replace(name, "the frame")
                key = key[:200]
                seen.setdefault(key, []).append(r.frame)
        for msg, frames in seen.items():
            lines.append(f"- frames {', '.join(map(str, frames))}: “{msg}”")
        lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kim-dir", default=os.environ.get("KIM_DIR"),
                    help="folder holding Kim's cd1.gif and dvd1.gif (or KIM_DIR)")
    ap.add_argument("--out", default="bench/real_photos.md")
    ap.add_argument("--sheet", default="build/real_photos_sheet.png")
    ap.add_argument("--frames", default="", help="comma-separated frame numbers (default: all)")
    ap.add_argument("--no-control", action="store_true", help="skip the simulated control")
    ap.add_argument("--control-only", action="store_true",
                    help="only the simulated control (needs no Kim files; prints, writes nothing)")
    args = ap.parse_args(argv)
    if args.control_only:
        print("\n".join(control_report(*simulated_control())))
        return
    if not args.kim_dir:
        raise SystemExit("give the folder with Kim's cd1.gif and dvd1.gif: --kim-dir DIR or KIM_DIR=DIR "
                         "(github.com/yongwookkkkim/Diffraction-on-Optical-Disks, unwritten/)")
    t0 = time.perf_counter()
    results: list[FrameResult] = []
    joints: dict[str, JointResult] = {}
    for name, disc in SERIES.items():
        path = Path(args.kim_dir) / name
        if not path.is_file():
            print(f"{path}: not found, skipped")
            continue
        frames = [int(f) for f in args.frames.split(",")] if args.frames else range(frame_count(path))
        series = []
        focal = series_focal(path, disc, list(range(frame_count(path))))
        print(f"{name}: the series' focal length from its disc outlines: "
              + ("none found" if focal is None else f"{focal:.0f} px"), flush=True)
        for frame in frames:
            res = read_frame(path, disc, frame, focal)
            series.append(res)
            state = res.refused[:90] if res.refused else f"CCT {res.cct_k and round(res.cct_k)} r={res.planck_r:.2f}"
            print(f"{name}#{frame} θ={res.theta:g} first order {res.stated_first_order_nm:.0f} nm: {state}", flush=True)
        results += series
        joints[name] = read_joint(series, disc)
        j = joints[name]
        print(f"{name} joint: " + (j.refused[:120] if j.refused else
                                   f"frames {j.used}, CCT {j.cct_k and round(j.cct_k)} r={j.planck_r:.2f}"), flush=True)
        sheet = Path(args.sheet)
        contact_sheet(path, series, sheet.with_name(f"{sheet.stem}_{disc}{sheet.suffix}"))
    control = [] if args.no_control else control_report(*simulated_control())
    text = report(results, joints, time.perf_counter() - t0) + ("\n" + "\n".join(control) if control else "")
    Path(args.out).write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
