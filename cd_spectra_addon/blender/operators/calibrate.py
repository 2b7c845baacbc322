"""Calibrate camera + disc + set-up from a photo of a lamp whose spectrum is known (and optionally a
second photo under a known lamp of another colour)."""

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
    filepath2: StringProperty(name="Second photo", subtype="FILE_PATH", options={"SKIP_SAVE"})
    lamp2: EnumProperty(name="Second lamp", items=[(i, n, d) for i, n, d, _ in REFERENCE_LAMPS],
                        default="daylight-d65")
    spd_path2: StringProperty(name="Second lamp spectrum", subtype="FILE_PATH", options={"SKIP_SAVE"})
    profile_name: StringProperty(name="Calibration name", options={"SKIP_SAVE"})

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        settings = context.scene.cd_spectra
        self.filepath = self.filepath or settings.calibration_photo
        if not self.properties.is_property_set("lamp"):
            self.lamp = settings.calibration_lamp
        self.spd_path = self.spd_path or settings.calibration_spd_path
        self.filepath2 = self.filepath2 or settings.calibration_photo2
        if not self.properties.is_property_set("lamp2"):
            self.lamp2 = settings.calibration_lamp2
        self.spd_path2 = self.spd_path2 or settings.calibration_spd_path2
        self.profile_name = self.profile_name or settings.calibration_name
        return self.execute(context)

    @staticmethod
    def _reference(lamp: str, spd_path: str) -> tuple[list[float], str]:
        """(SPD, name for the profile) of a known lamp or a spectrum file."""
        from ..spectra_io import read_reference, standard_lamp

        if lamp == "FILE":
            if not spd_path:
                raise ValueError("choose the lamp's spectrum file")
            _, spd = read_reference(bpy.path.abspath(spd_path))
            name = Path(bpy.path.abspath(spd_path)).name
        else:
            spd = standard_lamp(lamp)
            name = next(label for key, label, _, _ in REFERENCE_LAMPS if key == lamp)
        valid = state.valid_spd(spd)
        if valid is None:
            raise ValueError("the lamp's spectrum has no usable values between 380 and 780 nm")
        return valid, name

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
            from ...core.inverse.calibration_shot import LampPhoto, calibrate_photos
        except ImportError as exc:
            self.report({"ERROR"}, f"This build of CD Spectra cannot calibrate ({exc})")
            return {"CANCELLED"}
        import numpy as np

        with progress(context) as update:
            try:
                update(0.0, "calibrating")
                shots = []
                second = bpy.path.abspath(self.filepath2 or settings.calibration_photo2)
                for path, lamp, spd_path in ((photo, self.lamp, self.spd_path),
                                             (second, self.lamp2, self.spd_path2)):
                    if path:  # the second photo is optional
                        spd, lamp_name = self._reference(lamp, spd_path)
                        shots.append(LampPhoto(path, np.asarray(spd, dtype=np.float64), lamp_name))
                profile = calibrate_photos(shots, name, settings.preset or DEFAULT_PRESET,
                                           state.camera_choice(settings.camera))
            except (CDSpectraError, ValueError, OSError) as exc:
                self.report({"ERROR"}, f"Calibration failed: {exc}")
                return {"CANCELLED"}
            except Exception as exc:  # a bug, not the photo: say so; nothing was saved
                self.report({"ERROR"}, f"Calibration failed: internal error in CD Spectra ({type(exc).__name__}: "
                            f"{exc}); nothing was saved. This is a bug: please report it with the photo")
                return {"CANCELLED"}
        settings.calibration_photo = self.filepath or settings.calibration_photo
        settings.calibration_photo2 = self.filepath2 or settings.calibration_photo2
        settings.calibration_name = name
        saved_as = Path(profile).stem  # the profile's name is its file's (the core makes names file-safe)
        if saved_as in calibration_names():
            settings.calibration = saved_as  # the new profile is the one to use from now on
        self.report({"INFO"}, f"Saved calibration profile {saved_as} ({profile})")
        self._report_checks(profile)
        return {"FINISHED"}

    def _report_checks(self, profile: Path) -> None:
        """What ``calibrate`` prints after saving, in the status bar: the cross-check of two
        lamps, and the warning of a calibration that cannot explain its photo or does not carry
        over from one known lamp to another (every estimate with it repeats it)."""
        from ...core.calibration.calibration import calibration_warning, cross_check_summary, load_calibration

        try:
            made = load_calibration(profile)
        except (CDSpectraError, ValueError, OSError):
            return  # just saved by the core: nothing to add if it cannot be read back
        checked = cross_check_summary(made)
        if checked:
            self.report({"INFO"}, checked)
        poor = calibration_warning(made)
        if poor:
            self.report({"WARNING"}, poor)
