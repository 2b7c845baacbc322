"""The fallback decoders :func:`images.load_photo` tries on files its own readers cannot decode.

A module of its own, importing no format reader, so that registering one (the add-on's
``register()`` at Blender start-up adds Blender's image loader) loads neither Pillow nor the
photo pipeline: those load with the first photo read.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .image_formats import DecodedPixels, PhotoHeader

__all__ = ["Decoder", "register_decoder", "unregister_decoder", "registered_decoders",
           "decoders_need_main_thread"]

Decoder = Callable[[str, "PhotoHeader"], "DecodedPixels | None"]
_decoders: list[Decoder] = []


def register_decoder(func: Decoder) -> None:
    """Add a fallback decoder, tried in order for files the built-in decoders cannot read.

    ``func(path, header)`` returns :class:`DecodedPixels` or None (not its kind of file). It is
    only called after the header passed the size checks."""
    if func not in _decoders:
        _decoders.append(func)


def unregister_decoder(func: Decoder) -> None:
    if func in _decoders:
        _decoders.remove(func)


def registered_decoders() -> tuple[Decoder, ...]:
    """The fallback decoders in the order they are tried."""
    return tuple(_decoders)


def decoders_need_main_thread() -> bool:
    """Whether a registered fallback decoder is in use: Blender's loader is, and bpy may only be
    called from the main thread (a float TIFF loaded on a worker thread crashed the process)."""
    return bool(_decoders)
