"""Files that hold several photos (an animated GIF): naming one frame, counting them, expanding a
file into its frames.

A frame is named by the file's path, ``#`` and its number counted from 0: ``cd1.gif#12`` is the
13th frame of ``cd1.gif``. The one public series of real CD photos is such a GIF, each frame
exposed differently: every frame is a photo of its own, so nothing reads "the" GIF. The loader
refuses an animated GIF without a frame (a frame picked for the user would give an estimate —
or a calibration — from a photo nobody chose, and a warning is easy to miss in a batch); the
command line expands the file into all its frames and the Blender panel always names one.

A file whose name really ends in ``#N`` is that file: a name is a frame only where no file has
it. Still photos have one frame, ``#0``.

Frames are composited by Pillow's seek, as viewers do, with one difference: Pillow (13) carries
a frame's disposal method over to a later frame that leaves it unspecified (0), where browsers
keep that frame; a GIF that mixes "restore" disposals with unspecified ones may then differ
from what a browser shows (tests/test_gif_frames.py leaves that combination out). Kim's frames
are whole frames with disposal 1, which both read alike.
"""

from __future__ import annotations

import os
from typing import Any

from ..errors import PhotoError
from .image_formats import DECODE_ERRORS, check_file, open_pillow

__all__ = ["FRAME_MARK", "split_frame", "with_frame", "frame_count", "photo_frames", "gif_frames"]

FRAME_MARK = "#"


def split_frame(path: str | os.PathLike[str]) -> tuple[str, int | None]:
    """(file, frame) a path names: ``cd1.gif#12`` → ("cd1.gif", 12); a plain path, or a file
    that really has that name → (path, None). A mark after an existing file that is not a
    number is a PhotoError (the user meant a frame and mistyped it)."""
    name = os.fspath(path)
    base, mark, tail = name.rpartition(FRAME_MARK)
    if not mark or not base or os.path.lexists(name):
        return name, None
    if tail.isascii() and tail.isdigit():
        return base, int(tail)
    if os.path.isfile(base):
        raise PhotoError(f"{name}: a frame is named by its number counted from 0 ({base}{FRAME_MARK}0), "
                         f"not {tail!r}")
    return name, None


def with_frame(path: str | os.PathLike[str], frame: int) -> str:
    """The path naming frame ``frame`` of the file ``path``."""
    if isinstance(frame, bool) or not isinstance(frame, int) or frame < 0:
        raise ValueError(f"a frame is a number from 0, not {frame!r}")
    return f"{os.fspath(path)}{FRAME_MARK}{frame}"


def gif_frames(im: Any, name: str) -> int:
    """How many frames an opened GIF has (Pillow reads the blocks, no pixel data)."""
    try:
        count = int(im.n_frames)
    except DECODE_ERRORS as exc:
        raise PhotoError(f"{name}: cannot read the GIF's frames; the file is damaged or truncated ({exc})") from exc
    if count < 1:
        raise PhotoError(f"{name}: the GIF has no frame")
    return count


def frame_count(path: str | os.PathLike[str]) -> int:
    """How many photos the file holds: a GIF's frames, 1 for any other file (the loader says
    what is wrong with one that is no photo). ``path`` names the file (a frame mark is ignored).
    PhotoError where the file is missing or a GIF cannot be read."""
    name, _ = split_frame(path)
    file = check_file(name)
    try:
        with open(file, "rb") as fh:
            if not fh.read(4).startswith(b"GIF8"):
                return 1
    except OSError as exc:
        raise PhotoError(f"{name}: cannot read the file ({exc.strerror or exc})") from None
    try:
        im = open_pillow(file, "gif")
    except PhotoError:
        raise
    except DECODE_ERRORS as exc:
        raise PhotoError(f"{name}: cannot decode the GIF image; the file is damaged or truncated ({exc})") from exc
    with im:
        return gif_frames(im, name)


def photo_frames(path: str | os.PathLike[str]) -> list[str]:
    """The photos ``path`` names, in order: a named frame or a still photo is itself; an
    animated GIF is each of its frames (``cd1.gif#0``, ``cd1.gif#1``, ...)."""
    name, frame = split_frame(path)
    if frame is not None:
        return [os.fspath(path)]
    count = frame_count(name)
    return [name] if count == 1 else [with_frame(name, i) for i in range(count)]
