"""Create a light whose colour and spectral node group come from the last estimate."""

from __future__ import annotations

from typing import Any

import bpy
from bpy.props import EnumProperty

from .. import state
from ..light import create_light
from ..node_group import find_node_group, spd_hash
from ..properties import LIGHT_TYPES


class CDSPECTRA_OT_create_light(bpy.types.Operator):
    """Add a light at the 3D cursor with the colour and spectrum of the last estimate"""

    bl_idname = "cd_spectra.create_light"
    bl_label = "Create Matched Light"
    bl_options = {"REGISTER", "UNDO"}

    light_type: EnumProperty(name="Type", items=LIGHT_TYPES, default="SPOT")

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return state.has_estimate(cls, context)

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        if not self.properties.is_property_set("light_type"):
            self.light_type = context.scene.cd_spectra.light_type
        return self.execute(context)

    def execute(self, context: bpy.types.Context) -> set[str]:
        from ...core.spectra.colour import spectral_colour

        settings = context.scene.cd_spectra
        data = state.last_estimate(settings)
        if data is None:
            self.report({"ERROR"}, "Estimate an SPD first")
            return {"CANCELLED"}
        spd = state.valid_spd(data["spd"])
        try:
            info = spectral_colour(spd, state.working_space_for(self))
            obj = create_light(context.view_layer.active_layer_collection.collection, spd, info,
                               state.estimate_meta(data), self.light_type, context.scene.cursor.location)
        except ValueError as exc:
            self.report({"ERROR"}, f"Cannot make a light from this estimate: {exc}")
            return {"CANCELLED"}
        for other in context.view_layer.objects:
            if other.select_get():
                other.select_set(False)
        obj.select_set(True)
        context.view_layer.objects.active = obj
        settings.node_group = find_node_group(spd_hash(spd))
        self.report({"INFO"}, f"Created {obj.name}")
        return {"FINISHED"}
