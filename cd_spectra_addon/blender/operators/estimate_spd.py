"""Estimate the lamp's SPD from a photo of a CD (the add-on's main button)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import bpy
from bpy.props import EnumProperty, IntProperty, StringProperty

from ...core.errors import CDSpectraError
from .. import photo_frames, state
from ..node_group import ensure_node_group
from ..progress import progress
from ..properties import (
    DEFAULT_PRESET,
    PHOTO_FILTER_GLOB,
    calibration_items,
    camera_items,
    preset_items,
    stable_number,
)
from ...core.spectra.cameras import DEFAULT_CAMERA

_CHOICES = ("preset", "camera", "calibration")
# Below this confidence the estimate is still stored and shown, but the status bar says it is not
# to be trusted and why, not just a percentage: a photo the fit could not place reads 0–5 %
# (bench/pose_errors_oblique205.md); eval's nominal photos of 312 lamps read 63–100 %, mean 98 %
# (bench/eval.md).
LOW_CONFIDENCE = 0.5


def outcome_report(data: dict[str, Any], colour: str) -> tuple[str, str]:
    """The status bar's line for an estimate (its JSON) of ``colour``: INFO, or WARNING with the
    estimate's first warning where its confidence is low."""
    confidence = float(data.get("confidence") or 0.0)
    text = f"Estimated {colour}, confidence {confidence:.0%}"
    if confidence >= LOW_CONFIDENCE:
        return "INFO", text
    warnings = [str(w) for w in data.get("warnings") or ()]
    reason = f" — {warnings[0]}" if warnings else ""
    more = " (every warning is in the panel)" if len(warnings) > 1 else ""
    return "WARNING", f"{text}: too low to trust{reason}{more}"


class CDSPECTRA_OT_estimate_spd(bpy.types.Operator):
    """Recover the lamp's spectrum from the photo of the CD"""

    bl_idname = "cd_spectra.estimate_spd"
    bl_label = "Estimate SPD"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="Photo", subtype="FILE_PATH", options={"SKIP_SAVE"})
    filter_glob: StringProperty(default=PHOTO_FILTER_GLOB, options={"HIDDEN"})
    frame: IntProperty(name="Frame", min=0, default=0, options={"SKIP_SAVE"},
                       description="Frame of an animated GIF, counted from 0 (default: the panel's)")
    preset: EnumProperty(name="Capture", items=preset_items, default=stable_number(DEFAULT_PRESET))
    camera: EnumProperty(name="Camera", items=camera_items, default=stable_number(DEFAULT_CAMERA))
    calibration: EnumProperty(name="Calibration", items=calibration_items, default=0)

    def _take_unset_choices_from(self, settings: Any) -> None:
        for name in _CHOICES:
            if not self.properties.is_property_set(name) and getattr(settings, name):
                setattr(self, name, getattr(settings, name))
        if not self.properties.is_property_set("frame"):
            self.frame = settings.photo_frame

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        settings = context.scene.cd_spectra
        self._take_unset_choices_from(settings)
        if not self.filepath:
            self.filepath = settings.photo_path
        if not self.filepath:
            context.window_manager.fileselect_add(self)
            return {"RUNNING_MODAL"}
        return self.execute(context)

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.cd_spectra
        self._take_unset_choices_from(settings)
        path = bpy.path.abspath(self.filepath or settings.photo_path)
        if not path:
            self.report({"ERROR"}, "Choose a photo of the CD first")
            return {"CANCELLED"}
        path = photo_frames.photo_with_frame(path, self.frame)  # an animated GIF: the chosen frame
        try:
            from ...core.inverse.estimate import estimate_photo
        except ImportError as exc:
            self.report({"ERROR"}, f"This build of CD Spectra has no estimator ({exc})")
            return {"CANCELLED"}

        def estimate(update: Callable[[float, str], None], space: str) -> Any:
            update(0.0, "reading the photo")
            return estimate_photo(path, preset=self.preset or DEFAULT_PRESET,
                                  camera=state.camera_choice(self.camera),
                                  calibration=state.calibration_choice(self.calibration), working_space=space,
                                  progress=update)

        if not run_and_store(self, context, estimate):
            return {"CANCELLED"}
        settings.photo_path = self.filepath or settings.photo_path
        settings.photo_frame = self.frame
        for name in _CHOICES:
            if getattr(self, name):
                setattr(settings, name, getattr(self, name))
        return {"FINISHED"}


def run_and_store(operator: bpy.types.Operator, context: bpy.types.Context,
                  estimate: Callable[[Callable[[float, str], None], str], Any]) -> bool:
    """Run ``estimate(update, working_space)`` under a progress cursor and store its result as
    the scene's last estimate with its node group; False (reported, the scene untouched) when
    it fails. Shared by the one-photo and the several-photo estimate."""
    from ...core.spectra.colour import spectral_colour

    settings = context.scene.cd_spectra
    space = state.working_space_for(operator)
    with progress(context) as update:
        try:
            data = estimate(update, space).to_json()
            spd = state.valid_spd(data.get("spd", ()))
            if spd is None:
                raise CDSpectraError("the estimate is not a usable spectrum (empty or not finite)")
            info = spectral_colour(spd, space)
        except CDSpectraError as exc:
            operator.report({"ERROR"}, str(exc))
            return False
        except ValueError as exc:  # colour conversion refused the SPD
            operator.report({"ERROR"}, f"Cannot use this estimate: {exc}")
            return False
        except Exception as exc:  # a bug, not the photo: say so; the scene is not touched yet
            operator.report({"ERROR"}, f"Internal error in CD Spectra ({type(exc).__name__}: {exc}); the scene "
                            "was not changed. This is a bug: please report it with the photo")
            return False
        update(0.95, "building the spectral node group")
        group = ensure_node_group(spd, info, state.estimate_meta(data))
    state.store_estimate(settings, data)
    settings.node_group = group
    cct = f"{info.cct_k:.0f} K" if info.cct_k else f"xy {info.xy[0]:.4f}, {info.xy[1]:.4f}"
    level, text = outcome_report(data, cct)
    operator.report({level}, text)
    return True
