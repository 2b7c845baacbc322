"""What every command shares: the one-line error, argument parsing, and whole-or-nothing files."""

from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any, NoReturn

EXIT_BAD_INPUT = 2
EXIT_INTERNAL = 3  # a bug in CD Spectra, not the user's input
STDOUT = "-"  # ``--json -``: the machine-readable output goes to stdout


class UsageError(Exception):
    """Bad input: reported as one ``error:`` line, exit status 2."""


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # argparse would print the usage too
        raise UsageError(message)


def check_output(path: Path | None, suffix: str | None = None) -> None:
    """Refuse an output path that cannot be written before any work is done."""
    if path is None or str(path) == STDOUT:
        return
    if suffix and path.suffix.lower() != suffix:
        raise UsageError(f"{path} should end in {suffix}")
    try:
        if not path.parent.resolve().is_dir():
            raise UsageError(f"folder {path.parent} does not exist")
        if path.is_dir():
            raise UsageError(f"{path} is a folder")
        if len(os.fsencode(path.name)) > _name_max(path.parent):
            raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG))
        temp_beside(path).unlink()  # the same kind of temporary file the real write will use
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (AttributeError, OSError, ValueError):  # no pathconf (Windows) or no answer
        return 255


def temp_beside(target: Path) -> Path:
    """A new empty file in ``target``'s folder, named so it fits wherever ``target``'s name fits."""
    fd, name = tempfile.mkstemp(prefix=f".{target.name[:32]}.", suffix=target.suffix[:16], dir=target.parent)
    os.close(fd)
    return Path(name)


@contextlib.contextmanager
def atomic_path(target: Path) -> Iterator[Path]:
    """A temporary path next to ``target``, renamed onto it only if the block succeeds."""
    tmp = temp_beside(target)
    try:
        yield tmp
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def check_preset_path(path: Path, option: str = "--write-preset") -> None:
    """Refuse a preset file name or folder that cannot be written, before the work that fills it
    (a plan takes ~2 s): UsageError."""
    if path.suffix.lower() != ".json":
        raise UsageError(f"{option} needs a .json file name, not {path.name!r}")
    check_output(path)


def write_preset_file(path: Path, data: dict[str, Any], option: str = "--write-preset") -> None:
    """A capture preset as a .json file, whole or not at all (the core's one atomic JSON writer);
    UsageError if the name or the folder is wrong (callers check first, :func:`check_preset_path`)."""
    from ..core.atomic_files import write_json

    check_preset_path(path, option)
    write_json(path, data)


@contextlib.contextmanager
def writing(path: Path) -> Iterator[None]:
    """An OSError while writing ``path`` (the disk filled up since the check, ...) is one error line."""
    try:
        yield
    except OSError as exc:
        raise UsageError(f"cannot write {path}: {exc.strerror or exc}") from exc


@contextlib.contextmanager
def quiet_fds() -> Iterator[None]:
    """Silence Blender's C-level prints (they would mix with the output on stdout)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, devnull):
            os.close(fd)


def progress(message: str) -> None:
    """A progress line for people, on stderr (stdout stays clean for ``--json -``)."""
    print(message, file=sys.stderr, flush=True)
