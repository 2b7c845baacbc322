"""Hostile inputs for the reliability suite and report, each built from nothing (no blobs).

A :class:`Case` names an input, knows how to build it in a folder, and says what the product
must do with it: refuse it with a specific :class:`CDSpectraError` subclass whose message holds
given words, or estimate with at most a given confidence and a warning that says why (and,
where a result is still meaningful, the right colour temperature). The same catalogue drives
``tests/test_hostile_inputs.py`` (which asserts it) and ``training.reliability.report`` (which
records what happened), so the report always describes the suite that runs.

Every photo derives from one rendered capture of a CIE A lamp (``make_base``): the numpy twin
of the Cycles render at 256 px, camera noise, EXIF like a real camera's.
"""

from __future__ import annotations

import functools
import io
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Scene, load_preset
from cd_spectra_addon.core.errors import CDSpectraError, ModelError, NoDiscError, PhotoError
from cd_spectra_addon.core.spectrum.model import INPUT_SIZE, MODEL_NAME, layout_hash
from cd_spectra_addon.core.spectra.grid import N_BANDS
from cd_spectra_addon.core.photo.srgb import srgb_encode

from training.simulation import photo

ROOT = Path(__file__).resolve().parents[2]
BASE_SIZE = 256
TRUE_CCT_K = 2856.0  # CIE A
CCT_TOLERANCE_K = 150.0

__all__ = ["Base", "Expect", "Case", "CASES", "make_base", "build_case", "write_toy_model", "CLI_RUNNER",
           "cli_command", "run_cli", "run_in_process", "Outcome", "unwritable_folder", "judge"]


@dataclass(frozen=True)
class Base:
    """The clean capture every hostile photo is made from."""

    linear: NDArray[np.float64]  # (H, W, 3) sensor-linear, clipped at 1
    exif: bytes
    spd: NDArray[np.float64]
    cube: NDArray[np.float32]  # the basis cube, to synthesise other lamps and exposures
    meter: NDArray[np.bool_]  # where the auto-exposure meters (the tracked area)

    def shoot(self, spd: NDArray[np.float64], exposure: float = 1.0, seed: int = 7) -> NDArray[np.float64]:
        """Another photo of the same capture: a lamp, an exposure, fresh camera noise."""
        image, _ = photo.synthesize(self.cube, spd, load_camera(DEFAULT_CAMERA), exposure=exposure, noise=0.01,
                                    rng=np.random.default_rng(seed), meter=self.meter)
        return image


@functools.lru_cache(maxsize=2)
def make_base(size: int = BASE_SIZE) -> Base:
    """A 256 px photo of a CD under CIE A (≈1.5 s: the basis cube is rendered once per process)."""
    from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
    from training.simulation.render_numpy import render_cube

    scene = Scene(load_preset(REFERENCE_PRESET).with_image_size(size))
    cube = render_cube(scene, supersample=2)
    spd = known_lamp_spd("incandescent")
    meter = photo.track_mask(scene)
    image, _ = photo.synthesize(cube, spd, load_camera(DEFAULT_CAMERA), noise=0.01,
                                rng=np.random.default_rng(7), meter=meter)
    cam = scene.preset.camera
    exif = photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm, cam.image_size_px[0], DEFAULT_CAMERA)
    return Base(image, exif, spd, cube, meter)


@dataclass(frozen=True)
class Expect:
    """What the product must do. ``error`` None: a result (CLI exit 0)."""

    error: type[CDSpectraError] | None
    words: tuple[str, ...] = ()  # all in the error message, or all in one warning of the result
    max_confidence: float = 1.0
    min_confidence: float = 0.0
    cct: bool = False  # the result must still be right: CCT within CCT_TOLERANCE_K of CIE A


