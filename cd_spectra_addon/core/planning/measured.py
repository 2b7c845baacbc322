"""A capture set-up described by what a person can measure, wherever lamp and camera were.

Lamp and camera are each given by their distance from the disc centre (mm), their angle from
the disc's axis (degrees: 0 straight above the disc, 90 in the disc's plane) and their azimuth
around the axis (degrees, **seen from above the disc, counter-clockwise**; only the difference
matters — the lamp's azimuth minus the camera's is how far counter-clockwise the lamp stands
from the camera). The two need not share a vertical plane. A check for which way round: standing
at the camera and facing the disc, a lamp 90° counter-clockwise from the camera is on your right.
The preset's world frame puts azimuth 0 along +x and 90 along +y, the disc centre at the origin.

The camera is aimed at the disc centre and held upright: the image's up is the disc's axis
projected into the image (the far side of the disc at the top). A camera straight above the disc
(angle 0) looks straight down with the image's top towards azimuth 90° (+y), as the shipped
on-axis presets do, and its preset is exactly theirs.

Every number is checked (:mod:`..validation`) and refused with a message naming it; nothing
here raises anything but :class:`MeasurementError` for bad input.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from ..errors import CDSpectraError
from ..scene.capture import DEFAULT_PRESET, REFERENCE_PRESET, Preset, load_preset, preset_from_dict
from ..scene.relative_pose import near_axis
from ..validation import check_number, check_numbers
from .setups import NEAR_AXIS, OBLIQUE, SetUp, angular_sigma, setup_from_dict

__all__ = ["DISC_TYPES", "MAX_ANGLE_DEG", "MeasurementError", "Measurements", "check_measurements",
           "position_mm", "lamp_azimuth_from_camera_deg", "measured_preset_data", "measured_preset",
           "measured_setup", "placement_steps"]

# Disc types: (label, pitch µm, groove height µm); radii as the CD's. The DVD's groove height is
# the one training/evaluation/evaluate.py renders its DVD with.
DISC_TYPES: dict[str, tuple[str, float, float]] = {
    "cd": ("CD (track pitch 1.6 µm)", 1.6, 0.045),
    "dvd": ("DVD (track pitch 0.74 µm)", 0.74, 0.06),
}
PHONE_FOCAL_MM = 26.0  # a phone's main camera, 35 mm-equivalent
FULL_FRAME_WIDTH_MM = 36.0  # the sensor width that equivalent focal length is quoted for
# Entrance pupil when none is given: a phone's main camera (5.5 mm at f/1.8) and a 24 mm lens at
# f/8 both have ~3 mm (README: "a phone's ~3 mm pupil").
DEFAULT_APERTURE_MM = 3.0
DEFAULT_LAMP_SIGMA = 0.003  # rad: the presets' lamp when its size is not given
# At 89.5° from the axis every cosine the kernel takes stays above its 1e-3 clamp for lamps and
# cameras ≥ 60 mm out (cos ≥ 0.0087 at the centre); beyond that the disc is seen or lit edge-on.
MAX_ANGLE_DEG = 89.5
# Closer than this the lamp or the lens hangs over the disc's tracks (the disc is 120 mm across):
# it shades them, a lens cannot take the disc in, and the first order's curve need not reach the
# centre (a lamp 4 mm away: the set-up analysis could not follow it; none failed from 50 mm in a
# sweep of 150 random set-ups out to 3 m).
MIN_DISTANCE_MM = 50.0
MAX_DISTANCE_MM = 100_000.0  # 100 m: farther is not a distance anyone measured in mm
MIN_SEPARATION_MM = 1.0  # a lamp within 1 mm of the lens centre would be inside the lens
_ROUND_MM = 6  # positions are written to 1 nm (so 0 and 180° give exact zeros)


class MeasurementError(CDSpectraError):
    """A measured set-up that cannot be: the message names the number and what it must be."""


@dataclass(frozen=True)
class Measurements:
    """What a person measured. Distances in mm from the disc centre, angles in degrees from the
    disc's axis, azimuths in degrees seen from above the disc, counter-clockwise."""

    lamp_distance_mm: float
    lamp_angle_deg: float
    lamp_azimuth_deg: float
    camera_distance_mm: float
    camera_angle_deg: float
    camera_azimuth_deg: float = 0.0
    disc: str = "cd"
    lamp_size_mm: float | None = None  # the glowing part (filament, LED, the hole of a card)
    focal_mm: float = PHONE_FOCAL_MM
    sensor_width_mm: float = FULL_FRAME_WIDTH_MM
    image_size_px: tuple[int, int] = (512, 512)  # width, height
    aperture_mm: float = DEFAULT_APERTURE_MM  # the lens's entrance pupil (focal length / f-number)
    name: str = "measured"

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["image_size_px"] = list(self.image_size_px)
        return data


