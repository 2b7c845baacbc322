"""The capture seen from the camera: disc pose, lamp position and lamp size for any set-up.

A photo cannot tell where the world is, only where the disc and the lamp are relative to the
camera. So the general pose fit works in the camera's own frame (x right, y up, looking down −z)
with no gauge to fix: the disc centre P, the disc normal N (towards the camera) and the lamp L,
in mm. A disc tilt, a camera aimed a few degrees off, a camera moved sideways and a lamp moved or
swung all become changes of (P, N, L) — every pose error of issue 10 is in this space, none is
absorbed into another parameter. The disc's rotation about its own normal is invisible (its
tracks are circles) and does not appear.

The fit's parameters (:func:`apply_params`) are small changes from a start, chosen so that each
user error moves few of them: the whole capture turned about the lens (the camera's aim), the
disc turned about its centre with the lamp turned twice as far (a tilt that keeps the glint),
the lamp's direction and distance seen from the disc centre, and log σ. The overall scale
(camera distance) leaves every angle, hence every pixel's λ₁, unchanged; the start fixes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from .capture import Camera, Light, Pose, Preset, Scene
from .kernel import camera_rays, diffraction_along, project, rotation_about, rotation_xy, turn_between

__all__ = ["RelativePose", "N_PARAMS", "LAMP_DISTANCE_PARAM", "SIGMA_PARAM", "relative_pose", "scene_from_relative", "nominal_scene", "apply_params",
           "aimed_at", "mirror_point", "with_glint_at", "with_lamp_mirrored_at", "with_disc_centre_at", "near_axis", "with_lamp_distance",
           "RayDiffraction", "ray_diffraction", "turned_in_plane", "plane_axis"]

N_PARAMS = 8  # aim (2, deg), disc normal (2, deg), lamp direction (2, deg), log lamp distance, log σ
LAMP_DISTANCE_PARAM = 6  # their indices where a caller holds one or frees it
SIGMA_PARAM = 7


@dataclass(frozen=True)
class RelativePose:
    """Disc and lamp in the camera frame (mm; the camera at the origin looking down −z)."""

    disc_centre_mm: NDArray[np.float64]
    disc_normal: NDArray[np.float64]  # unit, pointing to the camera's side of the disc
    lamp_mm: NDArray[np.float64]
    lobe_sigma: float
    disc_x: NDArray[np.float64]  # a direction in the disc plane: keeps the rebuilt world frame continuous

    @property
    def distance_mm(self) -> float:
        return float(np.linalg.norm(self.disc_centre_mm))


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    return v / np.linalg.norm(v)


def relative_pose(scene: Scene) -> RelativePose:
    """The scene's disc and lamp as the camera sees them."""
    rot = scene.camera_rotation  # camera → world, columns right, up, back
    cam = scene.camera_position
    centre = rot.T @ (scene.disc_center - cam) * 1e3
    normal = rot.T @ scene.disc_normal
    if float(normal @ -centre) < 0:
        normal = -normal
    lamp = rot.T @ (scene.light_position - cam) * 1e3
    disc_x = rot.T @ scene.disc_rotation[:, 0]
    return RelativePose(centre, normal, lamp, float(scene.preset.light.lobe_sigma), disc_x)


def scene_from_relative(rel: RelativePose, preset: Preset, image_size: tuple[int, int], focal_px: float) -> Scene:
    """A world Scene (disc at the origin, untilted) that the camera sees as ``rel``, for an image of
    ``image_size`` (width, height) with focal length ``focal_px`` and its principal point at the
    centre. Disc, lamp intensity and everything else come from ``preset``."""
    n = _unit(np.asarray(rel.disc_normal, dtype=np.float64))
    x = np.asarray(rel.disc_x, dtype=np.float64) - float(np.asarray(rel.disc_x) @ n) * n
    if np.linalg.norm(x) < 1e-6:  # looking along the stored axis: any in-plane direction will do
        x = np.cross(n, [0.0, 1.0, 0.0]) if abs(n[1]) < 0.9 else np.cross(n, [1.0, 0.0, 0.0])
    x = _unit(x)
    y = np.cross(n, x)
    to_disc = np.stack([x, y, n], axis=0)  # camera coords → disc coords
    centre = np.asarray(rel.disc_centre_mm, dtype=np.float64)
    eye = to_disc @ -centre
    axes = to_disc  # columns: camera right, up, back in disc coords
    forward = -axes[:, 2]
    dist = float(np.linalg.norm(centre))
    width, height = image_size
    camera = Camera(distance_mm=dist, focal_length_mm=float(focal_px), sensor_width_mm=float(width),
                    image_size_px=(int(width), int(height)), position_mm=tuple(float(v) for v in eye),
                    look_at_mm=tuple(float(v) for v in eye + forward * dist),
                    up=tuple(float(v) for v in axes[:, 1]))
    lamp = to_disc @ (np.asarray(rel.lamp_mm, dtype=np.float64) - centre)
    light = Light(position_mm=tuple(float(v) for v in lamp), lobe_sigma=float(rel.lobe_sigma),
                  intensity=preset.light.intensity)
    return Scene(replace(preset, camera=camera, light=light, disc_tilt_deg=(0.0, 0.0)), Pose())