@dataclass(frozen=True)
class Case:
    name: str
    category: str
    what: str  # one line for the report
    build: Callable[[Path, Base], Path | None]  # writes the photo, returns its path (None: cannot here)
    expect: Expect
    model: str | None = None  # a broken model variant stands in for the shipped one
    cli_args: Callable[[Path], list[str]] | None = None  # extra CLI arguments (given the case folder)
    in_process: bool = True  # False: only the CLI can show it (output paths)
    preset_json: str | None = None  # a preset file with this text is used instead of REFERENCE_PRESET
    cli_expect: Expect | None = None  # where the CLI may do better than the API (its fallback decoder)

    def expected(self, via: str) -> Expect:
        return self.cli_expect if via == "cli" and self.cli_expect is not None else self.expect
    blender: bool = False  # part of the subset run through the Blender operators


# --- writers ---------------------------------------------------------------------------------


def _write(folder: Path, name: str, image: NDArray[np.float64], fmt: str, exif: bytes | None = None) -> Path:
    path = folder / name
    photo.write_photo(path, image, fmt, exif)
    return path


def _put(path: Path, data: bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def _head(data: bytes, fraction: float) -> bytes:
    return data[: int(len(data) * fraction)]


def _codes8(linear: NDArray[np.float64]) -> NDArray[np.uint8]:
    return np.rint(srgb_encode(linear) * 255.0).astype(np.uint8)


def _png_bomb() -> bytes:
    """A valid 96×128 PNG whose header then claims 50 000 × 50 000 pixels (CRC fixed)."""
    buffer = io.BytesIO()
    Image.fromarray(np.full((96, 128, 3), 90, np.uint8)).save(buffer, format="PNG")
    data = bytearray(buffer.getvalue())
    data[16:24] = struct.pack(">II", 50_000, 50_000)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])) & 0xFFFFFFFF)
    return bytes(data)


def _jpeg_bomb(base: Base) -> bytes:
    data = bytearray(photo.encode_photo(base.linear, "jpg"))
    sof = data.index(b"\xff\xc0")
    data[sof + 5: sof + 9] = struct.pack(">HH", 50_000, 50_000)
    return bytes(data)


def _tiff(values: NDArray[Any]) -> bytes:
    """Minimal uncompressed RGB TIFF (uint16 or float32), little-endian, one strip, no ICC."""
    h, w, c = values.shape
    floats = values.dtype.kind == "f"
    data = np.ascontiguousarray(values, dtype="<f4" if floats else "<u2").tobytes()
    bits = 32 if floats else 16
    tags: list[tuple[int, int, list[int]]] = [
        (256, 4, [w]), (257, 4, [h]), (258, 3, [bits] * c), (259, 3, [1]), (262, 3, [2]), (273, 4, [8]),
        (277, 3, [c]), (278, 4, [h]), (279, 4, [len(data)]), (284, 3, [1])]
    if floats:
        tags.append((339, 3, [3] * c))
    ifd_at = 8 + len(data)
    extra = b""
    tail = ifd_at + 2 + 12 * len(tags) + 4
    entries = b""
    for tag, kind, vals in tags:
        payload = struct.pack("<" + ("H" if kind == 3 else "I") * len(vals), *vals)
        if len(payload) <= 4:
            entries += struct.pack("<HHI", tag, kind, len(vals)) + payload.ljust(4, b"\0")
        else:
            entries += struct.pack("<HHII", tag, kind, len(vals), tail + len(extra))
            extra += payload
    return b"II" + struct.pack("<HI", 42, ifd_at) + data + struct.pack("<H", len(tags)) + entries + b"\0" * 4 + extra


def _exr_damaged(base: Base, rng: np.random.Generator) -> NDArray[np.float64]:
    """What a careless raw conversion writes: unclipped noise below zero, a few NaN and ±Inf."""
    image = base.linear + rng.normal(0.0, 0.004, base.linear.shape)  # negative values in the dark
    pick = rng.random(image.shape[:2])
    image[pick < 0.01] = np.nan
    image[(pick >= 0.01) & (pick < 0.015)] = np.inf
    image[(pick >= 0.015) & (pick < 0.02)] = -np.inf
    return image


