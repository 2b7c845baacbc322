"""The TM-30 colour vector graphic in the sidebar: the core's numpy drawing, shown as an icon.

A preview collection (``bpy.utils.previews``), not an image data-block: the graphic is made from
the estimate's JSON whenever the panel needs it, so nothing is added to the user's file and a
reopened .blend draws it again. One preview per distinct graphic, made on first draw (a few ms)
and reused; the collection is freed when the add-on is disabled.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

SIZE = 256  # pixels per side; the panel shows it scaled to the sidebar
_previews: Any = None  # bpy.utils.previews.ImagePreviewCollection, made on first use


def icon_for(rendition: dict[str, Any] | None) -> int | None:
    """The icon id of this rendition's vector graphic, or None (no graphic: no rendition, an
    empty hue bin, or previews unavailable in this Blender session)."""
    global _previews
    if not rendition or not rendition.get("defined"):
        return None
    key = hashlib.sha1(json.dumps(rendition.get("tm30_cvg"), sort_keys=True).encode()).hexdigest()[:16]
    if _previews is not None and key in _previews:
        return _previews[key].icon_id
    from ..core.rendition.vector_graphic import vector_graphic_image

    image = vector_graphic_image(rendition, SIZE)
    if image is None:
        return None
    import bpy.utils.previews

    if _previews is None:
        _previews = bpy.utils.previews.new()
    preview = _previews.new(key)
    preview.image_size = (SIZE, SIZE)
    preview.image_pixels_float.foreach_set(image.ravel())
    return preview.icon_id


def release() -> None:
    """Free the previews (the add-on's unregister)."""
    global _previews
    if _previews is not None:
        import bpy.utils.previews

        bpy.utils.previews.remove(_previews)
        _previews = None
