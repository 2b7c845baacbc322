"""Scene settings of the add-on (``scene.cd_spectra``) and the choices its menus offer.

Capture presets (the shipped ones, then the user's own from their presets folder), cameras and
calibration profiles come from the core at draw time (dynamic enums), so registering reads no
files. Dynamic enum items carry a number derived from the
identifier's CRC-32: a .blend saved with one camera list reopens on the same camera when a later
version adds cameras (plain indices would shift).
"""

from __future__ import annotations

import zlib
from typing import Any

import bpy
from bpy.props import (
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ..core.scene.preset_names import DEFAULT_PRESET
from ..core.spectra.cameras import DEFAULT_CAMERA, GENERIC_CAMERA
from ..core.spectra.illuminants import KNOWN_LAMPS
from .registration import register_classes, unregister_classes

NO_CALIBRATION = "NONE"

PHOTO_FILTER_GLOB = "*.jpg;*.jpeg;*.png;*.tif;*.tiff;*.exr;*.gif"
SPECTRA_FILTER_GLOB = "*.csv;*.tsv;*.txt;*.json;*.spd;*.xml;*.spdx"

LIGHT_TYPES = [
    ("SPOT", "Spot", "Spot light (the usual lamp on a stand)", "LIGHT_SPOT", 0),
    ("AREA", "Area", "Area light (panels, softboxes)", "LIGHT_AREA", 1),
    ("POINT", "Point", "Point light (bare bulbs)", "LIGHT_POINT", 2),
    ("SUN", "Sun", "Sun light (daylight, far sources)", "LIGHT_SUN", 3),
]

# The core's known lamps (one table), plus a metered spectrum file.
REFERENCE_LAMPS = [
    *((key, lamp.label, lamp.description, i) for i, (key, lamp) in enumerate(KNOWN_LAMPS.items())),
    ("FILE", "Spectrum file", "The lamp's spectrum measured by a meter (CSV, JSON, pbrt, TM-27-14)", 99),
]

# Blender keeps only pointers to enum item strings: the lists must stay alive in Python.
_ITEMS: dict[str, list[tuple[str, str, str, int]]] = {}
_USER_PRESETS: dict[str, tuple[tuple[str, int], ...]] = {}  # the user preset files the menu was built from

DISCS = [("cd", "CD", "A CD: track pitch 1.6 µm", 0), ("dvd", "DVD", "A DVD: track pitch 0.74 µm", 1)]


def stable_number(identifier: str) -> int:
    """Enum item number that does not depend on the item's position in the list."""
    return zlib.crc32(identifier.encode("utf-8")) & 0x7FFFFFFF


def _user_preset_files() -> tuple[tuple[str, int], ...]:
    """(name, modification time) of the user's presets: what the menu's user part depends on."""
    from ..core.scene.capture import preset_path, user_preset_names

    out = []
    for name in user_preset_names():
        try:
            out.append((name, preset_path(name).stat().st_mtime_ns))
        except OSError:
            continue
    return tuple(out)


def preset_items(_self: Any, _context: Any) -> list[tuple[str, str, str, int]]:
    """Shipped presets (read once), then the user's own (re-listed when their folder changes: a
    folder listing per call, descriptions read only for new or changed files)."""
    from ..core.errors import CDSpectraError
    from ..core.scene.capture import load_preset, preset_names

    if "shipped_presets" not in _ITEMS:
        items = []
        for name in preset_names():
            try:
                description = load_preset(name).description or name
            except ValueError:
                continue
            items.append((name, name, description, stable_number(name)))
        _ITEMS["shipped_presets"] = items
    files = _user_preset_files()
    if _USER_PRESETS.get("files") != files or "preset" not in _ITEMS:
        mine = []
        for name, _ in files:
            try:
                description = load_preset(name).description or name
            except CDSpectraError as exc:
                description = f"cannot be used: {exc}"
            mine.append((name, name, f"Your preset: {description}", stable_number(name)))
        _USER_PRESETS["files"] = files
        _ITEMS["preset"] = _ITEMS["shipped_presets"] + mine
    return _ITEMS["preset"]


def camera_items(_self: Any, _context: Any) -> list[tuple[str, str, str, int]]:
    if "camera" not in _ITEMS:
        from ..core.spectra.cameras import camera_names

        names = camera_names()
        items = [(DEFAULT_CAMERA, DEFAULT_CAMERA.replace("_", " "), "Default camera profile",
                  stable_number(DEFAULT_CAMERA)),
                 (GENERIC_CAMERA, "Generic camera", "Your camera is not listed: a typical camera's "
                  "sensitivities (less accurate; a calibration shot helps most here)",
                  stable_number(GENERIC_CAMERA))]
        items += [(n, n.replace("_", " "), f"Spectral sensitivities of the {n.replace('_', ' ')}",
                   stable_number(n)) for n in names if n != DEFAULT_CAMERA]
        _ITEMS["camera"] = items
    return _ITEMS["camera"]


def calibration_names() -> list[str]:
    """Saved calibration profiles (none until the estimator's calibration module is present)."""
    try:
        from ..core.calibration.calibration import list_calibrations
    except ImportError:
        return []
    names = []
    for entry in list_calibrations():
        names.append(str(getattr(entry, "name", entry)))
    return names


def calibration_items(_self: Any, _context: Any) -> list[tuple[str, str, str, int]]:
    items = [(NO_CALIBRATION, "None", "No calibration profile", 0)]
    items += [(n, n, f"Calibration profile {n}", stable_number(n) or 1) for n in calibration_names()]
    _ITEMS["calibration"] = items  # replaced on every call, kept alive until the next
    return items


class CDSpectraJointPhoto(bpy.types.PropertyGroup):
    """One photo of a joint estimate (several photos of one lamp)."""

    path: StringProperty(name="Photo", subtype="FILE_PATH",
                         description="A photo of the CD under the same lamp as the others")


class CDSpectraSettings(bpy.types.PropertyGroup):
    """Everything the sidebar shows; saved in the .blend with the scene."""

    photo_path: StringProperty(
        name="Photo", subtype="FILE_PATH",
        description="Photo of a CD lit by the lamp, lamp and camera on the disc's axis "
                    "(JPEG, PNG, TIFF, EXR or GIF)")
    photo_frame: IntProperty(
        name="Frame", min=0, default=0,
        description="Which frame of the animated GIF to read, counted from 0: each frame is a photo of its own")
    preset: EnumProperty(
        name="Capture", items=preset_items, default=stable_number(DEFAULT_PRESET),
        description="How the photo was taken (disc, distances)")
    camera: EnumProperty(
        name="Camera", items=camera_items, default=stable_number(DEFAULT_CAMERA),
        description="Camera that took the photo (its colour sensitivities)")
    calibration: EnumProperty(
        name="Calibration", items=calibration_items, default=0,
        description="Calibration from a photo of a known lamp taken with the same camera and disc")
    light_type: EnumProperty(name="Light", items=LIGHT_TYPES, default="SPOT",
                             description="Type of light to create")

    estimate_json: StringProperty(
        name="Last estimate", options={"HIDDEN"},
        description="The last estimate as JSON (what the command line prints), its SPD included")
    node_group: PointerProperty(name="Spectral light", type=bpy.types.NodeTree,
                                description="Node group holding the last estimated SPD")

    reference_path: StringProperty(name="Reference", subtype="FILE_PATH",
                                   description="Spectrum file to compare the estimate with")
    reference_json: StringProperty(name="Reference spectrum", options={"HIDDEN"})
    reference_node_group: PointerProperty(name="Reference curve", type=bpy.types.NodeTree)

    calibration_photo: StringProperty(
        name="Photo of known lamp", subtype="FILE_PATH",
        description="Photo of the CD under a lamp whose spectrum is known, same camera and set-up")
    calibration_lamp: EnumProperty(name="Known lamp", items=REFERENCE_LAMPS, default="incandescent")
    calibration_spd_path: StringProperty(name="Lamp spectrum", subtype="FILE_PATH",
                                         description="The lamp's spectrum as measured by a meter")
    # Optional: a second photo under a known lamp of another colour (daylight beside a bulb).
    calibration_photo2: StringProperty(
        name="Second photo", subtype="FILE_PATH",
        description="Optional: the CD under a second known lamp of another colour (daylight beside a bulb), "
                    "same camera, settings and set-up — it measures the colours the first lamp leaves dark")
    calibration_lamp2: EnumProperty(name="Second lamp", items=REFERENCE_LAMPS, default="daylight-d65")
    calibration_spd_path2: StringProperty(name="Second lamp spectrum", subtype="FILE_PATH",
                                          description="The second lamp's spectrum as measured by a meter")
    calibration_name: StringProperty(name="Calibration name", default="my-camera",
                                      description="Name to save the calibration profile under")

    # A set-up described by what can be measured (core.planning.measured): saved as a preset of the user's.
    # Limits are loose on purpose: the core refuses what cannot be, with a message naming the field.
    setup_name: StringProperty(name="Preset name", default="my-setup",
                               description="Name to save this set-up under, as a preset of yours")
    setup_lamp_distance_mm: FloatProperty(name="Lamp distance (mm)", default=300.0, min=0.0, soft_max=5000.0,
                                          description="From the disc centre to the lamp (its glowing part)")
    setup_lamp_angle_deg: FloatProperty(name="Lamp angle (°)", default=30.0, min=0.0, max=180.0,
                                        description="From the disc's axis: 0 straight above the disc, 90 in its plane")
    setup_lamp_azimuth_deg: FloatProperty(name="Lamp azimuth (°)", default=180.0, min=-360.0, max=360.0,
                                          description="Around the disc's axis, seen from above, counter-clockwise; "
                                                      "facing the disc from the camera, +90° from the camera is "
                                                      "on your right")
    setup_camera_distance_mm: FloatProperty(name="Camera distance (mm)", default=250.0, min=0.0, soft_max=2000.0,
                                            description="From the disc centre to the lens")
    setup_camera_angle_deg: FloatProperty(name="Camera angle (°)", default=35.0, min=0.0, max=180.0,
                                          description="From the disc's axis: 0 straight above the disc")
    setup_camera_azimuth_deg: FloatProperty(name="Camera azimuth (°)", default=0.0, min=-360.0, max=360.0,
                                            description="Measured like the lamp's; only the difference matters")
    setup_disc: EnumProperty(name="Disc", items=DISCS, default="cd")
    setup_lamp_size_mm: FloatProperty(name="Lamp size (mm)", default=0.0, min=0.0, soft_max=100.0,
                                      description="Glowing part (filament, LED, a card's hole); 0: not known")
    setup_focal_mm: FloatProperty(name="Focal length (mm)", default=26.0, min=0.0, soft_max=600.0,
                                  description="Lens focal length; a phone's 35 mm-equivalent with a 36 mm sensor")
    setup_sensor_width_mm: FloatProperty(name="Sensor width (mm)", default=36.0, min=0.0, soft_max=50.0,
                                         description="The sensor width the focal length is for (36: 35 mm-equivalent)")
    setup_aperture_mm: FloatProperty(name="Aperture (mm)", default=3.0, min=0.0, soft_max=50.0,
                                     description="Lens entrance pupil: focal length / f-number (a phone: about 3)")

    joint_photos: CollectionProperty(
        type=CDSpectraJointPhoto, name="Photos of one lamp",
        description="Several photos of the CD under the same lamp (angles, positions, video frames): one "
                    "estimate from all of them")


_CLASSES = (CDSpectraJointPhoto, CDSpectraSettings)  # the item first: the settings hold a collection of it


def register() -> None:
    register_classes(_CLASSES)
    try:
        bpy.types.Scene.cd_spectra = PointerProperty(type=CDSpectraSettings)
    except Exception:
        unregister_classes(_CLASSES)
        raise


def refresh_presets() -> None:
    """Forget the preset menu's items (a preset was saved): the next draw lists the folder again."""
    _ITEMS.pop("preset", None)
    _USER_PRESETS.clear()


def unregister() -> None:
    del bpy.types.Scene.cd_spectra
    unregister_classes(_CLASSES)
    _ITEMS.clear()
    _USER_PRESETS.clear()