def _crop(base: Base, rows: slice, cols: slice) -> NDArray[np.float64]:
    return np.ascontiguousarray(base.linear[rows, cols])


def unwritable_folder(scratch: Path) -> Path | None:
    """A folder this process cannot create files in: a read-only folder, or for root (who
    ignores permission bits) a read-only system folder; None where there is none."""
    folder = scratch / "read-only"
    folder.mkdir(exist_ok=True)
    folder.chmod(0o555)
    candidates = [folder, Path("/sys")] if os.name == "posix" else [folder]
    for candidate in candidates:
        try:
            fd, name = tempfile.mkstemp(dir=candidate)
        except OSError:
            return candidate
        os.close(fd)
        os.unlink(name)
    return None


def _no_disc_scene(folder: Path, base: Base) -> Path:
    """A colourful, smooth 'ordinary photo' (blurred blobs), with the same EXIF."""
    from scipy import ndimage

    rng = np.random.default_rng(3)
    blobs = ndimage.gaussian_filter(rng.random((BASE_SIZE, BASE_SIZE, 3)), (14, 14, 0))
    blobs = (blobs - blobs.min()) / (blobs.max() - blobs.min())
    return _write(folder, "street.jpg", 0.7 * blobs ** 2, "jpg", base.exif)


def _fifo(folder: Path, base: Base) -> Path | None:
    if not hasattr(os, "mkfifo"):
        return None
    path = folder / "pipe.jpg"
    os.mkfifo(path)
    return path


def _non_ascii(folder: Path, base: Base) -> Path:
    sub = folder / "фото 写真 ñ"
    sub.mkdir(exist_ok=True)
    return _write(sub, "диск-Ω ü.jpg", base.linear, "jpg", base.exif)


def _good(folder: Path, base: Base) -> Path:
    return _write(folder, "good.jpg", base.linear, "jpg", base.exif)


def _good_if_unwritable(folder: Path, base: Base) -> Path | None:
    """The good photo, where this process can have a folder it cannot write (not as root)."""
    return _good(folder, base) if unwritable_folder(folder) else None


# --- toy models ------------------------------------------------------------------------------

def write_toy_model(folder: Path, variant: str) -> Path:
    """``folder/cd_spectra.onnx`` + metadata, broken as ``variant`` says (or "ok": a valid toy
    model with the shipped name and layout: a flat SPD, whatever the input)."""
    import onnx
    from onnx import TensorProto, helper

    folder.mkdir(parents=True, exist_ok=True)
    onnx_path = folder / f"{MODEL_NAME}.onnx"
    meta: dict[str, Any] = {"name": MODEL_NAME, "version": f"toy-{variant}", "layout_hash": layout_hash()}
    n_in = 10 if variant == "wrong-inputs" else INPUT_SIZE
    n_out = N_BANDS - 1 if variant == "wrong-output-length" else N_BANDS
    weight = np.full((n_in, n_out), np.nan if variant == "nan-output" else 0.0, np.float32)
    bias = np.ones(n_out, np.float32)
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["inputs", "w"], ["mm"]), helper.make_node("Add", ["mm", "b"], ["spd"]),
         helper.make_node("Mul", ["spd", "zero"], ["log_std"])],
        "toy",
        [helper.make_tensor_value_info("inputs", TensorProto.FLOAT, ["batch", n_in])],
        [helper.make_tensor_value_info("spd", TensorProto.FLOAT, ["batch", n_out]),
         helper.make_tensor_value_info("log_std", TensorProto.FLOAT, ["batch", n_out])],
        [helper.make_tensor("w", TensorProto.FLOAT, weight.shape, weight.ravel().tolist()),
         helper.make_tensor("b", TensorProto.FLOAT, bias.shape, bias.tolist()),
         helper.make_tensor("zero", TensorProto.FLOAT, [], [0.0])])
    proto = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], producer_name="cd-spectra-tests")
    proto.ir_version = 8
    onnx.save(proto, str(onnx_path))
    side = onnx_path.with_suffix(".json")
    side.write_text(json.dumps(meta), encoding="utf-8")
    if variant == "garbage-bytes":
        onnx_path.write_bytes(b"this is not an ONNX model\n" * 64)
    elif variant == "missing-metadata":
        side.unlink()
    elif variant == "metadata-not-json":
        side.write_text("{ layout_hash: oops", encoding="utf-8")
    elif variant == "layout-mismatch":
        side.write_text(json.dumps({**meta, "layout_hash": "0123456789abcdef"}), encoding="utf-8")
    elif variant == "metadata-prior-shape":
        side.write_text(json.dumps({**meta, "prior": {"mean": [0.5] * 10, "covariance": [[1.0]]}}), encoding="utf-8")
    elif variant == "metadata-fusion-text":
        side.write_text(json.dumps({**meta, "fusion": {"strength": "strong"}}), encoding="utf-8")
    return onnx_path


