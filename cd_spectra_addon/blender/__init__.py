"""Blender layer (the only part of the add-on that imports bpy): properties, operators, panels.

Registration goes by sub-module, each with its own ``register``/``unregister`` (the pattern of
Blender's node_wrangler). A failure half-way unregisters what was already registered and then
raises, so Blender shows the real error and no half-registered add-on stays behind.
"""

from __future__ import annotations

from . import operators, panels, properties

_MODULES = (properties, operators, panels)


def register() -> None:
    done = []
    try:
        for module in _MODULES:
            module.register()
            done.append(module)
    except Exception:
        for module in reversed(done):
            module.unregister()
        raise


def unregister() -> None:
    for module in reversed(_MODULES):
        module.unregister()
