"""Synthesize CD photos of given SPDs, as a camera would record them.

    python -m training.simulation.render_photo --spd SPD.csv --out DIR [--preset NAME]
        [--camera NAME|FILE.json] [--format exr|png|png16|jpg] [--noise F] [--exposure F]
        [--camera-offset-mm X Y] [--light-offset-mm X Y] [--tilt-deg X Y]
        [--camera-rotation-deg X Y] [--light-rotation-deg X Y] [--seed N]
        [--camera-position-mm X Y Z] [--light-position-mm X Y Z]
        [--size W [H]] [--upsample K] [--engine cycles|numpy] [--samples N] [--cache-dir DIR]
    python -m training.simulation.render_photo --print-geometry [--preset NAME] [...pose options]

SPD.csv: wavelength (nm) in the first column, one SPD per further column (any sampling).
One photo per column is written to DIR/<column>.<ext>, plus DIR/render_photo.json describing
the capture. The basis cube of the geometry is rendered on first use (Cycles by default) and
cached under data/basis/.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET, Pose, Scene, load_preset, preset_from_dict
from cd_spectra_addon.core.spectra.spectra_files import read_spectra_csv, safe_stem
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation import photo
from training.simulation.basis import CACHE_DIR, ENGINES, basis_cube


def add_pose_arguments(p: argparse.ArgumentParser) -> None:
    """The :class:`Pose` flags: what a person building the capture gets wrong."""
    p.add_argument("--camera-offset-mm", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"))
    p.add_argument("--light-offset-mm", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"))
    p.add_argument("--tilt-deg", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="disc tilt about the x and y axes")
    p.add_argument("--camera-rotation-deg", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="camera turned about its image's horizontal and vertical axes (aimed off)")
    p.add_argument("--light-rotation-deg", type=float, nargs=2, default=(0.0, 0.0), metavar=("X", "Y"),
                   help="lamp swung about the disc centre, about the x and y axes")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m training.simulation.render_photo", description=__doc__.split("\n\n")[0])
    p.add_argument("--spd", type=Path, help="CSV: wavelength column, then one column per SPD")
    p.add_argument("--out", type=Path, help="output folder")
    p.add_argument("--preset", default=DEFAULT_PRESET, help="capture preset name or JSON file")
    p.add_argument("--camera", default=DEFAULT_CAMERA, help="shipped camera name or rawtoaces JSON file")
    p.add_argument("--format", choices=photo.FORMATS, default="jpg")
    p.add_argument("--noise", type=float, default=0.0, help="shot-noise std at full scale (0.01 = 1%%)")
    p.add_argument("--exposure", type=float, default=1.0,
                   help="multiplier on auto exposure (brightest pixel of the tracks at 80%% of full scale)")
    add_pose_arguments(p)
    p.add_argument("--camera-position-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="put the camera here (above the disc, aimed at its centre) instead of the preset's place")
    p.add_argument("--light-position-mm", type=float, nargs=3, metavar=("X", "Y", "Z"),
                   help="put the lamp here (anywhere, metres away too) instead of the preset's place")
    p.add_argument("--size", type=int, nargs="+", metavar="PX", help="image width [height] (default: preset)")
    p.add_argument("--upsample", type=int, default=1, metavar="K",
                   help="the photo has K× the basis cube's pixels per side (noise per photo pixel)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--engine", choices=ENGINES, default="cycles")
    p.add_argument("--samples", type=int, help="Cycles samples per pixel (default: preset)")
    p.add_argument("--cache-dir", type=Path, default=CACHE_DIR, help="where basis cubes are cached")
    p.add_argument("--print-geometry", action="store_true", help="print the capture geometry as JSON and exit")
    return p


def scene_from_args(args: argparse.Namespace) -> Scene:
    preset = load_preset(args.preset)
    camera_position = getattr(args, "camera_position_mm", None)  # render_basis shares this without the flags
    light_position = getattr(args, "light_position_mm", None)
    if camera_position or light_position:
        data = preset.to_dict()  # through the preset format, so the same validation applies
        if camera_position:
            camera = {k: v for k, v in data["camera"].items() if k != "distance_mm"}  # derived from the position
            data["camera"] = {**camera, "position_mm": list(camera_position)}
        if light_position:
            data["light"] = {**data["light"], "position_mm": list(light_position)}
        preset = preset_from_dict(data)
    if args.size:
        if len(args.size) > 2 or min(args.size) < 8 or max(args.size) > 8192:
            raise ValueError("--size takes a width and optional height between 8 and 8192")
        preset = preset.with_image_size(*args.size)
    pose = Pose(tuple(args.camera_offset_mm), tuple(args.light_offset_mm), tuple(args.tilt_deg),
                tuple(args.camera_rotation_deg), tuple(args.light_rotation_deg))
    return Scene(preset, pose)


def run(args: argparse.Namespace) -> int:
    scene = scene_from_args(args)
    if args.print_geometry:
        print(json.dumps(scene.geometry_dict(), indent=2))
        return 0
    if args.spd is None or args.out is None:
        raise ValueError("--spd and --out are required (or use --print-geometry)")
    if args.noise < 0 or args.noise > 1 or not args.exposure > 0:
        raise ValueError("--noise must be in [0, 1] and --exposure > 0")
    if not 1 <= args.upsample <= 8:
        raise ValueError("--upsample takes 1 to 8")
    table = read_spectra_csv(args.spd)
    spds = table.on_grid()
    for name, spd in zip(table.names, spds):
        if not np.any(spd > 0):
            raise ValueError(f"SPD {name!r} is zero everywhere in 380–780 nm")
    camera = load_camera(args.camera)
    cube, cube_meta = basis_cube(scene, args.engine, args.samples, args.cache_dir,
                                 log=lambda m: print(m, file=sys.stderr))
    cam = scene.preset.camera
    exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, cam.image_size_px[0] * args.upsample, camera.name)
    ext = {"png16": "png", "jpg422": "jpg", "heic10": "heic", "tiff16": "tif"}.get(args.format, args.format)
    rng = np.random.default_rng(args.seed)
    meter = photo.track_mask(scene)
    written = []
    used: set[str] = set()
    for name, spd in zip(table.names, spds):
        stem = safe_stem(name)
        while stem in used:
            stem += "_"
        used.add(stem)
        image, gain = photo.expose(photo.linear_photo(cube, spd, camera), args.exposure, meter)
        image = np.minimum(photo.add_noise(photo.upsample(image, args.upsample), args.noise, rng), 1.0)
        path = args.out / f"{stem}.{ext}"
        photo.write_photo(path, image, args.format, exif)
        written.append({"spd": name, "file": path.name,
                        **photo.photo_metadata(gain, args.exposure, args.noise, camera.name, args.format)})
        print(path)
    manifest = {"geometry": scene.geometry_dict(), "basis": {k: cube_meta.get(k) for k in ("engine", "samples")},
                "seed": args.seed, "photos": written, "wavelength_nm": WAVELENGTHS_NM.tolist()}
    (args.out / "render_photo.json").write_text(json.dumps(manifest, indent=2) + "\n", encoding="utf-8")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return run(args)
    except (ValueError, TypeError, KeyError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