_LABELS = {
    "lamp_distance_mm": "lamp distance from the disc centre (mm)",
    "lamp_angle_deg": "lamp angle from the disc's axis (degrees)",
    "lamp_azimuth_deg": "lamp azimuth (degrees)",
    "camera_distance_mm": "camera distance from the disc centre (mm)",
    "camera_angle_deg": "camera angle from the disc's axis (degrees)",
    "camera_azimuth_deg": "camera azimuth (degrees)",
    "lamp_size_mm": "lamp size (mm)",
    "focal_mm": "lens focal length (mm)",
    "sensor_width_mm": "sensor width (mm)",
    "image_size_px": "image size (pixels)",
    "aperture_mm": "lens aperture (mm)",
}


def _distance(m: Measurements, key: str, what: str) -> float:
    value = check_number(_LABELS[key], getattr(m, key), above=0.0, error=MeasurementError)
    if value < MIN_DISTANCE_MM:
        raise MeasurementError(f"{_LABELS[key]}: a {what} {value:g} mm from the disc centre hangs over the disc's "
                               f"tracks; place it at least {MIN_DISTANCE_MM:g} mm from the disc centre (measure to "
                               f"the centre of the {what})")
    if value > MAX_DISTANCE_MM:
        raise MeasurementError(f"{_LABELS[key]}: {value:g} mm is more than 100 m; give the distance in mm")
    return value


def _angle(m: Measurements, key: str, what: str, role: str) -> float:
    value = check_number(_LABELS[key], getattr(m, key), error=MeasurementError)
    if value >= 90.0:
        where = "in" if value == 90.0 else "below"
        raise MeasurementError(f"{_LABELS[key]}: a {what} {value:g}° from the disc's axis is {where} the disc's plane "
                               f"and cannot {role} the disc's face; angles run from 0 (straight above the disc) "
                               f"to {MAX_ANGLE_DEG:g}")
    if value < 0.0:
        raise MeasurementError(f"{_LABELS[key]}: angles from the disc's axis run from 0 to {MAX_ANGLE_DEG:g}, not "
                               f"{value:g}; for the other side of the disc add 180° to the azimuth")
    return check_number(_LABELS[key], value, at_least=0.0, at_most=MAX_ANGLE_DEG, unit=" degrees",
                        error=MeasurementError)


def _azimuth(m: Measurements, key: str) -> float:
    value = check_number(_LABELS[key], getattr(m, key), at_least=-360.0, at_most=360.0, unit=" degrees",
                         error=MeasurementError)
    return value % 360.0 + 0.0


def check_measurements(m: Measurements) -> Measurements:
    """``m`` with every number checked and azimuths in [0, 360); MeasurementError names the
    first that is wrong."""
    lamp_d = _distance(m, "lamp_distance_mm", "lamp")
    cam_d = _distance(m, "camera_distance_mm", "camera")
    lamp_a = _angle(m, "lamp_angle_deg", "lamp", "light")
    cam_a = _angle(m, "camera_angle_deg", "camera", "see")
    lamp_z, cam_z = _azimuth(m, "lamp_azimuth_deg"), _azimuth(m, "camera_azimuth_deg")
    disc = m.disc.strip().lower() if isinstance(m.disc, str) else None
    if disc not in DISC_TYPES:
        raise MeasurementError(f"disc must be {' or '.join(map(repr, DISC_TYPES))}, not {m.disc!r}")
    size = None
    if m.lamp_size_mm is not None:
        size = check_number(_LABELS["lamp_size_mm"], m.lamp_size_mm, above=0.0, error=MeasurementError)
        if size > lamp_d:
            raise MeasurementError(f"{_LABELS['lamp_size_mm']}: a lamp {size:g} mm wide {lamp_d:g} mm from the disc is "
                                   "not a small source (its size must be less than its distance)")
    focal = check_number(_LABELS["focal_mm"], m.focal_mm, above=0.0, error=MeasurementError)
    sensor = check_number(_LABELS["sensor_width_mm"], m.sensor_width_mm, above=0.0, error=MeasurementError)
    w, h = check_numbers(_LABELS["image_size_px"], list(m.image_size_px) if isinstance(m.image_size_px, tuple)
                         else m.image_size_px, 2, names="[width, height]", at_least=16.0, at_most=100_000.0,
                         integer=True, error=MeasurementError)
    aperture = check_number(_LABELS["aperture_mm"], m.aperture_mm, above=0.0, at_most=200.0, error=MeasurementError)
    checked = Measurements(lamp_d, lamp_a, lamp_z, cam_d, cam_a, cam_z, disc, size, focal, sensor,
                           (int(w), int(h)), aperture, str(m.name))
    gap = math.dist(position_mm(lamp_d, lamp_a, lamp_z), position_mm(cam_d, cam_a, cam_z))
    if gap < MIN_SEPARATION_MM:
        raise MeasurementError(f"the lamp and the camera are {gap:.2g} mm apart: they cannot be in the same place "
                               f"(a lamp on the lens axis needs a beam splitter; that is the preset {REFERENCE_PRESET})")
    return checked


