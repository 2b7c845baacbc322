"""Whole-or-nothing files: every file the product writes (spectra, calibration profiles,
capture presets) goes through :func:`atomic_write`, so a crash, a full disk or an exception
mid-write leaves the previous file as it was and never a half-written one.

A root module of the core (like ``errors`` and ``validation``): every package and the command
line may import it. Kept free of numpy so the Blender layer can use it cheaply.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import CDSpectraError

__all__ = ["atomic_write", "write_bytes", "write_json"]


def atomic_write(path: str | Path, write: Callable[[Path], None]) -> Path:
    """Write through ``write(temp_path)`` into the target's folder, then rename over the target.

    The temporary name is reserved with O_EXCL (no clash with another writer) and created
    with mode 0o666 so the umask applies as for any new file. Whatever goes wrong, the
    temporary file is removed and the previous target is untouched; an OSError becomes a
    :class:`CDSpectraError` naming the file.
    """
    target = Path(path)
    folder = target.parent
    try:
        if target.is_dir():
            raise CDSpectraError(f"cannot write {target}: it is a folder")
        if not folder.is_dir():
            raise CDSpectraError(f"cannot write {target.name}: the folder {folder} does not exist")
    except OSError as exc:  # a name too long, a loop of links, ...
        raise CDSpectraError(f"cannot write {target}: {exc.strerror or exc}") from exc
    try:
        while True:
            temp = folder / f".{target.name[:40]}.{secrets.token_hex(4)}.tmp"
            try:
                os.close(os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
                break
            except FileExistsError:
                continue
    except OSError as exc:
        raise CDSpectraError(f"cannot write in {folder}: {exc.strerror or exc}") from exc
    try:
        write(temp)
        os.replace(temp, target)
    except BaseException as exc:
        with contextlib.suppress(OSError):
            os.unlink(temp)
        if isinstance(exc, OSError):
            raise CDSpectraError(f"cannot write {target}: {exc.strerror or exc}") from exc
        raise
    return target


def write_bytes(data: bytes) -> Callable[[Path], None]:
    """A writer for :func:`atomic_write` that puts ``data`` on disk before the rename."""
    def write(temp: Path) -> None:
        with open(temp, "wb") as handle:
            handle.write(data)
            handle.flush()
            os.fsync(handle.fileno())  # on disk before the rename makes it the real file

    return write


def write_json(path: str | Path, data: Any, indent: int = 2) -> Path:
    """``data`` as UTF-8 JSON text (one trailing newline), atomically. Data JSON cannot hold is
    refused before anything is written."""
    try:
        text = json.dumps(data, indent=indent, ensure_ascii=False, allow_nan=False)
    except (TypeError, ValueError) as exc:
        raise CDSpectraError(f"cannot write {Path(path).name}: {exc}") from exc
    return atomic_write(path, write_bytes((text + "\n").encode("utf-8")))
