"""Operators, one per file; registered together in a fixed order and removed in reverse."""

from __future__ import annotations

from ..registration import register_classes, unregister_classes
from .apply_to_light import CDSPECTRA_OT_apply_to_light
from .calibrate import CDSPECTRA_OT_calibrate
from .create_light import CDSPECTRA_OT_create_light
from .estimate_spd import CDSPECTRA_OT_estimate_spd
from .export_spd import CDSPECTRA_OT_export_spd
from .joint_photos import (CDSPECTRA_OT_estimate_joint, CDSPECTRA_OT_joint_add_photos,
                           CDSPECTRA_OT_joint_remove_photo)
from .load_reference_spd import CDSPECTRA_OT_load_reference_spd
from .save_measured_setup import CDSPECTRA_OT_save_measured_setup

classes = (
    CDSPECTRA_OT_estimate_spd,
    CDSPECTRA_OT_create_light,
    CDSPECTRA_OT_apply_to_light,
    CDSPECTRA_OT_export_spd,
    CDSPECTRA_OT_load_reference_spd,
    CDSPECTRA_OT_calibrate,
    CDSPECTRA_OT_save_measured_setup,
    CDSPECTRA_OT_joint_add_photos,
    CDSPECTRA_OT_joint_remove_photo,
    CDSPECTRA_OT_estimate_joint,
)


def register() -> None:
    register_classes(classes)


def unregister() -> None:
    unregister_classes(classes)
