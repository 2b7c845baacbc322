"""Capture geometry: the disc, the pinhole camera and the lamp, loaded from preset JSON files.

World frame (shared with the Blender scene): metres, disc centre at the origin, disc normal +z.
A preset's camera sits anywhere above the disc (``camera.position_mm``, aimed at
``camera.look_at_mm``, the disc centre by default, image up towards ``camera.up``); without a
position it is on the axis at ``distance_mm`` looking down −z with image rows running towards
−y (the original presets, which give bit-identical scenes). The lamp is anywhere
(``light.position_mm``, metres away too) and the disc may be tilted (``disc_tilt_deg``).
Presets describe the nominal capture; a :class:`Pose` adds what a real user gets wrong
(camera or lamp moved sideways, a tilted disc) on top of it.

Presets ship in ``presets/``; a user's own (a set-up described by measurements,
``planning.measured``) live in ``user_folders.preset_dir()`` and are found by name after the
shipped ones, which they may not shadow.
"""

from __future__ import annotations

import hashlib
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..atomic_files import write_json
from ..errors import CDSpectraError
from ..user_folders import preset_dir
from ..validation import check_number, check_numbers
from .kernel import camera_rays, intersect_plane, project, rotation_xy
from .preset_names import (DEFAULT_PRESET, DISTANT_LAMP_PRESET, FAR_LIGHT_PRESET, NEAR_AXIS_PRESET, OBLIQUE_PRESET,
                           PAPER_PRESET, REFERENCE_PRESET, SETUP_PRESETS)

PRESET_DIR = Path(__file__).resolve().parents[2] / "presets"

__all__ = [
    "Disc",
    "Camera",
    "Light",
    "Preset",
    "Pose",
    "Scene",
    "PRESET_DIR",
    "preset_digests",
    "DEFAULT_PRESET",
    "REFERENCE_PRESET",
    "NEAR_AXIS_PRESET",
    "OBLIQUE_PRESET",
    "DISTANT_LAMP_PRESET",
    "SETUP_PRESETS",
    "FAR_LIGHT_PRESET",
    "PAPER_PRESET",
    "preset_names",
    "user_preset_names",
    "preset_path",
    "load_preset",
    "preset_from_dict",
    "user_preset_name",
    "save_user_preset",
]


@dataclass(frozen=True)
class Disc:
    """Optical data of the disc. Pitch and groove height in µm, radii in mm."""

    pitch_um: float = 1.6
    groove_height_um: float = 0.045  # amplitude h0 of the sinusoidal profile
    profile: str = "sinusoidal"  # or "rectangular" (binary pits of width duty·pitch)
    duty: float = 0.31  # pit width / pitch, rectangular profile only
    medium_index: float = 1.585  # polycarbonate above the aluminium
    hole_radius_mm: float = 7.5
    rim_radius_mm: float = 60.0
    grating_r_min_mm: float = 23.0
    grating_r_max_mm: float = 58.5
    diffuse_albedo: float = 0.02
    max_order: int = 3


_ORIGIN_MM = (0.0, 0.0, 0.0)
_WORLD_UP = (0.0, 1.0, 0.0)


