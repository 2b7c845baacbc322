"""Blender extension entry point: the zip's root package registers the CD Spectra add-on.

Imports are relative so the add-on works under whatever package name Blender gives an
extension (``bl_ext.<repository>.cd_spectra``), and happen inside the functions: importing
this file alone does nothing (pytest imports a repository root that has an ``__init__.py``,
under a name that may not even be a package). onnxruntime and the model load on the first
estimate, not when Blender starts.
"""

from __future__ import annotations


def register() -> None:
    from .cd_spectra_addon import blender

    blender.register()


def unregister() -> None:
    from .cd_spectra_addon import blender

    blender.unregister()
