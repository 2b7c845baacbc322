"""Write the last estimate's SPD for other renderers and tools."""

from __future__ import annotations

from typing import Any

import bpy
from bpy.props import EnumProperty, StringProperty
from bpy_extras.io_utils import ExportHelper

from ...core.errors import CDSpectraError
from .. import state
from ..spectra_io import export_format, export_formats, write_spd

_ITEMS: list[tuple[str, str, str]] = []


def format_items(_self: Any, _context: Any) -> list[tuple[str, str, str]]:
    _ITEMS[:] = [(f.identifier, f.label, f.description) for f in export_formats()] or [
        ("NONE", "No format", "This build cannot write spectra files")]
    return _ITEMS


class CDSPECTRA_OT_export_spd(bpy.types.Operator, ExportHelper):
    """Save the estimated spectrum (CSV, JSON, pbrt-v4, IES TM-27-14 or Mitsuba λ:value)"""

    bl_idname = "cd_spectra.export_spd"
    bl_label = "Export SPD"
    bl_options = {"REGISTER", "UNDO"}

    filename_ext = ".csv"
    filter_glob: StringProperty(default="*.csv;*.json;*.spd;*.xml;*.txt", options={"HIDDEN"})
    file_format: EnumProperty(name="Format", items=format_items)

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        return state.has_estimate(cls, context)

    def _format(self):
        """The chosen format where this build can write it, else None ("NONE" or no colour-science)."""
        try:
            fmt = export_format(self.file_format)
        except CDSpectraError:
            return None
        return fmt if fmt.available() else None

    def check(self, context: bpy.types.Context) -> bool:
        fmt = self._format()
        if fmt is not None:
            self.filename_ext = fmt.extension
        return super().check(context)

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        fmt = self._format()
        if fmt is not None:
            self.filename_ext = fmt.extension
        return super().invoke(context, event)

    def execute(self, context: bpy.types.Context) -> set[str]:
        data = state.last_estimate(context.scene.cd_spectra)
        fmt = self._format()
        if data is None:
            self.report({"ERROR"}, "Estimate an SPD first")
            return {"CANCELLED"}
        if fmt is None:
            self.report({"ERROR"}, f"Cannot write the format {self.file_format!r} in this build")
            return {"CANCELLED"}
        if not self.filepath:
            self.report({"ERROR"}, "Choose a file to write")
            return {"CANCELLED"}
        meta = {**state.estimate_meta(data), **{k: data.get(k) for k in ("xy", "cct_k", "duv", "confidence",
                                                                          "warnings", "spd_std")}}
        try:
            path = write_spd(fmt, bpy.path.abspath(self.filepath), data["spd"], meta)
        except (OSError, ValueError) as exc:
            self.report({"ERROR"}, f"Could not write {self.filepath}: {exc}")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Wrote {path}")
        return {"FINISHED"}
