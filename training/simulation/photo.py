"""Synthetic photos of a CD from a basis cube: camera, exposure, noise and file encoding.

A photo is ``camera_c(λ_i) · Σ_i spd_i · basis_i`` (camera-native linear RGB, no white balance,
as a raw file would hold), auto-exposed so the brightest pixel sits at 80 % of full scale times
``exposure``, then shot + read noise, then clipped at full scale like a sensor. Integer
encodings (PNG, JPEG) also clip at zero and use the sRGB curve; EXR keeps linear floats.
"""

from __future__ import annotations

import io
import os
import struct
import tempfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from PIL import Image

from cd_spectra_addon.core.spectra.cameras import CameraProfile
from cd_spectra_addon.core.scene.capture import Scene
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.photo.images import LinearImage, load_photo
from cd_spectra_addon.core.photo.srgb import srgb_encode

FORMATS = ("exr", "png", "png16", "jpg", "jpg422", "heic", "heic10", "tiff16")
DSLR_JPEG_QUALITY = 95  # "jpg422": a DSLR's in-camera "fine" JPEG, 4:2:2 chroma (Canon, Nikon, Sony)
AUTO_EXPOSURE_LEVEL = 0.8
JPEG_QUALITY = 90
READ_NOISE_FRACTION = 0.2  # read noise std as a fraction of --noise

__all__ = ["FORMATS", "linear_photo", "track_mask", "disc_mask", "expose", "upsample", "add_noise", "synthesize", "write_photo", "exif_for"]


def linear_photo(cube: NDArray[np.floating], spd: NDArray[np.floating], camera: CameraProfile) -> NDArray[np.float64]:
    """(H, W, 3) camera-native radiance: Σ_i spd_i · S_c(λ_i) · basis_i."""
    weights = (np.asarray(spd, dtype=np.float64)[:, None] * camera.sensitivities).astype(np.float32)  # (81, 3)
    bands, height, width = cube.shape
    flat = np.asarray(cube, dtype=np.float32).reshape(bands, -1)  # float32: the cube's own precision
    return (weights.T @ flat).T.reshape(height, width, 3).astype(np.float64)


def track_mask(scene: Scene) -> NDArray[np.bool_]:
    """Pixels whose centre sees the tracked area of the disc: where a photographer meters."""
    width, height = scene.preset.camera.image_size_px
    px = pixel_diffraction(scene)
    mask = np.zeros(width * height, dtype=bool)
    mask[px.index[px.on_tracks]] = True
    return mask.reshape(height, width)


def disc_mask(scene: Scene) -> NDArray[np.bool_]:
    """Pixels whose centre sees the disc between its hole and its rim: what room light on a table
    leaves darker (a mirror with a faint diffuse base), so that its outline shows."""
    width, height = scene.preset.camera.image_size_px
    mask = np.zeros(width * height, dtype=bool)
    mask[pixel_diffraction(scene).index] = True
    return mask.reshape(height, width)


def expose(image: NDArray[np.float64], exposure: float = 1.0,
           meter: NDArray[np.bool_] | None = None) -> tuple[NDArray[np.float64], float]:
    """Scale so the brightest metered value is AUTO_EXPOSURE_LEVEL × exposure (a specular glint
    off the metered area may clip, as it does in a real photo); returns (image, gain)."""
    metered = image if meter is None or not np.any(meter) else image[meter]
    peak = float(np.max(metered))
    gain = AUTO_EXPOSURE_LEVEL * float(exposure) / peak if peak > 0 else 0.0
    return image * gain, gain


def upsample(image: NDArray[np.float64], factor: int) -> NDArray[np.float64]:
    """A camera with ``factor``× the basis cube's pixels per side: each cube pixel becomes a
    factor × factor block, so noise, encoding and the loader's draft/box reduction act at the
    scale they do on a real photo (a 24 MP JPEG is read at a quarter of its size or less), and
    reducing by ``factor`` again gives back exactly the cube's pixel footprints the forward
    model assumes (an interpolating upsampler would blur the rings beyond the model)."""
    if factor <= 1:
        return image
    return np.repeat(np.repeat(image, factor, axis=0), factor, axis=1)