def apply_params(start: RelativePose, x: NDArray[np.float64]) -> RelativePose:
    """``start`` changed by the parameter vector (see :data:`N_PARAMS`):
    x[0:2] turn the whole capture about the lens (the camera's aim), x[2:4] turn the disc about
    its centre (tilt), x[4:6] turn the lamp about the disc centre, x[6] scales the lamp's distance
    from the disc centre (log), x[7] scales σ (log)."""
    aim = rotation_xy(x[0], x[1])
    centre = aim @ start.disc_centre_mm
    lamp_rel = aim @ (start.lamp_mm - start.disc_centre_mm)
    normal = aim @ start.disc_normal
    disc_x = aim @ start.disc_x
    tilt = rotation_xy(x[2], x[3])
    normal = tilt @ normal
    disc_x = tilt @ disc_x
    # The lamp turns twice as far as the disc: the mirror direction, hence the glint and to first
    # order every pixel's λ₁, stays put, and the tilt is left with what only it does (the disc's
    # perspective). Without this a tilt and a lamp move trade off in a narrow valley.
    lamp_rel = tilt @ tilt @ lamp_rel
    lamp_rel = rotation_xy(x[4], x[5]) @ lamp_rel * math.exp(x[6])
    return RelativePose(centre, normal, centre + lamp_rel, start.lobe_sigma * math.exp(x[7]), disc_x)


def nominal_scene(preset: Preset, image_size: tuple[int, int], focal_px: float) -> Scene:
    """The preset's capture seen by a camera of this image size and focal length."""
    width, height = image_size
    cam = replace(preset.camera, focal_length_mm=float(focal_px), sensor_width_mm=float(width),
                  image_size_px=(int(width), int(height)))
    return Scene(replace(preset, camera=cam))


def aimed_at(rel: RelativePose, rc: tuple[float, float], size: tuple[int, int], focal_px: float) -> RelativePose:
    """``rel`` turned about the lens so that the disc centre appears at image point ``rc``."""
    rot = turn_between(rel.disc_centre_mm / np.linalg.norm(rel.disc_centre_mm), camera_rays(rc[0], rc[1], size, focal_px))
    return RelativePose(rot @ rel.disc_centre_mm, rot @ rel.disc_normal, rot @ rel.lamp_mm, rel.lobe_sigma,
                        rot @ rel.disc_x)


def mirror_point(rel: RelativePose) -> NDArray[np.float64] | None:
    """Where the disc plane mirrors the lamp into the lens (camera frame, mm): the zero-order glint."""
    p, n, lamp = rel.disc_centre_mm, rel.disc_normal, rel.lamp_mm
    image = lamp - 2.0 * float((lamp - p) @ n) * n  # the lamp's mirror image behind the plane
    denom = float(image @ n)
    if abs(denom) < 1e-12:
        return None
    t = float(p @ n) / denom
    return image * t if t > 0 else None


def with_disc_centre_at(rel: RelativePose, rc: tuple[float, float], size: tuple[int, int], focal_px: float
                        ) -> RelativePose | None:
    """``rel`` with the disc slid within its own plane (camera, lamp and tilt kept) so that its
    centre appears at image point ``rc``: a disc centre misplaced on the table. None where that
    ray misses the disc's plane."""
    p, n = np.asarray(rel.disc_centre_mm, dtype=np.float64), np.asarray(rel.disc_normal, dtype=np.float64)
    d = camera_rays(rc[0], rc[1], size, focal_px)
    denom = float(d @ n)
    if abs(denom) < 1e-12 or float(p @ n) / denom <= 0:
        return None
    return replace(rel, disc_centre_mm=d * (float(p @ n) / denom))


