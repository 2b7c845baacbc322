"""Capture planner: from what a person has (a lamp at some distance, its size, a phone or a
camera and its lens), where to put lamp and camera so the first order shows 400–700 nm on the
disc's data area — found by searching positions with the forward model's geometry
(:mod:`.setups`), not by a rule of thumb.

Two families are searched, both with lamp, camera and disc axis in one vertical plane:
near-axis (phone only: the source — a card with a hole, an LED — within 15 mm of the lens, at
the camera's distance) and oblique (the lamp at its distance and some angle from the disc axis,
the camera on a tripod at another angle and distance, aimed at the disc centre). Every
candidate that covers 400–700 nm is then checked for occlusion (camera body, lamp housing),
the disc fitting the frame and the zero-order glint; the best one is the one that shows the
whole range on one side of the disc, away from the glint, with the sharpest spectrum.

Only where every such position is blocked (the lamp housing in the camera's way, or the two
colliding) are positions with the lamp turned around the disc's axis out of the camera's plane
tried (±30°, ±60°, ±90°, nearest first): off that plane the housing stands aside, and the first
order follows a curve (:func:`~.setups.first_order_curve`). They are ranked by λ along that
curve's tangent at the centre, then the full analysis reads the curve itself. So the plans for
equipment that works in one plane — the shipped set-ups' — stay what they were.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..scene.capture import DEFAULT_PRESET, Preset, load_preset, preset_from_dict
from ..errors import CDSpectraError
from ..validation import check_number
from .setups import (NEAR_AXIS, OBLIQUE, SETUP_KINDS, TILT_STEP_DEG, SetUp, SetUpReport, analyse, angular_sigma,
                     setup_from_dict, tilt_tolerance_deg)
from ..spectra.grid import VISIBLE_NM

__all__ = ["PlanError", "Equipment", "Plan", "PHONE", "CAMERA", "plan_capture", "setup_summary"]


class PlanError(CDSpectraError):
    """No buildable capture exists for this equipment (the message says what to change)."""


@dataclass(frozen=True)
class _Kind:
    body_mm: tuple[float, float, float]  # width, height, depth behind the lens front
    lens_offset_mm: tuple[float, float]  # lens from the body's front-face centre
    f_number: float
    min_focus_mm: float
    aspect: float  # short side / long side of the sensor


PHONE = _Kind((75.0, 160.0, 9.0), (-27.5, 70.0), 1.8, 80.0, 0.75)
CAMERA = _Kind((140.0, 100.0, 150.0), (0.0, -10.0), 8.0, 250.0, 2.0 / 3.0)
# A phone's lens sits ~10 mm from the body's edge (here its −x edge): a source beside it must be
# past that edge, and within 15 mm of the lens to stay near-axis.
_NEAR_AXIS_OFFSETS_MM = (-12.0, -13.0, -14.0, -15.0)
_MAX_FWHM_NM = 40.0
# Where every position in the camera's plane is blocked, the best candidates are tried again with
# the lamp turned this far around the disc's axis (counter-clockwise seen from above; nearest
# first). 30° moves an 80 mm housing 300 mm away ~150 mm aside; beyond 60° the first order's
# wavelengths fall with |ωi + ωo| in the plane.
_OFF_PLANE_TURNS_DEG = (30.0, -30.0, 60.0, -60.0, 90.0, -90.0)
_OFF_PLANE_ANALYSED = 15  # per turn: the fallback costs ≤ 6 × 15 full analyses (~0.1 s each)
# How level the disc must lie, searched per candidate (TILT_STEP_DEG steps) and preferred up to
# this: a disc laid on a table without a level is off by 1–3°, and a tilt in the plane of lamp and
# camera moves the first order's wavelengths by 35–56 nm per degree (setups.TILT_COVERAGE). Ranked
# before the blur: the tripod set-up of version 2 (lamp 300 mm, 7.5° and 27.5° on one side) was
# the sharpest (13 nm) but lost half of 400–700 nm at 3° of tilt (bench/pose_errors.md, simulated
# photos of 4 LSPDD lamps: nominal 0.013, tilted 3° 0.082, 0.071 at the true pose).
TILT_GOAL_DEG = 3.0


@dataclass(frozen=True)
class Equipment:
    """What the user has. Lengths in mm."""

    lamp_distance_mm: float
    lamp_size_mm: float
    focal_mm: float
    sensor_width_mm: float = 36.0
    phone: bool = False
    f_number: float | None = None
    lamp_housing_mm: float = 80.0
    min_focus_mm: float | None = None

    @property
    def kind(self) -> _Kind:
        return PHONE if self.phone else CAMERA


@dataclass(frozen=True)
class Plan:
    """Where to put things, what it gives, and the preset that renders it."""

    family: str  # NEAR_AXIS or OBLIQUE
    lamp_angle_deg: float  # from the disc axis; positive: on the far side from the camera
    lamp_distance_mm: float
    lamp_offset_mm: float  # near-axis: source beside the lens
    camera_angle_deg: float
    camera_distance_mm: float
    setup: SetUp
    report: SetUpReport
    read_side: str  # "camera side", "lamp side", "both sides"
    notes: tuple[str, ...] = field(default=())
    lamp_turn_deg: float = 0.0  # the lamp turned around the disc's axis out of the camera's plane (ccw from above)
    tilt_tolerance_deg: float = 0.0  # how far the disc may tip before 400–700 nm leaves the tracks

    @property
    def lamp_azimuth_from_camera_deg(self) -> float:
        """How far counter-clockwise (seen from above the disc) the lamp stands from the camera."""
        in_plane = 180.0 if self.lamp_angle_deg > 0 else 0.0
        return (in_plane + self.lamp_turn_deg) % 360.0

    def instructions(self) -> list[str]:
        """Plain steps with distances and angles."""
        cam = self.setup.preset.camera.nominal_position_mm
        lamp = self.setup.preset.light.position_mm
        if self.family == NEAR_AXIS:
            return [
                f"Lay the CD flat, label down. Hold the phone level {self.camera_distance_mm:.0f} mm above the disc "
                "centre, lens straight over the centre hole.",
                f"Make the light source small: a card with a {self.setup.source_size_mm:.0f} mm hole, taped flat "
                f"to the phone's back so the hole is {abs(self.lamp_offset_mm):.0f} mm from the lens centre, just "
                "past the phone's nearest edge, the lamp right behind the card (or a bare LED there).",
                "Darken the room; expose so the streak is bright but not clipped.",
            ]
        side = "on the other side of the disc from the camera" if self.lamp_angle_deg > 0 else "on the camera's side"
        level = (f"Lay the CD flat, label down, level to within {self.tilt_tolerance_deg:g}° (a phone's level app on "
                 "the table; a tilt moves the rainbow's colours along the disc)."
                 if self.tilt_tolerance_deg < TILT_GOAL_DEG else "Lay the CD flat, label down.")
        where = (f"{side}, in the same vertical plane as the camera" if self.lamp_turn_deg == 0.0 else
                 f"{self.lamp_azimuth_from_camera_deg:g}° counter-clockwise from the camera around the disc, seen "
                 f"from above (turned {abs(self.lamp_turn_deg):g}° out of the camera's vertical plane, "
                 "so its housing stands aside)")
        return [
            level,
            f"Camera on a tripod {self.camera_distance_mm:.0f} mm from the disc centre, "
            f"{self.camera_angle_deg:g}° from vertical (lens {cam[2]:.0f} mm above the disc plane, "
            f"{abs(cam[0]):.0f} mm out from the centre), aimed at the centre.",
            f"Lamp {self.lamp_distance_mm:.0f} mm from the disc centre, {abs(self.lamp_angle_deg):g}° from vertical, "
            f"{where} (lamp {lamp[2]:.0f} mm above the disc plane, {math.hypot(lamp[0], lamp[1]):.0f} mm out).",
            "The rainbow is a thin streak through the centre" + ("" if self.lamp_turn_deg == 0.0 else ", curved")
            + f"; read it on the {self.read_side}.",
        ]

    def to_dict(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "lamp_angle_deg": self.lamp_angle_deg,
            "lamp_distance_mm": self.lamp_distance_mm,
            "lamp_offset_mm": self.lamp_offset_mm,
            "lamp_azimuth_from_camera_deg": self.lamp_azimuth_from_camera_deg,
            "camera_angle_deg": self.camera_angle_deg,
            "camera_distance_mm": self.camera_distance_mm,
            "camera_position_mm": list(self.setup.preset.camera.nominal_position_mm),
            "lamp_position_mm": list(self.setup.preset.light.position_mm),
            "read_side": self.read_side,
            "tilt_tolerance_deg": self.tilt_tolerance_deg,
            "instructions": self.instructions(),
            "report": self.report.to_dict(),
            "notes": list(self.notes),
        }


def _check(equipment: Equipment) -> None:
    for name, value in (("lamp distance (mm)", equipment.lamp_distance_mm), ("lamp size (mm)", equipment.lamp_size_mm),
                        ("focal length (mm)", equipment.focal_mm), ("sensor width (mm)", equipment.sensor_width_mm),
                        ("lamp housing (mm)", equipment.lamp_housing_mm)):
        check_number(name, value, above=0.0, error=PlanError)
    if equipment.f_number is not None:
        check_number("f-number", equipment.f_number, above=0.5, error=PlanError)
    if equipment.min_focus_mm is not None:
        check_number("closest focus (mm)", equipment.min_focus_mm, above=0.0, error=PlanError)
    if equipment.lamp_distance_mm < 100.0:
        raise PlanError(f"a lamp {equipment.lamp_distance_mm:g} mm from the disc is too close: its first order "
                        "cannot reach the data area and the lamp would hang over the disc; put it ≥ 150 mm away")
    if equipment.lamp_distance_mm > 100_000.0:
        raise PlanError("a lamp more than 100 m away is not a lamp you can place; give its distance in mm")
    if equipment.focal_mm / equipment.sensor_width_mm > 20.0:
        raise PlanError(f"a {equipment.focal_mm:g} mm lens on a {equipment.sensor_width_mm:g} mm sensor sees too "
                        "narrow a field: the disc would only fit the frame metres away, too far to separate "
                        "the colours; use a wider lens")
    fwhm = 2.3548 * 1600.0 * angular_sigma(equipment.lamp_size_mm, equipment.lamp_distance_mm)
    if fwhm > _MAX_FWHM_NM:
        need = 2.3548 * 1600.0 * equipment.lamp_size_mm / (4.0 * 12.0)  # distance for a 12 nm blur
        raise PlanError(f"a {equipment.lamp_size_mm:g} mm lamp at {equipment.lamp_distance_mm:g} mm blurs the spectrum "
                        f"by ≈ {fwhm:.0f} nm (FWHM): put a card with a 2 mm hole in front of it, or move it to "
                        f"≥ {need / 1000.0:.1f} m")


def _preset(equipment: Equipment, name: str, camera_mm: tuple[float, float, float],
            lamp_mm: tuple[float, float, float], sigma: float) -> Preset:
    base = load_preset(DEFAULT_PRESET).to_dict()
    cam = {"focal_length_mm": float(equipment.focal_mm), "sensor_width_mm": float(equipment.sensor_width_mm),
           "image_size_px": [512, 512], "position_mm": list(camera_mm)}
    if abs(camera_mm[0]) < 1e-9 and abs(camera_mm[1]) < 1e-9:
        cam = {k: v for k, v in cam.items() if k != "position_mm"} | {"distance_mm": float(camera_mm[2])}
    lamp_dist = math.dist(lamp_mm, (0.0, 0.0, 0.0))
    # Intensity keeps the irradiance at the disc centre that of cd-default's lamp at 210 mm.
    intensity = (lamp_dist / 210.0) ** 2
    return preset_from_dict({**base, "name": name, "description": "planned capture", "camera": cam,
                             "light": {"position_mm": list(lamp_mm), "lobe_sigma": sigma, "intensity": intensity}})


def _setup(equipment: Equipment, preset: Preset, family: str, housing: bool) -> SetUp:
    kind = equipment.kind
    f_number = equipment.f_number or kind.f_number
    lamp = np.asarray(preset.light.position_mm)
    bodies = []
    if housing:
        back = lamp / np.linalg.norm(lamp)  # the housing sits behind the emitting face, away from the disc
        size = equipment.lamp_housing_mm
        bodies.append({"name": "lamp housing", "center_mm": (lamp + back * size / 2.0).tolist(),
                       "size_mm": [size, size, size], "facing": (-back).tolist(), "passes_source": True})
    return setup_from_dict(preset, {
        "kind": family, "camera_body_mm": list(kind.body_mm), "lens_offset_mm": list(kind.lens_offset_mm),
        "aperture_mm": _aperture_mm(equipment),
        "source_size_mm": equipment.lamp_size_mm, "bodies": bodies,
    })


def _aperture_mm(equipment: Equipment) -> float:
    """Entrance pupil: focal length / f-number. A phone's focal length is usually quoted
    35 mm-equivalent (sensor width 36): its real lens is ~4.7× shorter (a 7.6 mm-wide sensor)."""
    f_number = equipment.f_number or equipment.kind.f_number
    focal = equipment.focal_mm
    if equipment.phone and abs(equipment.sensor_width_mm - 36.0) < 1e-9:
        focal *= 7.6 / 36.0
    return focal / f_number


def _fit_distance(equipment: Equipment, rim_mm: float = 60.0) -> float:
    """Closest camera distance at which the whole disc fits the sensor's short side (10 % margin)."""
    short = equipment.sensor_width_mm * equipment.kind.aspect
    return 2.0 * rim_mm * 1.1 * equipment.focal_mm / short


