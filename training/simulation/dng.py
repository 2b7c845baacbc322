"""Write real DNG files from a synthesised linear photo: a Bayer mosaic (or a linear DNG).

Tests and the evaluation read them back through rawpy (LibRaw), the product's raw decoder, so
the whole raw path — black level, white level, CFA layout, EXIF focal length, saturation — is
exercised on files LibRaw accepts, not on a stub. A mosaic DNG holds one 16-bit sample per
photosite (``PhotometricInterpretation`` 32803, CFA); a "linear" DNG (34892, LinearRaw) holds
three demosaiced samples per pixel, as phones write.
"""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

__all__ = ["mosaic", "dng_bytes", "write_dng", "tiff16_bytes", "CFA_RGGB"]

CFA_RGGB = (0, 1, 1, 2)  # TIFF/EP CFAPattern colours: 0 red, 1 green, 2 blue


def mosaic(rgb: NDArray[np.floating], pattern: tuple[int, int, int, int] = CFA_RGGB) -> NDArray[np.float64]:
    """(2H, 2W) photosite values of a Bayer sensor whose 2×2 cells see ``rgb`` (H, W, 3): each
    cell's sites sample their colour of the same pixel, so 2×2 binning gives ``rgb`` back."""
    rgb = np.asarray(rgb, dtype=np.float64)
    h, w, _ = rgb.shape
    out = np.empty((2 * h, 2 * w))
    for k, colour in enumerate(pattern):
        out[k // 2::2, k % 2::2] = rgb[..., colour]
    return out


def _rational(x: float) -> tuple[int, int]:
    den = 10000
    return int(round(x * den)), den


class _Ifd:
    def __init__(self) -> None:
        self.entries: list[tuple[int, int, int, bytes]] = []  # tag, type, count, payload

    def add(self, tag: int, kind: int, values: object) -> None:
        if kind == 2:
            payload = str(values).encode("latin-1") + b"\x00"
            self.entries.append((tag, 2, len(payload), payload))
            return
        vals = list(values) if isinstance(values, (list, tuple)) else [values]
        if kind in (5, 10):
            flat = [v for x in vals for v in _rational(float(x))]
            payload = struct.pack(f"<{len(flat)}{'I' if kind == 5 else 'i'}", *flat)
        else:
            payload = struct.pack(f"<{len(vals)}{ {1: 'B', 3: 'H', 4: 'I'}[kind] }", *vals)
        self.entries.append((tag, kind, len(vals), payload))

    def size(self) -> int:
        return 2 + 12 * len(self.entries) + 4 + sum(len(p) + len(p) % 2 for *_, p in self.entries if len(p) > 4)

    def pack(self, offset: int, next_ifd: int = 0) -> bytes:
        """The IFD placed at ``offset`` with its out-of-line values right after it."""
        entries = sorted(self.entries)
        extra_at = offset + 2 + 12 * len(entries) + 4
        head, extra = [struct.pack("<H", len(entries))], []
        for tag, kind, count, payload in entries:
            if len(payload) <= 4:
                head.append(struct.pack("<HHI", tag, kind, count) + payload.ljust(4, b"\x00"))
            else:
                head.append(struct.pack("<HHII", tag, kind, count, extra_at))
                padded = payload + b"\x00" * (len(payload) % 2)
                extra.append(padded)
                extra_at += len(padded)
        head.append(struct.pack("<I", next_ifd))
        return b"".join(head) + b"".join(extra)


def dng_bytes(
    rgb: NDArray[np.floating],
    *,
    black: int = 512,
    white: int = 15000,
    make: str = "Canon",
    model: str = "EOS 5D Mark III",
    focal_length_mm: float | None = None,
    focal_plane_px_per_mm: float | None = None,
    linear: bool = False,
    pattern: tuple[int, int, int, int] = CFA_RGGB,
    software: str = "cd-spectra test writer",
    seed: int | None = 0,
    colour_matrix: NDArray[np.floating] | None = None,
) -> bytes:
    """A DNG of linear camera RGB (full scale 1.0 = ``white``, 0 = ``black``).

    Mosaic DNGs have twice ``rgb``'s size per side (one 2×2 cell per pixel), or take a (2H, 2W)
    array of photosite values as it is (noise added per photosite); linear DNGs ``rgb``'s size. Values are quantised to integer codes (with ±0.5 code dither when ``seed`` is not
    None, so the mean is unbiased) and clipped at ``white`` like a sensor. ``colour_matrix``:
    the (3, 3) XYZ (D65) → camera ColorMatrix1 LibRaw renders with (default: a plausible one)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    data = rgb if linear or rgb.ndim == 2 else mosaic(rgb, pattern)
    codes = black + data * (white - black)
    if seed is not None:
        codes = codes + np.random.default_rng(seed).uniform(-0.5, 0.5, codes.shape)
    codes = np.clip(np.rint(codes), 0, white).astype("<u2")
    height, width = codes.shape[:2]
    samples = 3 if linear else 1
    pixels = codes.tobytes()

    ifd0 = _Ifd()
    ifd0.add(254, 4, 0)  # NewSubFileType: main image
    ifd0.add(256, 4, width)
    ifd0.add(257, 4, height)
    ifd0.add(258, 3, [16] * samples)
    ifd0.add(259, 3, 1)  # no compression
    ifd0.add(262, 3, 34892 if linear else 32803)
    ifd0.add(271, 2, make)
    ifd0.add(272, 2, model)
    ifd0.add(274, 3, 1)
    ifd0.add(277, 3, samples)
    ifd0.add(278, 4, height)
    ifd0.add(279, 4, len(pixels))
    ifd0.add(284, 3, 1)
    ifd0.add(305, 2, software)
    if not linear:
        ifd0.add(33421, 3, [2, 2])  # CFARepeatPatternDim
        ifd0.add(33422, 1, list(pattern))  # CFAPattern
    ifd0.add(50706, 1, [1, 4, 0, 0])  # DNGVersion
    ifd0.add(50707, 1, [1, 1, 0, 0])
    ifd0.add(50708, 2, f"{make} {model}")
    if not linear:
        ifd0.add(50710, 1, [0, 1, 2])  # CFAPlaneColor
        ifd0.add(50711, 3, 1)  # CFALayout: rectangular
    ifd0.add(50714, 4, [black] * samples)  # BlackLevel
    ifd0.add(50717, 4, [white] * samples)  # WhiteLevel
    # XYZ (D65) → camera: LibRaw wants one (a plausible one unless given); the product never applies it.
    matrix = ([0.6722, -0.0635, -0.0963, -0.4287, 1.2460, 0.2028, -0.0908, 0.2162, 0.5668] if colour_matrix is None
              else [float(v) for v in np.asarray(colour_matrix, np.float64).reshape(9)])
    ifd0.add(50721, 10, matrix)
    ifd0.add(50778, 3, 21)  # CalibrationIlluminant1: D65
    ifd0.add(50728, 5, [0.5, 1.0, 0.7])  # AsShotNeutral
    return _assemble(ifd0, _exif_ifd(focal_length_mm, focal_plane_px_per_mm), pixels)


def _exif_ifd(focal_length_mm: float | None, focal_plane_px_per_mm: float | None) -> _Ifd:
    exif = _Ifd()
    exif.add(0x829A, 5, 1 / 60)  # ExposureTime
    if focal_length_mm:
        exif.add(0x920A, 5, focal_length_mm)
    if focal_plane_px_per_mm:
        exif.add(0xA20E, 5, focal_plane_px_per_mm)
        exif.add(0xA20F, 5, focal_plane_px_per_mm)
        exif.add(0xA210, 3, 4)  # millimetres
    return exif


def _assemble(ifd0: _Ifd, exif: _Ifd, pixels: bytes) -> bytes:
    """Header, IFD0, EXIF IFD, then the single strip; fills in the ExifIFD and StripOffsets."""
    ifd0.add(34665, 4, 0)  # placeholders: the sizes do not depend on their values
    ifd0.add(273, 4, 0)
    ifd0_at = 8
    exif_at = ifd0_at + ifd0.size()
    pixels_at = exif_at + exif.size()
    pixels_at += pixels_at % 2
    ifd0.entries = [e for e in ifd0.entries if e[0] not in (34665, 273)]
    ifd0.add(34665, 4, exif_at)
    ifd0.add(273, 4, pixels_at)
    body = b"II*\x00" + struct.pack("<I", ifd0_at) + ifd0.pack(ifd0_at) + exif.pack(exif_at)
    return body + b"\x00" * (pixels_at - len(body)) + pixels


def tiff16_bytes(rgb16: NDArray[np.uint16], make: str = "", model: str = "", focal_length_mm: float | None = None,
                 focal_plane_px_per_mm: float | None = None) -> bytes:
    """A 16-bit RGB TIFF without ICC profile (what ``dcraw -4 -T`` writes), with EXIF."""
    height, width, _ = rgb16.shape
    pixels = np.ascontiguousarray(rgb16, dtype="<u2").tobytes()
    ifd0 = _Ifd()
    for tag, kind, value in [(256, 4, width), (257, 4, height), (258, 3, [16, 16, 16]), (259, 3, 1), (262, 3, 2),
                             (277, 3, 3), (278, 4, height), (279, 4, len(pixels)), (284, 3, 1)]:
        ifd0.add(tag, kind, value)
    if make:
        ifd0.add(271, 2, make)
    if model:
        ifd0.add(272, 2, model)
    return _assemble(ifd0, _exif_ifd(focal_length_mm, focal_plane_px_per_mm), pixels)


def write_dng(path: Path, rgb: NDArray[np.floating], **kwargs: object) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(dng_bytes(rgb, **kwargs))  # type: ignore[arg-type]
    return path