def with_lamp_mirrored_at(rel: RelativePose, rc: tuple[float, float], size: tuple[int, int], focal_px: float
                          ) -> RelativePose | None:
    """``rel`` with the lamp moved (its distance from the disc centre kept) so that the disc mirrors
    it into the lens at image point ``rc``: on the ray reflected at the disc point seen there. None
    where that ray leaves the disc's camera side or never reaches the lamp's distance."""
    p, n = np.asarray(rel.disc_centre_mm, dtype=np.float64), np.asarray(rel.disc_normal, dtype=np.float64)
    d = camera_rays(rc[0], rc[1], size, focal_px)
    denom = float(d @ n)
    if abs(denom) < 1e-12 or float(p @ n) / denom <= 0:
        return None
    spot = d * (float(p @ n) / denom)
    out = d - 2.0 * float(d @ n) * n  # reflected, away from the disc towards the lamp
    if float(out @ n) <= 0:
        return None
    # |spot + s·out − P| = R: s² + 2 s (out·(spot − P)) + |spot − P|² − R² = 0
    radius = float(np.linalg.norm(np.asarray(rel.lamp_mm) - p))
    q = spot - p
    b = float(out @ q)
    disc = b * b - (float(q @ q) - radius * radius)
    if disc < 0:
        return None
    s = -b + math.sqrt(disc)
    return replace(rel, lamp_mm=spot + s * out) if s > 0 else None


def with_glint_at(rel: RelativePose, rc: tuple[float, float], size: tuple[int, int], focal_px: float,
                  iterations: int = 6) -> RelativePose | None:
    """``rel`` with the disc turned about its centre (camera and lamp kept) so that its mirror
    glint appears at image point ``rc``: a tilt read off the glint. None if none does."""
    target = np.asarray(rc, dtype=np.float64)
    angles = np.zeros(2)

    def glint(a: NDArray[np.float64]) -> NDArray[np.float64] | None:
        turn = rotation_xy(a[0], a[1])
        m = mirror_point(RelativePose(rel.disc_centre_mm, turn @ rel.disc_normal, rel.lamp_mm, rel.lobe_sigma,
                                      rel.disc_x))
        return None if m is None or m[2] >= 0 else project(m, size, focal_px)

    for _ in range(iterations):
        g = glint(angles)
        if g is None:
            return None
        jac = np.empty((2, 2))
        for k in range(2):
            da = np.zeros(2)
            da[k] = 0.01
            gk = glint(angles + da)
            if gk is None:
                return None
            jac[:, k] = (gk - g) / 0.01
        try:
            angles = angles - np.linalg.solve(jac, g - target)
        except np.linalg.LinAlgError:
            return None
        if np.max(np.abs(angles)) > 20.0:
            return None
    turn = rotation_xy(angles[0], angles[1])
    return RelativePose(rel.disc_centre_mm, turn @ rel.disc_normal, rel.lamp_mm, rel.lobe_sigma, turn @ rel.disc_x)


def near_axis(preset: Preset) -> bool:
    """A camera above the disc centre looking straight down (within a few degrees): the near-axis
    fit's model, a good first stage."""
    cam = preset.camera
    if cam.is_on_axis:
        return True
    eye = np.asarray(cam.nominal_position_mm, dtype=np.float64)
    forward = np.asarray(cam.look_at_mm, dtype=np.float64) - eye
    return bool(np.hypot(eye[0], eye[1]) < 0.1 * eye[2] and -forward[2] > 0.99 * np.linalg.norm(forward))


def with_lamp_distance(rel: RelativePose, distance_mm: float) -> RelativePose:
    """``rel`` with the lamp moved along its direction from the disc centre to ``distance_mm``."""
    lamp = rel.lamp_mm - rel.disc_centre_mm
    norm = float(np.linalg.norm(lamp))
    if norm <= 0:
        return rel
    return replace(rel, lamp_mm=rel.disc_centre_mm + lamp * (distance_mm / norm))


MIN_PLANE_SINE = math.sin(math.radians(2.0))  # lens and lamp closer than this, seen from the disc: no plane
# A lamp seen from the disc within this of the lens is beside it (a near-axis capture: the
# near-axis presets put it 0–3.3° away, the oblique ones 20–45°): there a tilted disc, not the
# lamp, sets the plane the pattern moves in.
BESIDE_LENS_DEG = 10.0