def _lambda_along(camera: np.ndarray, lamp: np.ndarray, direction: np.ndarray, s: np.ndarray,
                  pitch_nm: float) -> np.ndarray:
    """λ₁ = d·|(ωi + ωo)·ê| at the points s·ê of a line through the disc's centre in its plane, for
    many candidates at once: camera, lamp (N, 3) mm, ê (N, 3) unit, s (S,) mm. Written on dot
    products (|X − sê|² = |X|² − 2s X·ê + s²): the ranking's ~20 000 candidates × 144 points
    need no (N, S, 3) arrays (5× faster)."""
    total = np.zeros((len(camera), s.size))
    for x in (lamp, camera):
        xe = np.sum(x * direction, axis=1)[:, None]
        x2 = np.sum(x * x, axis=1)[:, None]
        total += (xe - s) / np.sqrt(np.maximum(x2 - 2.0 * s * xe + s * s, 1e-300))
    return np.abs(total) * pitch_nm


def _line_lambda(camera: np.ndarray, lamp: np.ndarray, s: np.ndarray, pitch_nm: float) -> np.ndarray:
    """λ₁ along the x axis (the plane of lamp and camera) for many candidates at once: camera,
    lamp (N, 3) mm, s (S,) mm."""
    return _lambda_along(camera, lamp, np.broadcast_to(np.array([1.0, 0.0, 0.0]), camera.shape), s, pitch_nm)


