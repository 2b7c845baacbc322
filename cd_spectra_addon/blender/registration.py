"""Register a list of classes all-or-nothing, so a failure leaves no class behind."""

from __future__ import annotations

from collections.abc import Sequence

import bpy


def register_classes(classes: Sequence[type]) -> None:
    done: list[type] = []
    try:
        for cls in classes:
            bpy.utils.register_class(cls)
            done.append(cls)
    except Exception:
        for cls in reversed(done):
            bpy.utils.unregister_class(cls)
        raise


def unregister_classes(classes: Sequence[type]) -> None:
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
