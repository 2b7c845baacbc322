"""Where the user's files live: calibration profiles and capture presets of their own (a set-up
described by measurements). Kept free of numpy and the solver so the Blender layer can point
these at the extension's user folders while the add-on is enabled, without paying for the
estimator's imports (enabling must stay ≤ 50 ms)."""

from __future__ import annotations

import os
from pathlib import Path

ENV_DIR = "CD_SPECTRA_CALIBRATION_DIR"
PRESET_ENV_DIR = "CD_SPECTRA_PRESET_DIR"

_default_dir: Path | None = None
_default_preset_dir: Path | None = None


def set_default_directory(path: Path | None) -> None:
    """Where profiles go when no folder is given (the Blender layer points this at the
    extension's user folder; None restores the default)."""
    global _default_dir
    _default_dir = None if path is None else Path(path)


def set_default_preset_directory(path: Path | None) -> None:
    """Where the user's own presets go (the Blender layer points this at the extension's user
    folder; None restores the default)."""
    global _default_preset_dir
    _default_preset_dir = None if path is None else Path(path)


def _config_dir() -> Path:
    base = os.environ.get("APPDATA") or os.environ.get("XDG_CONFIG_HOME") or os.path.join(
        os.path.expanduser("~"), ".config")
    return Path(base) / "cd_spectra"


def _folder(env_name: str, host_set: Path | None, name: str) -> Path:
    """The environment variable's folder, else the one the host application set, else ``name``
    in the user's config folder."""
    env = os.environ.get(env_name)
    if env:
        return Path(env)
    if host_set is not None:
        return host_set
    return _config_dir() / name


def calibration_dir() -> Path:
    """Where profiles live: $CD_SPECTRA_CALIBRATION_DIR, else the folder the host application set,
    else the user's config folder."""
    return _folder(ENV_DIR, _default_dir, "calibrations")


def preset_dir() -> Path:
    """Where the user's own presets live: $CD_SPECTRA_PRESET_DIR, else the folder the host
    application set, else the user's config folder (beside the calibrations)."""
    return _folder(PRESET_ENV_DIR, _default_preset_dir, "presets")