# --- the catalogue ---------------------------------------------------------------------------


def _case(name: str, category: str, what: str, build: Callable[[Path, Base], Path | None], expect: Expect,
          **kw: Any) -> Case:
    return Case(name, category, what, build, expect, **kw)


def _result(*words: str, max_confidence: float = 1.0, min_confidence: float = 0.0, cct: bool = False) -> Expect:
    return Expect(None, words, max_confidence, min_confidence, cct)


CASES: tuple[Case, ...] = (
    # -- the file itself
    _case("empty-file", "file", "zero-byte .jpg",
          lambda f, b: _put(f / "empty.jpg", b""), Expect(PhotoError, ("empty", "0 bytes")), blender=True),
    _case("truncated-jpeg", "file", "a JPEG cut after 40 % of its bytes",
          lambda f, b: _put(f / "cut.jpg", _head(photo.encode_photo(b.linear, "jpg", b.exif), 0.4)),
          Expect(PhotoError, ("truncated",)), blender=True),
    _case("text-as-png", "file", "a text file renamed .png",
          lambda f, b: _put(f / "notes.png", b"shopping list: milk, eggs, an unwritten CD\n" * 8),
          Expect(PhotoError, ("text",)), blender=True),
    _case("one-pixel", "file", "a valid 1x1 PNG",
          lambda f, b: (Image.fromarray(np.full((1, 1, 3), 128, np.uint8)).save(f / "dot.png"), f / "dot.png")[1],
          Expect(PhotoError, ("too small", "1x1"))),
    _case("bomb-png", "file", "a PNG header claiming 50 000 x 50 000 pixels",
          lambda f, b: _put(f / "bomb.png", _png_bomb()), Expect(PhotoError, ("megapixels", "refusing to decode")),
          blender=True),
    _case("bomb-jpeg", "file", "a JPEG header claiming 50 000 x 50 000 pixels",
          lambda f, b: _put(f / "bomb.jpg", _jpeg_bomb(b)), Expect(PhotoError, ("megapixels", "refusing to decode"))),
    _case("folder", "file", "a folder named like a photo",
          lambda f, b: (f / "album.jpg").mkdir() or f / "album.jpg", Expect(PhotoError, ("folder",))),
    _case("fifo", "file", "a named pipe (reading it would block forever)", _fifo,
          Expect(PhotoError, ("not a regular file",))),
    _case("non-ascii-path", "file", "a good JPEG in a folder and file named in Cyrillic, CJK and accents",
          _non_ascii, _result(min_confidence=0.7, cct=True), blender=True),
    # -- formats
    _case("greyscale", "format", "the photo saved as 8-bit greyscale PNG",
          lambda f, b: (Image.fromarray(_codes8(b.linear.mean(axis=2)), "L").save(f / "grey.png", exif=b.exif),
                        f / "grey.png")[1],
          _result("greyscale", max_confidence=0.3)),
    _case("png-16bit", "format", "16-bit RGB PNG (no EXIF)",
          lambda f, b: _write(f, "deep.png", b.linear, "png16"), _result(min_confidence=0.5, cct=True)),
    _case("cmyk-jpeg", "format", "the photo converted to a CMYK JPEG",
          lambda f, b: (Image.fromarray(_codes8(b.linear)).convert("CMYK").save(f / "print.jpg", quality=95, exif=b.exif),
                        f / "print.jpg")[1],
          _result(cct=True)),
    _case("tiff-16bit", "format", "16-bit linear RGB TIFF (what dcraw -4 -T writes)",
          lambda f, b: _put(f / "raw.tif", _tiff(np.rint(np.clip(b.linear, 0, 1) * 65535).astype(np.uint16))),
          _result(min_confidence=0.5, cct=True)),
    _case("tiff-float", "format", "32-bit float RGB TIFF (Pillow cannot read it; Blender's loader can: the CLI "
          "and the add-on register it, the bare API does not)",
          lambda f, b: _put(f / "float.tif", _tiff(b.linear.astype(np.float32))),
          Expect(PhotoError, ("no fallback decoder",)),
          cli_expect=_result(min_confidence=0.5, cct=True)),
    _case("exr-nan-inf-negative", "format", "EXR with unclipped negative noise, 1 % NaN, 1 % +-Inf",
          lambda f, b: _write(f, "damaged.exr", _exr_damaged(b, np.random.default_rng(11)), "exr"),
          _result("NaN/Inf", max_confidence=0.99, cct=True)),
    _case("exr-mostly-nan", "format", "EXR with 70 % NaN pixels",
          lambda f, b: _write(f, "void.exr", np.where(np.random.default_rng(2).random(b.linear.shape[:2])[..., None] < 0.7,
                                                       np.nan, b.linear), "exr"),
          Expect(PhotoError, ("NaN",)), blender=True),
    _case("exr-all-negative", "format", "EXR whose every value is below zero",
          lambda f, b: _write(f, "negative.exr", -b.linear - 0.01, "exr"), Expect(PhotoError, ("black",))),
    # -- exposure
    _case("all-black", "exposure", "an all-black JPEG (lens cap on)",
          lambda f, b: _write(f, "black.jpg", np.zeros_like(b.linear), "jpg", b.exif), Expect(PhotoError, ("black",)),
          blender=True),
    _case("all-white", "exposure", "an all-white PNG (fully saturated)",
          lambda f, b: _write(f, "white.png", np.ones_like(b.linear), "png", b.exif),
          Expect(PhotoError, ("over-exposed", "100%")), blender=True),
    _case("over-exposed", "exposure", "the disc at 20x the right exposure, rainbow clipped",
          lambda f, b: _write(f, "hot.png", np.minimum(b.linear * 20.0, 1.0), "png", b.exif),
          _result("over-exposed", max_confidence=0.3)),
    _case("very-dim", "exposure", "8-bit photo at 0.5 % of the right exposure",
          lambda f, b: _write(f, "dim.png", b.linear * 0.005, "png", b.exif), _result("very dark", max_confidence=0.5)),
    # -- what the photo shows
    _case("pure-noise", "content", "uniform random RGB noise",
          lambda f, b: _write(f, "noise.png", np.random.default_rng(0).random(b.linear.shape), "png", b.exif),
          Expect(NoDiscError, ("no CD rainbow",)), blender=True),
    _case("no-disc", "content", "an ordinary colourful photo without a disc", _no_disc_scene,
          Expect(NoDiscError, ("no CD rainbow",))),
    _case("disc-cut-by-frame", "content", "zoomed in: the frame cuts the disc all round (rainbow beyond ~640 nm lost)",
          lambda f, b: _write(f, "zoomed.png", _crop(b, slice(68, 188), slice(68, 188)), "png", b.exif),
          # Beyond 640 nm is gone, and with it most of what sets an incandescent's CCT: the
          # result must say so (warning, lower confidence); its CCT is not held to ±150 K.
          _result("only", "visible", max_confidence=0.9)),
    _case("disc-off-centre", "content", "the disc 24 mm right of the middle of the photo (cropped/re-aimed)",
          lambda f, b: _write(f, "aside.png", _crop(b, slice(None), slice(96, None)), "png", b.exif),
          _result("not centred", max_confidence=0.3)),
    _case("disc-in-corner", "content", "the disc's centre 31 px from a corner, most of it outside the frame",
          lambda f, b: _write(f, "corner.png", _crop(b, slice(96, None), slice(96, None)), "png", b.exif),
          _result("not centred", max_confidence=0.3)),
    # -- the model next to the add-on
    *(_case(f"model-{v}", "model", f"a good photo; the shipped model replaced by: {v.replace('-', ' ')}", _good,
            Expect(None, ("physics-only",), max_confidence=0.5) if v == "nan-output" else Expect(ModelError, words),
            model=v, blender=v in ("garbage-bytes", "layout-mismatch", "wrong-output-length"))
      for v, words in [("garbage-bytes", ("not a valid ONNX model",)), ("missing-metadata", ("metadata", "missing")),
                       ("metadata-not-json", ("metadata", "unreadable")), ("layout-mismatch", ("another input layout",)),
                       ("metadata-prior-shape", ("prior.mean",)), ("metadata-fusion-text", ("fusion",)),
                       ("wrong-inputs", ("inputs/outputs",)),
                       ("wrong-output-length", ("inputs/outputs",)), ("nan-output", ()),
                       ]),
    # -- a capture preset file given with --preset (or preset= in the API)
    *(_case(f"preset-{n}", "preset", f"a good photo with a preset file whose {what}", _good,
            Expect(CDSpectraError, ("not a valid preset", word)), preset_json=text)
      for n, what, text, word in [
          ("sigma-text", "lamp size is the word 'big'", '{"name": "x", "light": {"lobe_sigma": "big"}}', "lobe_sigma"),
          ("zero-pitch", "track pitch is 0", '{"name": "x", "disc": {"pitch_um": 0}}', "pitch_um"),
          ("not-json", "text is not JSON", "name = cd-default", "Expecting value")]),
    # -- where the results go (the CLI's --json; the add-on's export is tested on its own)
    _case("output-missing-folder", "output", "--json into a folder that does not exist", _good,
          Expect(CDSpectraError, ("does not exist",)), cli_args=lambda f: ["--json", str(f / "nowhere" / "out.json")],
          in_process=False),
    _case("output-read-only", "output", "--json into a folder this process cannot write",
          _good_if_unwritable,
          Expect(CDSpectraError, ("cannot write",)),
          cli_args=lambda f: ["--json", str(unwritable_folder(f) / "out.json")], in_process=False),
    _case("output-name-too-long", "output", "--json with a 300-character file name", _good,
          Expect(CDSpectraError, ("cannot write", "too long")), cli_args=lambda f: ["--json", str(f / ("x" * 300 + ".json"))],
          in_process=False),
    _case("plot-read-only", "output", "--plot into a folder this process cannot write",
          _good_if_unwritable,
          Expect(CDSpectraError, ("cannot write",)),
          cli_args=lambda f: ["--plot", str(unwritable_folder(f) / "spd.png")], in_process=False),
    _case("output-is-folder", "output", "--json naming an existing folder", _good,
          Expect(CDSpectraError, ("is a folder",)),
          cli_args=lambda f: (f / "results.json").mkdir(exist_ok=True) or ["--json", str(f / "results.json")],
          in_process=False),
)


