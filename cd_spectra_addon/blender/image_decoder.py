"""Blender's own image loader as a fallback decoder for :func:`core.images.load_photo`.

The core reads JPEG, PNG, TIFF and EXR itself (Pillow + OpenEXR, 16-bit at full precision).
This covers what it cannot: 16-bit grey+alpha PNG, 16-bit CMYK or float RGB TIFF, subsampled
EXR, ... It is slow (≈1.5 s for 12 MP plus importing bpy) and needs 32 bytes per pixel, which is
why it is a fallback and not the default.

Raw file values are read: the image is marked as data (Non-Color: no OCIO transform; the core
applies the transfer curve it decides from the header, the same as on every other path) and the
alpha mode to Channel Packed (Blender would otherwise premultiply float buffers). The datablock
is created with ``check_existing=False`` and removed afterwards, so the user's file is unchanged.

Registering imports only the decoder registry (:mod:`core.photo.decoders`), not the photo
pipeline, so that enabling the add-on stays fast.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import bpy
import numpy as np

from ..core.errors import PhotoError
from ..core.photo.decoders import register_decoder, unregister_decoder

if TYPE_CHECKING:
    from ..core.photo.image_formats import DecodedPixels, PhotoHeader

__all__ = ["decode_with_blender", "register", "unregister"]


def decode_with_blender(path: str, header: PhotoHeader) -> DecodedPixels | None:
    """Full-resolution pixels of ``path`` as stored, top row first; None if Blender cannot read it."""
    from ..core.photo.image_formats import DecodedPixels  # loaded already: the core is reading a photo
    try:
        image = bpy.data.images.load(path, check_existing=False)
    except RuntimeError:
        return None
    try:
        image.colorspace_settings.is_data = True  # the config's data space ("Non-Color"), whatever its name
        image.alpha_mode = "CHANNEL_PACKED"
        width, height = image.size
        channels = image.channels
        if width == 0 or height == 0 or not image.has_data:
            return None
        if (width, height) != (header.width, header.height):
            raise PhotoError(f"{path}: Blender reads {width}x{height} pixels, the header says "
                             f"{header.width}x{header.height}")
        flat = np.empty(width * height * channels, dtype=np.float32)
        image.pixels.foreach_get(flat)
        is_float = image.is_float
    finally:
        bpy.data.images.remove(image, do_unlink=True)
    pixels = flat.reshape(height, width, channels)[::-1]  # Blender's rows run bottom-up
    pixels = pixels[..., :1] if header.channels == 1 else pixels[..., :3]
    bits = header.bits if header.bits in (8, 16) else (32 if is_float else 8)
    return DecodedPixels(np.ascontiguousarray(pixels), bits)


def register() -> None:
    register_decoder(decode_with_blender)


def unregister() -> None:
    unregister_decoder(decode_with_blender)
