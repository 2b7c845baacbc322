"""A GIF writer for tests, independent of Pillow's: explicit partial frames, disposal methods,
transparency and local colour tables, so that what a viewer shows can be computed here
(:func:`composite`) and compared with what the loader reads.

LZW without compression: a clear code every 250 codes keeps the code width at 9 bits, which
every decoder reads (the dictionary never grows past 511 entries).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

MIN_CODE_SIZE = 8
CLEAR, END = 1 << MIN_CODE_SIZE, (1 << MIN_CODE_SIZE) + 1
CHUNK = 250


@dataclass(frozen=True)
class Frame:
    indices: np.ndarray  # (h, w) palette indices
    x: int = 0
    y: int = 0
    disposal: int = 0  # 0/1 keep, 2 background, 3 previous
    transparency: int | None = None
    palette: np.ndarray | None = None  # (n, 3) uint8, a local colour table; None: the global one


def _table(palette: np.ndarray) -> tuple[int, bytes]:
    """(size field, bytes) of a colour table padded to a power of two ≥ 2 entries."""
    n = max(2, len(palette))
    bits = max(1, int(np.ceil(np.log2(n))))
    padded = np.zeros((1 << bits, 3), np.uint8)
    padded[: len(palette)] = palette
    return bits - 1, padded.tobytes()


def _lzw(indices: np.ndarray) -> bytes:
    codes: list[int] = []
    flat = [int(v) for v in indices.reshape(-1)]
    for start in range(0, len(flat), CHUNK):
        codes.append(CLEAR)
        codes.extend(flat[start: start + CHUNK])
    codes.append(END)
    acc = nbits = 0
    out = bytearray()
    for code in codes:
        acc |= code << nbits
        nbits += MIN_CODE_SIZE + 1
        while nbits >= 8:
            out.append(acc & 0xFF)
            acc >>= 8
            nbits -= 8
    if nbits:
        out.append(acc & 0xFF)
    blocks = bytearray([MIN_CODE_SIZE])
    for i in range(0, len(out), 255):
        part = out[i: i + 255]
        blocks += bytes([len(part)]) + part
    return bytes(blocks + b"\x00")


def gif_bytes(size: tuple[int, int], palette: np.ndarray, frames: list[Frame], background: int = 0,
              icc: bytes | None = None) -> bytes:
    """A GIF89a of ``size`` (width, height) with the global ``palette`` and ``frames``."""
    width, height = size
    bits, table = _table(palette)
    out = bytearray(b"GIF89a" + struct.pack("<HHBBB", width, height, 0x80 | 0x70 | bits, background, 0) + table)
    if len(frames) > 1:
        out += b"!\xff\x0bNETSCAPE2.0\x03\x01\x00\x00\x00"
    if icc is not None:
        out += b"!\xff\x0bICCRGBG1012"
        for i in range(0, len(icc), 255):
            part = icc[i: i + 255]
            out += bytes([len(part)]) + part
        out += b"\x00"
    for frame in frames:
        h, w = frame.indices.shape
        flags = (frame.disposal << 2) | (1 if frame.transparency is not None else 0)
        out += b"!\xf9\x04" + struct.pack("<BHB", flags, 10, frame.transparency or 0) + b"\x00"
        local = b""
        packed = 0
        if frame.palette is not None:
            lbits, local = _table(frame.palette)
            packed = 0x80 | lbits
        out += b"," + struct.pack("<HHHHB", frame.x, frame.y, w, h, packed) + local
        out += _lzw(frame.indices)
    return bytes(out + b";")


def composite(size: tuple[int, int], palette: np.ndarray, frames: list[Frame], background: int = 0
              ) -> list[np.ndarray]:
    """The RGB codes a viewer shows for each frame (transparent pixels of the first frame, which
    have nothing under them, read as their palette colour: the loader ignores alpha). Frame 0
    covers the whole screen; disposal 2 is not combined with transparency (what lies under a
    pixel made transparent by it is up to the viewer)."""
    width, height = size
    canvas = np.zeros((height, width, 3), np.uint8)
    shown = []
    previous: tuple[Frame, np.ndarray] | None = None
    for frame in frames:
        if previous is not None:
            last, saved = previous
            h, w = last.indices.shape
            if last.disposal == 2:
                canvas[last.y: last.y + h, last.x: last.x + w] = palette[background]
            elif last.disposal == 3:
                canvas[last.y: last.y + h, last.x: last.x + w] = saved
        h, w = frame.indices.shape
        saved = canvas[frame.y: frame.y + h, frame.x: frame.x + w].copy()
        colours = (frame.palette if frame.palette is not None else palette)[frame.indices]
        opaque = np.ones((h, w), bool) if frame.transparency is None or previous is None \
            else frame.indices != frame.transparency
        canvas[frame.y: frame.y + h, frame.x: frame.x + w][opaque] = colours[opaque]
        shown.append(canvas.copy())
        previous = (frame, saved)
    return shown