def build_case(case: Case, folder: Path, base: Base | None = None) -> tuple[Path | None, Path | None]:
    """(photo, model folder or None) for ``case`` in a fresh ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    path = case.build(folder, base or make_base())
    model_dir = None
    if case.preset_json is not None:
        (folder / "preset.json").write_text(case.preset_json, encoding="utf-8")
    if case.model is not None:
        model_dir = folder / "models"
        write_toy_model(model_dir, case.model)
    return path, model_dir


# --- running a case --------------------------------------------------------------------------

# The CLI exactly as users run it, with two stand-ins a test needs: a broken model in place of
# the shipped one (HOSTILE_MODEL_DIR), and -- while no model has been trained into models/ --
# the estimator's physics + prior path (estimate_photo(model=None)), so the photo checks are
# exercised end to end. Peak RSS goes to a file so stderr stays the CLI's own.
CLI_RUNNER = r'''
import atexit, functools, os, sys
from pathlib import Path
rss_out = os.environ.get("HOSTILE_RSS_OUT")


def _peak_kb():
    # VmHWM: this process's own peak (ru_maxrss would include the parent's size at fork).
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return line.split()[1]
    return ""


if rss_out and Path("/proc/self/status").is_file():
    atexit.register(lambda: Path(rss_out).write_text(_peak_kb()))
from cd_spectra_addon.core.inverse import estimate
from cd_spectra_addon.core.spectrum import model
model_dir = os.environ.get("HOSTILE_MODEL_DIR")
if model_dir:
    model.MODEL_DIR = Path(model_dir)
elif not (model.MODEL_DIR / (model.MODEL_NAME + ".onnx")).is_file():
    estimate.estimate_photo = functools.partial(estimate.estimate_photo, model=None)
from cd_spectra_addon.__main__ import main
sys.exit(main(sys.argv[1:]))
'''


@dataclass
class Outcome:
    """What one run produced, in the report's terms."""

    ok: bool  # a result (exit 0 / an Estimate)
    error_type: str = ""
    message: str = ""  # the error message, or the warnings joined
    confidence: float | None = None
    cct_k: float | None = None
    warnings: list[str] = field(default_factory=list)
    exit_code: int | None = None
    stderr_lines: list[str] = field(default_factory=list)
    stdout: str = ""
    peak_rss_mb: float | None = None
    finite: bool = True
    files_after: list[str] = field(default_factory=list)
    error_class: type[BaseException] | None = None
    unexpected: bool = False  # an exception that is not a CDSpectraError: always a bug
    spd: list[float] = field(default_factory=list)


