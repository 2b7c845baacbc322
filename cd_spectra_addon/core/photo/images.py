"""Load a photo and linearise it: one function for training, the CLI and the Blender add-on.

``load_photo`` returns linear light at a bounded resolution, a saturation mask and EXIF, or a
:class:`PhotoError` whose message names the file and the reason (never another exception).

Decisions (measured on this project's 2-core machine, Pillow 13, numpy 1.26):

* **Size.** The loaded long side is at most ``max_side``. The total reduction ``scale`` is
  ``draft × box``: ``draft`` is the largest of 8/4/2 whose decode is still ≥ ``max_side``
  (1 if none), ``box`` the integer factor that brings that under ``max_side``. Every format uses
  the same factors, so one scene in JPEG, PNG or EXR loads at the same size and scale. JPEG gets
  ``draft`` from libjpeg's DCT-domain scaling (Pillow ``draft()``); other formats decode at full
  size and box-average by ``draft × box``. The box average is always in LINEAR light. A loaded
  pixel covers original pixels ``[i·scale, (i+1)·scale)`` (remainder rows/columns at the right
  and bottom are dropped), so a point at original x maps to x / scale.
* **Centred crop.** ``centre_crop_px`` loads only a window around the image centre — where the
  lens's axis meets the sensor, so the camera model stays a centred pinhole and nothing else
  changes — and ``max_side`` then bounds the window's long side. A phone 21 cm above a CD sees
  the disc across ~40 % of the frame: read whole at 1024 px, one pixel spans ~4 nm of the
  rainbow and whole 5 nm bins go missing; read as a window, the same disc gets ~2× the pixels
  per side at the cost of one more decode (:mod:`.disc_window` chooses the window). The window is
  placed on whole decoded pixels, so its centre may sit up to half a decoded pixel off the true
  image centre: a camera turned by < 0.1 mrad, far below what the pose fit resolves.
  ``origin_px`` says where the loaded image's top-left corner lies in the displayed photo.
* **Speed.** 24 MP JPEG (6000×4000, q90, 8 MB) → 750×500 in ≈ 85 ms: the 1/4 draft decode is
  ≈ 75 ms (full decode ≈ 240 ms, 1/2 ≈ 100 ms), LUT + box ≈ 10 ms. 12 MP: JPEG 75 ms, 8-bit
  PNG 0.45 s, 16-bit PNG 0.63 s (filter None) – 1.5 s (Paeth on every row), 16-bit TIFF
  0.16 s raw / 0.8 s Deflate, EXR 0.4 s (half) / 0.6 s (float), all → 1000×750. A
  :class:`PhotoReader` keeps each decode (JPEG: per draft scale; other formats: the whole file)
  for further loads of the same file, so a preview and a window cost one decode where they can.
* **Draft bias.** libjpeg's scaled IDCT averages sRGB *codes* over the draft block, so detail
  finer than the block loses a little radiance (Jensen): ring period 60 px < 0.3 %, 20 px
  −1…−2 %, 10 px −4…−7 %. CD rainbows at 24 MP are far broader than the 4-px block.
* **Linearisation.** 8-bit: sRGB. 16-bit PNG: sRGB unless gAMA says 1.0 (and no sRGB/iCCP).
  16-bit TIFF: linear without an ICC profile (dcraw ``-4 -T``), sRGB with one. EXR/float TIFF:
  as stored (negative values are kept: clipping noise at 0 would bias dark bins). HEIC/HEIF
  (libheif through pillow-heif): sRGB curve; 10/12-bit samples come as 16-bit codes. Camera
  raw: :mod:`.raw_files` (binned linear sensor RGB, its own saturation from the white level).
  ``transfer="srgb"|"linear"`` overrides. Integer codes go through a float32 LUT.
* **Palette images and GIF.** A palette image (PNG, TIFF or GIF, with or without transparency)
  is read as its palette's colours: 8-bit sRGB codes, saturated like 8-bit RGB; alpha is
  ignored, as for RGBA. It is judged processed: a palette is an editor's quantisation. A GIF
  frame is the composited frame a viewer shows (Pillow's seek applies each earlier frame's
  disposal); an animated GIF must be given with a frame, ``cd1.gif#12`` (:mod:`.frames` says
  why). Seeking decodes every earlier frame: frame 30 of a 750 × 625 GIF in 0.19 s. A GIF's
  ICC profile (an application extension Pillow leaves unread) is read for the processed reason.
* **16-bit colour.** Pillow truncates 16-bit RGB to 8 bits; :mod:`.image_formats` recovers the
  low bytes with a second pass of Pillow's own decoder (opposite byte order), bit-exact. For a
  12 MP 16-bit RGB PNG that costs 0.6 s (filter None) – 1.5 s (Paeth). A numpy decoder (zlib +
  unfilter) measured 0.4 s for None/Sub/Up rows but 2.2 s once Average/Paeth rows appear: they
  are sequential along the row, and a vectorised anti-diagonal wavefront was the best numpy
  could do; real encoders choose filters adaptively, so most files have them. Blender's loader
  took 1.1–1.7 s plus ~1 s to import bpy and 32 bytes per pixel. So: two Pillow passes by
  default, and Blender's loader as a registered fallback (:mod:`.decoders`,
  ``blender/image_decoder.py``) for what the trick does not cover (16-bit grey+alpha or CMYK,
  float RGB TIFF, subsampled EXR, ...).
* **Saturation.** A loaded pixel is saturated if any contributing decoded pixel has any
  channel ≥ 250/255 (8-bit) or ≥ 65000/65535 (16-bit); for floats, if a channel reaches an
  evident clip level: at least 8 samples within 0.1 % of the channel's maximum and 4× more there
  than in the 0.1 % below (a pile-up, not the top of a smooth peak). With JPEG draft the decoded
  pixels are already d×d averages (in sRGB codes), so a clipped spot smaller than the draft
  block is flagged only if the block mean is ≥ 250.
* **Invalid floats.** NaN/Inf pixels are excluded from the box mean (the mean of the valid
  contributors is used) and flagged ``invalid`` if any contributor was invalid; more than half
  the pixels invalid is an error.
* **Memory.** Pixels are read and reduced in row bands of ~1 MP, so no full-resolution float
  image exists. Peak: the decoded image itself (Pillow: 4 bytes/px, twice for 16-bit; EXR: all
  channels of the part) plus one band; 100 MP and 512 MB on disk are refused before decoding.
* **Limits.** Pillow's global ``MAX_IMAGE_PIXELS`` is left alone (the wheel is shared with other
  add-ons in Blender's Python); the 100 MP limit is ours, checked from the header; Pillow's own
  ``DecompressionBombError`` is caught too.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import PhotoError
from .decoders import Decoder, decoders_need_main_thread, register_decoder, registered_decoders, unregister_decoder
from .image_formats import (
    DECODE_ERRORS, MAX_PIXELS, MIN_SIDE, DecodedPixels, ExifInfo, PhotoHeader, Pixels, Unsupported,
    array_pixels, check_file, exif_from_pillow, exr_header, exr_pixels, heif_header, heif_pixels, open_pillow,
    pillow_header,
    pillow_pixels, sniff_format, tiff_header,
)
from .frames import FRAME_MARK, gif_frames, split_frame
from .jpeg_chroma import chroma_px
from .processed import judge_processed
from .raw_files import RawPhoto, read_raw
from .srgb import srgb_decode

__all__ = [
    "LinearImage", "ExifInfo", "PhotoHeader", "DecodedPixels", "Decoder", "load_photo", "reduced", "PhotoReader",
    "register_decoder", "unregister_decoder", "decoders_need_main_thread", "SATURATION_8BIT", "SATURATION_16BIT",
]

SATURATION_8BIT = 250
SATURATION_16BIT = 65000
BLACK_LEVEL = 1e-3  # brightest linear value (of full scale) below which an integer photo is black
BAND_PIXELS = 1_000_000
CLIP_EPS = 1e-3
CLIP_MIN_COUNT = 8
CLIP_RATIO = 4


@dataclass(frozen=True)
class LinearImage:
    rgb: NDArray[np.float32]  # (H, W, 3) linear light; integer formats: full scale = 1.0
    saturated: NDArray[np.bool_]  # (H, W) any contributing pixel at/near the encoding's maximum
    invalid: NDArray[np.bool_]  # (H, W) any contributing pixel NaN/Inf (EXR); excluded from rgb
    scale: float  # original pixels per loaded pixel
    original_size: tuple[int, int]  # (width, height) as stored in the file (before orientation)
    encoding: str  # "srgb-8", "srgb-16", "linear-8", "linear-16", "linear-float", "srgb-float"
    exif: ExifInfo
    path: str
    is_grey: bool = False  # no colour information: the spectrum cannot be estimated well
    processed: bool = False  # white balance / colour matrix / tone curve applied by the camera or an editor
    processed_reason: str = ""  # why the file is believed processed (for the user's warning)
    # Top-left corner of the loaded image in the displayed (EXIF-oriented) photo, original pixels:
    # loaded (row, col) maps to original (origin_y + (row + 0.5)·scale − 0.5, origin_x + …).
    origin_px: tuple[float, float] = (0.0, 0.0)  # (x, y)
    # Loaded pixels per colour sample: above 1 where a JPEG's subsampled chroma (4:2:0, 4:2:2) is
    # read finer than the file holds it (a 4:2:0 file at full size: 2), so each pixel's colour is
    # blurred over more than the pixel; a draft or box of 2 or more gives every pixel its own.
    colour_px: float = 1.0

    @property
    def displayed_size(self) -> tuple[int, int]:
        """(width, height) of the whole photo as shown (EXIF orientation applied), original pixels."""
        w, h = self.original_size
        return (h, w) if (self.exif.orientation or 1) >= 5 else (w, h)

    def to_original(self, row: float, col: float) -> tuple[float, float]:
        """(x, y) in the displayed photo's original pixels of a loaded (row, col) position."""
        return (self.origin_px[0] + (col + 0.5) * self.scale - 0.5, self.origin_px[1] + (row + 0.5) * self.scale - 0.5)