def _tangent_lambda(camera: np.ndarray, lamp: np.ndarray, s: np.ndarray, pitch_nm: float) -> np.ndarray:
    """λ₁ ≈ d·|(ωi + ωo)·ê| along the line through the centre in the direction ê of the in-plane
    part of ωi + ωo there — the tangent of the first order's curve at the centre (exact where lamp
    and camera share a plane with the axis). For ranking many candidates at once; the full
    analysis follows the curve. camera, lamp (N, 3) mm, s (S,) mm."""
    h = lamp / np.linalg.norm(lamp, axis=1, keepdims=True) + camera / np.linalg.norm(camera, axis=1, keepdims=True)
    e = np.stack([h[:, 0], h[:, 1], np.zeros(len(h))], axis=1)
    e /= np.maximum(np.linalg.norm(e, axis=1, keepdims=True), 1e-12)
    return _lambda_along(camera, lamp, e, s, pitch_nm)


def _quick_metrics(camera: np.ndarray, lamp: np.ndarray, pitch_nm: float, r_min: float,
                   r_max: float, along: Any = None) -> dict[str, np.ndarray]:
    """Per candidate, from λ₁ on the data area of both halves of the line (occlusion ignored:
    the full analysis checks that): does it cover 400–700 nm (on one side / with both), by how
    much margin, and does the zero-order glint fall on the data area."""
    half = np.linspace(r_min, r_max, 72)
    line = _line_lambda if along is None else along
    plus = line(camera, lamp, half, pitch_nm)
    minus = line(camera, lamp, -half, pitch_nm)
    lo, hi = VISIBLE_NM
    a_lo, a_hi, b_lo, b_hi = plus.min(1), plus.max(1), minus.min(1), minus.max(1)
    one_a = (a_lo <= lo) & (a_hi >= hi)
    one_b = (b_lo <= lo) & (b_hi >= hi)
    # two sides: each is continuous, so their union covers if they overlap and span the range
    union = (np.minimum(a_lo, b_lo) <= lo) & (np.maximum(a_hi, b_hi) >= hi) & (np.maximum(a_lo, b_lo) <= np.minimum(a_hi, b_hi))
    margin = np.maximum(np.where(one_a, np.minimum(lo - a_lo, a_hi - hi), 0.0),
                        np.where(one_b, np.minimum(lo - b_lo, b_hi - hi), 0.0))
    glint = (a_lo < 20.0) | (b_lo < 20.0)  # |u| ≈ 0 somewhere on the data area
    return {"covers": one_a | one_b | union, "single": one_a | one_b, "margin": margin, "glint": glint}


