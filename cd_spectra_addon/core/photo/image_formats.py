"""What a photo file holds: format sniffing, headers, EXIF, and band-wise pixel readers.

Split from ``images.py`` so the pipeline there reads as policy (limits, linearisation, box
averaging) while this module knows file formats. Pixels are handed out in row bands
(:class:`Pixels`) so that a large file never exists as one full-resolution float array.

16-bit colour without bpy: Pillow (up to 13 at least) decodes 16-bit RGB/RGBA PNG and TIFF to
8 bits by keeping the high byte of every sample (rawmode ``RGB;16B``/``RGB;16L``). Its unpackers
take the sample's high byte from the position the rawmode's byte order implies, so decoding the
same file a second time with the opposite byte order (``RGB;16L`` for a big-endian PNG) yields
exactly the low bytes. Two passes of Pillow's own C decoders (zlib, all five PNG filters, Adam7
interlace, libtiff compressions) give the full 16 bits. This relies on Pillow's tile
descriptors, so it is applied only to an allow-list of rawmodes and tests/test_images.py checks
it bit-exactly; anything else goes to the registered fallback decoders (Blender's loader).
"""

from __future__ import annotations

import io
import math
import os
import struct
import sys
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np
from numpy.typing import NDArray

from ..errors import PhotoError
from .jpeg_chroma import box_decode, scaled_decode_is_faithful

__all__ = [
    "ExifInfo", "PhotoHeader", "DecodedPixels", "Pixels", "Unsupported", "DECODE_ERRORS",
    "MAX_FILE_BYTES", "MAX_PIXELS", "RAW_EXTENSIONS", "MIN_SIDE", "check_file", "sniff_format", "open_pillow",
    "pillow_header", "pillow_pixels", "exif_from_pillow", "exif_info", "exif_number", "exif_text", "heif_header", "heif_pixels", "tiff_header", "exr_header", "exr_pixels",
    "array_pixels", "gif_icc_profile",
]

MAX_FILE_BYTES = 512 * 1024 * 1024
MAX_PIXELS = 100_000_000  # ~100 MP: refused from the header, before any pixel is decoded
MIN_SIDE = 64
MAX_EXR_DECODED_BYTES = 2 * 1024**3  # OpenEXR's reader decodes every channel of the part at once

# What third-party decoders raise on hostile bytes (Pillow: OSError/SyntaxError/ValueError/
# struct.error/EOFError/DecompressionBombError; OpenEXR: ValueError/RuntimeError). MemoryError is
# included so an image too large for this machine becomes a message, not a crash.
DECODE_ERRORS: tuple[type[BaseException], ...] = (
    OSError, SyntaxError, ValueError, EOFError, struct.error, RuntimeError, MemoryError,
    IndexError, KeyError, TypeError, ZeroDivisionError, OverflowError,
)

RAW_EXTENSIONS = frozenset({
    ".cr2", ".cr3", ".crw", ".nef", ".nrw", ".arw", ".srf", ".sr2", ".dng", ".orf", ".rw2", ".raf", ".pef",
    ".srw", ".x3f", ".3fr", ".iiq", ".erf", ".kdc", ".mrw", ".rwl", ".mos", ".mef", ".dcr"})  # read by LibRaw


HEIF_BRANDS = (b"heic", b"heix", b"hevc", b"hevx", b"mif1", b"msf1", b"heim", b"heis")
# ITU-T H.273 transfer characteristics of HDR HEIFs: the sRGB curve does not undo them.
_HDR_TRANSFERS = {16: "PQ", 18: "HLG"}


class Unsupported(Exception):
    """The built-in decoders cannot read this variant; a registered fallback decoder may."""


