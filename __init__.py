"""Blender extension entry point: the zip's root package registers the CD Spectra add-on.

Imports are relative so the add-on works under whatever package name Blender gives an
extension (``bl_ext.<repository>.cd_spectra``). Nothing heavy happens here: onnxruntime and
the model load on the first estimate, not when Blender starts.
"""

from __future__ import annotations

from .cd_spectra_addon import blender as _blender


def register() -> None:
    _blender.register()


def unregister() -> None:
    _blender.unregister()
