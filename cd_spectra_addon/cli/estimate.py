"""``estimate PHOTO...``: the lamp's SPD from photos of a CD.

An animated GIF is a series of photos: each of its frames is estimated, in order, named
``FILE.gif#N`` (from 0) in the results; ``FILE.gif#N`` on the command line reads that frame only.
By default a short summary per photo for people (source, CCT, Duv, xy, colour rendition — Ra, R9,
Rf, Rg with their 90 % ranges, peak and dominant wavelength — confidence, warnings, where files
went). ``--no-rendition`` skips the rendition figures (a bulk run that wants spectra only).
``--json FILE`` writes the results (``Estimate.to_json()``) as a JSON array,
``--json -`` prints them to stdout, one object per line, in the order given (and no summary).
``--blend`` saves a scene with one matched spot light per photo (bpy is imported only then);
``--plot`` draws the SPDs with their uncertainty and the TM-30 colour vector graphic (matplotlib,
imported only then). With several
photos, progress goes to stderr (when it is a terminal, or with ``--progress``). Files appear
whole or not at all; bad input writes nothing.

``--joint``: the photos show one lamp (a sweep of angles, the frames of a video, several
positions), so they give ONE result, solved from all of them at once (:mod:`..core.inverse.joint`),
with every photo's pose, brightness and coverage — or why it was left out — in its ``joint``
field; an animated GIF joins as each of its frames; ``--preset`` may then be given once per
PHOTO argument.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..core.rendition.result import summary_text
from ..core.spectra.cameras import DEFAULT_CAMERA
from ..core.scene.capture import DEFAULT_PRESET
from .common import STDOUT, UsageError, atomic_path, check_output, progress, quiet_fds, writing

NAME = "estimate"
HELP = "estimate the lamp's SPD from photos of a CD"
INTERMIXED, INTERMIXED_TYPE = "photos", Path  # `a.jpg --preset p b.jpg --preset q --joint` pairs as typed


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("photos", nargs="+", type=Path, metavar="PHOTO",
                        help="JPEG, PNG, TIFF, EXR, GIF (and camera raw / HEIC where this build reads them); "
                             "an animated GIF is each of its frames, FILE.gif#N one of them (from 0)")
    parser.add_argument("--preset", default=DEFAULT_PRESET, action=_Presets,
                        help=f"capture preset (default {DEFAULT_PRESET}); with --joint, once per PHOTO if "
                             "they differ (an animated GIF's frames share its preset)")
    parser.set_defaults(presets=None)
    parser.add_argument("--camera", default="auto",
                        help="camera profile (default: from the photo's EXIF Make/Model, else the generic profile "
                             f"with a warning; e.g. {DEFAULT_CAMERA}; see `cameras`)")
    parser.add_argument("--calibration", default=None, help="calibration profile name (see `calibrations`)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="write the results as JSON; '-' for stdout")
    parser.add_argument("--blend", type=Path, metavar="OUT.blend", help="save a scene with the matched lights")
    parser.add_argument("--plot", type=Path, metavar="OUT.png",
                        help="draw the SPDs and the TM-30 colour vector graphic (needs matplotlib)")
    parser.add_argument("--joint", action="store_true",
                        help="the photos show the same lamp: one estimate from all of them together")
    parser.add_argument("--no-rendition", dest="rendition", action="store_false",
                        help="skip the colour-rendition figures (CRI, TM-30, ...): spectra only, for bulk runs")
    parser.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                        help="a line on stderr per photo when there are several (default: when stderr "
                             "is a terminal)")


class _Presets(argparse.Action):
    """``--preset`` as before (``args.preset``: the first given), and every one given in
    ``args.presets`` (a joint estimate's, one per photo)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        given = list(getattr(namespace, "presets", None) or [])
        namespace.presets = [*given, values]
        namespace.preset = namespace.presets[0]


def _check_presets(args: argparse.Namespace) -> None:
    presets = args.presets or [args.preset]
    if len(presets) > 1 and not args.joint:
        raise UsageError("--preset given several times: that is for --joint (one preset per photo)")
    if len(presets) not in (1, len(args.photos)):
        raise UsageError(f"{len(presets)} presets for {len(args.photos)} photos: give --preset once, "
                         "or once per photo")


def _estimate_joint(args: argparse.Namespace) -> list[dict[str, Any]]:
    """The one joint result, as a list of one (the output paths take lists)."""
    try:
        from ..core.inverse.joint import estimate_joint
    except ImportError as exc:
        raise UsageError(f"this build has no estimator ({exc})") from exc
    given = args.presets if args.presets and len(args.presets) > 1 else [args.preset] * len(args.photos)
    photos: list[str] = []
    presets: list[str] = []
    for path, preset in zip(args.photos, given):  # an animated GIF: each frame, with the GIF's preset
        frames = _photo_list([path])
        photos += frames
        presets += [preset] * len(frames)
    show = (sys.stderr.isatty() if args.progress is None else args.progress) and len(photos) > 1

    def step(_fraction: float, message: str) -> None:  # "photo 2 of 5: b.jpg" → "[2/5] b.jpg", like the batch
        found = re.fullmatch(r"photo (\d+) of (\d+): (.*)", message)
        if show and found:
            progress(f"[{found[1]}/{found[2]}] {found[3]}")

    try:
        estimate = estimate_joint(photos, preset=presets if len(set(presets)) > 1 else args.preset,
                                  camera=args.camera, calibration=args.calibration, progress=step,
                                  rendition=args.rendition)
    except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
        raise UsageError(str(exc)) from exc
    return [estimate.to_json()]


def _estimate_all(args: argparse.Namespace) -> list[dict[str, Any]]:
    try:
        from ..core.inverse.batch import estimate_photos
    except ImportError as exc:
        raise UsageError(f"this build has no estimator ({exc})") from exc
    photos = _photo_list(args.photos)
    results: list[dict[str, Any]] = []
    show = sys.stderr.isatty() if args.progress is None else args.progress
    many = show and len(photos) > 1
    estimates = estimate_photos(photos, preset=args.preset, camera=args.camera, calibration=args.calibration,
                                rendition=args.rendition)
    while len(results) < len(photos):
        photo = photos[len(results)]
        if many:
            progress(f"[{len(results) + 1}/{len(photos)}] {photo}")
        try:
            estimate = next(estimates)
        except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
            message = str(exc)  # the loader's messages already start with the path: say it once
            raise UsageError(message if message.startswith(str(photo)) else f"{photo}: {message}") from exc
        results.append(estimate.to_json())
    return results


def _photo_list(paths: Sequence[Path]) -> list[str]:
    """The photos to estimate, in order: each path given, an animated GIF as each of its frames."""
    from ..core.errors import PhotoError
    from ..core.photo.frames import photo_frames, split_frame

    photos: list[str] = []
    for path in paths:
        try:
            file, _ = split_frame(path)
            Path(file).stat()
            photos += photo_frames(path)
        except FileNotFoundError:
            raise UsageError(f"{path}: no such file") from None
        except OSError as exc:  # e.g. a name too long for the file system
            raise UsageError(f"{path}: cannot access the file ({exc.strerror or exc})") from None
        except PhotoError as exc:
            raise UsageError(str(exc)) from exc
    return photos


def write_plot(results: Sequence[dict[str, Any]], path: Path) -> None:
    """The estimated SPDs with their one-sigma band, the physics-only solution dashed; beside
    them, where the estimates have colour rendition, the TM-30 colour vector graphic."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise UsageError(f"--plot needs matplotlib ({exc})") from exc
    graphics = [data for data in results if (data.get("rendition") or {}).get("defined")]
    if graphics:
        fig, (ax, cvg) = plt.subplots(1, 2, figsize=(10.4, 4.2), dpi=120, gridspec_kw={"width_ratios": [1.75, 1]})
    else:
        fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=120)
    for data in results:
        wl, spd = data["wavelength_nm"], data["spd"]
        joint = data.get("joint")
        label = f"joint, {joint['used']} photos" if joint else Path(str(data.get("source", ""))).name
        cct = data.get("cct_k")
        if cct:
            label += f" ({cct:.0f} K)"
        line = ax.plot(wl, spd, lw=1.8, label=label)[0]
        lo = [max(0.0, v - s) for v, s in zip(spd, data["spd_std"])]
        hi = [v + s for v, s in zip(spd, data["spd_std"])]
        ax.fill_between(wl, lo, hi, color=line.get_color(), alpha=0.2, lw=0)
        if "physics_spd" in data:
            ax.plot(wl, data["physics_spd"], ls="--", lw=0.8, color=line.get_color(), alpha=0.7)
        if data in graphics:
            _draw_vector_graphic(cvg, data["rendition"], line.get_color(), len(graphics) == 1)
    ax.axvspan(380, 400, color="0.9", lw=0)
    ax.axvspan(700, 780, color="0.9", lw=0)
    ax.set(xlim=(380, 780), ylim=(0, 1.15), xlabel="wavelength (nm)", ylabel="relative power",
           title="CD Spectra estimate (shaded: camera nearly blind; dashed: physics only)")
    ax.legend(fontsize=8, loc="upper left")
    if graphics:
        cvg.set(xlim=(-1.5, 1.5), ylim=(-1.5, 1.5), aspect="equal", xticks=[], yticks=[],
                title="TM-30 colour vector graphic")
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def _draw_vector_graphic(ax: Any, rendition: dict[str, Any], colour: str, alone: bool) -> None:
    """TM-30's graphic on matplotlib axes: the reference circle, the 16 hue bins' test points (and,
    for one estimate, their arrows in the bins' colours), the figures in the corners."""
    import math

    from ..core.rendition.vector_graphic import BIN_COLOURS, vector_graphic_points

    points = vector_graphic_points(rendition)
    if points is None:
        return
    ref, test = points
    circle = [(math.cos(2 * math.pi * k / 180), math.sin(2 * math.pi * k / 180)) for k in range(181)]
    ax.plot(*zip(*circle), color="black", lw=1.0)
    for k in range(16):
        a = 2 * math.pi * k / 16
        ax.plot((0.15 * math.cos(a), 1.5 * math.cos(a)), (0.15 * math.sin(a), 1.5 * math.sin(a)), ls="--",
                color="0.7", lw=0.6)
        if alone:
            ax.annotate("", xy=test[k], xytext=ref[k], arrowprops={"arrowstyle": "-|>", "color": BIN_COLOURS[k],
                                                                    "lw": 1.2})
    loop = list(test) + [test[0]]
    ax.plot(*zip(*loop), color=colour if not alone else "#F05046", lw=1.8)
    if alone:  # the figures in the corners, as TM-30's report puts Rf and Rg
        corners = (("tm30_rf", "Rf", -1.45, 1.45), ("tm30_rg", "Rg", 1.45, 1.45), ("cri_ra", "Ra", -1.45, -1.45),
                   ("cri_r9", "R9", 1.45, -1.45))
        for key, label, x, y in corners:
            value = rendition.get(key)
            if isinstance(value, (int, float)):
                ax.text(x, y, f"{label} {value:.0f}", ha="left" if x < 0 else "right", va="top" if y > 0 else "bottom",
                        weight="bold")


def _blender_fallback_decoder(path: str, header: Any) -> Any:
    """Blender's image loader for the few photo layouts Pillow cannot read (16-bit grey+alpha,
    float TIFF, ...): bpy is imported only when such a photo turns up."""
    try:
        with quiet_fds():
            from ..blender.image_decoder import decode_with_blender
    except ImportError:
        return None
    with quiet_fds():
        return decode_with_blender(path, header)


def write_blend(results: Sequence[dict[str, Any]], path: Path) -> None:
    """A scene with one matched spot light per estimate, 1 m apart, 2 m up, pointing down."""
    with quiet_fds():
        import bpy

        from ..blender import properties, state
        from ..blender.light import create_light
        from ..core.spectra.colour import spectral_colour
        from ..core.photo.frames import split_frame

        bpy.ops.wm.read_factory_settings(use_empty=True)
        space = state.working_space()
        properties.register()
        try:
            scene = bpy.context.scene
            for i, data in enumerate(results):
                spd = state.valid_spd(data.get("spd", ()))
                if spd is None:
                    raise UsageError(f"{data.get('source')}: the estimate is not a usable spectrum")
                try:
                    info = spectral_colour(spd, space)
                except ValueError as exc:
                    raise UsageError(f"{data.get('source')}: {exc}") from exc
                obj = create_light(scene.collection, spd, info, state.estimate_meta(data), "SPOT",
                                   (float(i), 0.0, 2.0))
                settings = scene.cd_spectra
                state.store_estimate(settings, data)
                settings.node_group = obj.data.node_tree.nodes["CD Spectra"].node_tree
                photo, frame = split_frame(str(data.get("source") or ""))  # FILE.gif#N: the file, its frame
                settings.photo_path, settings.photo_frame = photo, frame or 0
            try:
                with atomic_path(path) as tmp:
                    bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True, compress=True)
            except RuntimeError as exc:  # bpy reports a failed save as RuntimeError
                raise UsageError(f"cannot write {path}: {' '.join(str(exc).split())}") from exc
        finally:
            properties.unregister()


def _joint_lines(joint: dict[str, Any]) -> list[str]:
    """One line per photo of a joint estimate: the stretch of 400–700 nm it holds (else the
    wavelengths it reads), how bright, how much say; "left out" for a photo not read (the
    warnings say why)."""
    lines = []
    for photo in joint.get("photos") or []:
        name = Path(str(photo.get("source") or "?")).name
        if photo.get("refused"):
            lines.append(f"  {name}: left out")
            continue
        held = photo.get("held_nm") if photo.get("held_nm") is not None else photo.get("coverage_nm")
        spans = ", ".join(f"{lo:.0f}–{hi:.0f}" for lo, hi in held or []) or "no"
        short = " (too little alone)" if photo.get("partial") else ""
        say = f", say {photo['weight']:.2f}" if float(photo.get("weight", 1.0)) < 1.0 else ""
        lines.append(f"  {name}: {spans} nm{short}, brightness ×{float(photo.get('brightness', 1.0)):.2f}, "
                     f"residual {100 * float(photo.get('residual', 0.0)):.1f}%{say}")
    return lines


def summary(data: dict[str, Any]) -> list[str]:
    """A few lines a person reads: which photo, the lamp's colour, how sure, what to watch."""
    joint = data.get("joint")
    if joint:
        lines = [f"joint estimate from {joint.get('given')} photos ({joint.get('used')} used)"]
    else:
        lines = [str(data.get("source") or "?")]
    cct, duv, xy = data.get("cct_k"), data.get("duv"), data.get("xy") or (float("nan"), float("nan"))
    colour = f"CCT {cct:.0f} K, Duv {duv:+.4f}" if cct is not None and duv is not None else "no CCT (far from white)"
    lines.append(f"  {colour}, xy ({xy[0]:.4f}, {xy[1]:.4f}), confidence {float(data.get('confidence', 0)):.0%}")
    lines += [f"  {line}" for line in summary_text(data.get("rendition"))]
    extras = [f"{key} {data[key]}" for key in ("preset", "camera", "calibration") if data.get(key)]
    if extras:
        lines.append("  " + ", ".join(extras))
    if joint:
        lines += _joint_lines(joint)
    lines += [f"  warning: {w}" for w in data.get("warnings") or []]
    return lines


def run(args: argparse.Namespace, out: Callable[[str], None]) -> int:
    to_stdout = args.json is not None and str(args.json) == STDOUT
    check_output(args.json)
    check_output(args.blend, ".blend")
    check_output(args.plot, ".png")
    from ..core.photo.images import register_decoder, unregister_decoder

    _check_presets(args)
    register_decoder(_blender_fallback_decoder)
    try:
        results = _estimate_joint(args) if args.joint else _estimate_all(args)
    finally:
        unregister_decoder(_blender_fallback_decoder)
    written = []
    if args.blend is not None:
        with writing(args.blend):
            write_blend(results, args.blend)
        written.append(args.blend)
    if args.plot is not None:
        with writing(args.plot):
            write_plot(results, args.plot)
        written.append(args.plot)
    if args.json is not None and not to_stdout:
        with writing(args.json), atomic_path(args.json) as tmp:
            tmp.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
        written.append(args.json)
    if to_stdout:
        for data in results:
            out(json.dumps(data))
        return 0
    for data in results:
        for line in summary(data):
            out(line)
    if written:
        out("wrote " + ", ".join(str(p) for p in written))
    return 0