def _turned_about(v: np.ndarray, axis: np.ndarray, angle_rad: float) -> np.ndarray:
    """Rows of ``v`` turned by ``angle_rad`` about the matching unit rows of ``axis`` (Rodrigues)."""
    c, s = math.cos(angle_rad), math.sin(angle_rad)
    return v * c + np.cross(axis, v) * s + axis * np.sum(axis * v, axis=1, keepdims=True) * (1.0 - c)


def _quick_tolerance(camera: np.ndarray, lamp: np.ndarray, pitch_nm: float, r_min: float, r_max: float,
                     along: Any = None) -> np.ndarray:
    """Per candidate, the largest tilt of the disc in the plane of lamp and camera (TILT_STEP_DEG
    steps up to TILT_GOAL_DEG) at which the line still covers 400–700 nm: the disc tilted by δ is
    camera and lamp turned by −δ about the disc centre, about the horizontal axis across the
    streak. Ranking only; the plan's own figure is :func:`~.setups.tilt_tolerance_deg` (both axes,
    the curve where the tilt leaves the plane, the frame)."""
    h = lamp / np.linalg.norm(lamp, axis=1, keepdims=True) + camera / np.linalg.norm(camera, axis=1, keepdims=True)
    line = h[:, :2].copy()  # the streak's direction at the centre: the in-plane part of ωi + ωo ...
    flat = np.linalg.norm(line, axis=1) < 1e-6  # ... or, with the glint at the centre, the camera's foot
    line[flat] = camera[flat, :2]
    axis = np.stack([-line[:, 1], line[:, 0], np.zeros(len(h))], axis=1)
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
    out = np.zeros(len(camera))
    alive = np.ones(len(camera), dtype=bool)
    for k in range(1, int(round(TILT_GOAL_DEG / TILT_STEP_DEG)) + 1):
        ok = alive.copy()
        for sign in (1.0, -1.0):
            t = math.radians(sign * k * TILT_STEP_DEG)
            turned = _turned_about(camera, axis, t), _turned_about(lamp, axis, t)
            ok &= _quick_metrics(*turned, pitch_nm, r_min, r_max, along)["covers"]
        out[ok] = k * TILT_STEP_DEG
        alive = ok
    return out


