"""Save a set-up described by what was measured (lamp and camera wherever they were) as a preset
of the user's, and select it for the next estimate."""

from __future__ import annotations

import bpy

from ...core.errors import CDSpectraError
from .. import properties


class CDSPECTRA_OT_save_measured_setup(bpy.types.Operator):
    """Save the measured set-up (distances, angles from the disc's axis, azimuths seen from above,
    counter-clockwise) as a capture preset of yours and use it for the next estimate"""

    bl_idname = "cd_spectra.save_measured_setup"
    bl_label = "Save Set-up as Preset"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        from ...core.planning.measured import Measurements, measured_preset_data
        from ...core.planning.planner import setup_summary
        from ...core.planning.setups import analyse, setup_from_dict
        from ...core.scene.capture import preset_from_dict, save_user_preset, user_preset_name

        settings = context.scene.cd_spectra
        measurements = Measurements(
            lamp_distance_mm=settings.setup_lamp_distance_mm, lamp_angle_deg=settings.setup_lamp_angle_deg,
            lamp_azimuth_deg=settings.setup_lamp_azimuth_deg, camera_distance_mm=settings.setup_camera_distance_mm,
            camera_angle_deg=settings.setup_camera_angle_deg, camera_azimuth_deg=settings.setup_camera_azimuth_deg,
            disc=settings.setup_disc, lamp_size_mm=settings.setup_lamp_size_mm or None,
            focal_mm=settings.setup_focal_mm, sensor_width_mm=settings.setup_sensor_width_mm,
            aperture_mm=settings.setup_aperture_mm, name=settings.setup_name)
        try:
            user_preset_name(measurements.name)  # a name that cannot be saved is refused before anything is written
            data = measured_preset_data(measurements)
            summary = setup_summary(analyse(setup_from_dict(preset_from_dict(data), data["setup"])))
            path = save_user_preset(data)
        except CDSpectraError as exc:
            self.report({"ERROR"}, f"Set-up not saved: {exc}")
            return {"CANCELLED"}
        properties.refresh_presets()
        settings.preset = path.stem
        self.report({"INFO"}, f"Saved preset {path.stem} ({path}). {summary[0]}")
        return {"FINISHED"}
