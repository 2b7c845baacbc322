"""What to move when the rainbow misses the disc's tracks, computed from the capture geometry.

With the lamp beside the lens, the first order is seen only along the line through the lamp's
and the camera's feet, and it moves towards the centre as the lamp moves out: at 60 mm beside
a lens 210 mm above the disc, 400–700 nm falls on the clear hub (r < 23 mm) and no algorithm
can read it. How far the lamp may be is found here with the same per-pixel diffraction
coordinate the readout uses, for the preset's camera and lamp height.

For an oblique set-up (camera and lamp at angles from the disc's axis, anywhere around it) what
matters is those angles and how far around the disc the lamp stands from the camera (its azimuth,
seen from above, counter-clockwise): the fitted capture's are compared with the preset's, the part
of 400–700 nm that lands on the tracks is read along the first order's streak
(:func:`~.setups.first_order_visible`), and the advice names the moves that bring the capture back
to the preset — or, where the preset itself leaves part of 400–700 nm off the tracks, the one move
of lamp or camera (5° of angle, 15° around the disc) that shows the most of it.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..photo.resample import channel_sum
from ..scene.capture import Camera, Light, Pose, Preset, Scene
from ..scene.diffraction import lobe_pixels
from ..scene.kernel import rotation_about
from ..scene.relative_pose import near_axis
from .setups import first_order_visible
from ..spectra.grid import FEATURE_STEP_NM, MIN_VISIBILITY, VISIBLE_NM

REACH_SIDE = 256  # image side the reach is computed at (a pixel ≈ 0.5 mm on the disc)
REACH_STEP_MM = 2.5
REACH_MAX_MM = 120.0
REACH_COVERAGE = 0.95  # share of 400–700 nm (5 nm bins) that must land on the tracks
# 400–700 nm in the readout's 5 nm steps (edges on whole multiples of 5 nm from 400 nm): 60 bins.
_VISIBLE_BINS = round((VISIBLE_NM[1] - VISIBLE_NM[0]) / FEATURE_STEP_NM)

__all__ = ["coverage_400_700", "lamp_reach_mm", "lamp_offset_mm", "glint_px", "lamp_advice", "missing_nm",
           "capture_angles", "lamp_azimuth_deg", "oblique_advice", "coverage_advice", "advice_for_photo"]


def _covered_bins(scene: Scene) -> NDArray[np.int64]:
    px = lobe_pixels(scene, MIN_VISIBILITY).pixels  # every visible pixel, the kernel evaluated near the lobe only
    lam = px.lambda1_nm[px.on_tracks & (px.visibility >= MIN_VISIBILITY)]
    bins = np.floor((lam - VISIBLE_NM[0]) / FEATURE_STEP_NM).astype(np.int64)
    return np.unique(bins[(bins >= 0) & (bins < _VISIBLE_BINS)])


def coverage_400_700(scene: Scene) -> float:
    """Share of the 5 nm bins of 400–700 nm that some visible first-order pixel on the tracks shows."""
    return float(_covered_bins(scene).size / float(_VISIBLE_BINS))


def missing_nm(scene: Scene) -> list[tuple[int, int]]:
    """The stretches of 400–700 nm (nm, 5 nm bins) no visible first-order pixel on the tracks shows."""
    have = np.zeros(_VISIBLE_BINS, dtype=bool)
    have[_covered_bins(scene)] = True
    out: list[tuple[int, int]] = []
    start = None
    for i, ok in enumerate(np.append(have, True)):
        if not ok and start is None:
            start = i
        elif ok and start is not None:
            out.append((int(VISIBLE_NM[0] + FEATURE_STEP_NM * start), int(VISIBLE_NM[0] + FEATURE_STEP_NM * i)))
            start = None
    return out


def _lamp_at_lens(preset: Preset) -> Preset:
    """``preset`` at REACH_SIDE px with its lamp on the lens's axis, at the preset's lamp height."""
    base = preset.with_image_size(REACH_SIDE)
    height = base.light.position_mm[2]
    return replace(base, light=Light(position_mm=(0.0, 0.0, height), lobe_sigma=base.light.lobe_sigma,
                                     intensity=base.light.intensity))


@lru_cache(maxsize=16)
def lamp_reach_mm(preset: Preset) -> float:
    """Largest distance of the lamp beside the lens (at the preset's lamp height) for which the
    first order still covers 400–700 nm on the tracks."""
    base = _lamp_at_lens(preset)
    reach = 0.0
    for offset in np.arange(0.0, REACH_MAX_MM + 1e-9, REACH_STEP_MM):
        if coverage_400_700(Scene(base, Pose(light_offset_mm=(float(offset), 0.0)))) < REACH_COVERAGE:
            break
        reach = float(offset)
    return reach


def lamp_offset_mm(scene: Scene) -> float:
    """How far the fitted lamp is from the lens axis, parallel to the disc (mm)."""
    d = (scene.light_position - scene.camera_position) * 1e3
    return float(math.hypot(d[0], d[1]))


GLINT_CONTRAST = 5.0  # an unclipped glint outshines the photo's 99.5th percentile this many times
# A clipped glint told to the user is a solid spot: at least this share of its brightest pixel's
# eight neighbours clipped too. A photo of pure noise (8-bit, ~3.5 % of its pixels with a channel
# at 255) has clipped pixels everywhere, and its brightest one, with ~0.04 of its neighbours
# clipped, was read as a glint: "move the lamp closer: it is about 40 mm from the lens axis".
SOLID_GLINT = 0.5


def glint_px(rgb: NDArray[np.float64], saturated: NDArray[np.bool_], solid: bool = False
             ) -> tuple[float, float] | None:
    """Centre (row, col) of the zero-order glint — the lamp's mirror image in the disc — or None.

    It is the brightest spot where that spot is clipped or outshines nearly all of the photo
    (a photo exposed for the glint leaves the rainbow dim). Its place gives the lamp's
    direction even when the fit finds no rainbow. ``solid``: a clipped spot counts only where
    it is one (:data:`SOLID_GLINT`) — for advice, which has no fit to check it against."""
    lum = channel_sum(rgb)
    sat = np.asarray(saturated, dtype=bool)
    if np.any(sat):
        spot = sat
        lum = np.where(sat, lum, -np.inf)
    else:
        peak = float(np.max(lum))
        if not peak > GLINT_CONTRAST * max(float(np.percentile(lum, 99.5)), 1e-12):
            return None
        spot = lum >= 0.5 * peak
    r0, c0 = np.unravel_index(int(np.argmax(lum)), lum.shape)
    if solid and np.any(sat):
        around = sat[max(r0 - 1, 0):r0 + 2, max(c0 - 1, 0):c0 + 2]
        if int(np.sum(around)) - 1 < SOLID_GLINT * (around.size - 1):
            return None
    rows, cols = np.nonzero(spot)
    near = np.hypot(rows - r0, cols - c0) <= 4.0
    return float(np.mean(rows[near])), float(np.mean(cols[near]))


def lamp_offset_from_glint(glint: tuple[float, float], image_size: tuple[int, int], focal_px: float,
                           preset: Preset) -> float:
    """Lamp distance beside the lens (mm) from the glint, for a camera looking straight down at
    the disc: the mirror point m sits at D/(D + D_L) of the way from the camera's foot to the lamp's."""
    width, height = image_size
    dist = preset.camera.distance_mm
    lamp_height = max(preset.light.position_mm[2], 1e-6)
    m_mm = math.hypot(glint[0] - (height / 2.0 - 0.5), glint[1] - (width / 2.0 - 0.5)) * dist / focal_px
    return m_mm * (dist + lamp_height) / dist


def lamp_advice(preset: Preset, offset_mm: float | None) -> str:
    """A sentence saying where to put the lamp, with the distances of this capture."""
    reach = lamp_reach_mm(preset)
    dist = preset.camera.distance_mm
    if reach == 0.0 and (missing := missing_nm(Scene(_lamp_at_lens(preset)))):
        # No lamp position helps: at this distance the tracks' first order leaves the short end
        # of 400–700 nm off the disc's tracks (camera too near) or the long end (too far).
        way = "further from" if missing[0][0] <= VISIBLE_NM[0] else "closer to"
        held = ", ".join(f"{a}–{b}" for a, b in missing)
        return (f"with the camera {dist:.0f} mm above the disc even a lamp at the lens leaves {held} nm off the "
                f"disc's tracks: move camera and lamp {way} the disc (see the capture guide)")
    if offset_mm is not None and offset_mm > reach + REACH_STEP_MM:
        return (f"move the lamp closer to the lens: it is about {offset_mm:.0f} mm from the lens axis, and only "
                f"within about {reach:.0f} mm does the first order (400–700 nm) land on the disc's tracks with the "
                f"camera {dist:.0f} mm above the disc")
    return (f"photograph the disc with the lamp within about {reach:.0f} mm of the lens, camera and lamp "
            f"{dist:.0f} mm above the disc's centre (see the capture guide)")


def advice_for_photo(preset: Preset, scene: Scene, fit_trusted: bool, rgb: NDArray[np.float64],
                     saturated: NDArray[np.bool_], focal_px: float) -> str:
    """What to move for a photo whose rainbow could not be read. Near-axis set-ups: the lamp's
    distance from the lens from the clipped glint (a direct sighting of the lamp's mirror image)
    where there is one, else from the fitted pose where the fit is trusted. Oblique set-ups: the
    fitted angles against the preset's, or the preset's angles alone."""
    if not near_axis(preset):
        return oblique_advice(preset, scene if fit_trusted else None)
    glint = glint_px(rgb, saturated, solid=True)
    offset: float | None = None
    if glint is not None:
        height, width = np.asarray(rgb).shape[:2]
        offset = lamp_offset_from_glint(glint, (width, height), focal_px, preset)
    elif fit_trusted:
        offset = lamp_offset_mm(scene)
    return lamp_advice(preset, offset)


def capture_angles(scene: Scene) -> tuple[float, float, float]:
    """(camera, lamp) angles from the disc's axis in degrees, and the angle between their
    directions around the axis (0: same side, 180: opposite sides) — in the disc's own frame,
    so a tilted disc shows as changed angles."""
    n = scene.disc_normal
    cam = scene.camera_position - scene.disc_center
    lamp = scene.light_position - scene.disc_center

    def polar(v: NDArray[np.float64]) -> float:
        return math.degrees(math.atan2(float(np.linalg.norm(v - (v @ n) * n)), float(v @ n)))

    cam_t, lamp_t = cam - (cam @ n) * n, lamp - (lamp @ n) * n
    norms = float(np.linalg.norm(cam_t) * np.linalg.norm(lamp_t))
    between = math.degrees(math.acos(float(np.clip(cam_t @ lamp_t / norms, -1.0, 1.0)))) if norms > 1e-12 else 0.0
    return polar(cam), polar(lamp), between


def lamp_azimuth_deg(scene: Scene) -> float:
    """How far counter-clockwise the lamp stands from the camera around the disc's axis, seen from
    above the disc (its own frame), in [0, 360); 0 where either is on the axis."""
    n = scene.disc_normal
    cam = scene.camera_position - scene.disc_center
    lamp = scene.light_position - scene.disc_center
    cam_t, lamp_t = cam - (cam @ n) * n, lamp - (lamp @ n) * n
    if np.linalg.norm(cam_t) < 1e-9 or np.linalg.norm(lamp_t) < 1e-9:
        return 0.0
    return math.degrees(math.atan2(float(np.cross(cam_t, lamp_t) @ n), float(cam_t @ lamp_t))) % 360.0 + 0.0


_MOVE_DEG = 2.0  # differences below this are within what a fitted pose and a person's protractor agree on
_PROBE_DEG = 5.0  # the probe's step for an angle from the axis
_PROBE_TURN_DEG = 15.0  # and around the disc
_MAX_ANGLE_DEG = 89.5


def _deg(value: float) -> str:
    return f"{round(value, 1):g}°"


def _where(cam: float, lamp: float, azimuth: float) -> str:
    """Camera and lamp angles from the axis and the lamp's azimuth from the camera, in words."""
    angles = f"camera {_deg(cam)} and lamp {_deg(lamp)} from the disc's axis"
    if lamp < 0.5 or cam < 0.5:
        return f"{angles} ({'the lamp above the disc centre' if lamp < 0.5 else 'the camera straight above it'})"
    turn = round(azimuth, 1) % 360.0
    side = ("on the camera's side, in its vertical plane" if turn == 0.0 else
            "opposite the camera, in its vertical plane" if turn == 180.0 else
            f"{_deg(turn)} counter-clockwise from the camera, seen from above the disc")
    return f"{angles}, the lamp {side}"


def _angles_of(scene: Scene) -> tuple[float, float, float]:
    cam, lamp, _ = capture_angles(scene)
    return cam, lamp, lamp_azimuth_deg(scene)


def _landing(parts: list[tuple[float, float]]) -> str:
    if not parts:
        return "none of 400–700 nm lands on the disc's tracks"
    if parts == [VISIBLE_NM] or parts == [(float(VISIBLE_NM[0]), float(VISIBLE_NM[1]))]:
        return "all of 400–700 nm lands on the disc's tracks"
    return f"only {', '.join(f'{a:.0f}–{b:.0f}' for a, b in parts)} nm of 400–700 nm lands on the disc's tracks"


def _moves(now: tuple[float, float, float], want: tuple[float, float, float]) -> list[str]:
    """The moves that take the capture ``now`` (camera, lamp angle, lamp azimuth) to ``want``."""
    out = []
    for name, k in (("camera", 0), ("lamp", 1)):
        change = want[k] - now[k]
        if abs(change) > _MOVE_DEG:
            out.append(f"{'lower' if change > 0 else 'raise'} the {name} {_deg(abs(change))} "
                       f"(to {_deg(want[k])} from the disc's axis)")
    turn = (want[2] - now[2] + 180.0) % 360.0 - 180.0
    if min(now[0], now[1], want[0], want[1]) >= 0.5 and abs(turn) > _MOVE_DEG:
        out.append(f"move the lamp {_deg(abs(turn))} {'counter-clockwise' if turn > 0 else 'clockwise'} around the "
                   f"disc, seen from above (to {_deg(want[2] % 360.0)} counter-clockwise from the camera)")
    return out


def _moved(scene: Scene, camera_deg: float = 0.0, lamp_deg: float = 0.0, lamp_turn_deg: float = 0.0) -> Scene | None:
    """``scene`` with the camera or the lamp moved by angles from the disc's axis (positive: lower)
    or the lamp turned around the axis (positive: counter-clockwise seen from above); the camera
    aimed at the disc centre. None where the move would leave 0–89.5° or needs a direction the
    axis does not give."""
    n, centre = scene.disc_normal, scene.disc_center * 1e3
    cam, lamp = scene.camera_position * 1e3 - centre, scene.light_position * 1e3 - centre

    def tilt(v: np.ndarray, degrees: float) -> np.ndarray | None:
        if degrees == 0.0:
            return v
        foot = v - (v @ n) * n
        angle = math.degrees(math.atan2(float(np.linalg.norm(foot)), float(v @ n))) + degrees
        if np.linalg.norm(foot) < 1e-9 or not 0.0 <= angle <= _MAX_ANGLE_DEG:
            return None
        axis = np.cross(n, foot / np.linalg.norm(foot))
        return rotation_about(axis, degrees) @ v

    cam, lamp = tilt(cam, camera_deg), tilt(lamp, lamp_deg)
    if cam is None or lamp is None:
        return None
    lamp = rotation_about(n, lamp_turn_deg) @ lamp
    forward = -cam / np.linalg.norm(cam)
    up = n - (n @ forward) * forward
    if np.linalg.norm(up) < 1e-9:
        up = scene.camera_rotation[:, 1]
    old = scene.preset
    camera = Camera(distance_mm=float(np.linalg.norm(cam)), focal_length_mm=old.camera.focal_length_mm,
                    sensor_width_mm=old.camera.sensor_width_mm, image_size_px=old.camera.image_size_px,
                    position_mm=tuple(float(x) for x in centre + cam), look_at_mm=tuple(float(x) for x in centre),
                    up=tuple(float(x) for x in up))
    tilt_deg = tuple(a + b for a, b in zip(old.disc_tilt_deg, scene.pose.tilt_deg))
    return Scene(replace(old, camera=camera, light=replace(old.light, position_mm=tuple(float(x) for x in centre + lamp)),
                         disc_tilt_deg=tilt_deg))


def _best_move(scene: Scene, shown: float) -> str | None:
    """The one move of lamp or camera that shows the most more of 400–700 nm on the tracks, if any
    shows ≥ 10 nm more, with what it shows."""
    probes = (("raise the lamp", {"lamp_deg": -_PROBE_DEG}), ("lower the lamp", {"lamp_deg": _PROBE_DEG}),
              ("move the lamp {t}° counter-clockwise around the disc", {"lamp_turn_deg": _PROBE_TURN_DEG}),
              ("move the lamp {t}° clockwise around the disc", {"lamp_turn_deg": -_PROBE_TURN_DEG}),
              ("raise the camera", {"camera_deg": -_PROBE_DEG}), ("lower the camera", {"camera_deg": _PROBE_DEG}))
    best: tuple[float, str] | None = None
    for words, move in probes:
        moved = _moved(scene, **move)
        if moved is None:
            continue
        parts = first_order_visible(moved)
        total = sum(b - a for a, b in parts)
        if total >= shown + 10.0 and (best is None or total > best[0]):
            text = words.format(t=f"{_PROBE_TURN_DEG:g}")
            text += "" if "around" in text else f" {_PROBE_DEG:g}°"
            best = (total, f"{text}: then {_landing(parts).replace('lands', 'would land')}")
    return None if best is None else best[1]


def _tilt_deg(scene: Scene) -> float:
    """How far the disc is tilted from the preset's disc (degrees)."""
    nominal = Scene(scene.preset).disc_normal
    return math.degrees(math.acos(float(np.clip(scene.disc_normal @ nominal, -1.0, 1.0))))


def oblique_advice(preset: Preset, scene: Scene | None) -> str:
    """What to move for an oblique set-up: the fitted camera and lamp angles and the lamp's azimuth
    against the preset's (where a fit is trusted), which part of 400–700 nm lands on the tracks,
    and the moves that would show more of it."""
    want = _angles_of(Scene(preset))
    placement = f"{_where(*want)} (preset '{preset.name}')"
    if scene is None:
        return f"place them as the set-up says: {placement}"
    now = _angles_of(scene)
    parts = first_order_visible(scene)
    lands = _landing(parts)
    moves = _moves(now, want)
    tilt = _tilt_deg(scene)
    if tilt > _MOVE_DEG:  # a tilted disc changes every angle measured from its axis
        moves.append(f"or, if they stand where the set-up says, lay the disc flat (it is tilted {_deg(tilt)})")
    if moves:
        return f"{lands}: the photo shows the {_where(*now)} — {'; '.join(moves)}; the set-up: {placement}"
    shown = sum(b - a for a, b in parts)
    if shown >= VISIBLE_NM[1] - VISIBLE_NM[0]:
        return (f"{lands} with the capture the photo shows ({_where(*now)}); the disc may be cut off by the frame, "
                "or the streak is too faint or blurred to read there")
    better = _best_move(scene, shown)
    return (f"{lands} with the set-up as preset '{preset.name}' places it ({_where(*want)}) — "
            + (better if better else "no single move of 5° helps: plan another set-up with 'plan'"))


def coverage_advice(preset: Preset, scene: Scene) -> str:
    """What to move when part of 400–700 nm misses the tracks, for the fitted ``scene``."""
    if not near_axis(preset):
        return oblique_advice(preset, scene)
    offset, reach = lamp_offset_mm(scene), lamp_reach_mm(preset)
    if offset > reach or reach == 0.0:  # reach 0: the camera's distance is what to change
        return lamp_advice(preset, offset)
    return "the disc may be cut off by the frame, or the lamp and camera are too far off the disc's axis"