def cli_command(photo_path: Path, extra: Sequence[str] = ()) -> list[str]:
    # The camera that took every photo here is named: a 16-bit PNG/TIFF or an EXR carries no
    # EXIF Make/Model, and "auto" would rightly fall back to the generic profile.
    return [sys.executable, "-c", CLI_RUNNER, "estimate", str(photo_path), "--camera", DEFAULT_CAMERA, *extra]


def run_cli(case: Case, folder: Path, photo_path: Path, model_dir: Path | None, timeout: float = 120.0) -> Outcome:
    """Run the CLI on one case in a child process; ``folder`` is listed afterwards (no leftovers)."""
    extra = case.cli_args(folder) if case.cli_args else []
    if "--json" not in extra:
        extra += ["--json", "-"]  # the results on stdout (the default output is a summary for people)
    # The photos are rendered on the reference geometry: name it, as the in-process run does,
    # rather than lean on the CLI's default preset (a buildable set-up the photos were not made in).
    extra += ["--preset", str(folder / "preset.json") if case.preset_json is not None else REFERENCE_PRESET]
    rss_file = folder / ".peak_rss"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "HOSTILE_RSS_OUT": str(rss_file), "PYTHONIOENCODING": "utf-8"}
    env.pop("HOSTILE_MODEL_DIR", None)
    if model_dir is not None:
        env["HOSTILE_MODEL_DIR"] = str(model_dir)
    before = _listing(folder)
    proc = subprocess.run(cli_command(photo_path, extra), capture_output=True, text=True, cwd=ROOT, env=env,
                          timeout=timeout, encoding="utf-8", errors="replace")
    text = rss_file.read_text().strip() if rss_file.is_file() else ""
    rss = float(text) / 1024.0 if text else None
    rss_file.unlink(missing_ok=True)
    out = Outcome(ok=proc.returncode == 0, exit_code=proc.returncode, stderr_lines=proc.stderr.splitlines(),
                  stdout=proc.stdout, peak_rss_mb=rss, files_after=sorted(set(_listing(folder)) - set(before)))
    if proc.returncode == 0:
        lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
        if lines:
            data = json.loads(lines[-1])
            out.confidence, out.cct_k, out.warnings = data["confidence"], data["cct_k"], list(data["warnings"])
            out.spd = [float(v) for v in data["spd"]]
            out.finite = bool(np.all(np.isfinite(out.spd)) and min(out.spd) >= 0 and np.isfinite(out.confidence))
            out.message = " | ".join(out.warnings)
    else:
        out.message = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else ""
    return out