@dataclass(frozen=True)
class ExifInfo:
    """The EXIF fields the inverse uses (camera distance from the focal length); all optional."""

    focal_length_mm: float | None = None
    focal_length_35mm: float | None = None
    focal_plane_px_per_mm: float | None = None  # FocalPlaneXResolution converted with its unit
    make: str | None = None
    model: str | None = None
    orientation: int | None = None  # EXIF 1..8
    software: str | None = None  # what wrote the file (camera firmware, phone OS, editor)
    colour_space: int | None = None  # EXIF ColorSpace: 1 sRGB, 2 Adobe RGB, 0xFFFF uncalibrated
    white_balance: int | None = None  # EXIF WhiteBalance: 0 auto, 1 manual — only cameras that balance write it
    icc_profile: str | None = None  # the embedded ICC profile's description ("" if it has none)


@dataclass(frozen=True)
class PhotoHeader:
    """What the file says about itself, read before any pixel is decoded (passed to decoders)."""

    path: str
    format: str  # "jpeg" | "png" | "tiff" | "exr" | "heif" | "gif"
    width: int
    height: int
    bits: int  # 8 or 16 (integer codes), 32 (float samples)
    channels: int  # colour channels without alpha: 1 (grey) or 3
    transfer: str  # the file's own transfer curve: "srgb" | "linear"
    exif: ExifInfo = field(default_factory=ExifInfo)
    palette_colours: int = 0  # entries of a palette image's colour table (a GIF: ≤ 256 per frame); 0: none


@dataclass(frozen=True)
class DecodedPixels:
    """What a fallback decoder returns: full-resolution pixels, top row first.

    ``pixels`` is (H, W) or (H, W, C) with C = 1..4 (a 4th/2nd channel is alpha and ignored).
    For ``bits`` 8 or 16 it holds the stored codes, either as integers or as floats normalised by
    the maximum code (Blender's loader gives code / 65535); for ``bits`` 32 it holds float samples.
    """

    pixels: NDArray[Any]
    bits: int


@dataclass
class Pixels:
    """Decoded pixels, read in row bands: ``read(y0, y1)`` → (y1 - y0, width, channels) with
    uint8/uint16 codes (bits 8/16) or floats (bits 32)."""

    width: int
    height: int
    channels: int  # 1 or 3
    bits: int
    draft: int  # original pixels per decoded pixel (JPEG DCT-domain scaling), else 1
    read: Callable[[int, int], NDArray[Any]]
    # read(y0, y1) of columns x0..x1 only, ``read_box(y0, y1, x0, x1)``, where the decoder can
    # copy out just those (Pillow: a window's band costs its own pixels, not whole rows).
    read_box: Callable[[int, int, int, int], NDArray[Any]] | None = None


def check_file(path: str | os.PathLike[str]) -> Path:
    """A readable, non-empty regular file no larger than MAX_FILE_BYTES, or PhotoError."""
    name = os.fspath(path)
    p = Path(name)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise PhotoError(f"{name}: file not found") from None
    except OSError as exc:
        raise PhotoError(f"{name}: cannot access the file ({exc.strerror or exc})") from None
    if p.is_dir():
        raise PhotoError(f"{name}: is a folder, not a photo file")
    if not p.is_file():
        raise PhotoError(f"{name}: not a regular file")
    if st.st_size == 0:
        raise PhotoError(f"{name}: the file is empty (0 bytes)")
    if st.st_size > MAX_FILE_BYTES:
        raise PhotoError(f"{name}: the file is too large ({st.st_size / 2**20:.0f} MB; "
                         f"the limit is {MAX_FILE_BYTES // 2**20} MB)")
    return p


