"""Sidebar: View3D › Sidebar › CD Spectra. Every ``draw`` works with and without an estimate.

Draw code only reads: node groups and lights are made by operators (Blender forbids writing
data-blocks while drawing).
"""

from __future__ import annotations

import os
import textwrap
from typing import Any

import bpy

from . import photo_frames, state, vector_graphic
from .node_group import curve_node
from .registration import register_classes, unregister_classes

CATEGORY = "CD Spectra"
JOINT_ROWS = 8  # photos listed by name in the joint panel (a video's frames can be hundreds)
# core.colour.compare_spds keys worth showing, with their labels and formats.
METRICS = (
    ("mae_400_700", "MAE 400–700 nm", "{:.3f}"),
    ("mae_380_780", "MAE 380–780 nm", "{:.3f}"),
    ("delta_uv_prime", "Δu′v′", "{:.4f}"),
    ("delta_cct_k", "ΔCCT", "{:+.0f} K"),
    ("pearson_r", "Shape r", "{:.3f}"),
    ("delta_cri_ra", "ΔRa", "{:+.1f}"),
    ("delta_cri_r9", "ΔR9", "{:+.1f}"),
    ("delta_tm30_rf", "ΔRf", "{:+.1f}"),
    ("delta_tm30_rg", "ΔRg", "{:+.1f}"),
)
# The rendition figures the Result panel lists (the estimate JSON's keys), with their labels.
RENDITION_ROWS = (("cri_ra", "Ra"), ("cri_r9", "R9"), ("tm30_rf", "Rf"), ("tm30_rg", "Rg"),
                  ("peak_wavelength_nm", "Peak"), ("dominant_wavelength_nm", "Dominant λ"))


def _settings(context: bpy.types.Context) -> Any:
    return getattr(context.scene, "cd_spectra", None)


def _wrapped(layout: bpy.types.UILayout, context: bpy.types.Context, text: str, icon: str = "NONE") -> None:
    """Labels do not wrap: split long text to the sidebar's width."""
    region = getattr(context, "region", None)
    width = max(24, int((region.width if region is not None else 300) / 7))
    for i, line in enumerate(textwrap.wrap(text, width) or [""]):
        layout.label(text=line, icon=icon if i == 0 else "BLANK1")


def _fmt(value: Any, spec: str, unit: str = "") -> str:
    return "—" if value is None else f"{format(value, spec)}{unit}"


class _SidebarPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = CATEGORY


class CDSPECTRA_PT_main(_SidebarPanel, bpy.types.Panel):
    bl_idname = "CDSPECTRA_PT_main"
    bl_label = "CD Spectra"

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            layout.label(text="Add-on settings missing: re-enable CD Spectra", icon="ERROR")
            return
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.prop(settings, "photo_path")
        frames = photo_frames.frame_count(settings.photo_path)
        if frames > 1:  # an animated GIF: each frame is a photo of its own
            col.prop(settings, "photo_frame", text=f"Frame (0–{frames - 1})")
        col.prop(settings, "preset")
        col.prop(settings, "camera")
        col.prop(settings, "calibration")
        row = layout.row()
        row.scale_y = 1.4
        op = row.operator("cd_spectra.estimate_spd", icon="LIGHT")
        op.filepath = settings.photo_path
        op.frame = settings.photo_frame


class CDSPECTRA_PT_joint(_SidebarPanel, bpy.types.Panel):
    """Several photos of one lamp, one estimate (capture, camera and calibration from above)."""

    bl_idname = "CDSPECTRA_PT_joint"
    bl_label = "Several Photos, One Lamp"
    bl_parent_id = "CDSPECTRA_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            return
        _wrapped(layout, context, "Photos of the CD under the same lamp from several angles or positions (or a "
                 "video's frames) give one spectrum that covers more, with less noise. Capture, camera and "
                 "calibration are the ones above.")
        photos = settings.joint_photos
        box = layout.box()
        if not photos:
            box.label(text="No photos yet", icon="INFO")
        for i, item in enumerate(photos[:JOINT_ROWS]):
            row = box.row(align=True)
            row.label(text=os.path.basename(item.path) or "—", icon="IMAGE_DATA")
            row.operator("cd_spectra.joint_remove_photo", text="", icon="X", emboss=False).index = i
        if len(photos) > JOINT_ROWS:
            box.label(text=f"… and {len(photos) - JOINT_ROWS} more ({len(photos)} photos)")
        row = layout.row(align=True)
        row.operator("cd_spectra.joint_add_photos", icon="ADD")
        row.operator("cd_spectra.joint_remove_photo", text="Clear", icon="TRASH").index = -1
        row = layout.row()
        row.scale_y = 1.4
        row.operator("cd_spectra.estimate_joint", icon="LIGHT")