def reduced(image: LinearImage, k: int) -> LinearImage:
    """``image`` box-averaged ``k`` × ``k`` in linear light (trailing rows and columns dropped, as
    every load drops them), a block saturated or invalid where any of its pixels is: the photo
    read ``k`` times coarser without another decode, and without averaging a JPEG's codes over
    a larger draft block than the read it comes from."""
    if k <= 1:
        return image
    h, w = image.rgb.shape[0] // k * k, image.rgb.shape[1] // k * k
    rgb = _box_sum(np.ascontiguousarray(image.rgb[:h, :w]), k) * np.float32(1.0 / (k * k))
    return replace(image, rgb=np.ascontiguousarray(rgb, dtype=np.float32),
                   saturated=_box_any(image.saturated[:h, :w], k), invalid=_box_any(image.invalid[:h, :w], k),
                   scale=image.scale * k, colour_px=max(1.0, image.colour_px / k))


def load_photo(path: str | os.PathLike[str], max_side: int = 1024, transfer: str = "auto",
               centre_crop_px: tuple[float, float] | None = None) -> LinearImage:
    """Decode ``path`` into linear light with the long side ≤ ``max_side`` (see module doc);
    ``centre_crop_px`` (half width, half height, in the displayed photo's original pixels) loads
    only that window around the image centre."""
    _check_transfer(transfer)
    _check_request(max_side, centre_crop_px)
    with PhotoReader(path, transfer) as reader:
        return reader.load(max_side, centre_crop_px)


