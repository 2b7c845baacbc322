"""Several photos of one lamp: the list the joint estimate reads, and the estimate itself."""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import bpy
from bpy.props import CollectionProperty, IntProperty, StringProperty

from .. import state
from ..properties import DEFAULT_PRESET, PHOTO_FILTER_GLOB
from .estimate_spd import run_and_store


class CDSPECTRA_OT_joint_add_photos(bpy.types.Operator):
    """Add photos of the CD under the same lamp (select several in the file browser)"""

    bl_idname = "cd_spectra.joint_add_photos"
    bl_label = "Add Photos"
    bl_options = {"REGISTER", "UNDO"}

    directory: StringProperty(subtype="DIR_PATH", options={"SKIP_SAVE"})
    files: CollectionProperty(type=bpy.types.OperatorFileListElement, options={"SKIP_SAVE"})
    filter_glob: StringProperty(default=PHOTO_FILTER_GLOB, options={"HIDDEN"})

    def invoke(self, context: bpy.types.Context, event: Any) -> set[str]:
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        photos = context.scene.cd_spectra.joint_photos
        names = [f.name for f in self.files if f.name]
        if not names:
            self.report({"ERROR"}, "Choose one or more photos")
            return {"CANCELLED"}
        have = {p.path for p in photos}
        added = 0
        for name in names:
            path = os.path.join(self.directory, name)
            if path not in have:
                photos.add().path = path
                have.add(path)
                added += 1
        self.report({"INFO"}, f"Added {added} photo{'s' if added != 1 else ''} ({len(photos)} in the list)")
        return {"FINISHED"}


class CDSPECTRA_OT_joint_remove_photo(bpy.types.Operator):
    """Remove a photo from the list (all of them with index -1)"""

    bl_idname = "cd_spectra.joint_remove_photo"
    bl_label = "Remove Photo"
    bl_options = {"REGISTER", "UNDO"}

    index: IntProperty(name="Photo", default=-1)

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        settings = getattr(context.scene, "cd_spectra", None)
        if settings is None or not settings.joint_photos:
            cls.poll_message_set("The list is empty")
            return False
        return True

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.cd_spectra
        photos = settings.joint_photos
        if self.index < 0:
            photos.clear()
        elif self.index < len(photos):
            photos.remove(self.index)
        else:
            self.report({"ERROR"}, f"No photo {self.index + 1} in the list")
            return {"CANCELLED"}
        return {"FINISHED"}


class CDSPECTRA_OT_estimate_joint(bpy.types.Operator):
    """One spectrum from every photo in the list (same lamp; each photo's pose and brightness are fitted; an
    animated GIF is each of its frames)"""

    bl_idname = "cd_spectra.estimate_joint"
    bl_label = "Estimate from All Photos"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context: bpy.types.Context) -> bool:
        settings = getattr(context.scene, "cd_spectra", None)
        if settings is None or not settings.joint_photos:
            cls.poll_message_set("Add photos of the same lamp first")
            return False
        return True

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.cd_spectra
        paths = [bpy.path.abspath(p.path) for p in settings.joint_photos if p.path]
        if not paths:
            self.report({"ERROR"}, "Add photos of the same lamp first")
            return {"CANCELLED"}
        try:
            from ...core.inverse.joint import estimate_joint
        except ImportError as exc:
            self.report({"ERROR"}, f"This build of CD Spectra has no estimator ({exc})")
            return {"CANCELLED"}

        def estimate(update: Callable[[float, str], None], space: str) -> Any:
            photos = [frame for path in paths for frame in _frames(path)]
            return estimate_joint(photos, preset=settings.preset or DEFAULT_PRESET,
                                  camera=state.camera_choice(settings.camera),
                                  calibration=state.calibration_choice(settings.calibration), working_space=space,
                                  progress=update)

        return {"FINISHED"} if run_and_store(self, context, estimate) else {"CANCELLED"}


def _frames(path: str) -> list[str]:
    """The photos a listed file holds: an animated GIF's frames (``FILE.gif#N``), else the file.
    One that cannot be opened stays as it is: the joint estimate lists it as left out, saying why."""
    from ...core.errors import PhotoError
    from ...core.photo.frames import photo_frames

    try:
        return photo_frames(path)
    except PhotoError:
        return [path]