def sniff_format(path: Path) -> str:
    """The format from the file's first bytes (never its extension), or a PhotoError that says
    what the file is instead."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(64)
    except OSError as exc:
        raise PhotoError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    supported = ("supported: JPEG, HEIC/HEIF, PNG, TIFF, OpenEXR, GIF and camera raw "
                 "(CR2, CR3, NEF, ARW, RAF, ORF, RW2, DNG, ...)")
    if path.suffix.lower() in RAW_EXTENSIONS or (head[4:8] == b"ftyp" and head[8:12] == b"crx ") \
            or head.startswith(b"FUJIFILMCCD-RAW"):
        return "raw"
    if head.startswith(b"\xff\xd8\xff"):
        return "jpeg"
    if head.startswith(b"\x89PNG\r\n\x1a\n"):
        return "png"
    if head[:4] in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return "tiff"
    if head.startswith(b"v/1\x01"):
        return "exr"
    if head.startswith(b"GIF8"):
        return "gif"
    if head[4:8] == b"ftyp" and head[8:12] in HEIF_BRANDS:
        return "heif"
    other = _other_format(head)
    if other:
        raise PhotoError(f"{path}: {other} files are not supported ({supported})")
    if len(head) < 8:
        raise PhotoError(f"{path}: too short to be an image ({len(head)} bytes)")
    if _looks_like_text(head):
        raise PhotoError(f"{path}: not an image, the file contains text ({supported})")
    raise PhotoError(f"{path}: not a recognised image format ({supported})")


def _other_format(head: bytes) -> str | None:
    if head[4:8] == b"ftyp":
        brand = head[8:12]
        if brand in (b"avif", b"avis"):
            return "AVIF"
    known = [(b"BM", "BMP"), (b"8BPS", "Photoshop PSD"), (b"#?RADIANCE", "Radiance HDR"),
             (b"#?RGBE", "Radiance HDR"), (b"\x00\x00\x00\x0cjP  ", "JPEG 2000"),
             (b"\xff\x4f\xff\x51", "JPEG 2000"),
             (b"%PDF", "PDF"), (b"\xff\x0a", "JPEG XL"),
             (b"\x00\x00\x00\x0cJXL ", "JPEG XL")]
    for magic, name in known:
        if head.startswith(magic):
            return name
    if head.startswith(b"RIFF") and head[8:12] == b"WEBP":
        return "WebP"
    return None


def _looks_like_text(head: bytes) -> bool:
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return all(ch.isprintable() or ch in "\r\n\t" for ch in text)


# --- Pillow ----------------------------------------------------------------------------------


def open_pillow(path: Path, fmt: str) -> Any:
    """``Image.open`` restricted to the sniffed format (header only, nothing decoded yet).

    Pillow's global MAX_IMAGE_PIXELS is left alone: the wheel is shared with other add-ons in
    Blender's Python. Our own MAX_PIXELS is checked from the header by the caller; Pillow's
    warning between its limit and ours is silenced, its hard DecompressionBombError caught."""
    from PIL import Image

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", Image.DecompressionBombWarning)
        try:
            return Image.open(path, formats=[fmt.upper()])
        except Image.DecompressionBombError:
            raise PhotoError(f"{path}: the header claims an enormous image (more than "
                             f"{MAX_PIXELS // 1_000_000} megapixels); refusing to decode it") from None


_WIDE_RAWMODES = {f"{m};16{e}" for m in ("RGB", "RGBA", "RGBX") for e in "BLN"}


def _tile_rawmode(tile: Any) -> str | None:
    args = tile[3]
    if isinstance(args, str):
        return args
    if isinstance(args, tuple) and args and isinstance(args[0], str):
        return args[0]
    return None


def _swap_byte_order(rawmode: str) -> str:
    order = rawmode[-1]
    if order == "N":
        order = "L" if sys.byteorder == "little" else "B"
    return rawmode[:-1] + ("L" if order == "B" else "B")


def _with_rawmode(tile: Any, rawmode: str) -> Any:
    args = tile[3]
    args = rawmode if isinstance(args, str) else (rawmode, *args[1:])
    return tile._replace(args=args) if hasattr(tile, "_replace") else (*tile[:3], args)


def _truncated_16bit(im: Any) -> bool:
    """True when Pillow would keep only the high byte of 16-bit samples."""
    return any((r or "").endswith((";16B", ";16L", ";16N")) and not (r or "").startswith("I;")
               for r in map(_tile_rawmode, im.tile))


def pillow_header(im: Any, path: Path, fmt: str) -> PhotoHeader:
    """Header fields from a lazily opened image. EXIF is left empty: Pillow's PNG ``getexif()``
    decodes the whole image when the eXIf chunk follows IDAT, so it is read after the size check
    and the decode (:func:`exif_from_pillow`)."""
    mode = im.mode
    if mode.startswith("I;16") or _truncated_16bit(im):
        bits = 16
    elif mode in ("F", "I"):
        bits = 32
    else:
        bits = 8
    rawmodes = [r or "" for r in map(_tile_rawmode, im.tile)]
    grey = mode in ("1", "L", "LA", "La", "I", "I;16", "I;16B", "I;16L", "I;16N", "F") or any(
        r.startswith("LA;") for r in rawmodes)
    if mode == "P":
        grey = False  # palette images are converted to RGB; `is_grey` is decided from the pixels
    info = im.info
    if fmt == "png":
        gamma = info.get("gamma")
        linear = (bits == 16 and gamma is not None and abs(float(gamma) - 1.0) < 0.01
                  and "srgb" not in info and "icc_profile" not in info)
    elif fmt == "tiff":
        linear = bits == 32 or (bits == 16 and not info.get("icc_profile"))
    else:
        linear = False
    return PhotoHeader(str(path), fmt, im.width, im.height, bits, 1 if grey else 3,
                       "linear" if linear else "srgb", palette_colours=_palette_colours(im, fmt))


def _palette_colours(im: Any, fmt: str) -> int:
    """Entries of the colour table a palette image's codes index (0: not a palette image). A
    GIF is palette-coded throughout, though Pillow hands frames after the first out as RGB."""
    palette = getattr(im, "palette", None) if im.mode in ("P", "PA") else None
    entries = len(palette.palette) // 3 if palette is not None and palette.palette else 0
    if fmt == "gif":
        return min(entries, 256) or 256
    return min(entries, 256) or (256 if im.mode in ("P", "PA") else 0)


def pillow_pixels(im: Any, path: Path, fmt: str, header: PhotoHeader, draft: int,
                  keep: Callable[[Any], Any]) -> Pixels:
    """Decode ``im`` (JPEG: DCT-domain scaled by ``draft``). ``keep`` registers images to close."""
    used_draft = 1
    if fmt == "jpeg" and draft > 1 and not scaled_decode_is_faithful(im):
        codes = box_decode(im, draft)  # 4:2:2 chroma: see jpeg_chroma
        return Pixels(codes.shape[1], codes.shape[0], 3, 8, draft, lambda y0, y1: codes[y0:y1])
    if fmt == "jpeg" and draft > 1:
        im.draft("RGB", (im.width // draft, im.height // draft))
        sizes = {s: (-(-header.width // s), -(-header.height // s)) for s in (8, 4, 2, 1)}
        used_draft = next((s for s, size in sizes.items() if size == im.size), 0)
        if used_draft == 0:
            raise RuntimeError(f"unexpected JPEG draft size {im.size} for {header.width}x{header.height}")
    wide = _truncated_16bit(im)
    if wide:
        rawmodes = [_tile_rawmode(t) for t in im.tile]
        if not all(r in _WIDE_RAWMODES for r in rawmodes):
            layout = ", ".join(sorted(set(map(str, rawmodes))))
            raise Unsupported(f"Pillow cannot decode this 16-bit layout ({layout}) at full precision")
        low = keep(open_pillow(path, fmt))
        low.tile = [_with_rawmode(t, _swap_byte_order(_tile_rawmode(t) or "")) for t in low.tile]
        im.load()
        low.load()
        if low.size != im.size or low.mode != im.mode:
            raise RuntimeError("16-bit low-byte pass disagrees with the high-byte pass")

        def read_wide(y0: int, y1: int) -> NDArray[np.uint16]:
            box = (0, y0, im.width, y1)
            hi = np.asarray(im.crop(box))[..., :3].astype(np.uint16)
            hi <<= 8
            hi |= np.asarray(low.crop(box))[..., :3]
            return hi

        return Pixels(im.width, im.height, 3, 16, 1, read_wide)

    im.load()
    mode = im.mode
    if mode in ("1",):
        im = keep(im.convert("L"))
    elif mode in ("P", "PA", "CMYK", "YCbCr", "LAB", "HSV"):
        # A palette with per-entry alpha (PNG tRNS) converted to RGB makes Pillow warn; to RGBA it
        # gives the same colours and an alpha that is ignored here, as everywhere.
        target = "RGBA" if mode == "P" and "transparency" in im.info else "RGB"
        try:
            im = keep(im.convert(target))
        except ValueError as exc:
            raise Unsupported(f"cannot convert {mode} pixels to RGB ({exc})") from None
    mode = im.mode
    if mode in ("L", "LA", "La"):
        channels, dtype = 1, np.uint8
    elif mode in ("RGB", "RGBA", "RGBX", "RGBa"):
        channels, dtype = 3, np.uint8
    elif mode.startswith("I;16"):
        channels, dtype = 1, np.uint16
    elif mode == "F":
        channels, dtype = 1, np.float32
    else:
        raise Unsupported(f"pixel mode {mode!r} is not supported")
    bits = {np.uint8: 8, np.uint16: 16, np.float32: 32}[dtype]
    image = im

    def read_box(y0: int, y1: int, x0: int, x1: int) -> NDArray[Any]:
        band = np.asarray(image.crop((x0, y0, x1, y1)))
        if band.ndim == 2:
            band = band[..., None]
        return band[..., :channels].astype(dtype, copy=False)

    def read(y0: int, y1: int) -> NDArray[Any]:
        return read_box(y0, y1, 0, image.width)

    return Pixels(im.width, im.height, channels, bits, used_draft, read, read_box)


# --- EXIF ------------------------------------------------------------------------------------


def exif_number(value: Any) -> float | None:
    """A positive finite number from an EXIF / TIFF value (int, rational, or a tuple holding
    one, as TIFF readers give count-1 arrays), else None: damaged metadata is no error."""
    if isinstance(value, tuple):
        value = value[0] if value else None
    try:
        x = float(value)
    except (TypeError, ValueError, ZeroDivisionError, OverflowError):
        return None
    return x if math.isfinite(x) and x > 0 else None


def exif_text(value: Any) -> str | None:
    """An EXIF / TIFF ASCII value as text without NULs and padding (bytes decoded as UTF-8), else None."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    if not isinstance(value, str):
        return None
    value = value.replace("\x00", "").strip()
    return value or None