def position_mm(distance_mm: float, angle_deg: float, azimuth_deg: float) -> tuple[float, float, float]:
    """World position (mm) of a point ``distance_mm`` from the disc centre, ``angle_deg`` from
    its axis, at ``azimuth_deg`` (counter-clockwise from +x seen from above, i.e. towards +y)."""
    a, z = math.radians(angle_deg), math.radians(azimuth_deg)
    out = (distance_mm * math.sin(a) * math.cos(z), distance_mm * math.sin(a) * math.sin(z), distance_mm * math.cos(a))
    return tuple(round(v, _ROUND_MM) + 0.0 for v in out)  # type: ignore[return-value]


def lamp_azimuth_from_camera_deg(m: Measurements) -> float:
    """How far counter-clockwise (seen from above) the lamp stands from the camera, [0, 360)."""
    return (m.lamp_azimuth_deg - m.camera_azimuth_deg) % 360.0 + 0.0


def _upright(angle_deg: float, azimuth_deg: float) -> list[float]:
    """The disc's axis projected into the view of a camera at this angle and azimuth, aimed at
    the centre: the image's up (a unit vector perpendicular to the line of sight)."""
    a, z = math.radians(angle_deg), math.radians(azimuth_deg)
    return [-math.cos(a) * math.cos(z), -math.cos(a) * math.sin(z), math.sin(a)]


def _lamp_sigma(m: Measurements) -> float:
    return DEFAULT_LAMP_SIGMA if m.lamp_size_mm is None else angular_sigma(m.lamp_size_mm, m.lamp_distance_mm)


def _camera(m: Measurements) -> dict[str, Any]:
    camera: dict[str, Any] = {"focal_length_mm": m.focal_mm, "sensor_width_mm": m.sensor_width_mm,
                              "image_size_px": list(m.image_size_px)}
    if m.camera_angle_deg == 0.0:  # straight above: the shipped on-axis camera, image top towards +y
        return {"distance_mm": m.camera_distance_mm, **camera}
    return {**camera, "position_mm": list(position_mm(m.camera_distance_mm, m.camera_angle_deg, m.camera_azimuth_deg)),
            "up": _upright(m.camera_angle_deg, m.camera_azimuth_deg)}


def _words(distance: float, angle: float, azimuth: float) -> str:
    if angle == 0.0:
        return f"{distance:g} mm straight above the disc centre"
    return f"{distance:g} mm from the disc centre, {angle:g}° from the disc's axis, at azimuth {azimuth:g}°"


def _describe(m: Measurements) -> str:
    label = DISC_TYPES[m.disc][0]
    lamp = (f"lamp {m.lamp_size_mm:g} mm (σ {_lamp_sigma(m):.4f} rad)" if m.lamp_size_mm is not None
            else f"lamp size not given (σ {DEFAULT_LAMP_SIGMA:g} rad assumed)")
    return (f"Measured set-up: lamp {_words(m.lamp_distance_mm, m.lamp_angle_deg, m.lamp_azimuth_deg)}; camera "
            f"{_words(m.camera_distance_mm, m.camera_angle_deg, m.camera_azimuth_deg)}, aimed at the centre, held upright. "
            "Azimuths are seen from above the disc, counter-clockwise: the lamp stands "
            f"{lamp_azimuth_from_camera_deg(m):g}° counter-clockwise from the camera. {label}; {lamp}; lens "
            f"{m.focal_mm:g} mm on a {m.sensor_width_mm:g} mm-wide sensor, aperture {m.aperture_mm:g} mm.")