@dataclass(frozen=True)
class Camera:
    """Pinhole camera (Blender: sensor fit horizontal).

    ``position_mm`` None: on the disc axis at ``distance_mm``, looking straight down (the
    original presets). Otherwise anywhere above the disc, aimed at ``look_at_mm``;
    ``distance_mm`` is then the distance from the camera to that aim point (derived when a
    preset file gives only the position). ``up`` is the world direction that appears upwards
    in the image (projected onto the image plane).
    """

    distance_mm: float = 210.0
    focal_length_mm: float = 58.0
    sensor_width_mm: float = 36.0
    image_size_px: tuple[int, int] = (512, 512)  # width, height
    position_mm: tuple[float, float, float] | None = None
    look_at_mm: tuple[float, float, float] = _ORIGIN_MM
    up: tuple[float, float, float] = _WORLD_UP

    @property
    def focal_px(self) -> float:
        return self.focal_length_mm / self.sensor_width_mm * self.image_size_px[0]

    @property
    def is_on_axis(self) -> bool:
        """The original geometry: on the disc axis, looking straight down, +y up."""
        return self.position_mm is None and self.look_at_mm == _ORIGIN_MM and self.up == _WORLD_UP

    @property
    def nominal_position_mm(self) -> tuple[float, float, float]:
        """Where the preset puts the camera (before any :class:`Pose` offset)."""
        if self.position_mm is None:
            ax, ay, az = self.look_at_mm
            return (ax, ay, az + self.distance_mm)
        return self.position_mm

    def rotation(self) -> NDArray[np.float64]:
        """Camera-to-world rotation, columns (image right, image up, backwards), as Blender's
        camera matrix: the camera looks down its own −z."""
        if self.is_on_axis:
            return np.eye(3)
        eye = np.asarray(self.nominal_position_mm, dtype=np.float64)
        forward = np.asarray(self.look_at_mm, dtype=np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(self.up, dtype=np.float64))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        return np.stack([right, up, -forward], axis=1)


@dataclass(frozen=True)
class Light:
    """Small lamp; ``lobe_sigma`` is its angular size (Gaussian std, radians) in (u, v)."""

    position_mm: tuple[float, float, float] = (0.0, 0.0, 210.0)  # anywhere, metres away too
    lobe_sigma: float = 0.003
    intensity: float = 1.0  # radiant intensity per nm, arbitrary units


@dataclass(frozen=True)
class Preset:
    name: str
    description: str
    disc: Disc
    camera: Camera
    light: Light
    samples: int = 16  # Cycles samples per pixel for basis renders
    disc_tilt_deg: tuple[float, float] = (0.0, 0.0)  # nominal disc tilt about x then y

    def with_image_size(self, width: int, height: int | None = None) -> "Preset":
        """Same capture at another resolution (field of view unchanged)."""
        size = (int(width), int(height if height is not None else width))
        return replace(self, camera=replace(self.camera, image_size_px=size))

    def to_dict(self) -> dict[str, Any]:
        """The preset as its JSON file holds it. Full-pose fields appear only where they differ
        from the on-axis defaults, so the original presets (and basis-cube cache keys, which
        hash this) are unchanged."""
        camera = {k: list(v) if isinstance(v, tuple) else v for k, v in self.camera.__dict__.items()}
        for key, default in (("position_mm", None), ("look_at_mm", _ORIGIN_MM), ("up", _WORLD_UP)):
            if getattr(self.camera, key) == default:
                del camera[key]
        data = {
            "name": self.name,
            "description": self.description,
            "disc": self.disc.__dict__.copy(),
            "camera": camera,
            "light": {**self.light.__dict__, "position_mm": list(self.light.position_mm)},
            "samples": self.samples,
        }
        if self.disc_tilt_deg != (0.0, 0.0):
            data["disc_tilt_deg"] = list(self.disc_tilt_deg)
        return data


@dataclass(frozen=True)
class Pose:
    """Departures from the preset: lateral offsets (mm), a disc tilt about x and y (degrees), the
    camera turned about its own image axes (degrees: about image right, then image up — a
    camera aimed a few degrees off), and the lamp swung about the disc centre (degrees, about
    world x then y — a lamp placed a few degrees off its stated angle, whatever its distance)."""

    camera_offset_mm: tuple[float, float] = (0.0, 0.0)
    light_offset_mm: tuple[float, float] = (0.0, 0.0)
    tilt_deg: tuple[float, float] = (0.0, 0.0)
    camera_rotation_deg: tuple[float, float] = (0.0, 0.0)
    light_rotation_deg: tuple[float, float] = (0.0, 0.0)

    @property
    def turns_camera(self) -> bool:
        return self.camera_rotation_deg != (0.0, 0.0)