_UNIT_PER_MM = {2: 1 / 25.4, 3: 1 / 10.0, 4: 1.0, 5: 1000.0}  # FocalPlaneResolutionUnit → per mm


def exif_from_pillow(im: Any) -> ExifInfo:
    """The few EXIF fields we use (and the ICC profile's name). Damaged EXIF is metadata we can
    do without: it yields None fields, never a failure to load the photo."""
    profile = im.info.get("icc_profile")
    if profile is None and getattr(im, "format", None) == "GIF" and getattr(im, "filename", None):
        profile = gif_icc_profile(Path(im.filename))  # Pillow leaves the GIF's ICC extension unread
    icc = icc_description(profile)
    try:
        return replace(exif_from_tags(im.getexif()), icc_profile=icc)
    except DECODE_ERRORS:
        return ExifInfo(icc_profile=icc)


def exif_from_tags(exif: Any, container_orientation: bool = False) -> ExifInfo:
    """ExifInfo from a Pillow ``Image.Exif``. ``container_orientation``: the container already
    rotated the pixels (HEIF's irot/imir, applied by libheif), so EXIF orientation is ignored."""
    orientation = exif.get(0x0112)
    orientation = orientation if isinstance(orientation, int) and 1 <= orientation <= 8 else None
    if container_orientation:
        orientation = None
    return exif_info(exif, exif.get_ifd(0x8769), orientation)


