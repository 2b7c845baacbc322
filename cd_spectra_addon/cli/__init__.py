"""Headless command line: ``python -m cd_spectra_addon COMMAND ...`` without opening Blender.

One module per command, each with ``NAME``, ``HELP``, ``add_arguments(parser)`` and
``run(args, out) -> exit status``; :data:`COMMAND_NAMES` lists them (a new command is one name
there). A command whose photos may come between its options (``calibrate bulb.jpg --known-lamp A
window.jpg --known-lamp D65``, as people type it) names that list in ``INTERMIXED = "photos"``.
Bad input exits with status 2 and a single ``error: ...`` line on stderr, and writes nothing; an
internal error (a bug) exits with status 3 and one line saying so, never a traceback.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable, Sequence
from types import ModuleType

from .common import EXIT_BAD_INPUT, EXIT_INTERNAL, Parser, UsageError

# The commands, in the order `--help` lists them: a module of this package each.
COMMAND_NAMES: tuple[str, ...] = ("estimate", "export", "compare", "calibrate", "plan", "setup", "presets",
                                  "cameras", "calibrations")
COMMANDS: tuple[ModuleType, ...] = tuple(importlib.import_module(f"{__name__}.{name}") for name in COMMAND_NAMES)
from ..core.scene.capture import DEFAULT_PRESET  # noqa: E402  (re-exported for callers of the CLI)


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="python -m cd_spectra_addon",
                    description="CD Spectra: a lamp's spectrum from one photo of a CD.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=Parser, metavar="COMMAND")
    for command in COMMANDS:
        command.add_arguments(sub.add_parser(command.NAME, help=command.HELP,
                                             description=(command.__doc__ or "").strip()))
    return parser


def parse(argv: Sequence[str] | None = None) -> argparse.Namespace:
    """The arguments of one command line. argparse takes a positional list in one run (the
    photos, then the options); a command's photos given later, between its options, are added
    to the list in the order given. Anything else left over is refused as argparse would."""
    parser = build_parser()
    args, extra = parser.parse_known_args(argv)
    command = next(c for c in COMMANDS if c.NAME == args.command)
    listed = getattr(command, "INTERMIXED", None)
    if extra and listed and not any(token.startswith("-") and token != "-" for token in extra):
        setattr(args, listed, [*getattr(args, listed), *(command.INTERMIXED_TYPE(t) for t in extra)])
    elif extra:
        parser.error(f"unrecognized arguments: {' '.join(extra)}")
    return args


def run(argv: Sequence[str] | None = None, *, out: Callable[[str], None] = print) -> int:
    args = parse(argv)
    command = next(c for c in COMMANDS if c.NAME == args.command)
    return int(command.run(args, out))


def main(argv: Sequence[str] | None = None) -> int:
    try:
        return run(argv)
    except UsageError as exc:
        message = " ".join(str(exc).split())  # exactly one line
        print(f"error: {message}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # a bug, not the input: one line, no traceback; outputs are whole-or-nothing
        detail = " ".join(f"{type(exc).__name__}: {exc}".split())
        print(f"error: internal error in CD Spectra ({detail}); nothing was written. This is a bug: please "
              "report it with the photo and the command", file=sys.stderr)
        return EXIT_INTERNAL


__all__ = ["COMMANDS", "COMMAND_NAMES", "DEFAULT_PRESET", "EXIT_BAD_INPUT", "EXIT_INTERNAL", "UsageError", "build_parser", "main", "parse", "run"]
