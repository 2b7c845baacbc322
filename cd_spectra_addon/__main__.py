"""``python -m cd_spectra_addon``: the command line (see :mod:`cd_spectra_addon.cli`)."""

from __future__ import annotations

import sys

from .cli import DEFAULT_PRESET, EXIT_BAD_INPUT, UsageError, build_parser, main, run

__all__ = ["DEFAULT_PRESET", "EXIT_BAD_INPUT", "UsageError", "build_parser", "main", "run"]

if __name__ == "__main__":
    sys.exit(main())