def exif_info(ifd0: Mapping[int, Any], sub: Mapping[int, Any], orientation: int | None,
              focal_fallback: float | None = None, rendering: bool = True) -> ExifInfo:
    """ExifInfo from the tags of IFD0 (make, model, software) and of the Exif sub-IFD (focal
    length, focal-plane resolution, colour space, white balance); a raw file's TIFF reader gives
    one dict for both. ``focal_fallback`` stands in for a missing FocalLength. ``rendering``:
    read ColorSpace and WhiteBalance, which describe how the camera rendered the file. They
    are read for JPEG/HEIC/TIFF, but not for a raw file's photosites, which no camera rendering
    touched."""
    focal_plane = exif_number(sub.get(0xA20E))
    unit = sub.get(0xA210, 2)  # EXIF default: inches
    per_mm = _UNIT_PER_MM.get(unit) if isinstance(unit, int) else None
    return ExifInfo(
        focal_length_mm=exif_number(sub.get(0x920A)) or focal_fallback,
        focal_length_35mm=exif_number(sub.get(0xA405)),
        focal_plane_px_per_mm=focal_plane * per_mm if focal_plane and per_mm else None,
        make=exif_text(ifd0.get(0x010F)),
        model=exif_text(ifd0.get(0x0110)),
        orientation=orientation,
        software=exif_text(ifd0.get(0x0131)),
        colour_space=_small_int(sub.get(0xA001)) if rendering else None,
        white_balance=_small_int(sub.get(0xA403)) if rendering else None,
    )