def _check_transfer(transfer: str) -> None:
    if transfer not in ("auto", "srgb", "linear"):
        raise ValueError(f"transfer must be 'auto', 'srgb' or 'linear', not {transfer!r}")


def _check_request(max_side: int, centre_crop_px: tuple[float, float] | None) -> None:
    if int(max_side) < 16:
        raise ValueError(f"max_side must be at least 16, not {max_side}")
    if centre_crop_px is not None and not (len(centre_crop_px) == 2 and all(
            isinstance(v, (int, float)) and np.isfinite(v) and v >= 8 for v in centre_crop_px)):
        raise ValueError(f"centre_crop_px must be two finite half-sizes ≥ 8 pixels, not {centre_crop_px!r}")


class PhotoReader:
    """One photo file, opened once and loaded at one or more sizes or windows (each as
    :func:`load_photo` would): every decode — a JPEG draft scale, or the whole file for other
    formats — is made once and kept while the reader is open. The estimate reads a whole-frame
    preview and then, for a small disc, a window, often from the same decode (a 24 MP JPEG read
    at 1/4 twice cost 2 × 31 ms of Huffman decoding; a 12 MP PNG 2 × 0.45 s).

    Use as a context manager (or call :meth:`close`): it holds the decoded pixels."""

    def __init__(self, path: str | os.PathLike[str], transfer: str = "auto") -> None:
        _check_transfer(transfer)
        self.name = os.fspath(path)  # with its frame mark: what results name as their source
        self.transfer = transfer
        file_name, self.frame = split_frame(self.name)
        self.file = check_file(file_name)
        self.fmt = sniff_format(self.file)
        if self.frame not in (None, 0) and self.fmt != "gif":
            raise PhotoError(f"{self.name}: {file_name} is a still photo, one frame ({file_name}{FRAME_MARK}0); "
                             f"frame {self.frame} does not exist")
        self._stack = ExitStack()
        self._opened: _Opened | None = None
        self._raw: RawPhoto | None = None

    def __enter__(self) -> PhotoReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._opened is not None:
            self._opened.wait()  # a decode still running uses an image about to be closed
        self._stack.close()
        self._opened = None
        self._raw = None

    def _open(self) -> _Opened:
        if self._opened is None:
            self._opened = _Opened(self.file, self.name, self.fmt, _closer(self._stack), self.frame)
        return self._opened

    def layout(self, max_side: int) -> tuple[int, int, float, ExifInfo, tuple[int, int]] | None:
        """(width, height, scale, EXIF, displayed size) of the whole-frame load(``max_side``):
        the loaded image's size as displayed and the whole photo's, known before decoding — for
        a JPEG (None for other formats, or where the header cannot be read: :meth:`load` says)."""
        if self.fmt != "jpeg":
            return None
        try:
            return self._open().layout(int(max_side))
        except (PhotoError, Unsupported, *DECODE_ERRORS):
            return None

    def prefetch(self, max_side: int, centre_crop_px: tuple[float, float] | None = None) -> None:
        """Start decoding, on another thread, what load(``max_side``, ``centre_crop_px``) will
        need, so that it overlaps with other work: a JPEG's draft scale (other formats decode
        whole, once, anyway). Pillow decodes without the GIL: a 24 MP JPEG's 1/4 and 1/2 drafts
        took 40 ms side by side on two cores, 70 ms one after the other. Errors surface at load."""
        if self.fmt != "jpeg":
            return
        _check_request(max_side, centre_crop_px)
        try:
            opened = self._open()
            opened.prefetch(opened.draft_for(int(max_side), centre_crop_px))
        except (PhotoError, Unsupported, *DECODE_ERRORS):
            return

    def load(self, max_side: int = 1024, centre_crop_px: tuple[float, float] | None = None,
             judge: bool = True) -> LinearImage:
        """The photo with the long side ≤ ``max_side``, or the centred window ``centre_crop_px``
        (see :func:`load_photo`). ``judge=False`` leaves out the pixel statistics that say
        whether a file was processed (:mod:`.processed`); :meth:`judge` adds them later, for an
        image the caller keeps."""
        _check_request(max_side, centre_crop_px)
        if self.fmt == "raw":
            if self._raw is None:
                self._raw = read_raw(self.file)
            return _load_raw(self._raw, self.name, int(max_side), centre_crop_px)
        try:
            image = self._open().load(int(max_side), self.transfer, centre_crop_px)
        except PhotoError:
            raise
        except Unsupported as exc:
            raise PhotoError(f"{self.name}: {exc}") from exc
        except DECODE_ERRORS as exc:
            raise PhotoError(f"{self.name}: cannot decode the {_FORMAT_NAMES[self.fmt]} image; the file is damaged, "
                             f"truncated or an unsupported variant ({_reason(exc)})") from exc
        return self.judge(image) if judge else image

    def judge(self, image: LinearImage) -> LinearImage:
        """``image`` (loaded from this file) with its processed flag and reason."""
        if self.fmt == "raw":
            return image  # raw files are judged by their own metadata (:mod:`.raw_files`)
        palette = self._opened.header.palette_colours if self._opened is not None else 0
        processed, reason = judge_processed(self.fmt, image.encoding, image.exif, image.rgb, image.saturated,
                                            palette_colours=palette)
        return replace(image, processed=processed, processed_reason=reason)


