"""Which frame of an animated GIF the panel's photo means.

Each frame of an animated GIF is a photo of its own (the one public series of real CD photos is
one, each frame exposed differently), so the panel shows a frame number next to such a photo and
the estimate reads ``FILE.gif#N`` (see ``core.photo.frames``). The frame count is read when the
panel draws — the GIF's blocks only, cached by the file's size and time — never at register.
"""

from __future__ import annotations

import os
from functools import lru_cache

import bpy

__all__ = ["frame_count", "photo_with_frame"]


def frame_count(path: str) -> int:
    """Frames of the photo at ``path`` (Blender's ``//`` paths too): more than 1 for an animated
    GIF; 1 for anything else, a path that names its frame itself, or a file that cannot be read
    (the estimate then says why)."""
    if not path:
        return 1
    from ..core.photo.frames import split_frame

    try:
        name, frame = split_frame(bpy.path.abspath(path))
        if frame is not None:
            return 1
        stat = os.stat(name)
    except (OSError, ValueError):
        return 1
    return _count(name, stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=32)
def _count(name: str, _mtime_ns: int, _size: int) -> int:
    from ..core.errors import PhotoError
    from ..core.photo.frames import frame_count as count

    try:
        return count(name)
    except PhotoError:
        return 1


def photo_with_frame(path: str, frame: int) -> str:
    """What to estimate: frame ``frame`` of an animated GIF (``FILE.gif#N``), else ``path``."""
    if frame_count(path) <= 1:
        return path
    from ..core.photo.frames import with_frame

    return with_frame(path, max(0, int(frame)))