def _read_side(report: SetUpReport, camera: np.ndarray) -> tuple[str, bool]:
    """Which half of the streak to read, in words, and whether one half holds 400–700 nm."""
    if report.read_side == 0:
        return "both sides", False
    if math.hypot(camera[0], camera[1]) < 1e-9:
        return ("side towards the source" if report.read_side > 0 else "side away from the source"), True
    if not report.coplanar:  # a curve: say where the arm to read leaves the centre, as the lamp's azimuth is given
        arm = math.degrees(math.atan2(report.line_direction[1], report.line_direction[0])) + (
            0.0 if report.read_side > 0 else 180.0)
        turn = (arm - math.degrees(math.atan2(camera[1], camera[0]))) % 360.0
        return f"arm that leaves the centre {turn:.0f}° counter-clockwise from the camera's direction", True
    towards = (report.line_direction[0] * camera[0] + report.line_direction[1] * camera[1]) * report.read_side
    return ("camera side" if towards > 0 else "far side from the camera"), True


def _margin(report: SetUpReport) -> float:
    lo, hi = VISIBLE_NM
    best = 0.0
    for cov in report.sides:
        best = max(best, min(lo - cov.lambda_range_nm[0], cov.lambda_range_nm[1] - hi))
    return best


def _candidates(equipment: Equipment) -> list[tuple[str, float, float, float, float]]:
    """(family, lamp angle, lamp offset, camera angle, camera distance) to try."""
    kind = equipment.kind
    near = max(_fit_distance(equipment), equipment.min_focus_mm or kind.min_focus_mm)
    out: list[tuple[str, float, float, float, float]] = []
    if equipment.phone and equipment.lamp_distance_mm >= near:
        out += [(NEAR_AXIS, 0.0, off, 0.0, equipment.lamp_distance_mm) for off in _NEAR_AXIS_OFFSETS_MM]
    far = max(near * 3.0, near + 100.0)
    distances = np.geomspace(near, far, 14)
    for beta in np.arange(0.0, 62.5, 2.5):
        for dc in distances:
            for alpha in np.arange(-75.0, 77.5, 2.5):
                out.append((OBLIQUE, float(alpha), 0.0, float(beta), float(dc)))
    return out