def _listing(folder: Path) -> list[str]:
    return [str(p.relative_to(folder)) for p in folder.rglob("*")] if folder.is_dir() else []


def run_in_process(case: Case, photo_path: Path, model_dir: Path | None) -> Outcome:
    """``estimate_photo`` on one case (physics + prior while no shipped model exists)."""
    from cd_spectra_addon.core.inverse.estimate import estimate_photo
    from cd_spectra_addon.core.spectrum.model import MODEL_DIR

    preset = str(photo_path.parent / "preset.json") if case.preset_json is not None else REFERENCE_PRESET
    if model_dir is not None:
        model: Any = str(model_dir / f"{MODEL_NAME}.onnx")
    else:
        model = "shipped" if (MODEL_DIR / f"{MODEL_NAME}.onnx").is_file() else None
    try:
        result = estimate_photo(photo_path, model=model, preset=preset, camera=DEFAULT_CAMERA)
    except CDSpectraError as exc:
        return Outcome(ok=False, error_type=type(exc).__name__, message=str(exc), error_class=type(exc))
    except Exception as exc:  # noqa: BLE001 -- recorded, so the suite and the report can name it
        return Outcome(ok=False, error_type=f"UNEXPECTED {type(exc).__name__}", message=repr(exc),
                       error_class=type(exc), unexpected=True)
    finite = bool(np.all(np.isfinite(result.spd)) and result.spd.min() >= 0 and np.isfinite(result.confidence))
    return Outcome(ok=True, message=" | ".join(result.warnings), confidence=result.confidence, cct_k=result.cct_k,
                   warnings=list(result.warnings), finite=finite, spd=[float(v) for v in result.spd])


