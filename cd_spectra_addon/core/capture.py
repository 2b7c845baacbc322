"""Capture geometry: the disc, the pinhole camera and the lamp, loaded from preset JSON files.

World frame (shared with the Blender scene): metres, disc centre at the origin, disc normal +z,
camera looking down −z with image rows running towards −y. Presets describe the nominal
capture; a :class:`Pose` adds what a real user gets wrong (camera or lamp beside the axis,
a tilted disc).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import CDSpectraError

PRESET_DIR = Path(__file__).resolve().parent.parent / "presets"
DEFAULT_PRESET = "cd-default"  # the capture a photo is read as unless the user picks another preset

__all__ = [
    "Disc",
    "Camera",
    "Light",
    "Preset",
    "Pose",
    "Scene",
    "PRESET_DIR",
    "DEFAULT_PRESET",
    "preset_names",
    "load_preset",
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


@dataclass(frozen=True)
class Camera:
    """Pinhole camera on the disc axis looking at the disc (Blender: sensor fit horizontal)."""

    distance_mm: float = 210.0
    focal_length_mm: float = 58.0
    sensor_width_mm: float = 36.0
    image_size_px: tuple[int, int] = (512, 512)  # width, height

    @property
    def focal_px(self) -> float:
        return self.focal_length_mm / self.sensor_width_mm * self.image_size_px[0]


@dataclass(frozen=True)
class Light:
    """Small lamp; ``lobe_sigma`` is its angular size (Gaussian std, radians) in (u, v)."""

    position_mm: tuple[float, float, float] = (0.0, 0.0, 210.0)
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

    def with_image_size(self, width: int, height: int | None = None) -> "Preset":
        """Same capture at another resolution (field of view unchanged)."""
        size = (int(width), int(height if height is not None else width))
        return replace(self, camera=replace(self.camera, image_size_px=size))

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "description": self.description,
            "disc": self.disc.__dict__.copy(),
            "camera": {**self.camera.__dict__, "image_size_px": list(self.camera.image_size_px)},
            "light": {**self.light.__dict__, "position_mm": list(self.light.position_mm)},
            "samples": self.samples,
        }


@dataclass(frozen=True)
class Pose:
    """Departures from the preset: lateral offsets (mm) and a disc tilt about x and y (degrees)."""

    camera_offset_mm: tuple[float, float] = (0.0, 0.0)
    light_offset_mm: tuple[float, float] = (0.0, 0.0)
    tilt_deg: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class Scene:
    """A fully posed capture in world metres, ready for ray casting or a Blender scene."""

    preset: Preset
    pose: Pose = field(default_factory=Pose)

    @property
    def camera_position(self) -> NDArray[np.float64]:
        dx, dy = self.pose.camera_offset_mm
        return np.array([dx, dy, self.preset.camera.distance_mm]) * 1e-3

    @property
    def light_position(self) -> NDArray[np.float64]:
        dx, dy = self.pose.light_offset_mm
        x, y, z = self.preset.light.position_mm
        return np.array([x + dx, y + dy, z]) * 1e-3

    @property
    def disc_center(self) -> NDArray[np.float64]:
        return np.zeros(3)

    @property
    def disc_rotation(self) -> NDArray[np.float64]:
        """Rotation of the disc (columns: its x, y and normal axes in the world), Rx then Ry."""
        ax, ay = (math.radians(a) for a in self.pose.tilt_deg)
        rx = np.array([[1, 0, 0], [0, math.cos(ax), -math.sin(ax)], [0, math.sin(ax), math.cos(ax)]])
        ry = np.array([[math.cos(ay), 0, math.sin(ay)], [0, 1, 0], [-math.sin(ay), 0, math.cos(ay)]])
        return ry @ rx

    @property
    def disc_normal(self) -> NDArray[np.float64]:
        return self.disc_rotation[:, 2].copy()

    def pixel_rays(
        self, rows: NDArray[np.float64], cols: NDArray[np.float64]
    ) -> NDArray[np.float64]:
        """Unit world directions through image positions.

        Positions use the array-index convention: the centre of pixel ``[i, j]`` is
        ``(row, col) = (i, j)``, row 0 at the top of the image.
        """
        cam = self.preset.camera
        width, height = cam.image_size_px
        f = cam.focal_px
        x = cols + 0.5 - width / 2.0
        y = height / 2.0 - (rows + 0.5)
        d = np.stack([x, y, -np.full_like(x, f)], axis=-1)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def intersect_disc(
        self, directions: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        """Points where camera rays meet the disc plane and a mask of those on the disc annulus."""
        origin = self.camera_position
        n = self.disc_normal
        denom = directions @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(np.abs(denom) > 1e-12, ((self.disc_center - origin) @ n) / denom, -1.0)
        points = origin + t[..., None] * directions
        radius = np.linalg.norm(self.to_disc_frame(points)[..., :2], axis=-1) * 1e3
        disc = self.preset.disc
        hit = (t > 0) & (radius >= disc.hole_radius_mm) & (radius <= disc.rim_radius_mm)
        return points, hit

    def to_disc_frame(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """World points in the disc's own frame (x, y in its plane, z along its normal)."""
        return (points - self.disc_center) @ self.disc_rotation

    def project(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """(row, col) image positions of world points, array-index convention (see pixel_rays)."""
        cam = self.preset.camera
        width, height = cam.image_size_px
        rel = points - self.camera_position
        scale = cam.focal_px / -rel[..., 2]
        cols = rel[..., 0] * scale + width / 2.0 - 0.5
        rows = height / 2.0 - 0.5 - rel[..., 1] * scale
        return np.stack([rows, cols], axis=-1)

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
        }


