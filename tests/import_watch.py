"""Which of Blender's modules a piece of code imports: conftest's rule that an unmarked test
must not, and the in-process CLI runner's report of whether ``main`` loaded bpy."""

from __future__ import annotations

import builtins
import types
from typing import Any

# Blender's modules, and project modules that import them at the top.
BLENDER_MODULES = ("bpy", "addon_utils", "bmesh", "mathutils", "cd_spectra_addon.blender",
                   "training.simulation.cycles_scene")
_BLENDER_PREFIXES = tuple(m + "." for m in BLENDER_MODULES)


def is_blender(name: str) -> bool:
    # one C call: it runs on every import statement a test executes (~0.6 M in make test-fast)
    return name in BLENDER_MODULES or name.startswith(_BLENDER_PREFIXES)


class ImportWatch:
    """Records imports of Blender's modules while installed as ``builtins.__import__``; it sees
    ``import bpy`` of a module already loaded too, so what ran before does not hide it."""

    def __init__(self) -> None:
        self.seen: list[str] = []
        self._original = builtins.__import__

    def __call__(self, name: str, globals: Any = None, locals: Any = None, fromlist: Any = (),
                 level: int = 0) -> types.ModuleType:
        if level == 0 and is_blender(name) and name not in self.seen:
            self.seen.append(name)
        return self._original(name, globals, locals, fromlist, level)

    def __enter__(self) -> ImportWatch:
        self._original = builtins.__import__
        builtins.__import__ = self
        return self

    def __exit__(self, *exc: object) -> None:
        builtins.__import__ = self._original