def plane_axis(rel: RelativePose) -> NDArray[np.float64] | None:
    """Unit normal of the plane of incidence at the disc centre, or None where there is none.

    The plane through the lens and the lamp; but with the lamp beside the lens (within
    BESIDE_LENS_DEG) and the disc tilted further from the mirror direction (the half-way vector
    between lens and lamp) than the lamp is from the lens, the plane through the disc's normal and
    that mirror direction: a disc tilted 5° under a camera with a lamp beside it swings the
    mirror glint 10° off the disc centre along that plane, and the rings become arcs whose axis
    lies in it. None where both planes are undefined (angles under MIN_PLANE_SINE)."""
    centre = np.asarray(rel.disc_centre_mm, dtype=np.float64)
    lens = -centre / np.linalg.norm(centre)
    lamp = np.asarray(rel.lamp_mm, dtype=np.float64) - centre
    lamp = lamp / np.linalg.norm(lamp)
    axis = np.cross(lens, lamp)
    sine = float(np.linalg.norm(axis))
    if sine < math.sin(math.radians(BESIDE_LENS_DEG)):
        half = (lens + lamp) / np.linalg.norm(lens + lamp)
        tilted = np.cross(np.asarray(rel.disc_normal, dtype=np.float64), half)
        if float(np.linalg.norm(tilted)) > sine:
            axis, sine = tilted, float(np.linalg.norm(tilted))
    return axis / sine if sine >= MIN_PLANE_SINE else None


def turned_in_plane(rel: RelativePose, tilt_deg: float, swing_deg: float) -> RelativePose | None:
    """``rel`` with the disc tilted by ``tilt_deg`` and the lamp turned by 2·tilt + ``swing_deg``
    about the disc centre, both about the normal of the plane of incidence (:func:`plane_axis`;
    for an untilted disc, the plane through the disc centre, the lens and the lamp). The lamp
    turns twice as far as the disc for the reason :func:`apply_params` gives.

    These are the two angles that slide the wavelength axis along an oblique streak (a degree
    moves it by ~40 nm) without moving the streak sideways: a lamp swung or a disc tilted about
    that normal. None where there is no plane of incidence (:func:`plane_axis`)."""
    axis = plane_axis(rel)
    if axis is None:
        return None
    centre = np.asarray(rel.disc_centre_mm, dtype=np.float64)
    lamp = np.asarray(rel.lamp_mm, dtype=np.float64) - centre
    tilt = rotation_about(axis, tilt_deg)
    lamp = rotation_about(axis, 2.0 * tilt_deg + swing_deg) @ lamp
    return replace(rel, disc_normal=tilt @ rel.disc_normal, disc_x=tilt @ rel.disc_x, lamp_mm=centre + lamp)


@dataclass(frozen=True)
class RayDiffraction:
    """First-order coordinates of fixed camera rays (see :func:`ray_diffraction`)."""

    hit: NDArray[np.bool_]  # the ray meets the disc plane in front of the camera
    lambda1_nm: NDArray[np.float64]
    v: NDArray[np.float64]
    amplitude: NDArray[np.float64]  # visibility × gain, as PixelDiffraction.amplitude
    radius_mm: NDArray[np.float64]


def ray_diffraction(rays: NDArray[np.float64], rel: RelativePose, pitch_um: float) -> RayDiffraction:
    """λ₁, v and amplitude along fixed camera rays for the capture ``rel``: :func:`.kernel.diffraction_along`
    in the camera's frame (the pose fit evaluates it ~10³ times; it agrees with
    :func:`.diffraction.pixel_diffraction` of the same capture to 1e-9, tests/test_pose_recovery.py)."""
    hit, geo = diffraction_along(rays, np.zeros(3), rel.disc_centre_mm, rel.disc_normal, rel.lamp_mm)
    n = hit.size
    lam = np.zeros(n)
    v = np.zeros(n)
    amp = np.zeros(n)
    radius = np.full(n, np.inf)
    lam[hit] = geo.lambda1_nm(pitch_um)
    v[hit] = geo.v
    amp[hit] = geo.visibility(rel.lobe_sigma) * geo.gain
    radius[hit] = geo.radius
    return RayDiffraction(hit, lam, v, amp, radius)
