"""The general-pose inverse: disc pose, lamp position and lamp size of any capture, from the photo.

Used by :func:`.analysis.prepare` for every preset. The preset is only a start. In order:

1. starts — the preset's capture; the same turned so the photo's bright pattern lines up with
   the predicted one (an FFT correlation); where the disc's outline shows, the two poses its
   ellipse allows (:mod:`.rim_ellipse`); each of those moved by the rainbow's own colours
   (:mod:`.streak_colours`); for a camera above the disc the near-axis fit
   (:func:`.pose_fit.fit_pose`); and where the zero-order glint is seen (clipped), poses that put
   the lamp's mirror image exactly there, with the disc centre sought along the arcs' axis
   (:func:`_glint_line_start`);
2. the best start by the smooth self-consistency (:mod:`.profile_residuals`) on a coarse λ₁
   profile (5 nm nodes): a profile too coarse for lamp lines does not lock onto them;
3. Levenberg–Marquardt on all eight parameters (:func:`.relative_pose.apply_params`), first on
   the coarse profile with the camera's colour at full weight (it pins the wavelength axis along
   a single streak), then on a finer profile with the colour at 0.3 (the lamp's spectrum within
   the lobe biases the colour by ~1 nm; the self-consistency is unbiased). The best start from
   the glint's line is carried through both stages beside the overall best, and the finer
   profile picks between them (a tilted disc near the axis and a flat one with the lamp further
   off are told apart there, not on the coarse profile).

The zero-order glint and clipped pixels are left out of every comparison. The result is a
:class:`.pose_fit.PoseFit` whose ``known_scene`` is the fitted capture; its residual and null
residual are the binned ``consistency`` of :mod:`.pose_fit`, so the rainbow contrast and the
refusals mean what they always meant.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import Preset, Scene
from ..planning.capture_advice import glint_px
from ..scene.diffraction import pixel_diffraction
from ..numerics.least_squares import levenberg_marquardt
from .pose_fit import (FIT_STEP_NM, PoseFit, axis_of_arcs, informative_pixels, glint_mask, box_downsample,
                       colour_blur_nm, consistency, expected_colours, fit_pose)
from .profile_residuals import ProfileGrid, profile_residuals
from ..scene.kernel import index_rays, project, turn_between
from ..scene.relative_pose import (N_PARAMS, RelativePose, aimed_at, apply_params, mirror_point, near_axis, nominal_scene,
                            ray_diffraction, relative_pose, scene_from_relative, with_glint_at,
                            turned_in_plane, with_lamp_distance)
from .rim_ellipse import Ellipse, circle_poses, disc_base, disc_ellipse
from .streak_colours import streak_fit

__all__ = ["fit_general_pose", "STAGES"]

COARSE_SIDE = 256  # the bright pattern is lined up on an image of about this size
FINE_PIXELS = 12_000  # pixels the reported (binned) consistency looks at, as pose_fit's refinement


def _expected_pattern(scene: Scene) -> NDArray[np.float64]:
    """Where the scene puts first-order light of 420–680 nm (amplitude per pixel, image-shaped)."""
    width, height = scene.preset.camera.image_size_px
    px = pixel_diffraction(scene)
    keep = px.on_tracks & (px.lambda1_nm > 420) & (px.lambda1_nm < 680)
    out = np.zeros(width * height)
    out[px.index[keep]] = px.amplitude[keep]
    return out.reshape(height, width)


def _shift_by_correlation(photo_lum: NDArray[np.float64], pattern: NDArray[np.float64]) -> tuple[float, float]:
    """(rows, cols) by which the photo's bright pattern is displaced from the predicted one."""
    h, w = photo_lum.shape
    a = np.fft.rfft2(photo_lum, s=(2 * h, 2 * w))
    b = np.fft.rfft2(pattern, s=(2 * h, 2 * w))
    corr = np.fft.irfft2(a * np.conj(b), s=(2 * h, 2 * w))
    r, c = np.unravel_index(int(np.argmax(corr)), corr.shape)
    r = r - 2 * h if r >= h else r
    c = c - 2 * w if c >= w else c
    return float(r), float(c)