def _positions(cand: tuple[str, float, float, float, float], lamp_distance: float) -> tuple[np.ndarray, np.ndarray]:
    family, alpha, offset, beta, dc = cand
    if family == NEAR_AXIS:  # the on-axis camera's image x is world x
        return np.array([0.0, 0.0, dc]), np.array([offset, 0.0, dc])
    b, a = math.radians(beta), math.radians(alpha)
    camera = np.array([-dc * math.sin(b), 0.0, dc * math.cos(b)])
    lamp = np.array([lamp_distance * math.sin(a), 0.0, lamp_distance * math.cos(a)])
    return camera, lamp


def plan_capture(equipment: Equipment, name: str = "planned", max_analysed: int = 60,
                 families: tuple[str, ...] = SETUP_KINDS) -> Plan:
    """The best buildable capture for this equipment, or PlanError saying what to change.

    Candidates are ranked by cheap geometry first (one side covers 400–700 nm, glint off the
    data area, margin, estimated blur); the best ``max_analysed`` get the full analysis
    (occlusion, frame), and the best of those that pass is the plan."""
    _check(equipment)
    disc = load_preset(DEFAULT_PRESET).disc
    cands = [c for c in _candidates(equipment) if c[0] in families]
    if not cands:
        raise PlanError("the near-axis set-up needs a phone (a small lens the source can sit within 15 mm of) "
                        "and the lamp at least as far from the disc as the phone must be for the disc to fit")
    cams, lamps = zip(*(_positions(c, equipment.lamp_distance_mm) for c in cands))
    cam_arr, lamp_arr = np.array(cams), np.array(lamps)
    quick = _quick_metrics(cam_arr, lamp_arr, disc.pitch_um * 1e3, disc.grating_r_min_mm, disc.grating_r_max_mm)
    ok = quick["covers"] & (lamp_arr[:, 2] > 0)
    tolerance = np.zeros(len(cands))
    tolerance[ok] = _quick_tolerance(cam_arr[ok], lamp_arr[ok], disc.pitch_um * 1e3, disc.grating_r_min_mm,
                                     disc.grating_r_max_mm)
    sigma_src = angular_sigma(equipment.lamp_size_mm, equipment.lamp_distance_mm)
    sigma_ap = angular_sigma(_aperture_mm(equipment), 1.0) / np.linalg.norm(cam_arr, axis=1)
    fwhm = 2.3548 * disc.pitch_um * 1e3 * np.hypot(sigma_src, sigma_ap)
    order = sorted(np.flatnonzero(ok), key=lambda i: (bool(quick["glint"][i]), -float(tolerance[i]),
                                                      not bool(quick["single"][i]),
                                                      bool(quick["margin"][i] < 15.0), round(fwhm[i] * 2.0) / 2.0,
                                                      -min(float(quick["margin"][i]), 60.0), cands[i][4]))
    best: tuple[tuple[Any, ...], Plan] | None = None
    reasons: dict[str, int] = {}

    def consider(i: int, turn_deg: float, tol: float) -> None:
        nonlocal best
        cand = cands[i]
        camera, lamp = cam_arr[i], _turned(lamp_arr[i], turn_deg)
        sigma = math.hypot(sigma_src, angular_sigma(_aperture_mm(equipment), float(np.linalg.norm(camera))))
        preset = _preset(equipment, name, tuple(camera.tolist()), tuple(lamp.tolist()), sigma)
        setup = _setup(equipment, preset, cand[0], housing=cand[0] == OBLIQUE)
        report = analyse(setup)
        if not report.covers_visible or report.occlusions:
            reasons["blocked"] = reasons.get("blocked", 0) + 1
            return
        if not report.disc_in_frame:
            reasons["frame"] = reasons.get("frame", 0) + 1
            return
        side, single = _read_side(report, camera)
        glint = any(disc.grating_r_min_mm <= abs(g) <= disc.grating_r_max_mm for g in report.glint_mm)
        worst = max(report.resolution_nm.values()) if report.resolution_nm else float("inf")
        margin = _margin(report)
        rest = (not single, margin < 15.0, round(worst * 2.0) / 2.0, -min(margin, 60.0), cand[4])
        if best is not None and (glint, -tol, *rest) >= best[0]:
            return  # not better even at the quick tolerance, which the exact one rarely exceeds
        # the exact figure (both axes, the frame): the in-plane line can miss what the frame cuts
        tol = tilt_tolerance_deg(preset, limit_deg=min(tol, TILT_GOAL_DEG)) if tol > 0 else 0.0
        key = (glint, -float(tol), *rest)
        if best is None or key < best[0]:
            plan = Plan(family=cand[0], lamp_angle_deg=cand[1], lamp_distance_mm=float(np.linalg.norm(lamp)),
                        lamp_offset_mm=cand[2], camera_angle_deg=cand[3], camera_distance_mm=cand[4],
                        setup=setup, report=report, read_side=side, notes=report.occlusions + report.notes,
                        lamp_turn_deg=turn_deg)
            best = (key, plan)

    for i in order[:max_analysed]:
        consider(i, 0.0, float(tolerance[i]))
    if best is None and reasons.get("blocked"):  # in the camera's plane something is always in the way
        oblique = np.array([i for i, c in enumerate(cands) if c[0] == OBLIQUE], dtype=np.int64)
        for turn in _OFF_PLANE_TURNS_DEG:
            if oblique.size == 0:
                break
            turned = np.array([_turned(lamp_arr[i], turn) for i in oblique])
            q = _quick_metrics(cam_arr[oblique], turned, disc.pitch_um * 1e3, disc.grating_r_min_mm,
                               disc.grating_r_max_mm, along=_tangent_lambda)
            fits = np.flatnonzero(q["covers"] & (turned[:, 2] > 0))
            tol_t = np.zeros(len(oblique))
            tol_t[fits] = _quick_tolerance(cam_arr[oblique[fits]], turned[fits], disc.pitch_um * 1e3,
                                           disc.grating_r_min_mm, disc.grating_r_max_mm, along=_tangent_lambda)
            ranked = sorted(fits, key=lambda j: (bool(q["glint"][j]), -float(tol_t[j]), not bool(q["single"][j]),
                                                 bool(q["margin"][j] < 15.0), round(fwhm[oblique[j]] * 2.0) / 2.0,
                                                 -min(float(q["margin"][j]), 60.0), cands[oblique[j]][4]))
            for j in ranked[:_OFF_PLANE_ANALYSED]:
                consider(int(oblique[j]), turn, float(tol_t[j]))
            if best is not None:  # the smallest turn that works
                break
    if best is None:
        raise PlanError(_no_plan_message(equipment, int(ok.sum()), reasons))
    plan = best[1]
    return replace(plan, tilt_tolerance_deg=tilt_tolerance_deg(plan.setup.preset))


