"""What to move when the rainbow misses the disc's tracks, computed from the capture geometry.

With the lamp beside the lens, the first order is seen only along the line through the lamp's
and the camera's feet, and it moves towards the centre as the lamp moves out: at 60 mm beside
a lens 210 mm above the disc, 400–700 nm falls on the clear hub (r < 23 mm) and no algorithm
can read it. How far the lamp may be is found here with the same per-pixel diffraction
coordinate the readout uses, for the preset's camera and lamp height.

For an oblique set-up (camera and lamp at angles from the disc's axis) what matters is those
angles: the fitted capture's are compared with the preset's, and the part of 400–700 nm that
misses the tracks is named.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..photo.resample import channel_sum
from ..scene.capture import Light, Pose, Preset, Scene
from ..scene.diffraction import lobe_pixels
from ..scene.relative_pose import near_axis
from ..spectra.grid import FEATURE_STEP_NM, MIN_VISIBILITY, VISIBLE_NM

REACH_SIDE = 256  # image side the reach is computed at (a pixel ≈ 0.5 mm on the disc)
REACH_STEP_MM = 2.5
REACH_MAX_MM = 120.0
REACH_COVERAGE = 0.95  # share of 400–700 nm (5 nm bins) that must land on the tracks
# 400–700 nm in the readout's 5 nm steps (edges on whole multiples of 5 nm from 400 nm): 60 bins.
_VISIBLE_BINS = round((VISIBLE_NM[1] - VISIBLE_NM[0]) / FEATURE_STEP_NM)

__all__ = ["coverage_400_700", "lamp_reach_mm", "lamp_offset_mm", "glint_px", "lamp_advice", "missing_nm",
           "capture_angles", "oblique_advice", "coverage_advice", "advice_for_photo"]


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


@lru_cache(maxsize=16)
def lamp_reach_mm(preset: Preset) -> float:
    """Largest distance of the lamp beside the lens (at the preset's lamp height) for which the
    first order still covers 400–700 nm on the tracks."""
    base = preset.with_image_size(REACH_SIDE)
    height = base.light.position_mm[2]
    base = replace(base, light=Light(position_mm=(0.0, 0.0, height), lobe_sigma=base.light.lobe_sigma,
                                     intensity=base.light.intensity))
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


def glint_px(rgb: NDArray[np.float64], saturated: NDArray[np.bool_]) -> tuple[float, float] | None:
    """Centre (row, col) of the zero-order glint — the lamp's mirror image in the disc — or None.

    It is the brightest spot where that spot is clipped or outshines nearly all of the photo
    (a photo exposed for the glint leaves the rainbow dim). Its place gives the lamp's
    direction even when the fit finds no rainbow."""
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
    glint = glint_px(rgb, saturated)
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


def oblique_advice(preset: Preset, scene: Scene | None) -> str:
    """What to move for an oblique set-up: the fitted camera and lamp angles against the preset's
    (where a fit is trusted), and which part of 400–700 nm misses the tracks."""
    cam0, lamp0, between0 = capture_angles(Scene(preset))
    side0 = "the camera's side" if between0 < 90 else "the other side from the camera"
    want = (f"camera {cam0:.0f}° and lamp {lamp0:.0f}° from the disc's axis, the lamp on {side0}, in one "
            f"vertical plane through the disc's centre (preset '{preset.name}')")
    if scene is None:
        return f"place them as the set-up says: {want}"
    cam, lamp, between = capture_angles(scene)
    gaps = missing_nm(scene)
    lost = ", ".join(f"{a}–{b} nm" for a, b in gaps)
    told = f"{lost} misses the disc's tracks" if gaps else "the first order is on the tracks"
    side = "the camera's side" if between < 90 else "the other side"
    return (f"{told}: the photo shows the camera {cam:.0f}° and the lamp {lamp:.0f}° from the disc's axis "
            f"(on {side}, {abs(between if between < 90 else 180 - between):.0f}° out of the camera's plane) — "
            f"move them to the set-up's {want}")


def coverage_advice(preset: Preset, scene: Scene) -> str:
    """What to move when part of 400–700 nm misses the tracks, for the fitted ``scene``."""
    if not near_axis(preset):
        return oblique_advice(preset, scene)
    offset = lamp_offset_mm(scene)
    if offset > lamp_reach_mm(preset):
        return lamp_advice(preset, offset)
    return "the disc may be cut off by the frame, or the lamp and camera are too far off the disc's axis"