def _small_int(value: Any) -> int | None:
    return value if isinstance(value, int) and 0 <= value <= 0xFFFF else None


def icc_description(icc: bytes | None) -> str | None:
    """The ICC profile's description, "" for a profile without one, None without a profile."""
    if not icc:
        return None
    try:
        from PIL import ImageCms

        return str(ImageCms.ImageCmsProfile(io.BytesIO(icc)).profile.profile_description or "").strip()
    except (ImportError, OSError, ValueError, TypeError, AttributeError):
        return ""


_GIF_ICC = b"ICCRGBG1012"


def gif_icc_profile(path: Path) -> bytes | None:
    """The ICC profile a GIF carries in an ``ICCRGBG1012`` application extension before its
    first image (a phone's photo turned into a GIF keeps its Display P3 profile there), or None.
    Damaged blocks are no error: the profile is metadata we can do without."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(13)
            if len(head) < 13 or not head.startswith(b"GIF8"):
                return None
            flags = head[10]
            if flags & 0x80:
                fh.seek(3 << ((flags & 7) + 1), os.SEEK_CUR)  # the global colour table
            while True:
                introducer = fh.read(1)
                if introducer != b"!":
                    return None  # an image (","), the end (";") or damage: no profile before the first image
                label = fh.read(1)
                blocks = _gif_sub_blocks(fh)
                if label == b"\xff" and blocks and blocks[0] == _GIF_ICC:
                    return b"".join(blocks[1:]) or None
    except OSError:
        return None


def _gif_sub_blocks(fh: BinaryIO) -> list[bytes]:
    """A GIF extension's data sub-blocks, up to its terminator (or the end of the file)."""
    blocks = []
    while True:
        size = fh.read(1)
        if not size or size == b"\x00":
            return blocks
        data = fh.read(size[0])
        blocks.append(data)
        if len(data) < size[0]:
            return blocks


# --- HEIC / HEIF ------------------------------------------------------------------------------


def heif_header(path: Path) -> tuple[PhotoHeader, Any]:
    """Header of a HEIC/HEIF file through libheif (pillow-heif): size, bit depth (8, or 10/12
    handed out as 16-bit codes), EXIF. The pixels are decoded later by :func:`heif_pixels`."""
    try:
        import pillow_heif
    except ImportError as exc:
        raise PhotoError(f"{path}: reading HEIC/HEIF needs the pillow-heif package, which is not installed "
                         f"({exc}); install it or export the photo as JPEG") from None
    heif = pillow_heif.open_heif(path, convert_hdr_to_8bit=False)
    width, height = heif.size
    depth = int(heif.info.get("bit_depth") or 8)
    exif = ExifInfo()
    raw_exif = heif.info.get("exif")
    if raw_exif:
        from PIL import Image

        try:
            tags = Image.Exif()
            tags.load(raw_exif)
            exif = exif_from_tags(tags, container_orientation=True)
        except DECODE_ERRORS:
            exif = ExifInfo()
    exif = replace(exif, icc_profile=icc_description(heif.info.get("icc_profile")))
    channels = 1 if heif.mode in ("L", "I;16", "I;16L") else 3
    return PhotoHeader(str(path), "heif", width, height, 8 if depth <= 8 else 16, channels, "srgb", exif), heif