def _turned(lamp: np.ndarray, turn_deg: float) -> np.ndarray:
    """The lamp turned ``turn_deg`` around the disc's axis (counter-clockwise seen from above)."""
    if turn_deg == 0.0:
        return lamp
    t = math.radians(turn_deg)
    return np.array([lamp[0] * math.cos(t) - lamp[1] * math.sin(t), lamp[0] * math.sin(t) + lamp[1] * math.cos(t),
                     lamp[2]])


def _lamp_distances_that_work(equipment: Equipment) -> list[float]:
    """Lamp distances for which some camera position covers 400–700 nm (geometry only)."""
    disc = load_preset(DEFAULT_PRESET).disc
    works = []
    for dist in (150.0, 210.0, 300.0, 500.0, 1000.0, 2000.0, 5000.0):
        trial = Equipment(**{**equipment.__dict__, "lamp_distance_mm": dist})
        cands = _candidates(trial)
        cams, lamps = zip(*(_positions(c, dist) for c in cands))
        if np.any(_quick_metrics(np.array(cams), np.array(lamps), disc.pitch_um * 1e3,
                                 disc.grating_r_min_mm, disc.grating_r_max_mm)["covers"]):
            works.append(dist)
    return works


def _no_plan_message(equipment: Equipment, geometric: int, reasons: dict[str, int]) -> str:
    what = "phone" if equipment.phone else f"{equipment.focal_mm:g} mm lens"
    reach = max(_fit_distance(equipment), equipment.min_focus_mm or equipment.kind.min_focus_mm)
    if geometric == 0:
        works = _lamp_distances_that_work(equipment)
        hint = (f"with this {what} a lamp at {', '.join(f'{d:g}' for d in works)} mm works"
                if works else "no lamp distance works with it: use a wider lens or one that focuses closer")
        return (f"with the lamp {equipment.lamp_distance_mm:g} mm away no position of the {what} "
                f"({reach:.0f} mm from the disc or further, where the disc fits the frame and the lens focuses) "
                f"puts 400–700 nm on the disc's data area; {hint}")
    parts = []
    if reasons.get("blocked"):
        parts.append("the camera body or the lamp housing is in the way (or they collide)")
    if reasons.get("frame"):
        parts.append("the disc does not fit the frame")
    return (f"every position that puts 400–700 nm on the data area fails, in the camera's plane and with the lamp "
            f"turned up to {max(_OFF_PLANE_TURNS_DEG):g}° out of it: {' or '.join(parts)}; "
            "try a smaller lamp housing, a wider lens or a more distant lamp")