def placement_steps(m: Measurements) -> list[str]:
    """The set-up in plain steps, with the heights and distances out that the angles give."""
    lamp = position_mm(m.lamp_distance_mm, m.lamp_angle_deg, m.lamp_azimuth_deg)
    cam = position_mm(m.camera_distance_mm, m.camera_angle_deg, m.camera_azimuth_deg)
    disc = "DVD" if m.disc == "dvd" else "CD"
    if m.camera_angle_deg == 0.0:
        camera = (f"Camera {m.camera_distance_mm:g} mm straight above the disc centre, looking straight down, the "
                  "top of the image towards azimuth 90°.")
    else:
        camera = (f"Camera {m.camera_distance_mm:g} mm from the disc centre, {m.camera_angle_deg:g}° from the disc's "
                  f"axis (lens {cam[2]:.0f} mm above the disc plane, {math.hypot(cam[0], cam[1]):.0f} mm out from the "
                  f"centre), at azimuth {m.camera_azimuth_deg:g}°, aimed at the centre and held upright.")
    if m.lamp_angle_deg == 0.0:
        lamp_text = f"Lamp {m.lamp_distance_mm:g} mm straight above the disc centre."
    else:
        lamp_text = (f"Lamp {m.lamp_distance_mm:g} mm from the disc centre, {m.lamp_angle_deg:g}° from the disc's axis "
                     f"({lamp[2]:.0f} mm above the disc plane, {math.hypot(lamp[0], lamp[1]):.0f} mm out), at azimuth "
                     f"{m.lamp_azimuth_deg:g}°: {lamp_azimuth_from_camera_deg(m):g}° counter-clockwise from the camera, "
                     "seen from above.")
    return [f"Lay the {disc} flat, label down.", camera, lamp_text]


def measured_preset_data(m: Measurements) -> dict[str, Any]:
    """The preset file for measured numbers: the preset, a ``"setup"`` section for the set-up
    analysis (the camera as its lens alone: no body or lamp housing was described, so nothing is
    checked for standing in the light's way) and the numbers it was made from (``"measured"``)."""
    m = check_measurements(m)
    base = load_preset(DEFAULT_PRESET).to_dict()
    _, pitch, groove = DISC_TYPES[m.disc]
    lamp_mm = position_mm(m.lamp_distance_mm, m.lamp_angle_deg, m.lamp_azimuth_deg)
    # Intensity keeps the irradiance at the disc centre that of cd-default's lamp at 210 mm (as the planner's).
    intensity = (m.lamp_distance_mm / 210.0) ** 2
    data = {
        **base, "name": m.name, "description": _describe(m),
        "disc": {**base["disc"], "pitch_um": pitch, "groove_height_um": groove},
        "camera": _camera(m),
        "light": {"position_mm": list(lamp_mm), "lobe_sigma": _lamp_sigma(m), "intensity": intensity},
    }
    source_mm = m.lamp_size_mm if m.lamp_size_mm is not None else 4.0 * m.lamp_distance_mm * DEFAULT_LAMP_SIGMA
    try:
        preset = preset_from_dict(data)
    except (ValueError, TypeError, KeyError) as exc:  # the checks above should make this unreachable
        raise MeasurementError(f"these measurements make no valid preset: {exc}") from exc
    data["setup"] = {
        "kind": NEAR_AXIS if near_axis(preset) else OBLIQUE,
        "camera_body_mm": [m.aperture_mm] * 3, "lens_offset_mm": [0.0, 0.0], "aperture_mm": m.aperture_mm,
        "source_size_mm": source_mm, "bodies": [], "steps": placement_steps(m),
    }
    data["measured"] = m.to_dict()
    return data


def measured_preset(m: Measurements) -> Preset:
    """The validated preset for measured numbers."""
    return preset_from_dict(measured_preset_data(m))


def measured_setup(m: Measurements) -> SetUp:
    """The preset and its set-up section, ready for :func:`~.setups.analyse`."""
    data = measured_preset_data(m)
    return setup_from_dict(preset_from_dict(data), data["setup"])
