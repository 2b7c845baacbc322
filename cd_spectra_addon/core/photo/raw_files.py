"""Camera raw files (CR2, CR3, NEF, ARW, RAF, ORF, RW2, DNG, ...) as linear sensor RGB.

LibRaw, through rawpy, reads every raw format; writing decoders ourselves is out of the
question. From it we take only the undemosaiced photosites and the file's own black and white
levels, and do the rest here, because each of LibRaw's processing steps would change what the
camera's spectral sensitivities predict:

* **no white balance, no colour matrix, no curve**: the solve models camera-native RGB
  (LibRaw's ``postprocess`` would apply all three);
* **binning, not demosaicing**: each CFA cell (2×2 Bayer, 6×6 X-Trans) becomes one pixel whose
  channel is the mean of that colour's photosites — half the resolution, no interpolation
  colour artefacts across the rainbow's narrow rings, and 4× less data to read out;
* **saturation per photosite** from the raw white level: a cell is clipped when any of its
  photosites reaches :data:`SATURATION_FRACTION` of the black-to-white range, before binning
  could hide it.

A *linear* DNG (PhotometricInterpretation 34892, LinearRaw — what phones write for "ProRAW" or
"RAW" modes) is already demosaiced and possibly colour-processed (noise reduction, lens shading,
sometimes tone mapping or a colour transform): it is read the same way but flagged processed.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import PhotoError
from .image_formats import RAW_EXTENSIONS, ExifInfo, exif_info, exif_number
from .tiff_tags import find_tiff_tags

__all__ = ["RAW_EXTENSIONS", "RawPhoto", "read_raw", "is_raw_path", "SATURATION_FRACTION"]

SATURATION_FRACTION = 0.98  # of (white − black): the 8-bit loader's 250/255 margin, for raw
HEAD_BYTES = 4 << 20  # embedded TIFF metadata (CR3, RAF) is looked for in the first 4 MB
LINEAR_RAW = 34892
_FLIP_TO_ORIENTATION = {0: 1, 3: 3, 5: 8, 6: 6}


@dataclass(frozen=True)
class RawPhoto:
    """Binned linear sensor RGB (0 = black level, 1 = white level), before any resizing."""

    rgb: NDArray[np.float32]  # (H, W, 3) camera-native, not white balanced
    saturated: NDArray[np.bool_]  # (H, W) a contributing photosite reached the white level
    binning: int  # sensor pixels per output pixel along each side (2 for Bayer, 1 for linear DNG)
    original_size: tuple[int, int]  # (width, height) of the visible sensor area
    exif: ExifInfo
    linear_dng: bool  # demosaiced (LinearRaw) DNG: possibly colour-processed by the phone
    software: str | None
    black: tuple[float, ...]
    white: tuple[float, ...]


def is_raw_path(path: str | Path) -> bool:
    return Path(path).suffix.lower() in RAW_EXTENSIONS


def _channel_map(color_desc: bytes) -> list[int]:
    letters = color_desc.decode("ascii", "replace")
    index = {"R": 0, "G": 1, "B": 2}
    if any(ch not in index for ch in letters[:3]) or (len(letters) > 3 and letters[3] not in index):
        raise PhotoError(f"the sensor's colour filters are {letters!r}, not red/green/blue: "
                         "this raw format is not supported")
    return [index[ch] for ch in letters]


def _bin_mosaic(raw: Any, channel_of: list[int]) -> tuple[NDArray[np.float32], NDArray[np.bool_], int,
                                                          tuple[float, ...], tuple[float, ...]]:
    pattern = np.asarray(raw.raw_pattern)
    p, q = pattern.shape
    if p != q or p not in (2, 3, 6):
        raise PhotoError(f"unsupported colour filter layout ({p}×{q})")
    site = raw.raw_image_visible
    h, w = site.shape[0] // p, site.shape[1] // q
    black = [float(b) for b in raw.black_level_per_channel]
    whites = raw.camera_white_level_per_channel
    white = [float(x) for x in whites] if whites is not None else [float(raw.white_level)] * len(black)
    total = np.zeros((h, w, 3), np.float32)
    count = np.zeros(3, np.float32)
    saturated = np.zeros((h, w), bool)
    for i in range(p):
        for j in range(q):
            idx = int(pattern[i, j])
            lo, hi = black[idx], white[idx]
            if hi <= lo:
                raise PhotoError(f"the raw file's white level ({hi:g}) is not above its black level ({lo:g})")
            sub = site[i::p, j::q][:h, :w]
            saturated |= sub >= lo + SATURATION_FRACTION * (hi - lo)
            c = channel_of[idx]
            total[..., c] += (sub.astype(np.float32) - np.float32(lo)) * np.float32(1.0 / (hi - lo))
            count[c] += 1
    if np.any(count == 0):
        raise PhotoError("the raw file's colour filter pattern lacks a red, green or blue photosite")
    return total / count, saturated, p, tuple(black), tuple(white)


def _linear_pixels(raw: Any, channel_of: list[int]) -> tuple[NDArray[np.float32], NDArray[np.bool_],
                                                            tuple[float, ...], tuple[float, ...]]:
    data = raw.raw_image_visible
    if data.ndim != 3 or data.shape[2] < 3:
        raise PhotoError(f"unexpected linear raw layout {data.shape}")
    black = [float(b) for b in raw.black_level_per_channel]
    white = float(raw.white_level)
    rgb = np.zeros(data.shape[:2] + (3,), np.float32)
    saturated = np.zeros(data.shape[:2], bool)
    for k in range(3):
        lo = black[k] if k < len(black) else 0.0
        if white <= lo:
            raise PhotoError(f"the raw file's white level ({white:g}) is not above its black level ({lo:g})")
        plane = data[..., k]
        saturated |= plane >= lo + SATURATION_FRACTION * (white - lo)
        rgb[..., channel_of[k]] = (plane.astype(np.float32) - np.float32(lo)) / np.float32(white - lo)
    return rgb, saturated, tuple(black[:3]), (white,) * 3


def read_raw(path: str | Path, data: bytes | None = None) -> RawPhoto:
    """Decode a raw file with LibRaw (no processing) and bin it; PhotoError on anything wrong."""
    name = str(path)
    try:
        import rawpy
    except ImportError as exc:  # the extension bundles it; a bare checkout may not have it
        raise PhotoError(f"{name}: reading camera raw files needs the rawpy package (LibRaw), which is not "
                         f"installed ({exc}); install rawpy or convert the file to a 16-bit TIFF") from None
    if data is None:
        data = Path(path).read_bytes()
    tags = find_tiff_tags(data if data[:4] in (b"II*\x00", b"MM\x00*") else data[:HEAD_BYTES])
    try:
        with rawpy.imread(io.BytesIO(data)) as raw:
            channel_of = _channel_map(raw.color_desc)
            photometric = tags.get(0x0106)
            linear = raw.raw_type == rawpy.RawType.Stack or photometric == LINEAR_RAW
            if linear:
                rgb, saturated, black, white = _linear_pixels(raw, channel_of)
                binning = 1
            else:
                rgb, saturated, binning, black, white = _bin_mosaic(raw, channel_of)
            sizes = raw.sizes
            focal = exif_number(getattr(raw.other, "focal_length", None))
            orientation = _FLIP_TO_ORIENTATION.get(int(sizes.flip), 1)
            original = (int(sizes.width), int(sizes.height))
    except PhotoError as exc:
        raise PhotoError(f"{name}: {exc}") from None
    except NotImplementedError as exc:
        # rawpy raises this for a colour-filter code it has no pattern for (seen on a damaged DNG
        # header: "filters: 148"); it is the file, not the product, that is unusual.
        raise PhotoError(f"{name}: this raw file's colour filter layout is not supported or the file is "
                         f"damaged ({exc})") from None
    except rawpy.LibRawError as exc:
        detail = exc.args[0].decode("utf-8", "replace") if exc.args and isinstance(exc.args[0], bytes) else str(exc)
        raise PhotoError(f"{name}: LibRaw cannot read this raw file; it is damaged, truncated or a camera "
                         f"LibRaw {'.'.join(map(str, rawpy.libraw_version))} does not know "
                         f"({type(exc).__name__}: {detail})") from None
    exif = exif_info(tags, tags, orientation, focal_fallback=focal, rendering=False)
    return RawPhoto(rgb=rgb, saturated=saturated, binning=binning, original_size=original, exif=exif,
                    linear_dng=bool(linear), software=exif.software, black=black, white=white)