_FORMAT_NAMES = {"jpeg": "JPEG", "png": "PNG", "tiff": "TIFF", "exr": "OpenEXR", "heif": "HEIC/HEIF", "gif": "GIF"}


def _load_raw(photo: RawPhoto, name: str, max_side: int, crop: tuple[float, float] | None) -> LinearImage:
    """Camera raw: binned linear sensor RGB (:mod:`.raw_files`, read once by the caller),
    box-averaged to ``max_side``."""
    height, width = photo.rgb.shape[:2]
    if min(height, width) * photo.binning < MIN_SIDE:
        raise PhotoError(f"{name}: the image is too small ({width}x{height} after binning); the disc needs at least "
                         f"{MIN_SIDE} pixels on the short side")
    orientation = photo.exif.orientation or 1
    half = _stored_half(crop, orientation)
    unit = photo.binning
    full = (width * unit, height * unit)
    box = max(1, _ceil_div(_span(width, height, unit, half), max_side))
    x0, y0, w, h = _window((width, height), unit, box, half, full)
    rgb = _box_sum(photo.rgb[y0: y0 + h * box, x0: x0 + w * box], box) * np.float32(1.0 / (box * box))
    saturated = _box_any(photo.saturated[y0: y0 + h * box, x0: x0 + w * box], box)
    if float(np.max(rgb)) < BLACK_LEVEL:
        raise PhotoError(f"{name}: photo is black — no light reached the camera")
    rgb, saturated = _orient(rgb, orientation), _orient(saturated, orientation)
    reason = ("a linear (demosaiced) DNG: the phone or converter that wrote it may have processed its colours"
              if photo.linear_dng else "")
    scale = float(box * unit)
    return LinearImage(
        rgb=np.ascontiguousarray(rgb, dtype=np.float32), saturated=np.ascontiguousarray(saturated),
        invalid=np.zeros(saturated.shape, bool), scale=scale, original_size=photo.original_size,
        encoding="linear-raw", exif=photo.exif, path=name, processed=photo.linear_dng, processed_reason=reason,
        origin_px=_displayed_origin((x0 * unit, y0 * unit, w * scale, h * scale), full, orientation))


def _stored_half(crop: tuple[float, float] | None, orientation: int) -> tuple[float, float] | None:
    """A displayed-frame centred crop's half sizes in the stored frame (orientations 5–8 swap
    the axes)."""
    if crop is None:
        return None
    return (float(crop[1]), float(crop[0])) if orientation >= 5 else (float(crop[0]), float(crop[1]))


def _span(width: int, height: int, unit: float, half: tuple[float, float] | None) -> int:
    """Long side, in array pixels, of what will be loaded: the whole array or the crop within it."""
    if half is None:
        return max(width, height)
    return int(math.ceil(max(min(width, 2.0 * half[0] / unit), min(height, 2.0 * half[1] / unit))))


