"""Where the add-on keeps the user's files (calibration profiles, presets of their own set-ups):
Blender's per-extension user folder, which survives add-on updates and is what Blender's own tools
clean up on removal. Only paths are set here: no file is read at register (enabling ≤ 50 ms)."""

from __future__ import annotations

from pathlib import Path

import bpy

from ..core import user_folders


def _extension_package() -> str | None:
    parts = (__package__ or "").split(".")
    return ".".join(parts[:3]) if len(parts) >= 3 and parts[0] == "bl_ext" else None


def register() -> None:
    package = _extension_package()
    if package is None:  # loaded as a plain module (tests, CLI): keep the core's default folders
        return
    try:
        folder = bpy.utils.extension_path_user(package, path="calibrations", create=True)
        presets = bpy.utils.extension_path_user(package, path="presets", create=False)  # made on first save
    except (ValueError, OSError):
        return
    user_folders.set_default_directory(Path(folder))
    user_folders.set_default_preset_directory(Path(presets))


def unregister() -> None:
    user_folders.set_default_directory(None)
    user_folders.set_default_preset_directory(None)