def heif_hdr_transfer(heif: Any) -> str | None:
    """"PQ"/"HLG" when the file declares an HDR transfer curve (read as sRGB: approximate)."""
    nclx = heif.info.get("nclx_profile") or {}
    return _HDR_TRANSFERS.get(int(nclx.get("transfer_characteristics", 0) or 0))


def heif_pixels(heif: Any, header: PhotoHeader) -> Pixels:
    data = np.asarray(heif)
    if data.ndim == 2:
        data = data[..., None]
    if data.shape[:2] != (header.height, header.width):
        raise Unsupported(f"libheif returned {data.shape[1]}x{data.shape[0]} pixels for a "
                          f"{header.width}x{header.height} image")
    dtype = np.uint8 if header.bits == 8 else np.uint16
    if data.dtype != dtype:
        raise Unsupported(f"unexpected HEIF sample type {data.dtype} for {header.bits}-bit codes")
    channels = header.channels

    def read(y0: int, y1: int) -> NDArray[Any]:
        return data[y0:y1, :, :channels]

    return Pixels(header.width, header.height, channels, header.bits, 1, read)


# --- TIFF header (for files Pillow cannot open, before a fallback decoder reads them) ---------


def tiff_header(path: Path) -> PhotoHeader:
    """Size, bit depth and ICC presence from the first IFD of a classic TIFF."""
    with open(path, "rb") as fh:
        head = fh.read(8)
        order = "<" if head[:2] == b"II" else ">"
        if len(head) < 8 or struct.unpack(order + "H", head[2:4])[0] != 42:
            raise Unsupported("BigTIFF or damaged TIFF header")
        (offset,) = struct.unpack(order + "I", head[4:8])
        fh.seek(offset)
        (count,) = struct.unpack(order + "H", _read_exact(fh, 2))
        tags: dict[int, int] = {}
        sizes = {1: 1, 3: 2, 4: 4}
        for _ in range(min(count, 4096)):
            tag, kind, n, raw = struct.unpack(order + "HHI4s", _read_exact(fh, 12))
            if kind not in sizes or n == 0:
                tags.setdefault(tag, -1)
                continue
            fmt = {1: "B", 3: "H", 4: "I"}[kind]
            if n * sizes[kind] <= 4:
                value = struct.unpack(order + fmt, raw[: sizes[kind]])[0]
            else:  # first value lives at an offset
                here = fh.tell()
                fh.seek(struct.unpack(order + "I", raw)[0])
                value = struct.unpack(order + fmt, _read_exact(fh, sizes[kind]))[0]
                fh.seek(here)
            tags[tag] = value
    width, height = tags.get(256, 0), tags.get(257, 0)
    if width <= 0 or height <= 0:
        raise ValueError("the TIFF's first image has no size")
    bits = tags.get(258, 1)
    samples = tags.get(277, 1)
    sample_format = tags.get(339, 1)
    bits = 32 if sample_format == 3 else (16 if bits == 16 else 8)
    channels = 1 if samples in (1, 2) else 3
    linear = bits == 32 or (bits == 16 and 34675 not in tags)
    orientation = tags.get(274, 0)
    exif = ExifInfo(orientation=orientation if 1 <= orientation <= 8 else None)
    return PhotoHeader(str(path), "tiff", width, height, bits, channels,
                       "linear" if linear else "srgb", exif)


def _read_exact(fh: BinaryIO, n: int) -> bytes:
    data = fh.read(n)
    if len(data) != n:
        raise EOFError("TIFF header is truncated")
    return data


# --- OpenEXR -------------------------------------------------------------------------------


def _exr_file(path: Path, header_only: bool) -> Any:
    import OpenEXR

    # A Python file object, not the path: the C++ library would mangle non-ASCII paths on Windows.
    with open(path, "rb") as fh:
        return OpenEXR.File(fh, separate_channels=True, header_only=header_only)