def read_rendered(path: str | os.PathLike[str], scene: Scene) -> LinearImage:
    """A photo of ``scene``'s render (:func:`upsample`d, written as any file type) read back
    through the product's decoders (``load_photo``: DNG via rawpy, HEIC, JPEG draft, ...) at the
    rendered size, so the loader's draft/box reduction undoes :func:`upsample` and each loaded
    pixel has the footprint the renderer integrated over, as a real camera's pixels do and as
    training and tuning photos are read (``training.learning.dataset``). Not ``load_for_estimate``:
    it reads any photo under its 1024-px preview whole, and a render below that, read whole, is
    blocks of factor × factor equal pixels whose footprint the forward model takes for 1/factor
    per side of what it is (tilted, offset and clipped captures then read worse; see
    ``training.evaluation.evaluate.Photos.read``)."""
    return load_photo(path, max_side=max(scene.preset.camera.image_size_px))


def add_noise(image: NDArray[np.float64], noise: float, rng: np.random.Generator) -> NDArray[np.float64]:
    """Shot noise (std noise·√x) plus read noise (std 0.2·noise), in full-scale units."""
    if noise <= 0:
        return image
    std = np.sqrt(noise * noise * np.clip(image, 0.0, None) + (READ_NOISE_FRACTION * noise) ** 2)
    return image + std * rng.standard_normal(image.shape, dtype=np.float32)


def synthesize(
    cube: NDArray[np.floating],
    spd: NDArray[np.floating],
    camera: CameraProfile,
    exposure: float = 1.0,
    noise: float = 0.0,
    rng: np.random.Generator | None = None,
    meter: NDArray[np.bool_] | None = None,
) -> tuple[NDArray[np.float64], float]:
    """Sensor-level linear photo (clipped at full scale 1.0) and the exposure gain used."""
    rng = rng if rng is not None else np.random.default_rng(0)
    image, gain = expose(linear_photo(cube, spd, camera), exposure, meter)
    image = add_noise(image, noise, rng)
    return np.minimum(image, 1.0), gain


def exif_for(focal_length_mm: float, sensor_width_mm: float, image_width_px: int, camera_name: str) -> bytes:
    """EXIF a real camera would write: make/model, focal length, 35 mm equivalent, and the focal
    plane resolution (pixels per mm) from which the focal length in pixels follows."""
    exif = Image.Exif()
    make, _, model = camera_name.replace("_", " ").partition(" ")
    exif[0x010F] = make
    exif[0x0110] = model or make
    sub = exif.get_ifd(0x8769)
    sub[0x920A] = float(focal_length_mm)  # FocalLength
    sub[0xA405] = int(round(focal_length_mm * 36.0 / sensor_width_mm))  # FocalLengthIn35mmFilm
    sub[0xA20E] = float(image_width_px / sensor_width_mm)  # FocalPlaneXResolution
    sub[0xA20F] = float(image_width_px / sensor_width_mm)  # FocalPlaneYResolution
    sub[0xA210] = 4  # FocalPlaneResolutionUnit: millimetres
    return exif.tobytes()


def _png16(rgb16: NDArray[np.uint16], level: int = 6) -> bytes:
    """Minimal 16-bit RGB PNG writer (Pillow cannot write 16-bit colour PNGs)."""
    height, width, _ = rgb16.shape
    raw = np.zeros((height, 1 + width * 6), dtype=np.uint8)
    raw[:, 1:] = rgb16.astype(">u2").view(np.uint8).reshape(height, width * 6)

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 16, 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw.tobytes(), level))
            + chunk(b"IEND", b""))


_LUT_SIZE = 1 << 16
# Linear → 8-bit sRGB code through a 65 537-entry table (10× faster than the power law per
# pixel): rounding linear light to 1/65536 first changes 1 value in ~300 by one code, where the
# exact value sits on a rounding boundary — far below the noise of any photo.
_SRGB8_LUT = np.rint(srgb_encode(np.arange(_LUT_SIZE + 1) / _LUT_SIZE) * 255.0).astype(np.uint8)


