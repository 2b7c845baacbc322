"""Calibrate camera + disc + set-up from a photo of a lamp whose spectrum is known."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import bpy
from bpy.props import EnumProperty, StringProperty

from ...core.errors import CDSpectraError
from ...core.scene.preset_names import DEFAULT_PRESET
from .. import state
from ..progress import progress
from ..properties import PHOTO_FILTER_GLOB, REFERENCE_LAMPS, calibration_names


class CDSPECTRA_OT_calibrate(bpy.types.Operator):
    """Save a calibration profile from a photo of a known lamp (household bulb, daylight or a
    metered lamp), taken with the same camera, disc and set-up as later photos"""

    bl_idname = "cd_spectra.calibrate"
    bl_label = "Calibrate"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="Photo of known lamp", subtype="FILE_PATH", options={"SKIP_SAVE"})
    filter_glob: StringProperty(default=PHOTO_FILTER_GLOB, options={"HIDDEN"})
    lamp: EnumProperty(name="Known lamp", items=[(i, n, d) for i, n, d, _ in REFERENCE_LAMPS],
                       default="incandescent")
    spd_path: StringProperty(name="Lamp spectrum", subtype="FILE_PATH", options={"SKIP_SAVE"})
    profile_name: StringProperty(name="Calibration name", options={"SKIP_SAVE"})

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        settings = context.scene.cd_spectra
        self.filepath = self.filepath or settings.calibration_photo
        if not self.properties.is_property_set("lamp"):
            self.lamp = settings.calibration_lamp
        self.spd_path = self.spd_path or settings.calibration_spd_path
        self.profile_name = self.profile_name or settings.calibration_name
        return self.execute(context)

    def _reference_spd(self) -> list[float]:
        from ..spectra_io import read_reference, standard_lamp

        if self.lamp == "FILE":
            if not self.spd_path:
                raise ValueError("choose the lamp's spectrum file")
            _, spd = read_reference(bpy.path.abspath(self.spd_path))
        else:
            spd = standard_lamp(self.lamp)
        valid = state.valid_spd(spd)
        if valid is None:
            raise ValueError("the lamp's spectrum has no usable values between 380 and 780 nm")
        return valid

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.cd_spectra
        photo = bpy.path.abspath(self.filepath or settings.calibration_photo)
        name = (self.profile_name or settings.calibration_name).strip()
        if not photo:
            self.report({"ERROR"}, "Choose the photo of the known lamp")
            return {"CANCELLED"}
        if not name:
            self.report({"ERROR"}, "Give the calibration profile a name")
            return {"CANCELLED"}
        try:
            from ...core.inverse.calibration_shot import calibrate_photo
        except ImportError as exc:
            self.report({"ERROR"}, f"This build of CD Spectra cannot calibrate ({exc})")
            return {"CANCELLED"}
        import numpy as np

        with progress(context) as update:
            try:
                update(0.0, "calibrating")
                reference = np.asarray(self._reference_spd(), dtype=np.float64)
                profile = calibrate_photo(photo, reference, name, settings.preset or DEFAULT_PRESET,
                                          state.camera_choice(settings.camera))
            except (CDSpectraError, ValueError, OSError) as exc:
                self.report({"ERROR"}, f"Calibration failed: {exc}")
                return {"CANCELLED"}
            except Exception as exc:  # a bug, not the photo: say so; nothing was saved
                self.report({"ERROR"}, f"Calibration failed: internal error in CD Spectra ({type(exc).__name__}: "
                            f"{exc}); nothing was saved. This is a bug: please report it with the photo")
                return {"CANCELLED"}
        settings.calibration_photo = self.filepath or settings.calibration_photo
        settings.calibration_name = name
        saved_as = Path(profile).stem  # the profile's name is its file's (the core makes names file-safe)
        if saved_as in calibration_names():
            settings.calibration = saved_as  # the new profile is the one to use from now on
        self.report({"INFO"}, f"Saved calibration profile {saved_as} ({profile})")
        return {"FINISHED"}
