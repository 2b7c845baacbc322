"""Give the selected lights the colour and spectral node group of the last estimate."""

from __future__ import annotations

import bpy

from .. import state
from ..light import apply_spd


def _selected_lights(context: bpy.types.Context) -> list[bpy.types.Object]:
    lights = [o for o in context.selected_objects if o.type == "LIGHT"]
    active = context.active_object
    if not lights and active is not None and active.type == "LIGHT":
        lights = [active]
    return lights


class CDSPECTRA_OT_apply_to_light(bpy.types.Operator):
    """Set the selected lights' colour and spectrum from the last estimate (energy and size stay)"""

    bl_idname = "cd_spectra.apply_to_light"
    bl_label = "Apply to Selected Light"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        if not state.has_estimate(cls, context):
            return False
        if not _selected_lights(context):
            cls.poll_message_set("Select a light first")
            return False
        return True

    def execute(self, context: bpy.types.Context) -> set[str]:
        from ...core.spectra.colour import spectral_colour

        data = state.last_estimate(context.scene.cd_spectra)
        lights = _selected_lights(context)
        if data is None or not lights:
            self.report({"ERROR"}, "Estimate an SPD and select a light first")
            return {"CANCELLED"}
        spd = state.valid_spd(data["spd"])
        try:
            info = spectral_colour(spd, state.working_space_for(self))
        except ValueError as exc:
            self.report({"ERROR"}, f"Cannot use this estimate: {exc}")
            return {"CANCELLED"}
        meta = state.estimate_meta(data)
        for obj in lights:
            apply_spd(obj.data, spd, info, meta)
        self.report({"INFO"}, f"Applied to {', '.join(o.name for o in lights)}")
        return {"FINISHED"}