GRID_NM = (300.0, 2500.0)  # every λ₁ the disc shows: first order and the higher orders that share its |u|
# (profile node spacing nm, weight of the camera's colour) of the successive fits; chosen on
# synthetic spectra (sample_spds) at realistic resolution, never on the evaluation's lamps.
STAGES = ((5.0, 1.0), (3.0, 0.3))
LM_PIXELS = 8000
REFINE_NEAR_AXIS = False  # its full-resolution refinement: the LM below does that better (same MAE, 0.3 s less)
TRIED_STARTS = 3  # the best starts by the coarse cost that get a coarse fit each
# Fitted: aim, tilt, lamp direction, σ. The lamp's distance stays the preset's: it moves λ₁ only
# through the lamp's direction varying over the disc, and left free it soaked up colour errors of
# an in-camera JPEG (lamp 10 % nearer, residual 0.11, MAE 0.29 at 160 px).
FREE = np.array([0, 1, 2, 3, 4, 5, 7])
LM_STEP = 1e-3  # forward-difference step of every parameter (degrees or log units)
LM_ITERATIONS = 40
PRIOR_WEIGHT = 1e-2  # prior residual scale (a 1-scale departure costs 1e-4 of the photo's energy)
PRIOR_SCALE = np.array([5.0, 5.0, 3.0, 3.0, 3.0, 3.0, 0.3, 1.0])  # deg ×6, log lamp distance, log σ
ARCS_STRENGTH = 0.05  # below this the rainbow is full rings: the disc centre is the glint's
# The in-plane valley (_valley_start); chosen on synthetic spectra (sample_spds), never on the lamps.
SWING_DEG = 12.0  # the lamp's in-plane angle scanned this far either way (issue 10: lamp ±3°, tilt ≤ 5°: ~2° per degree of tilt)
SWING_STEP_DEG = 0.5  # the coarse cost's teeth in that angle are ~0.5° wide at the bottom, ~1.5° apart
SWUNG_STARTS = 2  # the deepest teeth of that scan are followed along the tilt
TILT_DEG = 6.0  # ...this far either way
TILT_STEP_DEG = 0.5
VALLEY_STEP_DEG = 0.25  # the swing sampled this far either side of the valley's line at each tilt
# The disc centre along the arcs' axis (_glint_line_start). A tilt of θ under a near-axis camera
# puts the centre D·tan θ from the glint: 24 mm is 6.5° at 210 mm. The coarse cost's valley in
# that offset is ~2 mm wide (cd-default, 5°: 7e-4 at the true 18.4 mm, 1.6e-2 and 7e-2 at 16 and
# 20 mm; synthetic spectra), so it is sampled every half millimetre and its bottom found by a
# parabola.
GLINT_LINE_MM = 24.0
GLINT_LINE_STEP_MM = 0.5
AIM_GRID_DEG = 0.15  # the line's best turned this far about the lens either way (glint centroid error)...
AIM_GRID_STEP_DEG = 0.05  # ...in these steps