def preset_names() -> list[str]:
    return sorted(p.stem for p in PRESET_DIR.glob("*.json"))


def _from_dict(data: dict[str, Any]) -> Preset:
    disc = Disc(**data.get("disc", {}))
    cam_data = dict(data.get("camera", {}))
    if "image_size_px" in cam_data:
        cam_data["image_size_px"] = tuple(int(v) for v in cam_data["image_size_px"])
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
    )
    _validate(preset)
    return preset


def _number(where: str, value: Any, low: float, low_open: bool = False, integer: bool = False) -> None:
    """A finite number ≥ low (> low if ``low_open``), an integer where asked; else ValueError."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (value > low if low_open else value >= low) and (not integer or float(value).is_integer())
    if not ok:
        kind = "a whole number" if integer else "a number"
        raise ValueError(f"{where} must be {kind} {'>' if low_open else '≥'} {low:g}, not {value!r}")


def _validate(preset: Preset) -> None:
    """Refuse a preset file's impossible values here, with the field's name, instead of a NaN
    image, a misleading 'no rainbow found' or a TypeError deep inside the estimate."""
    d, c, light = preset.disc, preset.camera, preset.light
    for name in ("pitch_um", "rim_radius_mm", "grating_r_max_mm"):
        _number(f"disc.{name}", getattr(d, name), 0.0, low_open=True)
    for name in ("groove_height_um", "hole_radius_mm", "grating_r_min_mm", "diffuse_albedo", "duty"):
        _number(f"disc.{name}", getattr(d, name), 0.0)
    _number("disc.medium_index", d.medium_index, 1.0)
    _number("disc.max_order", d.max_order, 0.0, integer=True)
    if d.profile not in ("sinusoidal", "rectangular"):
        raise ValueError(f"disc.profile must be 'sinusoidal' or 'rectangular', not {d.profile!r}")
    if d.duty > 1.0 or d.hole_radius_mm >= d.rim_radius_mm or d.grating_r_min_mm >= d.grating_r_max_mm:
        raise ValueError("disc: need duty ≤ 1, hole_radius_mm < rim_radius_mm and "
                         "grating_r_min_mm < grating_r_max_mm")
    for name in ("distance_mm", "focal_length_mm", "sensor_width_mm"):
        _number(f"camera.{name}", getattr(c, name), 0.0, low_open=True)
    for i, value in enumerate(c.image_size_px):
        _number(f"camera.image_size_px[{i}]", value, 1.0, integer=True)
    if len(c.image_size_px) != 2 or len(light.position_mm) != 3:
        raise ValueError("camera.image_size_px needs 2 values and light.position_mm 3")
    for i, value in enumerate(light.position_mm):
        _number(f"light.position_mm[{i}]", value, -math.inf)
    _number("light.lobe_sigma", light.lobe_sigma, 0.0, low_open=True)
    _number("light.intensity", light.intensity, 0.0)


def load_preset(name_or_path: str | Path) -> Preset:
    """A preset by name (``cd-default``) or from a JSON file path."""
    path = Path(name_or_path)
    if not path.suffix:
        path = PRESET_DIR / f"{name_or_path}.json"
    if not path.is_file():
        raise CDSpectraError(
            f"unknown capture preset {str(name_or_path)!r}; known: {', '.join(preset_names())}"
        )
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        return _from_dict(data)
    except (ValueError, TypeError, KeyError) as exc:  # JSONDecodeError is a ValueError
        raise CDSpectraError(f"preset file {path} is not a valid preset: {exc}") from exc