class CDSPECTRA_PT_result(_SidebarPanel, bpy.types.Panel):
    bl_idname = "CDSPECTRA_PT_result"
    bl_label = "Result"
    bl_parent_id = "CDSPECTRA_PT_main"

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        data = state.last_estimate(settings) if settings is not None else None
        if data is None:
            _wrapped(layout, context, "No estimate yet: choose a photo and press Estimate SPD.", "INFO")
            return
        node = curve_node(settings.node_group)
        if node is not None:
            layout.label(text="Relative power, 380–780 nm")
            layout.template_curve_mapping(node, "mapping")
        else:
            _wrapped(layout, context, "The spectrum's node group was deleted: press Estimate SPD again "
                     "to redraw the curve.", "ERROR")

        grid = layout.grid_flow(row_major=True, columns=2, even_columns=True, align=True)
        xy = data.get("xy") or [None, None]
        for label, value in (
            ("CCT", _fmt(data.get("cct_k"), ".0f", " K")),
            ("Duv", _fmt(data.get("duv"), "+.4f")),
            ("x", _fmt(xy[0], ".4f")),
            ("y", _fmt(xy[1], ".4f")),
            ("Confidence", _fmt(data.get("confidence"), ".0%")),
            ("Camera", str(data.get("camera") or "—")),
        ):
            grid.label(text=label)
            grid.label(text=value)
        if data.get("cct_k") is None:
            _wrapped(layout, context, "Too far from white light for a colour temperature.", "INFO")
        joint = data.get("joint")
        if isinstance(joint, dict):
            _wrapped(layout, context, f"From {joint.get('used')} of {joint.get('given')} photos of one lamp.",
                     "IMAGE_DATA")
        _draw_rendition(layout, context, data.get("rendition"))
        warnings = list(data.get("warnings") or [])
        if warnings:
            box = layout.box()
            for warning in warnings:
                _wrapped(box, context, str(warning), "ERROR")

        layout.separator()
        row = layout.row(align=True)
        row.prop(settings, "light_type", text="")
        op = row.operator("cd_spectra.create_light", icon="ADD")
        op.light_type = settings.light_type
        layout.operator("cd_spectra.apply_to_light", icon="LIGHT_DATA")
        layout.operator("cd_spectra.export_spd", icon="EXPORT")


def _draw_rendition(layout: bpy.types.UILayout, context: bpy.types.Context, rendition: Any) -> None:
    """Colour rendition: the figures with their 90 % ranges, the flags, the vector graphic."""
    if not isinstance(rendition, dict):
        return  # an estimate made without rendition (or before it existed)
    from ..core.rendition.result import format_figure

    box = layout.box()
    box.label(text="Colour rendition", icon="COLOR")
    if not rendition.get("defined"):
        _wrapped(box, context, str(rendition.get("reason", "not computed")), "INFO")
        return
    grid = box.grid_flow(row_major=True, columns=2, even_columns=False, align=True)
    for key, label in RENDITION_ROWS:
        grid.label(text=label)
        grid.label(text=format_figure(rendition, key).replace(": range too wide to mean anything", " (too wide)"))
    if rendition.get("ranges"):
        _wrapped(box, context, "[ ] = 90 % range from the estimate's uncertainty.")
    if rendition.get("too_wide"):
        _wrapped(box, context, "A range marked too wide does not tell a good lamp from a poor one: improve the "
                 "photo (exposure, lamp size) before trusting that figure.", "ERROR")
    for note in rendition.get("notes") or ():
        _wrapped(box, context, str(note), "INFO")
    icon = vector_graphic.icon_for(rendition)
    if icon:
        box.label(text="TM-30 colour vector graphic")
        box.template_icon(icon_value=icon, scale=9.0)
    _wrapped(box, context, "TLCI is not computed (no implementation in colour-science).")


class CDSPECTRA_PT_compare(_SidebarPanel, bpy.types.Panel):
    bl_idname = "CDSPECTRA_PT_compare"
    bl_label = "Compare with Reference"
    bl_parent_id = "CDSPECTRA_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            return
        layout.operator("cd_spectra.load_reference_spd", icon="IMPORT")
        ref = state.reference(settings)
        if ref is None:
            _wrapped(layout, context, "Load a measured spectrum (CSV, JSON, TM-27-14) to see how close "
                     "the estimate is.", "INFO")
            return
        layout.label(text=f"Reference: {ref.get('name', '')}")
        metrics = ref.get("metrics") or {}
        if state.last_estimate(settings) is None or not metrics:
            layout.label(text="Estimate an SPD to compare", icon="INFO")
        else:
            grid = layout.grid_flow(row_major=True, columns=2, even_columns=True, align=True)
            for key, label, fmt in METRICS:
                if isinstance(metrics.get(key), (int, float)):
                    grid.label(text=label)
                    grid.label(text=fmt.format(metrics[key]))
        for title, group in (("Estimate", settings.node_group), ("Reference", settings.reference_node_group)):
            node = curve_node(group)
            if node is not None:
                layout.label(text=title)
                layout.template_curve_mapping(node, "mapping")