class _Residuals:
    """Smooth self-consistency residuals of a fixed pixel subset for parameters around ``rel0``
    (normalised by the subset's energy), then the prior's."""

    def __init__(self, flat: NDArray[np.float64], subset: NDArray[np.int64], preset: Preset,
                 size: tuple[int, int], focal_px: float, rel0: RelativePose, grid: ProfileGrid, total: float):
        self.preset, self.rel0, self.grid = preset, rel0, grid
        self.norm = 1.0 / math.sqrt(max(total, 1e-300))
        self.values = flat[subset]
        self.rays = index_rays(subset, size, focal_px)
        # the tracks' edges soft over one pixel's footprint, as the photo's pixels average them
        # (a hard edge makes the residuals jump as the pose moves a pixel across it)
        self.edge_mm = max(rel0.distance_mm / focal_px, 1e-3)
        self.evaluations = 0

    def __call__(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.concatenate([self.at(apply_params(self.rel0, x)), PRIOR_WEIGHT * x / PRIOR_SCALE])

    def at(self, rel: RelativePose) -> NDArray[np.float64]:
        """The photo's residuals (no prior) for the capture ``rel``."""
        self.evaluations += 1
        rd = ray_diffraction(self.rays, rel, self.preset.disc.pitch_um)
        disc = self.preset.disc
        edge = (np.clip((rd.radius_mm - disc.grating_r_min_mm) / self.edge_mm + 0.5, 0.0, 1.0)
                * np.clip((disc.grating_r_max_mm - rd.radius_mm) / self.edge_mm + 0.5, 0.0, 1.0))
        amp = rd.amplitude * edge * self.grid.taper(rd.lambda1_nm)
        return profile_residuals(self.values, rd.lambda1_nm, amp, self.grid) * self.norm


def _subset(rgb: NDArray[np.float64], excluded: NDArray[np.bool_] | None, count: int) -> NDArray[np.int64]:
    """Flat indices of up to ``count`` pixels (sorted): the brightest half, where the rainbow is,
    and a fixed random sample of the rest, where the pose must predict darkness; ``excluded``
    pixels (clipped) never. A partial sort: a full one of a 1 MP photo took 60 ms per call."""
    lum = rgb.sum(axis=2).ravel()
    if excluded is not None:
        lum = np.where(np.asarray(excluded).reshape(-1), -np.inf, lum)
    usable = int(np.sum(np.isfinite(lum)))
    half = min(count // 2, usable)
    bright = np.argpartition(-lum, half - 1)[:half] if half > 0 else np.zeros(0, dtype=np.int64)
    rest = np.setdiff1d(np.flatnonzero(np.isfinite(lum)), bright)
    take = min(count - half, rest.size)
    sample = np.random.default_rng(0).choice(rest, size=take, replace=False) if take else rest[:0]
    return np.sort(np.concatenate([bright, sample])).astype(np.int64)


def _without_glint(subset: NDArray[np.int64], scene: Scene) -> NDArray[np.int64]:
    px = pixel_diffraction(scene, subset)
    return np.setdiff1d(subset, px.index[glint_mask(px, scene)])


def _starts(rgb: NDArray[np.float64], preset: Preset, focal_px: float,
            sensitivities: NDArray[np.float64] | None, saturated: NDArray[np.bool_] | None,
            outline: Ellipse | None = None
            ) -> tuple[list[tuple[RelativePose, NDArray[np.float64]]], list[_GlintLine], int]:
    """Candidate starting poses (see the module docstring, step 1), the lines along which the
    disc centre is sought where the glint is seen (:func:`_glint_line_start`), and the
    evaluations spent."""
    height, width, _ = rgb.shape
    size = (width, height)
    evals = 0
    nominal = relative_pose(nominal_scene(preset, size, focal_px))
    starts = [(nominal, np.zeros(N_PARAMS))]
    factor = max(1, int(round(max(height, width) / COARSE_SIDE)))
    small = box_downsample(rgb, factor)
    sh, sw, _ = small.shape
    lum = small.sum(axis=2)
    lum = np.clip(lum - np.median(lum), 0.0, None)
    dr, dc = _shift_by_correlation(lum, _expected_pattern(scene_from_relative(nominal, preset, (sw, sh),
                                                                              focal_px / factor)))
    shifted = np.zeros(N_PARAMS)  # the camera turned the other way from how the pattern moved
    shifted[0] = -math.degrees(math.atan2(dr * factor, focal_px))
    shifted[1] = -math.degrees(math.atan2(dc * factor, focal_px))
    starts.append((nominal, shifted))
    if outline is not None:
        # The disc's outline (where room light shows it): its centre, distance and turn from the
        # ellipse, the lamp kept where the preset puts it relative to the disc.
        for centre, normal in circle_poses(outline, preset.disc.rim_radius_mm, focal_px, size):
            turn = turn_between(nominal.disc_normal, normal)
            lamp = centre + turn @ (nominal.lamp_mm - nominal.disc_centre_mm)
            starts.append((RelativePose(centre, normal, lamp, nominal.lobe_sigma, turn @ nominal.disc_x),
                           np.zeros(N_PARAMS)))
    if sensitivities is not None:
        # the rainbow's own colours name λ₁ along the streaks: a smooth fit good from far away
        half = box_downsample(rgb, 2)
        half_sat = None if saturated is None else box_downsample(np.asarray(saturated, np.float64), 2) > 0
        for rel, x in list(starts):
            y, n = streak_fit(half, preset, focal_px / 2.0, rel, x, sensitivities, half_sat)
            evals += n
            starts.append((rel, y))
    bases = [nominal]
    if near_axis(preset):
        near = fit_pose(rgb, preset, focal_px, sensitivities=sensitivities, refine=REFINE_NEAR_AXIS)
        evals += near.evaluations
        # its lamp sits at the camera's height (its model); the preset states the lamp's distance
        lamp_distance = float(np.linalg.norm(nominal.lamp_mm - nominal.disc_centre_mm))
        bases.append(with_lamp_distance(relative_pose(near.scene(preset, size)), lamp_distance))
        starts.append((bases[-1], np.zeros(N_PARAMS)))
    glint = glint_px(rgb, np.asarray(saturated)) if saturated is not None and np.any(saturated) else None
    lines: list[_GlintLine] = []
    if glint is not None:
        # The clipped glint is where the disc mirrors the lamp into the lens: a direct sighting
        # of the lamp's direction. The disc centre is on the line the arcs follow through it.
        g_small = ((glint[0] + 0.5) / factor - 0.5, (glint[1] + 0.5) / factor - 0.5)
        px_per_mm = focal_px / nominal.distance_mm
        angle, strength = axis_of_arcs(lum, g_small, 15 * px_per_mm / factor, 60 * px_per_mm / factor)
        axis = (-math.sin(angle), math.cos(angle)) if strength >= ARCS_STRENGTH else None
        lines = [_GlintLine(base, glint, axis, px_per_mm, size, focal_px) for base in bases]
    return starts, lines, evals


@dataclass(frozen=True)
class _GlintLine:
    """Captures with the mirror glint at a seen pixel and the disc centre ``t`` mm from it along
    the arcs' axis (``axis``, a (row, col) unit vector; None: full rings, the centre is the glint's)."""

    base: RelativePose
    glint: tuple[float, float]
    axis: tuple[float, float] | None
    px_per_mm: float
    size: tuple[int, int]
    focal_px: float

    def offsets(self) -> NDArray[np.float64]:
        if self.axis is None:
            return np.zeros(1)
        return np.arange(-GLINT_LINE_MM, GLINT_LINE_MM + 1e-9, GLINT_LINE_STEP_MM)

    def at(self, t: float) -> RelativePose | None:
        axis = (0.0, 0.0) if self.axis is None else self.axis
        centre = (self.glint[0] + t * self.px_per_mm * axis[0], self.glint[1] + t * self.px_per_mm * axis[1])
        return with_glint_at(aimed_at(self.base, centre, self.size, self.focal_px), self.glint, self.size,
                             self.focal_px)


def _glint_line_start(line: _GlintLine, residuals_for: Callable[[RelativePose], _Residuals]
                      ) -> tuple[float, RelativePose, int] | None:
    """The deepest point of the coarse cost along ``line``: (cost, capture, evaluations), or None.

    Why: a disc tilted 5° under a near-axis camera puts the glint ~18 mm from the disc centre and
    the rings become arcs about it. A centre 2 mm off along the arcs (a few tried offsets) costs
    20–30× the true one, and LM from there settles 0.3° off in the aim and 1° in the camera's
    angle, where the track edges cut the rings in the wrong places (synthetic spectra: λ₁ 1 nm
    off, MAE 0.26 against 0.06 from the true pose). Every
    candidate mirrors the lamp at the same pixel, so one glint-free pixel subset serves them all."""
    candidates = [(float(t), line.at(float(t))) for t in line.offsets()]
    candidates = [(t, rel) for t, rel in candidates if rel is not None]
    if not candidates:
        return None
    res = residuals_for(candidates[0][1])

    def cost(rel: RelativePose) -> float:
        r = res.at(rel)
        return float(r @ r)

    costs = np.array([cost(rel) for _, rel in candidates])
    k = int(np.argmin(costs))
    best = (float(costs[k]), candidates[k][1])
    if 0 < k < costs.size - 1:
        curve = costs[k - 1] + costs[k + 1] - 2.0 * costs[k]
        if curve > 0:
            shift = 0.5 * (costs[k - 1] - costs[k + 1]) / curve
            rel = line.at(candidates[k][0] + shift * GLINT_LINE_STEP_MM)
            if rel is not None:
                c = cost(rel)
                if c < best[0]:
                    best = (c, rel)
    return (*_aim_refined(best, cost), res.evaluations)


def _aim_refined(best: tuple[float, RelativePose], cost: Callable[[RelativePose], float]
                 ) -> tuple[float, RelativePose]:
    """``best`` turned about the lens on a small grid of aims, the cheapest kept. Why: the clipped
    glint's centroid is ~2 px (0.1°) off the mirror point, and a 0.1° aim alone costs ~1e-2 on
    the coarse cost (more than the pose's whole misfit), enough to send LM 1.6° along the valley."""
    steps = np.arange(-AIM_GRID_DEG, AIM_GRID_DEG + 1e-9, AIM_GRID_STEP_DEG)
    for a in steps:
        for b in steps:
            if a == 0.0 and b == 0.0:
                continue
            x = np.zeros(N_PARAMS)
            x[0], x[1] = a, b
            rel = apply_params(best[1], x)
            c = cost(rel)
            if c < best[0]:
                best = (c, rel)
    return best


def _valley_start(base: RelativePose, res: _Residuals) -> tuple[float, RelativePose] | None:
    """The deepest point of the coarse cost's valley in the two in-plane angles about ``base``
    (:func:`.relative_pose.turned_in_plane`): (cost, capture), or None where the lamp is seen
    from the disc next to the lens.

    Why: on an oblique streak a degree of the lamp's (or the disc's) in-plane angle slides the
    wavelength axis by ~40 nm, and the camera's colour along the streak makes the coarse cost a
    comb of valleys ~0.5° wide in the lamp's angle. A lamp swung or a disc tilted 3° about the
    plane's normal puts the true valley teeth away from every start, and LM stays in a wrong one
    (MAE 0.1–0.3). Along the valley (tilt and swing together keep the wavelength axis) the cost
    is flat and bumpy, and LM stops where it enters it (a disc 3° tilted read as 0.7° the other
    way, twice the true cost). So: scan the swing at zero tilt, then follow each of the deepest
    SWUNG_STARTS teeth along the tilt, the swing re-centred at each step by a parabola through
    three samples; the deepest point found is a start."""
    if turned_in_plane(base, 0.0, 0.0) is None:
        return None

    def cost(tilt: float, swing: float) -> float:
        rel = turned_in_plane(base, tilt, swing)
        assert rel is not None
        r = res.at(rel)
        return float(r @ r)

    swings = np.arange(-SWING_DEG, SWING_DEG + 1e-9, SWING_STEP_DEG)
    costs = np.array([cost(0.0, float(s)) for s in swings])
    minima = [i for i in range(1, costs.size - 1) if costs[i] < costs[i - 1] and costs[i] <= costs[i + 1]]
    minima.sort(key=lambda i: costs[i])
    best: tuple[float, float, float] | None = None
    for i in minima[:SWUNG_STARTS]:
        for sign in (1.0, -1.0):
            swing = float(swings[i])
            for tilt in sign * np.arange(0.0 if sign > 0 else TILT_STEP_DEG, TILT_DEG + 1e-9, TILT_STEP_DEG):
                h = VALLEY_STEP_DEG
                c = [cost(float(tilt), swing + d) for d in (-h, 0.0, h)]
                curve = c[0] + c[2] - 2.0 * c[1]
                shift = 0.5 * h * (c[0] - c[2]) / curve if curve > 0 else 0.0
                shift = float(np.clip(shift, -h, h))
                if curve > 0:
                    low = c[1] - 0.25 * (c[0] - c[2]) * shift / h
                else:
                    k = int(np.argmin(c))
                    low, shift = c[k], (k - 1) * h
                swing += shift
                if best is None or low < best[0]:
                    best = (low, float(tilt), swing)
    if best is None:
        return None
    rel = turned_in_plane(base, best[1], best[2])
    assert rel is not None
    return cost(best[1], best[2]), rel


def _followed(cost: float, rel: RelativePose, x: NDArray[np.float64],
              residuals_at: Callable[..., _Residuals],
              fit_stage: Callable[..., tuple[NDArray[np.float64], float, int]]
              ) -> tuple[float, RelativePose, NDArray[np.float64], int]:
    """A coarse fit followed along the in-plane valley (:func:`_valley_start`) and fitted again
    from its deepest point where that is lower: (cost, start, parameters, evaluations)."""
    base = apply_params(rel, x)
    res = residuals_at(base, np.zeros(N_PARAMS), *STAGES[0])
    found = _valley_start(base, res)
    evals = res.evaluations
    if found is not None and found[0] < cost:
        y, cost_y, n = fit_stage(found[1], np.zeros(N_PARAMS), *STAGES[0])
        evals += n
        if cost_y < cost:
            return cost_y, found[1], y, evals
    return cost, rel, x, evals


def fit_general_pose(rgb: NDArray[np.floating], preset: Preset, focal_px: float,
                     sensitivities: NDArray[np.float64] | None = None,
                     saturated: NDArray[np.bool_] | None = None) -> PoseFit:
    """Disc pose, lamp position and lamp size of any capture from a linear photo (see the module
    docstring). ``saturated`` pixels (clipped, invalid) are left out; with the camera's
    ``sensitivities`` every λ₁ must also have the camera's colour there."""
    rgb = np.asarray(rgb, dtype=np.float64)
    height, width, _ = rgb.shape
    size = (width, height)
    outline = disc_ellipse(rgb, saturated)
    if outline is not None:
        # room light on the disc but not around it: the photo-wide offset missed it
        rgb = np.clip(rgb - disc_base(rgb, outline, saturated), 0.0, None)
    flat = rgb.reshape(-1, 3)
    starts, lines, evals = _starts(rgb, preset, focal_px, sensitivities, saturated, outline)
    blur = colour_blur_nm(preset, preset.light.lobe_sigma, focal_px)
    subset = _subset(rgb, saturated, LM_PIXELS)

    def residuals_at(rel: RelativePose, x: NDArray[np.float64], node_nm: float, colour_weight: float) -> _Residuals:
        grid = ProfileGrid.with_camera(*GRID_NM, node_nm, sensitivities, blur, colour_weight)
        use = _without_glint(subset, scene_from_relative(apply_params(rel, x), preset, size, focal_px))
        return _Residuals(flat, use, preset, size, focal_px, rel, grid, float(np.sum(flat[use] ** 2)))

    def fit_stage(rel: RelativePose, x: NDArray[np.float64], node_nm: float, colour_weight: float
                  ) -> tuple[NDArray[np.float64], float, int]:
        res = residuals_at(rel, x, node_nm, colour_weight)

        def free_residuals(y: NDArray[np.float64]) -> NDArray[np.float64]:
            z = x.copy()
            z[FREE] = y
            return res(z)

        y, cost, _ = levenberg_marquardt(free_residuals, x[FREE], np.full(FREE.size, LM_STEP),
                                         max_iter=LM_ITERATIONS)
        z = x.copy()
        z[FREE] = y
        return z, cost, res.evaluations

    scored = []
    for rel, x in starts:
        r = residuals_at(rel, x, *STAGES[0])(x)
        evals += 1
        scored.append((float(r @ r), rel, x))
    scored.sort(key=lambda item: item[0])
    # the disc centre along the arcs through the glint, from each base; the best of each line always
    # gets a coarse fit: an untilted disc with the lamp 10° off explains a tilted disc's arcs better
    # before LM (phone-near-axis, 5°: 3.5e-3 against 1.3e-2 for the true tilt) but not after it
    # (9e-4 against 6e-4), and the glint's centroid leaves the aim ~0.1° off, which alone costs ~1e-2
    on_line: list[tuple[float, RelativePose, NDArray[np.float64]]] = []
    for line in lines:
        found_on_line = _glint_line_start(line, lambda rel: residuals_at(rel, np.zeros(N_PARAMS), *STAGES[0]))
        if found_on_line is not None:
            evals += found_on_line[2]
            on_line.append((found_on_line[0], found_on_line[1], np.zeros(N_PARAMS)))
    on_line.sort(key=lambda item: item[0])
    scored.extend(on_line)
    scored.sort(key=lambda item: item[0])
    # the valley of the in-plane angles followed about the preset's capture and the best start
    for rel, x in (starts[0], scored[0][1:]):
        base = apply_params(rel, x)
        res = residuals_at(base, np.zeros(N_PARAMS), *STAGES[0])
        found = _valley_start(base, res)
        evals += res.evaluations
        if found is not None:
            scored.append((found[0], found[1], np.zeros(N_PARAMS)))
    scored.sort(key=lambda item: item[0])
    # The best few starts each get the coarse fit: a start that explains the photo best as it
    # stands can still lead into a worse valley (a streak read as second order).
    tried = scored[:TRIED_STARTS]
    tried += [item for item in on_line if not any(item is other for other in tried)]
    fits = []
    for item in tried:
        x, cost, n = fit_stage(item[1], item[2], *STAGES[0])
        evals += n
        fits.append((cost, item[1], x, any(item is other for other in on_line)))
    best = min(fits, key=lambda fit: fit[0])
    line_best = min((fit for fit in fits if fit[3]), key=lambda fit: fit[0], default=best)
    # ...and about the best fit: LM stops where it enters the valley, not at its deepest point.
    # The best fit from the glint's line is followed too and finished as well: a disc tilted 5°
    # near the axis and the same disc flat with the lamp 10° off differ by less on the coarse
    # profile (LM from near the truth stopped at 1.2e-3, the flat reading at 9e-4) than on the
    # fine one (4.4e-4 at the truth, 5.0e-4 flat); the fine stage decides.
    finalists = [best[:3]] if line_best is best else [best[:3], line_best[:3]]
    finished = []
    for cost0, rel0, x in finalists:
        cost0, rel0, x, n = _followed(cost0, rel0, x, residuals_at, fit_stage)
        evals += n
        cost = cost0
        for node_nm, colour_weight in STAGES[1:]:
            x, cost, n = fit_stage(rel0, x, node_nm, colour_weight)
            evals += n
        finished.append((cost, rel0, x))
    _, rel0, x = min(finished, key=lambda fit: fit[0])
    rel = apply_params(rel0, x)
    scene = scene_from_relative(rel, preset, size, focal_px)
    fine = _subset(rgb, saturated, FINE_PIXELS)
    total = float(np.sum(flat[fine] ** 2))
    colour = None if sensitivities is None else \
        expected_colours(sensitivities, FIT_STEP_NM, colour_blur_nm(preset, rel.lobe_sigma, focal_px))
    value = consistency(rgb, scene, total, step_nm=FIT_STEP_NM, pixels=fine, colour=colour)
    null = consistency(rgb, scene, total, step_nm=FIT_STEP_NM, pixels=fine, colour=colour, scramble=True)
    centre = tuple(float(v) for v in project(rel.disc_centre_mm, size, focal_px))
    glint = mirror_point(rel)
    ring = tuple(float(v) for v in project(glint, size, focal_px)) if glint is not None else centre
    return PoseFit(center_px=centre, ring_center_px=ring, lobe_sigma=float(rel.lobe_sigma), focal_px=float(focal_px),
                   distance_mm=rel.distance_mm, residual=value, symmetry_center_px=centre, evaluations=evals,
                   null_residual=null, known_scene=scene)