@dataclass(frozen=True)
class Scene:
    """A fully posed capture in world metres, ready for ray casting or a Blender scene."""

    preset: Preset
    pose: Pose = field(default_factory=Pose)

    @property
    def camera_position(self) -> NDArray[np.float64]:
        dx, dy = self.pose.camera_offset_mm
        cam = self.preset.camera
        if cam.is_on_axis:
            return np.array([dx, dy, cam.distance_mm]) * 1e-3
        x, y, z = cam.nominal_position_mm
        return np.array([x + dx, y + dy, z]) * 1e-3

    @property
    def camera_rotation(self) -> NDArray[np.float64]:
        """Camera-to-world rotation (columns: image right, image up, backwards). A Pose offset
        moves the camera sideways without turning it; ``camera_rotation_deg`` turns it about its
        own image axes."""
        base = self.preset.camera.rotation()
        if not self.pose.turns_camera:
            return base
        return base @ rotation_xy(*self.pose.camera_rotation_deg)

    @property
    def looks_straight_down(self) -> bool:
        """The original geometry's camera: on-axis preset, not turned (rays need no rotation)."""
        return self.preset.camera.is_on_axis and not self.pose.turns_camera

    @property
    def camera_look_at(self) -> NDArray[np.float64]:
        """The world point on the optical axis the camera aims at (metres), offset moved too; a
        turned camera aims where its optical axis now meets the preset aim point's height."""
        dx, dy = self.pose.camera_offset_mm
        x, y, z = self.preset.camera.look_at_mm
        aim = np.array([x + dx, y + dy, z]) * 1e-3
        if not self.pose.turns_camera:
            return aim
        eye = self.camera_position
        forward = -self.camera_rotation[:, 2]
        if forward[2] >= -1e-9:
            return eye + forward * float(np.linalg.norm(aim - eye))  # looks level or up: keep the distance
        return eye + forward * ((aim[2] - eye[2]) / forward[2])

    @property
    def light_position(self) -> NDArray[np.float64]:
        dx, dy = self.pose.light_offset_mm
        x, y, z = self.preset.light.position_mm
        position = np.array([x + dx, y + dy, z]) * 1e-3
        if self.pose.light_rotation_deg != (0.0, 0.0):
            position = rotation_xy(*self.pose.light_rotation_deg) @ position  # about the disc centre (origin)
        return position

    @property
    def disc_center(self) -> NDArray[np.float64]:
        return np.zeros(3)

    @property
    def disc_rotation(self) -> NDArray[np.float64]:
        """Rotation of the disc (columns: its x, y and normal axes in the world), Rx then Ry."""
        return rotation_xy(*(n + p for n, p in zip(self.preset.disc_tilt_deg, self.pose.tilt_deg)))

    @property
    def disc_normal(self) -> NDArray[np.float64]:
        return self.disc_rotation[:, 2].copy()

    def pixel_rays(
        self, rows: NDArray[np.float64], cols: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Unit world directions through image positions (pixel convention of :mod:`.kernel`)."""
        cam = self.preset.camera
        d = camera_rays(rows, cols, cam.image_size_px, cam.focal_px)
        return d if self.looks_straight_down else d @ self.camera_rotation.T

    def intersect_disc(
        self, directions: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Points where camera rays meet the disc plane and a mask of those on the disc annulus."""
        t, points = intersect_plane(directions, self.camera_position, self.disc_center, self.disc_normal)
        radius = np.linalg.norm(self.to_disc_frame(points)[..., :2], axis=-1) * 1e3
        disc = self.preset.disc
        hit = (t > 0) & (radius >= disc.hole_radius_mm) & (radius <= disc.rim_radius_mm)
        return points, hit

    def to_disc_frame(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points in the disc's own frame (x, y in its plane, z along its normal)."""
        return (points - self.disc_center) @ self.disc_rotation

    def to_camera_frame(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points in the camera's frame (x right, y up, looking down −z)."""
        rel = np.asarray(points, dtype=np.float64) - self.camera_position
        return rel if self.looks_straight_down else rel @ self.camera_rotation

    def project(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """(row, col) image positions of world points (pixel convention of :mod:`.kernel`)."""
        cam = self.preset.camera
        return project(self.to_camera_frame(points), cam.image_size_px, cam.focal_px)

    def geometry_dict(self) -> dict[str, Any]:
        """The numbers a user or test needs to interpret a photo of this capture."""
        cam = self.preset.camera
        center = self.project(self.disc_center[None, :])[0]
        px_per_mm = cam.focal_px / (cam.distance_mm)  # disc plane on axis, pinhole magnification
        return {
            "preset": self.preset.name,
            "pitch_um": self.preset.disc.pitch_um,
            "camera_distance_mm": cam.distance_mm,
            "light_distance_mm": float(np.linalg.norm(self.light_position - self.disc_center) * 1e3),
            "camera_position_mm": (self.camera_position * 1e3).tolist(),
            "light_position_mm": (self.light_position * 1e3).tolist(),
            "disc_normal": self.disc_normal.tolist(),
            "image_size_px": list(cam.image_size_px),
            "disc_center_px": [float(center[1]), float(center[0])],  # x (column), y (row)
            "px_per_mm": float(px_per_mm),
            "focal_px": float(cam.focal_px),
            "focal_length_mm": cam.focal_length_mm,
            "sensor_width_mm": cam.sensor_width_mm,
            "lobe_sigma": self.preset.light.lobe_sigma,
            "disc": self.preset.disc.__dict__.copy(),
            "camera_offset_mm": list(self.pose.camera_offset_mm),
            "light_offset_mm": list(self.pose.light_offset_mm),
            "tilt_deg": list(self.pose.tilt_deg),
            **({"camera_rotation_deg": list(self.pose.camera_rotation_deg)} if self.pose.turns_camera else {}),
            **({"light_rotation_deg": list(self.pose.light_rotation_deg)}
               if self.pose.light_rotation_deg != (0.0, 0.0) else {}),
            **self._full_pose_dict(),
        }

    def _full_pose_dict(self) -> dict[str, Any]:
        """Full-pose entries, only for presets that use them (keeps the original presets'
        geometry, and the basis-cube cache keys hashed from it, unchanged)."""
        extra: dict[str, Any] = {}
        if not self.looks_straight_down:
            extra["camera_look_at_mm"] = (self.camera_look_at * 1e3).tolist()
            extra["camera_rotation"] = self.camera_rotation.tolist()
        if self.preset.disc_tilt_deg != (0.0, 0.0):
            extra["disc_tilt_deg"] = list(self.preset.disc_tilt_deg)
        return extra


def preset_names() -> list[str]:
    """The presets that ship with the add-on."""
    return sorted(p.stem for p in PRESET_DIR.glob("*.json"))


def preset_digests() -> dict[str, str]:
    """Each shipped preset file's digest (16 hex digits): what a model records it was trained
    with, so a later change of a set-up's geometry shows (models/MODEL_CARD.md)."""
    return {name: hashlib.sha256((PRESET_DIR / f"{name}.json").read_bytes()).hexdigest()[:16]
            for name in preset_names()}


def user_preset_names() -> list[str]:
    """The user's own presets (``user_folders.preset_dir()``), those a shipped one does not
    shadow; none when the folder does not exist."""
    folder = preset_dir()
    try:
        found = [p.stem for p in folder.glob("*.json") if not p.name.startswith(".")] if folder.is_dir() else []
    except OSError:
        return []
    shipped = set(preset_names())
    return sorted(name for name in found if name not in shipped)


def preset_path(name_or_path: str | Path) -> Path:
    """The file of a preset given by name (shipped first, then the user's own) or by path."""
    path = Path(name_or_path)
    if path.suffix:
        return path
    shipped = PRESET_DIR / f"{name_or_path}.json"
    if shipped.is_file():
        return shipped
    mine = preset_dir() / f"{name_or_path}.json"
    return mine if mine.is_file() else shipped


def user_preset_name(name: str) -> str:
    """``name`` made safe as a preset's file name (letters, digits, ``_`` and ``-``: a dot would
    make ``--preset NAME`` read it as a file path). CDSpectraError if nothing is left of it or it
    is a shipped preset's name (the shipped one would always win)."""
    stem = re.sub(r"[^\w-]+", "_", str(name).strip(), flags=re.UNICODE).strip("_-")[:80]
    if not stem:
        raise CDSpectraError(f"a preset needs a name made of letters, digits, '-' or '_', not {name!r}")
    if stem in preset_names():
        raise CDSpectraError(f"{stem!r} is the name of a preset that ships with CD Spectra: choose another name")
    return stem


def save_user_preset(data: dict[str, Any], folder: Path | None = None) -> Path:
    """Validate a preset (a dict shaped like a preset file, its name made file-safe) and write it
    into the user's presets folder, whole or not at all; returns the file. ``load_preset(name)``,
    ``estimate --preset NAME`` and Blender's preset menu find it there."""
    name = user_preset_name(str(data.get("name", "")))
    data = {**data, "name": name}
    try:
        _from_dict(data)
    except (ValueError, TypeError, KeyError) as exc:
        raise CDSpectraError(f"preset {name!r} is not a valid preset: {exc}") from exc
    target = Path(folder) if folder is not None else preset_dir()
    try:
        target.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CDSpectraError(f"cannot make the presets folder {target}: {exc.strerror or exc}") from exc
    return write_json(target / f"{name}.json", data)


def preset_from_dict(data: dict[str, Any]) -> Preset:
    """A validated preset from a dict shaped like a preset file (ValueError/TypeError/KeyError
    name what is wrong); the set-up designer and planner build their presets through this."""
    return _from_dict(data)


def _from_dict(data: dict[str, Any]) -> Preset:
    disc = Disc(**data.get("disc", {}))
    cam_data = dict(data.get("camera", {}))
    if "image_size_px" in cam_data:
        cam_data["image_size_px"] = tuple(int(v) for v in cam_data["image_size_px"])
    for key in ("position_mm", "look_at_mm", "up"):
        if cam_data.get(key) is not None:
            cam_data[key] = check_numbers(f"camera.{key}", cam_data[key], 3, names="[x, y, z]")
    if cam_data.get("position_mm") is not None:
        aim = cam_data.get("look_at_mm", _ORIGIN_MM)
        span = math.dist(cam_data["position_mm"], aim)
        if span < 1e-6:
            raise ValueError("camera.look_at_mm must differ from camera.position_mm")
        if "distance_mm" not in cam_data:
            cam_data["distance_mm"] = span
        elif not math.isclose(float(cam_data["distance_mm"]), span, rel_tol=1e-6, abs_tol=1e-6):
            raise ValueError(f"camera.distance_mm {cam_data['distance_mm']!r} disagrees with the distance "
                             f"{span:.6g} mm from camera.position_mm to camera.look_at_mm; give one of them")
    camera = Camera(**cam_data)
    light_data = dict(data.get("light", {}))
    if "position_mm" in light_data:
        light_data["position_mm"] = tuple(float(v) for v in light_data["position_mm"])
    light = Light(**light_data)
    preset = Preset(
        name=str(data["name"]),
        description=str(data.get("description", "")),
        disc=disc,
        camera=camera,
        light=light,
        samples=int(data.get("samples", 16)),
        disc_tilt_deg=tuple(float(v) for v in data.get("disc_tilt_deg", (0.0, 0.0))),
    )
    _validate(preset)
    return preset


def _validate(preset: Preset) -> None:
    """Refuse a preset file's impossible values here, with the field's name, instead of a NaN
    image, a misleading 'no rainbow found' or a TypeError deep inside the estimate."""
    d, c, light = preset.disc, preset.camera, preset.light
    for name in ("pitch_um", "rim_radius_mm", "grating_r_max_mm"):
        check_number(f"disc.{name}", getattr(d, name), above=0.0)
    for name in ("groove_height_um", "hole_radius_mm", "grating_r_min_mm", "diffuse_albedo", "duty"):
        check_number(f"disc.{name}", getattr(d, name), at_least=0.0)
    check_number("disc.medium_index", d.medium_index, at_least=1.0)
    check_number("disc.max_order", d.max_order, at_least=0.0, integer=True)
    if d.profile not in ("sinusoidal", "rectangular"):
        raise ValueError(f"disc.profile must be 'sinusoidal' or 'rectangular', not {d.profile!r}")
    if d.duty > 1.0 or d.hole_radius_mm >= d.rim_radius_mm or d.grating_r_min_mm >= d.grating_r_max_mm:
        raise ValueError("disc: need duty ≤ 1, hole_radius_mm < rim_radius_mm and "
                         "grating_r_min_mm < grating_r_max_mm")
    for name in ("distance_mm", "focal_length_mm", "sensor_width_mm"):
        check_number(f"camera.{name}", getattr(c, name), above=0.0)
    for i, value in enumerate(c.image_size_px):
        check_number(f"camera.image_size_px[{i}]", value, at_least=1.0, integer=True)
    if len(c.image_size_px) != 2 or len(light.position_mm) != 3:
        raise ValueError("camera.image_size_px needs 2 values and light.position_mm 3")
    for i, value in enumerate(light.position_mm):
        check_number(f"light.position_mm[{i}]", value)
    if len(preset.disc_tilt_deg) != 2:
        raise ValueError("disc_tilt_deg needs 2 angles [about x, about y]")
    for i, value in enumerate(preset.disc_tilt_deg):
        check_number(f"disc_tilt_deg[{i}]", value, at_least=-80.0, at_most=80.0, unit=" degrees")
    _validate_aim(c)
    check_number("light.lobe_sigma", light.lobe_sigma, above=0.0)
    check_number("light.intensity", light.intensity, at_least=0.0)


def _validate_aim(camera: Camera) -> None:
    """A full-pose camera must be above the disc plane, aim at a point other than itself, and
    have an ``up`` direction that is not along its line of sight (else the image has no roll)."""
    if camera.is_on_axis:
        return
    eye = np.asarray(camera.nominal_position_mm)
    if eye[2] <= 0.0:
        raise ValueError(f"camera.position_mm {list(camera.nominal_position_mm)} must be above the disc (z > 0)")
    forward = np.asarray(camera.look_at_mm) - eye
    if np.linalg.norm(forward) < 1e-6:
        raise ValueError("camera.look_at_mm must differ from camera.position_mm")
    up = np.asarray(camera.up)
    if np.linalg.norm(up) < 1e-9 or np.linalg.norm(np.cross(forward / np.linalg.norm(forward),
                                                              up / np.linalg.norm(up))) < 1e-3:
        raise ValueError("camera.up must not point along the line of sight (give another 'up' direction)")
    if forward[2] >= 0.0:
        raise ValueError("camera.look_at_mm must be below the camera (it looks down at the disc)")


def load_preset(name_or_path: str | Path) -> Preset:
    """A preset by name (a shipped one such as ``phone-near-axis``, or one of the user's own), or from a JSON file path."""
    path = preset_path(name_or_path)
    if not path.is_file():
        raise CDSpectraError(
            f"unknown capture preset {str(name_or_path)!r}; known: {', '.join(preset_names() + user_preset_names())}"
        )
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return _from_dict(data)
    except (ValueError, TypeError, KeyError) as exc:  # JSONDecodeError is a ValueError
        raise CDSpectraError(f"preset file {path} is not a valid preset: {exc}") from exc
