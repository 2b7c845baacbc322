"""A small TIFF/EXIF tag reader for the metadata of camera raw files.

LibRaw (rawpy) decodes the pixels of every raw format but exposes neither Make/Model nor the
focal-plane resolution the inverse needs for the focal length in pixels. Most raw formats
(DNG, CR2, NEF, ARW, ORF, RW2, PEF, ...) are TIFF files, and the others keep a TIFF structure
inside (CR3's CMT1/CMT2 boxes, RAF's embedded JPEG's EXIF): reading IFD0 and the EXIF IFD of
the first TIFF structures found is enough. Damaged metadata yields empty fields, never an error.
"""

from __future__ import annotations

import struct
from typing import Any

__all__ = ["read_tiff_tags", "find_tiff_tags", "TAG_NAMES"]

TAG_NAMES = {
    0x010F: "Make", 0x0110: "Model", 0x0112: "Orientation", 0x0131: "Software", 0x0106: "PhotometricInterpretation",
    0xC612: "DNGVersion", 0xC614: "UniqueCameraModel", 0x920A: "FocalLength", 0xA405: "FocalLengthIn35mmFilm",
    0xA20E: "FocalPlaneXResolution", 0xA210: "FocalPlaneResolutionUnit", 0xA001: "ColorSpace",
    0xA403: "WhiteBalance", 0x8769: "ExifIFD", 0x014A: "SubIFDs", 0x00FE: "NewSubFileType",
}
_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 6: 1, 7: 1, 8: 2, 9: 4, 10: 8, 11: 4, 12: 8}
_FORMATS = {1: "B", 3: "H", 4: "I", 6: "b", 8: "h", 9: "i", 11: "f", 12: "d"}
MAX_ENTRIES = 1024
MAX_VALUES = 4096


def _value(data: bytes, order: str, kind: int, count: int, at: int) -> Any:
    size = _SIZES[kind] * count
    raw = data[at: at + size]
    if len(raw) != size:
        raise ValueError("tag value outside the data")
    if kind == 2:
        return raw.split(b"\x00", 1)[0].decode("latin-1").strip()
    if kind == 7:
        return raw
    if kind in (5, 10):
        nums = struct.unpack(f"{order}{2 * count}{'I' if kind == 5 else 'i'}", raw)
        vals = tuple(n / d if d else 0.0 for n, d in zip(nums[0::2], nums[1::2]))
    else:
        vals = struct.unpack(f"{order}{count}{_FORMATS[kind]}", raw)
    return vals[0] if count == 1 else vals


def _ifd(data: bytes, order: str, base: int, offset: int) -> tuple[dict[int, Any], int]:
    """Tags of the IFD at ``base + offset`` and the offset of the next IFD (0 if none)."""
    at = base + offset
    (count,) = struct.unpack(order + "H", data[at: at + 2])
    tags: dict[int, Any] = {}
    for i in range(min(count, MAX_ENTRIES)):
        entry = data[at + 2 + 12 * i: at + 14 + 12 * i]
        if len(entry) < 12:
            break
        tag, kind, n = struct.unpack(order + "HHI", entry[:8])
        if kind not in _SIZES or n == 0 or n > MAX_VALUES:
            continue
        where = at + 2 + 12 * i + 8
        if _SIZES[kind] * n > 4:
            where = base + struct.unpack(order + "I", entry[8:12])[0]
        try:
            tags[tag] = _value(data, order, kind, n, where)
        except (ValueError, struct.error, UnicodeDecodeError):
            continue
    tail = at + 2 + 12 * min(count, MAX_ENTRIES)
    nxt = struct.unpack(order + "I", data[tail: tail + 4])[0] if len(data) >= tail + 4 else 0
    return tags, nxt


def read_tiff_tags(data: bytes, base: int = 0) -> dict[int, Any]:
    """IFD0 (and, under their own tag numbers, the EXIF IFD's tags) of the TIFF at ``base``.

    Empty when the bytes there are not a readable TIFF."""
    head = data[base: base + 8]
    if head[:4] not in (b"II*\x00", b"MM\x00*"):
        return {}
    order = "<" if head[:2] == b"II" else ">"
    try:
        (first,) = struct.unpack(order + "I", head[4:8])
        tags, _ = _ifd(data, order, base, first)
        exif = tags.get(0x8769)
        if isinstance(exif, int) and 0 < exif < len(data) - base:
            sub, _ = _ifd(data, order, base, exif)
            for key, value in sub.items():
                tags.setdefault(key, value)
    except (ValueError, struct.error, IndexError):
        return {}
    return tags


def find_tiff_tags(data: bytes, limit: int = 4) -> dict[int, Any]:
    """Tags merged from the first ``limit`` TIFF structures in ``data`` (a raw file's head):
    the file itself when it is a TIFF, else embedded ones (CR3 CMT1/CMT2, RAF's JPEG EXIF)."""
    merged: dict[int, Any] = {}
    starts = [0] if data[:4] in (b"II*\x00", b"MM\x00*") else []
    for magic in (b"II*\x00", b"MM\x00*"):
        pos = data.find(magic, 1)
        while pos > 0 and len(starts) < 4 * limit:
            starts.append(pos)
            pos = data.find(magic, pos + 1)
    found = 0
    for base in sorted(set(starts)):
        tags = read_tiff_tags(data, base)
        if not tags:
            continue
        for key, value in tags.items():
            merged.setdefault(key, value)
        found += 1
        if found >= limit:
            break
    return merged