def setup_summary(report: SetUpReport) -> list[str]:
    """A few short lines for the panel and the CLI: coverage, resolution, problems."""
    lines = []
    if report.covered_nm:
        lo, hi = report.covered_nm
        lines.append(f"First order on the data area: {lo:.0f}–{hi:.0f} nm"
                     + (" (400–700 covered)" if report.covers_visible else " (400–700 NOT covered)"))
    else:
        lines.append("No first order on the unobstructed data area")
    for cov in report.sides:
        where = "" if report.coplanar else f" (azimuth {cov.azimuth_deg[0]:.0f}° to {cov.azimuth_deg[1]:.0f}°)"
        orders = "".join(f"; order {m} shows {a:.0f}–{b:.0f} nm there" for m, a, b in cov.orders_nm)
        lines.append(f"  {'side' if report.coplanar else 'arm'} {'+' if cov.side > 0 else '−'}{where}: "
                     f"{cov.lambda_range_nm[0]:.0f}–{cov.lambda_range_nm[1]:.0f} nm"
                     + (f", {cov.blocked_fraction:.0%} blocked" if cov.blocked_fraction else "") + orders)
    if report.resolution_nm:
        worst = max(report.resolution_nm.values())
        lines.append(f"Spectral blur ≤ {worst:.1f} nm FWHM (source σ {report.sigma_source:.4f}, "
                     f"lens σ {report.sigma_aperture:.4f} rad)")
    lines.extend(report.occlusions)
    lines.extend(report.notes)
    return lines