class CDSPECTRA_PT_calibrate(_SidebarPanel, bpy.types.Panel):
    bl_idname = "CDSPECTRA_PT_calibrate"
    bl_label = "Calibrate"
    bl_parent_id = "CDSPECTRA_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            return
        _wrapped(layout, context, "Photograph the CD once under a lamp of known spectrum, with the same "
                 "camera and set-up: later estimates with this profile are more accurate. A second photo under "
                 "a lamp of another colour (daylight beside a bulb) measures what the first leaves dark.")
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column()
        col.prop(settings, "calibration_photo")
        col.prop(settings, "calibration_lamp")
        if settings.calibration_lamp == "FILE":
            col.prop(settings, "calibration_spd_path")
        col.prop(settings, "calibration_photo2")
        if settings.calibration_photo2:
            col.prop(settings, "calibration_lamp2")
            if settings.calibration_lamp2 == "FILE":
                col.prop(settings, "calibration_spd_path2")
        col.prop(settings, "calibration_name")
        op = layout.operator("cd_spectra.calibrate", icon="CHECKMARK")
        op.filepath = settings.calibration_photo
        op.lamp = settings.calibration_lamp
        op.spd_path = settings.calibration_spd_path
        op.filepath2 = settings.calibration_photo2
        op.lamp2 = settings.calibration_lamp2
        op.spd_path2 = settings.calibration_spd_path2
        op.profile_name = settings.calibration_name


_ADVICE: dict[tuple[str, int], tuple[list[str], list[str]]] = {}  # (preset, file's mtime) → (steps, summary)


def capture_advice(preset: str) -> tuple[list[str], list[str]]:
    """(steps to build it, what it gives) for a preset, from the core's set-up analysis; once per
    preset file (a few ms; a user's preset saved again is analysed again). Presets that are not
    buildable set-ups point to the others, the planner and the measured set-up form."""
    from ..core.scene.capture import preset_path

    try:
        key = (preset, preset_path(preset).stat().st_mtime_ns)
    except OSError:
        key = (preset, 0)
    if key not in _ADVICE:
        from ..core.errors import CDSpectraError
        from ..core.planning.planner import setup_summary
        from ..core.planning.setups import analyse, load_setup, setup_names

        try:
            setup = load_setup(preset)
        except CDSpectraError:
            _ADVICE[key] = ([], [f"Not a set-up you can build as described (the lamp sits on the lens axis). "
                                 f"Buildable: {', '.join(setup_names())}; or run 'python -m cd_spectra_addon "
                                 "plan' for your lamp and camera, or describe where yours stand under "
                                 "'Your Set-up, Measured'."])
        else:
            _ADVICE[key] = (list(setup.steps), setup_summary(analyse(setup)))
    return _ADVICE[key]


class CDSPECTRA_PT_capture(_SidebarPanel, bpy.types.Panel):
    """How to build the chosen preset's capture and what it gives (the planner's advice)."""

    bl_idname = "CDSPECTRA_PT_capture"
    bl_label = "Capture Set-up"
    bl_parent_id = "CDSPECTRA_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            return
        steps, summary = capture_advice(settings.preset)
        for i, step in enumerate(steps, 1):
            _wrapped(layout, context, f"{i}. {step}")
        box = layout.box()
        for k, line in enumerate(summary):
            _wrapped(box, context, line.strip(), "INFO" if k == 0 else "NONE")


class CDSPECTRA_PT_measured(_SidebarPanel, bpy.types.Panel):
    """A set-up described by what was measured, saved as a preset of the user's."""

    bl_idname = "CDSPECTRA_PT_measured"
    bl_label = "Your Set-up, Measured"
    bl_parent_id = "CDSPECTRA_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context: bpy.types.Context) -> None:
        layout = self.layout
        settings = _settings(context)
        if settings is None:
            return
        _wrapped(layout, context, "Where lamp and camera stood: distance from the disc centre, angle from the "
                 "disc's axis (0: straight above) and azimuth around it, seen from above, counter-clockwise "
                 "(facing the disc from the camera, +90° is on your right). The camera is aimed at the centre.")
        layout.use_property_split = True
        layout.use_property_decorate = False
        col = layout.column(align=True)
        for name in ("setup_lamp_distance_mm", "setup_lamp_angle_deg", "setup_lamp_azimuth_deg"):
            col.prop(settings, name)
        col = layout.column(align=True)
        for name in ("setup_camera_distance_mm", "setup_camera_angle_deg", "setup_camera_azimuth_deg"):
            col.prop(settings, name)
        col = layout.column()
        for name in ("setup_disc", "setup_lamp_size_mm", "setup_focal_mm", "setup_sensor_width_mm",
                     "setup_aperture_mm", "setup_name"):
            col.prop(settings, name)
        layout.operator("cd_spectra.save_measured_setup", icon="PRESET_NEW")


classes = (CDSPECTRA_PT_main, CDSPECTRA_PT_joint, CDSPECTRA_PT_result, CDSPECTRA_PT_compare,
           CDSPECTRA_PT_calibrate, CDSPECTRA_PT_capture, CDSPECTRA_PT_measured)


def register() -> None:
    register_classes(classes)


def unregister() -> None:
    unregister_classes(classes)
    vector_graphic.release()
