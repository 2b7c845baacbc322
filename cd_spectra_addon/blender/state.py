"""Reading and writing the add-on's state in the scene: the last estimate and the reference."""

from __future__ import annotations

import json
import math
from functools import lru_cache
from typing import Any

import bpy

from ..core.spectra.grid import N_BANDS
from .properties import GENERIC_CAMERA, NO_CALIBRATION


def working_space() -> str:
    """The scene-linear space light colours are given in (see :func:`working_space_and_warning`)."""
    return working_space_and_warning()[0]


def working_space_and_warning() -> tuple[str, str | None]:
    """The file's working space, and a warning when it had to be assumed.

    Blender 4.x is always Linear Rec.709 (no ``bpy.data.colorspace``). Blender 5 has a per-file
    working space; its interop id (``lin_rec709_scene``, ``lin_rec2020_scene``,
    ``lin_ap1_scene``) names it independently of the OCIO config's display names. A custom OCIO
    config may have neither a known id nor a known name: Rec.709 then, and say so.
    """
    from ..core.spectra.colour import DEFAULT_WORKING_SPACE, known_working_space

    colorspace = getattr(bpy.data, "colorspace", None)
    if colorspace is None:
        return DEFAULT_WORKING_SPACE, None
    interop = str(getattr(colorspace, "working_space_interop_id", "") or "")
    name = str(getattr(colorspace, "working_space", "") or "")
    for candidate in (interop, name):
        known = known_working_space(candidate) if candidate else None
        if known is not None:
            return known, None
    return DEFAULT_WORKING_SPACE, (
        f"The file's working colour space ({name or interop or 'unnamed'}, from a custom OCIO config) "
        f"is not one CD Spectra knows; light colours are in {DEFAULT_WORKING_SPACE}")


def working_space_for(operator: Any) -> str:
    """The working space for an operator's colours; an assumed one is reported as a warning."""
    space, warning = working_space_and_warning()
    if warning:
        operator.report({"WARNING"}, warning)
    return space


@lru_cache(maxsize=8)
def _parse(text: str) -> dict[str, Any] | None:
    if not text:
        return None
    try:
        data = json.loads(text)
    except json.JSONDecodeError:
        return None
    return data if isinstance(data, dict) else None


def valid_spd(values: Any) -> list[float] | None:
    """The SPD as 81 finite, non-negative floats with a positive peak, or None."""
    try:
        spd = [float(v) for v in values]
    except (TypeError, ValueError):
        return None
    if len(spd) != N_BANDS or not all(math.isfinite(v) and v >= 0.0 for v in spd) or max(spd) <= 0:
        return None
    return spd


def last_estimate(settings: Any) -> dict[str, Any] | None:
    """The last estimate's JSON (as the CLI prints it), or None if there is none or it is broken."""
    data = _parse(settings.estimate_json)
    if data is None or valid_spd(data.get("spd", ())) is None:
        return None
    return data


def has_estimate(operator: Any, context: Any) -> bool:
    """Operator poll shared by everything that needs a result; says why it is greyed out."""
    settings = getattr(context.scene, "cd_spectra", None)
    if settings is None or last_estimate(settings) is None:
        operator.poll_message_set("Estimate an SPD first")
        return False
    return True


def store_estimate(settings: Any, data: dict[str, Any]) -> None:
    """The estimate's JSON is the one place the scene keeps it (SPD included); readers go
    through ``last_estimate``."""
    if valid_spd(data["spd"]) is None:
        raise ValueError("estimate without a valid SPD")
    settings.estimate_json = json.dumps(data)


def reference(settings: Any) -> dict[str, Any] | None:
    """The loaded reference spectrum ({name, spd, path, metrics}) or None."""
    data = _parse(settings.reference_json)
    if data is None or valid_spd(data.get("spd", ())) is None:
        return None
    return data


def camera_choice(value: str) -> str:
    """Enum value → the camera name the core expects (empty = an item that no longer exists)."""
    from ..core.spectra.cameras import DEFAULT_CAMERA

    return value or DEFAULT_CAMERA


def calibration_choice(value: str) -> str | None:
    return None if value in ("", NO_CALIBRATION) else value


__all__ = [
    "GENERIC_CAMERA",
    "working_space",
    "working_space_and_warning",
    "working_space_for",
    "valid_spd",
    "last_estimate",
    "store_estimate",
    "reference",
    "camera_choice",
    "calibration_choice",
]


def estimate_meta(data: dict[str, Any]) -> dict[str, Any]:
    """What a light or node group records about the estimate it came from."""
    import os

    source = str(data.get("source") or "")
    return {
        "kind": "estimate",
        "name": "CD Spectra",
        "source": source,
        "photo": os.path.basename(source),
        "model_version": data.get("model_version"),
        "preset": data.get("preset"),
        "camera": data.get("camera"),
        "calibration": data.get("calibration"),
        "confidence": data.get("confidence"),
        "rendition": data.get("rendition"),
    }
