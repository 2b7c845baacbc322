"""The Blender layer: everything that imports bpy (operators, panels, light builders, decoders).

Registration goes by sub-module, each with its own ``register``/``unregister`` (the pattern of
Blender's node_wrangler). A failure half-way unregisters what was already registered and then
raises, so Blender shows the real error and no half-registered add-on stays behind.

Enabling runs at every Blender start-up, so importing this package loads of the core only the
names and small tables the classes are defined with (the allow-list is
``tests/test_extension_blender.py``'s ``ENABLE_CORE_MODULES``); the photo pipeline, the colour
tables, the capture geometry and the estimator are imported where an operator first uses them.
"""

from __future__ import annotations

from . import image_decoder, operators, panels, properties, user_paths

# image_decoder: Blender's image loader as the core's fallback for photos Pillow cannot read.
# user_paths: calibration profiles in the extension's user folder.
_MODULES = (user_paths, properties, operators, panels, image_decoder)


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