def _window(size: tuple[int, int], unit: float, box: int, half: tuple[float, float] | None,
            full: tuple[float, float]) -> tuple[int, int, int, int]:
    """(x0, y0, w, h): the loaded image is w × h blocks of ``box`` × ``box`` array pixels from array
    pixel (x0, y0). ``unit`` is original pixels per array pixel (a JPEG draft, a raw binning),
    ``full`` the photo's original (width, height). Without ``half`` the whole array (remainders at
    the right and bottom dropped); with it the window of those half sizes (original pixels)
    around the photo's centre, on whole array pixels."""
    width, height = size
    if half is None:
        return 0, 0, width // box, height // box
    w = max(1, min(width // box, int(2.0 * half[0] / (unit * box))))
    h = max(1, min(height // box, int(2.0 * half[1] / (unit * box))))
    x0 = int(round(min(max(full[0] / (2.0 * unit) - w * box / 2.0, 0.0), width - w * box)))
    y0 = int(round(min(max(full[1] / (2.0 * unit) - h * box / 2.0, 0.0), height - h * box)))
    return x0, y0, w, h


def _displayed_origin(rect: tuple[float, float, float, float], full: tuple[float, float],
                      orientation: int) -> tuple[float, float]:
    """Top-left corner, in the displayed photo, of the stored-frame rectangle (x, y, w, h)."""
    x, y, w, h = rect
    width, height = full
    x1, y1 = x + w, y + h
    corners = {1: (x, y), 2: (width - x1, y), 3: (width - x1, height - y1), 4: (x, height - y1),
               5: (y, x), 6: (height - y1, x), 7: (height - y1, width - x1), 8: (y, width - x1)}
    return corners.get(orientation, (x, y))


def _reason(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return text if len(text) < 200 else text[:200] + "…"


class _Opened:
    """A non-raw file's header, read once, and its decodes by draft scale."""

    def __init__(self, file: Path, name: str, fmt: str, keep: Callable[[Any], Any], frame: int | None = None) -> None:
        self.file, self.name, self.fmt, self.keep = file, name, fmt, keep
        self.im: Any = None
        self.heif: Any = None
        self.sampling: dict[str, tuple[int, int]] = {}
        self.fallback_reason: Unsupported | None = None
        self.decoded: dict[int, Pixels] = {}
        self.pending: dict[int, Future[Pixels]] = {}  # JPEG drafts decoding on another thread
        if fmt == "exr":
            self.header, self.sampling = exr_header(file)
        elif fmt == "heif":
            self.header, self.heif = heif_header(file)
        else:
            try:
                self.im = keep(open_pillow(file, fmt))
                if fmt == "gif":
                    _seek_frame(self.im, name, frame)
                self.header = pillow_header(self.im, file, fmt)
            except PhotoError:
                raise
            except DECODE_ERRORS as exc:
                if fmt != "tiff":
                    raise
                self.header = tiff_header(file)
                self.fallback_reason = Unsupported(f"Pillow cannot read this TIFF ({_reason(exc)})")
        _check_size(name, self.header)
        self.exif_read = False
        # The orientation known before any decode (Pillow formats: none yet, see pillow_header):
        # every load picks its decode's draft with it, as a lone load_photo does, so a reader's
        # later loads decode at the same scale (and give the same pixels) as load_photo's.
        self.first_orientation = self.header.exif.orientation or 1

    def _plan(self, max_side: int, crop: tuple[float, float] | None, orientation: int
              ) -> tuple[tuple[float, float] | None, int, int]:
        """(stored-frame half window, draft, box) of a load."""
        half = _stored_half(crop, orientation)
        return (half, *_factors(_span(self.header.width, self.header.height, 1.0, half), max_side))

    def draft_for(self, max_side: int, crop: tuple[float, float] | None) -> int:
        """The JPEG draft a load of ``max_side`` (and ``crop``) decodes at."""
        return self._plan(max_side, crop, self.first_orientation)[1]

    def layout(self, max_side: int) -> tuple[int, int, float, ExifInfo, tuple[int, int]]:
        """See :meth:`PhotoReader.layout` (JPEG: Pillow reads its EXIF when it opens the file)."""
        header = self.header
        draft, box = _factors(_span(header.width, header.height, 1.0, None), max_side)
        width, height = _ceil_div(header.width, draft) // box, _ceil_div(header.height, draft) // box
        shown = (header.width, header.height)
        exif = exif_from_pillow(self.im)
        if (exif.orientation or 1) >= 5:
            width, height, shown = height, width, shown[::-1]
        return width, height, float(draft * box), exif, shown

    def prefetch(self, draft: int) -> None:
        """Start decoding JPEG draft ``draft`` on another thread, from its own Pillow image."""
        if self.fmt != "jpeg" or self.fallback_reason is not None or draft in self.decoded or draft in self.pending:
            return
        im = self.keep(open_pillow(self.file, self.fmt))
        worker = ThreadPoolExecutor(max_workers=1)
        self.pending[draft] = worker.submit(pillow_pixels, im, self.file, self.fmt, self.header, draft, self.keep)
        worker.shutdown(wait=False)

    def wait(self) -> None:
        for future in self.pending.values():
            future.exception()  # waits; the outcome of a decode nobody asked for does not matter
        self.pending.clear()

    def _prefetched(self, key: int) -> Pixels | None:
        future = self.pending.pop(key, None)
        if future is None:
            return None
        try:
            return future.result()  # a decode error is raised here, as it would be by decoding now
        except Unsupported as exc:
            self.fallback_reason = exc
            return None

    def pixels(self, draft: int) -> Pixels:
        """The decode at JPEG draft ``draft`` (other formats: the whole file), made once."""
        key = draft if self.fmt == "jpeg" else 1
        if key in self.decoded:
            return self.decoded[key]
        pixels = self._prefetched(key)
        im = self.im
        if pixels is None and self.fallback_reason is None:
            try:
                if self.fmt == "exr":
                    pixels = exr_pixels(self.file, self.header, self.sampling)
                elif self.fmt == "heif":
                    pixels = heif_pixels(self.heif, self.header)
                else:
                    if self.decoded or self.pending:  # draft() changes the image it is given: one per scale
                        im = self.keep(open_pillow(self.file, self.fmt))
                    pixels = pillow_pixels(im, self.file, self.fmt, self.header, draft, self.keep)
            except Unsupported as exc:
                self.fallback_reason = exc
        if not self.exif_read and im is not None and (pixels is not None or self.fmt != "png" or "exif" in im.info):
            self.header = replace(self.header, exif=exif_from_pillow(im))  # after the decode: see pillow_header
            self.exif_read = True
        if pixels is None:
            assert self.fallback_reason is not None
            pixels = _fallback(self.name, self.header, self.fallback_reason)
        self.decoded[key] = pixels
        return pixels

    def load(self, max_side: int, transfer: str, crop: tuple[float, float] | None) -> LinearImage:
        orientation = self.first_orientation
        half, draft, box = self._plan(max_side, crop, orientation)
        pixels = self.pixels(draft)
        header = self.header
        if (header.exif.orientation or 1) != orientation:  # PNG: EXIF read only now; swaps a window's axes
            orientation = header.exif.orientation or 1
            half, draft, box = self._plan(max_side, crop, orientation)
        if draft * box % pixels.draft:
            raise RuntimeError(f"decoder scaled by {pixels.draft}, which does not divide {draft * box}")
        block = draft * box // pixels.draft
        full = (float(header.width), float(header.height))
        x0, y0, w, h = _window((pixels.width, pixels.height), pixels.draft, block, half, full)
        if (x0, y0, w * block, h * block) != (0, 0, pixels.width, pixels.height):
            pixels = _windowed(pixels, x0, y0, w * block, h * block)
        image = _linearise(pixels, block, header, self.name, transfer)
        size = float(block * pixels.draft)
        colour_px = max(1.0, chroma_px(self.im) / size) if self.fmt == "jpeg" and self.im is not None else 1.0
        return replace(image, origin_px=_displayed_origin((x0 * pixels.draft, y0 * pixels.draft, w * size, h * size),
                                                          full, orientation), colour_px=colour_px)


def _seek_frame(im: Any, name: str, frame: int | None) -> None:
    """Move an opened GIF to ``frame``: Pillow composites each frame over the ones before with
    their disposal methods, so the pixels are the frame a viewer shows. An animated GIF without
    a frame is refused (see :mod:`.frames`)."""
    count = gif_frames(im, name)
    if frame is None:
        if count > 1:
            raise PhotoError(f"{name}: an animated GIF of {count} frames, each its own photo; name the one to "
                             f"read, counted from 0: {_frame_names(name, count)}")
        return
    if frame >= count:
        base = name.rpartition(FRAME_MARK)[0]
        raise PhotoError(f"{name}: frame {frame} is out of range; {base} has {count} "
                         f"frame{'s' if count > 1 else ''}: {_frame_names(base, count)}")
    im.seek(frame)


def _frame_names(base: str, count: int) -> str:
    first = f"{base}{FRAME_MARK}0"
    return first if count == 1 else f"{first} … {base}{FRAME_MARK}{count - 1}"


def _windowed(pixels: Pixels, x0: int, y0: int, width: int, height: int) -> Pixels:
    """The same decoded pixels seen through a window (rows are still read in bands)."""
    box = pixels.read_box
    if box is not None:
        def read_box(a: int, b: int, c: int, d: int) -> NDArray[Any]:
            return box(y0 + a, y0 + b, x0 + c, x0 + d)

        return Pixels(width, height, pixels.channels, pixels.bits, pixels.draft,
                      lambda a, b: read_box(a, b, 0, width), read_box)

    def read(a: int, b: int) -> NDArray[Any]:
        return pixels.read(y0 + a, y0 + b)[:, x0: x0 + width]

    return Pixels(width, height, pixels.channels, pixels.bits, pixels.draft, read)


def _closer(stack: ExitStack) -> Callable[[Any], Any]:
    def keep(obj: Any) -> Any:
        stack.callback(obj.close)
        return obj

    return keep


def _check_size(name: str, header: PhotoHeader) -> None:
    w, h = header.width, header.height
    if w * h > MAX_PIXELS:
        raise PhotoError(f"{name}: the header claims {w}x{h} pixels ({w * h / 1e6:.0f} megapixels); "
                         f"the limit is {MAX_PIXELS // 1_000_000} megapixels (refused before decoding)")
    if min(w, h) < MIN_SIDE:
        raise PhotoError(f"{name}: the image is too small ({w}x{h}); the disc needs at least "
                         f"{MIN_SIDE} pixels on the short side")


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


def _factors(long_side: int, max_side: int) -> tuple[int, int]:
    """(draft, box): draft the largest of 8/4/2 that still decodes ≥ max_side, box the rest."""
    draft = next((d for d in (8, 4, 2) if _ceil_div(long_side, d) >= max_side), 1)
    return draft, max(1, _ceil_div(_ceil_div(long_side, draft), max_side))


def _fallback(name: str, header: PhotoHeader, reason: Unsupported) -> Pixels:
    decoders = registered_decoders()
    for decoder in decoders:
        try:
            decoded = decoder(header.path, header)
        except PhotoError:
            raise
        except DECODE_ERRORS as exc:
            raise PhotoError(f"{name}: {reason}; the fallback decoder failed too ({_reason(exc)})") from exc
        if decoded is not None:
            pixels = array_pixels(decoded, header)
            if (pixels.width, pixels.height) != (header.width, header.height):
                raise PhotoError(f"{name}: the fallback decoder returned {pixels.width}x{pixels.height} "
                                 f"pixels, the header says {header.width}x{header.height}")
            return pixels
    hint = "no fallback decoder could read it" if decoders else \
        "no fallback decoder is registered (inside Blender the add-on registers Blender's image loader)"
    raise PhotoError(f"{name}: {reason}; {hint}")


# --- linearisation and reduction -------------------------------------------------------------


@lru_cache(maxsize=4)
def _lut(bits: int, srgb: bool) -> NDArray[np.float32]:
    codes = np.arange(1 << bits, dtype=np.float64) / ((1 << bits) - 1)
    return (srgb_decode(codes) if srgb else codes).astype(np.float32)


def _box_sum(x: NDArray[Any], k: int) -> NDArray[Any]:
    """Sum over k×k blocks of the first two axes (both multiples of k).

    k² strided adds: ~10× faster than ``reshape(h, k, w, k, c).sum(axis=(1, 3))`` here."""
    if k == 1:
        return x
    rows = x[0::k] + x[1::k]  # the first add makes the array: no copy pass before it
    for i in range(2, k):
        rows += x[i::k]
    return _column_sum(rows, k)


def _column_sum(rows: NDArray[Any], k: int) -> NDArray[Any]:
    """Σ_j rows[:, j::k], added in ascending j like copy-then-add but one pass fewer (the strided
    copy of a 24 MP JPEG's 1/4 draft, box 2, cost as much as its add: 13.8 -> 7.9 ms a load)."""
    out = rows[:, 0::k] + rows[:, 1::k]
    for j in range(2, k):
        out += rows[:, j::k]
    return out


@lru_cache(maxsize=2)
def _pair_lut(srgb: bool) -> NDArray[np.float32]:
    """lut[a] + lut[b] (float32) at a·256 + b: two 8-bit codes linearised and added in one look-up."""
    lut = _lut(8, srgb)
    return (lut[:, None] + lut[None, :]).reshape(-1)


def _linear_box_sum(codes: NDArray[np.uint8], lut: NDArray[np.float32], k: int, srgb: bool) -> NDArray[np.float32]:
    """``_box_sum(lut[codes], k)`` bit for bit, for 8-bit codes: each block's first two rows are
    linearised and added by one look-up of the pair (:func:`_pair_lut`), so a 2×2 box costs
    half the look-ups (24 MP JPEG at 1/4 draft, box 2: 10 → 5 ms)."""
    if k == 1:
        return lut[codes]
    pair = codes[0::k].astype(np.uint16)
    pair <<= 8
    pair |= codes[1::k]
    rows = _pair_lut(srgb)[pair]
    for i in range(2, k):
        rows += lut[codes[i::k]]
    return _column_sum(rows, k)


def _box_any(x: NDArray[np.bool_], k: int) -> NDArray[np.bool_]:
    if k == 1:
        return x
    rows = x[0::k].copy()
    for i in range(1, k):
        rows |= x[i::k]
    out = rows[:, 0::k].copy()
    for j in range(1, k):
        out |= rows[:, j::k]
    return out


def _box_all(x: NDArray[np.bool_], k: int) -> NDArray[np.bool_]:
    return ~_box_any(~x, k)


def _channel_max(x: NDArray[Any]) -> NDArray[Any]:
    """Max over the (short) last axis; ``x.max(axis=2)`` is ~30× slower for 3 channels."""
    out = x[..., 0].copy()
    for c in range(1, x.shape[-1]):
        np.maximum(out, x[..., c], out=out)
    return out


def _bands(pixels: Pixels, box: int) -> list[tuple[int, int]]:
    rows = pixels.height // box * box
    step = box * max(1, BAND_PIXELS // max(1, pixels.width * box))
    return [(y, min(y + step, rows)) for y in range(0, rows, step)]


def _linearise(pixels: Pixels, box: int, header: PhotoHeader, name: str, transfer: str) -> LinearImage:
    srgb = (header.transfer if transfer == "auto" else transfer) == "srgb"
    h, w = pixels.height // box, pixels.width // box
    if h < 1 or w < 1:
        raise PhotoError(f"{name}: the image is too small to reduce ({pixels.width}x{pixels.height})")
    reduce = _reduce_float if pixels.bits == 32 else _reduce_int
    rgb, saturated, invalid = reduce(pixels, box, srgb, name)
    kind = "float" if pixels.bits == 32 else str(pixels.bits)
    encoding = f"{'srgb' if srgb else 'linear'}-{kind}"
    channels = rgb.shape[2]
    if channels == 1:
        rgb = np.repeat(rgb, 3, axis=2)
    is_grey = channels == 1 or bool(
        np.array_equal(rgb[..., 0], rgb[..., 1]) and np.array_equal(rgb[..., 1], rgb[..., 2]))
    orientation = header.exif.orientation or 1
    rgb, saturated, invalid = (_orient(a, orientation) for a in (rgb, saturated, invalid))
    return LinearImage(
        rgb=np.ascontiguousarray(rgb, dtype=np.float32), saturated=np.ascontiguousarray(saturated),
        invalid=np.ascontiguousarray(invalid), scale=float(box * pixels.draft),
        original_size=(header.width, header.height), encoding=encoding, exif=header.exif, path=name,
        is_grey=is_grey)


_Reduced = tuple[NDArray[np.float32], NDArray[np.bool_], NDArray[np.bool_]]  # rgb, saturated, invalid


def _reduce_int(pixels: Pixels, box: int, srgb: bool, name: str) -> _Reduced:
    lut = _lut(pixels.bits, srgb)
    threshold = SATURATION_8BIT if pixels.bits == 8 else SATURATION_16BIT
    h, w, c = pixels.height // box, pixels.width // box, pixels.channels
    rgb = np.empty((h, w, c), np.float32)
    saturated = np.empty((h, w), bool)
    peak = 0
    inv = np.float32(1.0 / (box * box))
    for y0, y1 in _bands(pixels, box):
        codes = pixels.read(y0, y1)[:, : w * box]
        top = _channel_max(codes)
        peak = max(peak, int(top.max()))
        rows = slice(y0 // box, y1 // box)
        saturated[rows] = _box_any(top >= threshold, box)
        band = _linear_box_sum(codes, lut, box, srgb) if pixels.bits == 8 else _box_sum(lut[codes], box)
        if box > 1:
            np.multiply(band, inv, out=rgb[rows])  # into place: one pass fewer than a product then a copy
        else:
            rgb[rows] = band
    if lut[peak] < BLACK_LEVEL:
        raise PhotoError(f"{name}: photo is black — no light reached the camera")
    return rgb, saturated, np.zeros((h, w), bool)


def _float_planes(
        pixels: Pixels, y0: int, y1: int, width: int) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Rows as contiguous float64 channel planes (C, rows, width) with invalid pixels zeroed,
    and the valid mask. float64: sums of float32 values near 3e38 would overflow to inf."""
    planes = np.ascontiguousarray(np.moveaxis(pixels.read(y0, y1)[:, :width], -1, 0), dtype=np.float64)
    valid = np.isfinite(planes[0])
    for plane in planes[1:]:
        valid &= np.isfinite(plane)
    if not valid.all():
        planes[:, ~valid] = 0.0
    return planes, valid


def _reduce_float(pixels: Pixels, box: int, srgb: bool, name: str) -> _Reduced:
    h, w, c = pixels.height // box, pixels.width // box, pixels.channels
    bands = _bands(pixels, box)
    # Pass 1: invalid count and per-channel maximum of the finite samples.
    peak = np.full(c, -np.inf)
    n_invalid = 0
    for y0, y1 in bands:
        planes, valid = _float_planes(pixels, y0, y1, w * box)
        n_invalid += int(valid.size - np.count_nonzero(valid))
        peak = np.maximum(peak, [plane.max() for plane in planes])
    total = h * box * w * box
    if n_invalid * 2 > total:
        raise PhotoError(f"{name}: {100 * n_invalid / total:.0f}% of the pixels are NaN or infinite")
    if not np.any(peak > 0):
        raise PhotoError(f"{name}: photo is black — no light reached the camera")
    clip = np.where(peak > 0, peak * (1 - CLIP_EPS), np.inf)
    below = np.where(peak > 0, peak * (1 - 2 * CLIP_EPS), np.inf)
    # Pass 2: mean of the valid contributors, per-channel clip candidates and the pile-up counts.
    rgb = np.empty((h, w, c), np.float32)
    invalid = np.empty((h, w), bool)
    candidates = np.empty((c, h, w), bool)
    n_top = np.zeros(c, np.int64)
    n_below = np.zeros(c, np.int64)
    for y0, y1 in bands:
        planes, valid = _float_planes(pixels, y0, y1, w * box)
        rows = slice(y0 // box, y1 // box)
        count = np.maximum(_box_sum(valid.astype(np.float64), box), 1.0)
        invalid[rows] = ~_box_all(valid, box)
        for i, plane in enumerate(planes):
            high = plane >= clip[i]
            n_top[i] += np.count_nonzero(high)
            n_below[i] += np.count_nonzero(plane >= below[i]) - np.count_nonzero(high)
            candidates[i, rows] = _box_any(high, box)
            rgb[rows, :, i] = _box_sum(srgb_decode(plane) if srgb else plane, box) / count
    evident = (n_top >= CLIP_MIN_COUNT) & (n_top >= CLIP_RATIO * n_below)
    saturated = np.zeros((h, w), bool)
    for i in np.flatnonzero(evident):
        saturated |= candidates[i]
    return rgb, saturated, invalid


def _orient(a: NDArray[Any], orientation: int) -> NDArray[Any]:
    """Apply EXIF orientation (1..8) to an (H, W, ...) array, as Pillow's exif_transpose does."""
    if orientation == 2:
        return a[:, ::-1]
    if orientation == 3:
        return a[::-1, ::-1]
    if orientation == 4:
        return a[::-1]
    if orientation == 5:
        return a.swapaxes(0, 1)
    if orientation == 6:
        return np.rot90(a, -1)
    if orientation == 7:
        return a[::-1, ::-1].swapaxes(0, 1)
    if orientation == 8:
        return np.rot90(a, 1)
    return a