def judge(case: Case, out: Outcome, via: str) -> tuple[bool, str]:
    """Does ``out`` (from ``via`` = "cli" or "api") meet the case's expectation? (ok, why not)."""
    e = case.expected(via)
    if out.unexpected:
        return False, f"raised {out.message}"
    if via == "cli" and any("Traceback" in line for line in out.stderr_lines):
        return False, "traceback on stderr"
    if via == "cli" and out.files_after:
        return False, f"left {out.files_after}"
    if e.error is not None:
        if out.ok:
            return False, "a result where an error was expected"
        if via == "cli" and (out.exit_code != 2 or len(out.stderr_lines) != 1
                             or not out.stderr_lines[0].startswith("error: ")):
            return False, f"exit {out.exit_code}, {len(out.stderr_lines)} stderr lines"
        if via == "api" and not (out.error_class and issubclass(out.error_class, e.error)):
            return False, f"{out.error_type}, not {e.error.__name__}"
        missing = [w for w in e.words if w not in out.message]
        return (not missing, f"message lacks {missing}" if missing else "")
    if not out.ok:
        return False, f"{out.error_type or 'exit ' + str(out.exit_code)}: {out.message}"
    if not out.finite or len(out.spd) != N_BANDS or max(out.spd) != 1.0:
        return False, "SPD not finite / not peak 1"
    if out.confidence is None or not e.min_confidence <= out.confidence <= e.max_confidence:
        return False, f"confidence {out.confidence} outside [{e.min_confidence}, {e.max_confidence}]"
    if e.words and not any(all(w in text for w in e.words) for text in out.warnings):
        return False, f"no warning with {e.words}"
    if e.cct and (out.cct_k is None or abs(out.cct_k - TRUE_CCT_K) >= CCT_TOLERANCE_K):
        return False, f"CCT {out.cct_k}"
    return True, ""
