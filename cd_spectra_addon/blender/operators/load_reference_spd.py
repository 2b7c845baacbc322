"""Load a measured spectrum to compare the estimate with (MAE, Δu'v', both curves)."""

from __future__ import annotations

import json
from typing import Any

import bpy
from bpy.props import StringProperty
from bpy_extras.io_utils import ImportHelper

from ...core.errors import CDSpectraError
from .. import state
from ..node_group import ensure_node_group
from ..properties import SPECTRA_FILTER_GLOB
from ..spectra_io import compare, read_reference


class CDSPECTRA_OT_load_reference_spd(bpy.types.Operator, ImportHelper):
    """Load a reference spectrum (e.g. from a spectrometer) and compare the estimate with it"""

    bl_idname = "cd_spectra.load_reference_spd"
    bl_label = "Load Reference SPD"
    bl_options = {"REGISTER", "UNDO"}

    filter_glob: StringProperty(default=SPECTRA_FILTER_GLOB, options={"HIDDEN"})

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        if self.filepath:
            return self.execute(context)
        return super().invoke(context, event)

    def execute(self, context: bpy.types.Context) -> set[str]:
        from ...core.spectra.colour import spectral_colour

        settings = context.scene.cd_spectra
        path = bpy.path.abspath(self.filepath)
        if not path:
            self.report({"ERROR"}, "Choose a spectrum file")
            return {"CANCELLED"}
        try:
            name, spd = read_reference(path)
            spd = state.valid_spd(spd)
            if spd is None:
                raise ValueError("no usable spectrum between 380 and 780 nm")
            peak = max(spd)
            spd = [v / peak for v in spd]
            info = spectral_colour(spd, state.working_space_for(self))
            estimate = state.last_estimate(settings)
            metrics = compare(estimate["spd"], spd, estimate.get("rendition")) if estimate is not None else {}
        except (OSError, ValueError, CDSpectraError) as exc:
            self.report({"ERROR"}, f"Cannot use {bpy.path.basename(path)} as a reference: {exc}")
            return {"CANCELLED"}
        group = ensure_node_group(spd, info, {"kind": "reference", "name": name, "source": path})
        settings.reference_path = self.filepath
        settings.reference_node_group = group
        settings.reference_json = json.dumps({
            "name": name, "path": path, "spd": spd, "metrics": metrics,
            "xy": list(info.xy), "cct_k": info.cct_k, "duv": info.duv,
        })
        self.report({"INFO"}, f"Loaded reference {name}")
        return {"FINISHED"}
