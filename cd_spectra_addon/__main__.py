"""Headless command line: estimate SPDs from CD photos without opening Blender.

    python -m cd_spectra_addon estimate PHOTO... [--preset NAME] [--camera NAME]
        [--calibration NAME] [--json OUT.json] [--blend OUT.blend] [--plot OUT.png]
    python -m cd_spectra_addon plan --lamp-distance-mm D --lamp-size-mm S --focal-mm F [--phone|--camera] ...

Prints one JSON object per photo (``Estimate.to_json()``), one per line, in the order given.
``--json`` writes the same objects as a JSON array; ``--blend`` saves a Blender scene with one
matched spot light per photo (bpy is imported only then); ``--plot`` draws the SPDs with their
uncertainty (matplotlib, imported only then). Output files appear whole or not at
all (written to a temporary file, then renamed). Bad input exits with status 2 and a single
``error: ...`` line on stderr, and writes nothing.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import json
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any, NoReturn

from .core.cameras import DEFAULT_CAMERA
from .core.capture import DEFAULT_PRESET

EXIT_BAD_INPUT = 2


class UsageError(Exception):
    """Bad input: reported as one ``error:`` line, exit status 2."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse would print the usage too
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="python -m cd_spectra_addon", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    est = sub.add_parser("estimate", help="estimate the lamp's SPD from photos of a CD")
    est.add_argument("photos", nargs="+", type=Path, metavar="PHOTO", help="JPEG, PNG, TIFF or EXR")
    est.add_argument("--preset", default=DEFAULT_PRESET, help=f"capture preset (default {DEFAULT_PRESET})")
    est.add_argument("--camera", default="auto",
                     help="camera profile (default: from the photo's EXIF, else the generic profile; "
                          f"e.g. {DEFAULT_CAMERA})")
    est.add_argument("--calibration", default=None, help="calibration profile name")
    est.add_argument("--json", type=Path, metavar="OUT", help="also write the results as a JSON array")
    est.add_argument("--blend", type=Path, metavar="OUT.blend", help="save a scene with the matched lights")
    est.add_argument("--plot", type=Path, metavar="OUT.png", help="draw the SPDs (needs matplotlib)")
    return parser


def _check_output(path: Path | None, suffix: str | None = None) -> None:
    """Refuse an output path that cannot be written before any photo is estimated."""
    if path is None:
        return
    if suffix and path.suffix.lower() != suffix:
        raise UsageError(f"{path} should end in {suffix}")
    try:
        if not path.parent.resolve().is_dir():
            raise UsageError(f"folder {path.parent} does not exist")
        if path.is_dir():
            raise UsageError(f"{path} is a folder")
        if len(os.fsencode(path.name)) > _name_max(path.parent):
            raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG))
        _temp_beside(path).unlink()  # the same kind of temporary file the real write will use
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (AttributeError, OSError, ValueError):  # no pathconf (Windows) or no answer
        return 255


def _temp_beside(target: Path) -> Path:
    """A new empty file in ``target``'s folder, named so it fits wherever ``target``'s name fits."""
    fd, name = tempfile.mkstemp(prefix=f".{target.name[:32]}.", suffix=target.suffix[:16], dir=target.parent)
    os.close(fd)
    return Path(name)


@contextlib.contextmanager
def _atomic_path(target: Path) -> Iterator[Path]:
    """A temporary path next to ``target``, renamed onto it only if the block succeeds."""
    tmp = _temp_beside(target)
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


@contextlib.contextmanager
def _writing(path: Path) -> Iterator[None]:
    """An OSError while writing ``path`` (the disk filled up since the check, ...) is one error line."""
    try:
        yield
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc


@contextlib.contextmanager
def _quiet_fds() -> Iterator[None]:
    """Silence Blender's C-level prints (they would mix with the JSON on stdout)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def _estimate_all(args: argparse.Namespace) -> list[dict[str, Any]]:
    try:
        from .core.estimate import estimate_photo
    except ImportError as exc:
        raise UsageError(f"this build has no estimator ({exc})") from exc
    results = []
    for photo in args.photos:
        try:
            photo.stat()
        except FileNotFoundError:
            raise UsageError(f"{photo}: no such file") from None
        except OSError as exc:  # e.g. a name too long for the file system
            raise UsageError(f"{photo}: cannot access the file ({exc.strerror or exc})") from None
        try:
            estimate = estimate_photo(str(photo), preset=args.preset, camera=args.camera,
                                      calibration=args.calibration)
        except (ValueError, OSError) as exc:  # CDSpectraError is a ValueError
            message = str(exc)  # the loader's messages already start with the path: say it once
            raise UsageError(message if message.startswith(str(photo)) else f"{photo}: {message}") from exc
        results.append(estimate.to_json())
    return results


def write_plot(results: Sequence[dict[str, Any]], path: Path) -> None:
    """The estimated SPDs with their one-sigma band, the physics-only solution dashed."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:
        raise UsageError(f"--plot needs matplotlib ({exc})") from exc
    fig, ax = plt.subplots(figsize=(7.0, 3.8), dpi=120)
    for data in results:
        wl, spd = data["wavelength_nm"], data["spd"]
        label = Path(str(data.get("source", ""))).name
        cct = data.get("cct_k")
        if cct:
            label += f" ({cct:.0f} K)"
        line = ax.plot(wl, spd, lw=1.8, label=label)[0]
        lo = [max(0.0, v - s) for v, s in zip(spd, data["spd_std"])]
        hi = [v + s for v, s in zip(spd, data["spd_std"])]
        ax.fill_between(wl, lo, hi, color=line.get_color(), alpha=0.2, lw=0)
        if "physics_spd" in data:
            ax.plot(wl, data["physics_spd"], ls="--", lw=0.8, color=line.get_color(), alpha=0.7)
    ax.axvspan(380, 400, color="0.9", lw=0)
    ax.axvspan(700, 780, color="0.9", lw=0)
    ax.set(xlim=(380, 780), ylim=(0, 1.15), xlabel="wavelength (nm)", ylabel="relative power",
           title="CD Spectra estimate (shaded: camera nearly blind; dashed: physics only)")
    ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    with _atomic_path(path) as tmp:
        fig.savefig(tmp, format="png")
    plt.close(fig)


def _blender_fallback_decoder(path: str, header: Any) -> Any:
    """Blender's image loader for the few photo layouts Pillow cannot read (16-bit grey+alpha,
    float TIFF, ...): bpy is imported only when such a photo turns up."""
    try:
        with _quiet_fds():
            from .blender.image_decoder import decode_with_blender
    except ImportError:
        return None
    with _quiet_fds():
        return decode_with_blender(path, header)


def write_blend(results: Sequence[dict[str, Any]], path: Path) -> None:
    """A scene with one matched spot light per estimate, 1 m apart, 2 m up, pointing down."""
    with _quiet_fds():
        import bpy

        from .blender import properties, state
        from .blender.light import create_light
        from .blender.node_group import spectral_colour

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
                settings.photo_path = str(data.get("source") or "")
            try:
                with _atomic_path(path) as tmp:
                    bpy.ops.wm.save_as_mainfile(filepath=str(tmp), copy=True, compress=True)
            except RuntimeError as exc:  # bpy reports a failed save as RuntimeError
                raise UsageError(f"cannot write {path}: {' '.join(str(exc).split())}") from exc
        finally:
            properties.unregister()


def run(argv: Sequence[str] | None = None, *, out: Callable[[str], None] = print) -> int:
    args = build_parser().parse_args(argv)
    _check_output(args.json)
    _check_output(args.blend, ".blend")
    _check_output(args.plot, ".png")
    from .core.images import register_decoder, unregister_decoder

    register_decoder(_blender_fallback_decoder)
    try:
        results = _estimate_all(args)
    finally:
        unregister_decoder(_blender_fallback_decoder)
    if args.blend is not None:
        with _writing(args.blend):
            write_blend(results, args.blend)
    if args.plot is not None:
        with _writing(args.plot):
            write_plot(results, args.plot)
    if args.json is not None:
        with _writing(args.json), _atomic_path(args.json) as tmp:
            tmp.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    for data in results:
        out(json.dumps(data))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    words = list(sys.argv[1:] if argv is None else argv)
    if words[:1] == ["plan"]:  # the capture planner (see plan_command.py)
        from .plan_command import run_plan

        return run_plan(words[1:])
    try:
        return run(argv)
    except UsageError as exc:
        message = " ".join(str(exc).split())  # exactly one line
        print(f"error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
