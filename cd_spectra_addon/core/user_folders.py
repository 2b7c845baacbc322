"""Where the user's calibration profiles live. Kept free of numpy and the solver so the Blender
layer can point it at the extension's user folder while the add-on is enabled, without paying
for the estimator's imports (enabling must stay ≤ 50 ms)."""

from __future__ import annotations

import os
from pathlib import Path

ENV_DIR = "CD_SPECTRA_CALIBRATION_DIR"

_default_dir: Path | None = None


def set_default_directory(path: Path | None) -> None:
    """Where profiles go when no folder is given (the Blender layer points this at the
    extension's user folder; None restores the default)."""
    global _default_dir
    _default_dir = None if path is None else Path(path)


def calibration_dir() -> Path:
    """Where profiles live: $CD_SPECTRA_CALIBRATION_DIR, else the folder the host application set,
    else the user's config folder."""
    env = os.environ.get(ENV_DIR)
    if env:
        return Path(env)
    if _default_dir is not None:
        return _default_dir
    base = os.environ.get("APPDATA") or os.environ.get("XDG_CONFIG_HOME") or os.path.join(
        os.path.expanduser("~"), ".config")
    return Path(base) / "cd_spectra" / "calibrations"