def encode_photo(image: NDArray[np.float64], fmt: str, exif: bytes | None = None,
                 quality: int = JPEG_QUALITY) -> bytes:
    """File bytes of a sensor-level linear photo in ``fmt``."""
    if fmt == "exr":
        import OpenEXR

        channels = {c: np.ascontiguousarray(image[..., i], dtype=np.float32) for i, c in enumerate("RGB")}
        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "photo.exr")
            with OpenEXR.File(header, channels) as exr:
                exr.write(path)
            return Path(path).read_bytes()
    if fmt == "png16":
        return _png16(np.rint(srgb_encode(image) * 65535.0).astype(np.uint16), level=1)
    if fmt == "tiff16":  # what `dcraw -4 -T` writes: 16-bit linear, no ICC profile
        buffer = io.BytesIO()
        _tiff16(np.rint(np.clip(image, 0.0, 1.0) * 65535.0).astype(np.uint16), buffer, exif)
        return buffer.getvalue()
    if fmt == "heic10":  # a phone's 10-bit HEIC: 10-bit sRGB codes (pillow-heif takes them << 6)
        codes = np.rint(srgb_encode(np.clip(image, 0.0, 1.0)) * 1023.0).astype(np.uint16) << 6
        return _heif(codes, "RGB;16", exif, quality)
    rgb8 = _SRGB8_LUT[np.rint(np.clip(image, 0.0, 1.0) * _LUT_SIZE).astype(np.int32)]
    if fmt == "heic":
        return _heif(rgb8, "RGB", exif, quality)
    buffer = io.BytesIO()
    if fmt == "png":
        Image.fromarray(rgb8, "RGB").save(buffer, format="PNG", exif=exif or b"", compress_level=1)
    elif fmt == "jpg":
        Image.fromarray(rgb8, "RGB").save(buffer, format="JPEG", quality=int(quality), exif=exif or b"")
    elif fmt == "jpg422":
        Image.fromarray(rgb8, "RGB").save(buffer, format="JPEG", quality=DSLR_JPEG_QUALITY, subsampling=1,
                                          exif=exif or b"")
    else:
        raise ValueError(f"format must be one of {FORMATS}")
    return buffer.getvalue()


def _heif(codes: NDArray[np.integer], mode: str, exif: bytes | None, quality: int) -> bytes:
    """HEIC bytes through libheif's x265 encoder (4:2:0 chroma, as phones write)."""
    import pillow_heif

    height, width = codes.shape[:2]
    heif = pillow_heif.from_bytes(mode=mode, size=(width, height), data=np.ascontiguousarray(codes).tobytes())
    buffer = io.BytesIO()
    heif.save(buffer, quality=int(quality), exif=exif or None)
    return buffer.getvalue()


def _tiff16(rgb16: NDArray[np.uint16], buffer: io.BytesIO, exif: bytes | None) -> None:
    """Uncompressed 16-bit RGB TIFF with the EXIF fields a raw converter copies (Pillow cannot
    write 16-bit colour TIFFs)."""
    from training.simulation.dng import tiff16_bytes

    fields: dict[str, Any] = {}
    if exif:
        tags = Image.Exif()
        tags.load(exif)
        sub = tags.get_ifd(0x8769)
        fields = {"make": tags.get(0x010F), "model": tags.get(0x0110), "focal_length_mm": sub.get(0x920A),
                  "focal_plane_px_per_mm": sub.get(0xA20E) if sub.get(0xA210) == 4 else None}
    buffer.write(tiff16_bytes(rgb16, **{k: v for k, v in fields.items() if v is not None}))


def write_photo(path: Path, image: NDArray[np.float64], fmt: str, exif: bytes | None = None,
                quality: int = JPEG_QUALITY) -> None:
    """Encode and write atomically (temporary file in the same folder, then rename)."""
    data = encode_photo(image, fmt, exif, quality)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".tmp-", suffix=path.suffix, dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as handle:
            handle.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def photo_metadata(gain: float, exposure: float, noise: float, camera: str, fmt: str) -> dict[str, Any]:
    return {"exposure_gain": gain, "exposure": exposure, "noise": noise, "camera": camera, "format": fmt,
            "auto_exposure_level": AUTO_EXPOSURE_LEVEL}