def _exr_pick(names: list[str]) -> list[str]:
    have = set(names)
    if {"R", "G", "B"} <= have:
        return ["R", "G", "B"]
    if "Y" in have:
        return ["Y"]
    layers = sorted(n[:-2] for n in names if n.endswith(".R") and {n[:-2] + ".G", n[:-2] + ".B"} <= have)
    if not layers:
        found = ", ".join(sorted(names)) or "none"
        raise Unsupported(f"the EXR has no R, G, B or Y channels (it has {found})")
    preferred = [lay for lay in layers if "combined" in lay.lower() or "beauty" in lay.lower()]
    layer = (preferred or layers)[0]
    return [f"{layer}.R", f"{layer}.G", f"{layer}.B"]


def exr_header(path: Path) -> tuple[PhotoHeader, dict[str, tuple[int, int]]]:
    """Size from the data window, plus each channel's (x, y) sampling; no pixel is decoded."""
    head = _exr_file(path, header_only=True).header()
    (x0, y0), (x1, y1) = (tuple(int(v) for v in corner) for corner in head["dataWindow"])
    width, height = x1 - x0 + 1, y1 - y0 + 1
    sampling = {c.name: (int(c.xSampling), int(c.ySampling)) for c in head.get("channels", [])}
    if width * height <= MAX_PIXELS and width * height * 4 * len(sampling) > MAX_EXR_DECODED_BYTES:
        raise PhotoError(f"{path}: the EXR has {len(sampling)} channels of {width}x{height}; decoding "
                         f"them all would need more than {MAX_EXR_DECODED_BYTES / 2**30:.0f} GB")
    try:
        channels = len(_exr_pick(list(sampling)))
    except Unsupported:
        channels = 3
    return PhotoHeader(str(path), "exr", width, height, 32, channels, "linear"), sampling


def exr_pixels(path: Path, header: PhotoHeader, sampling: dict[str, tuple[int, int]]) -> Pixels:
    picked = _exr_pick(list(sampling))
    for name in picked:
        if sampling[name] != (1, 1):
            raise Unsupported(f"the EXR's {name} channel is subsampled {sampling[name]}")
    planes = _exr_file(path, header_only=False).channels()
    arrays = [planes[name].pixels for name in picked]
    for a in arrays:
        if a.shape != (header.height, header.width) or a.dtype.kind != "f":
            raise Unsupported(f"EXR channels of {a.dtype} {a.shape} are not supported")

    def read(y0: int, y1: int) -> NDArray[Any]:
        return np.stack([a[y0:y1] for a in arrays], axis=-1)

    return Pixels(header.width, header.height, len(arrays), 32, 1, read)


def array_pixels(decoded: DecodedPixels, header: PhotoHeader) -> Pixels:
    """Wrap a fallback decoder's array; float codes are turned back into integer codes so every
    path shares the same transfer LUT and saturation threshold."""
    px = np.asarray(decoded.pixels)
    if px.ndim == 2:
        px = px[..., None]
    if px.ndim != 3 or px.shape[2] not in (1, 2, 3, 4):
        raise RuntimeError(f"decoder returned an array of shape {px.shape}")
    channels = 1 if px.shape[2] <= 2 else 3
    bits = int(decoded.bits)
    if bits not in (8, 16, 32):
        raise RuntimeError(f"decoder returned bits={bits}")
    top = (1 << bits) - 1 if bits != 32 else 0
    dtype = np.uint8 if bits == 8 else np.uint16

    def read(y0: int, y1: int) -> NDArray[Any]:
        band = px[y0:y1, :, :channels]
        if bits == 32:
            return band.astype(np.float32, copy=False)
        if band.dtype.kind in "ui":
            return np.clip(band, 0, top).astype(dtype)
        band = np.nan_to_num(band.astype(np.float64), nan=0.0, posinf=1.0, neginf=0.0)
        return np.rint(np.clip(band, 0.0, 1.0) * top).astype(dtype)

    return Pixels(px.shape[1], px.shape[0], channels, bits, 1, read)
