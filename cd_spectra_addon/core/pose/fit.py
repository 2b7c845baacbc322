"""The pose fit: disc pose, lamp position and lamp size of any capture, from the photo.

The preset is only a start. Coarse to fine:

1. **Starts** (:mod:`.starts`): the cheap strategies — the preset's capture, the same lined up
   with the photo's bright pattern, the disc's outline where it shows, each moved by the
   rainbow's own colours.
2. **Coarse**: the photo box-averaged to about :data:`COARSE_SIDE` px. Every start is scored by
   the self-consistency (:mod:`.self_consistency`) on a coarse λ₁ profile (5 nm nodes, too coarse
   to lock onto lamp lines) with the camera's colour at full weight (it pins the wavelength axis
   along a single streak); the best few get Levenberg–Marquardt with the exact Jacobian. A
   coarse pixel averages a stretch of the lobe, so the lobe is widened there by the pixel's span.
3. **Escalations**, only when no coarse fit explains the photo (:data:`GOOD_COST`): on an oblique
   disc with no outline, the lamp sought on a grid by the bright pattern, then the near-symmetric
   tilts of the best fit (:data:`TILTED_COST`), both fitted through a widened lobe; the glint's
   line, the in-plane valley and, where the outline shows, the lamp sought about its poses
   (:data:`.starts.ESCALATIONS`), scanned on the coarse cost.
4. **Fine**: the best coarse fit (and the best from the glint's line, if any) refined on the
   photo's own pixels with a finer profile (3 nm) and the colour at 0.3 (the lamp's spectrum
   within the lobe biases the colour by ~1 nm; the self-consistency is unbiased).

Where the disc's outline shows, every cost also holds the capture's rim to it (:class:`_OutlineRows`).
The zero-order glint and clipped pixels are left out of every comparison. The result's residual
and null residual are the binned consistency of :mod:`.result`, as the refusals expect.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from ..numerics.least_squares import levenberg_marquardt, valley_step
from ..photo.resample import box_downsample, box_factor, brightest, channel_sum
from ..scene.capture import Preset
from ..scene.kernel import camera_rays, project
from ..scene.relative_pose import (LAMP_DISTANCE_PARAM, N_PARAMS, SIGMA_PARAM, RelativePose, apply_params,
                                   mirror_point, near_axis, scene_from_relative)
from .result import FIT_STEP_NM, ZERO_ORDER_SIGMAS, PoseFit, colour_blur_nm, consistency, expected_colours
from .lines import keeps_lines, line_agreement
from .rim_ellipse import Ellipse, disc_base, disc_ellipse, outline_mismatch, project_circle
from .self_consistency import ProfileGrid, RayGeometry, SelfConsistency, footprint_v_span, profile_spd
from .starts import CHEAP, ESCALATIONS, STRATEGIES, Start, StartContext

__all__ = ["fit_pose", "COARSE_SIDE", "STAGES"]

COARSE_SIDE = 450  # the coarse level's long side (px): a box of 2 px at a 24 MP photo's loaded size (3 blurs a near-axis tilt away)
COARSE_PIXELS = 3000  # pixels the coarse cost looks at
FINE_PIXELS = 8000  # ...and the fine one
GRID_NM = (300.0, 2500.0)  # every λ₁ the disc shows: first order and the higher orders that share its |u|
# (profile node spacing nm, weight of the camera's colour) of the coarse and the fine stage;
# chosen on synthetic spectra (sample_spds) at realistic resolution, never on evaluation lamps.
STAGES = ((5.0, 1.0), (3.0, 0.3))
TRIED_STARTS = 3  # the best starts by the coarse cost that get a coarse fit each
# Fitted: aim, tilt, lamp direction, σ. The lamp's distance stays the preset's: it moves λ₁ only
# through the lamp's direction varying over the disc, and left free it soaked up colour errors of
# an in-camera JPEG (lamp 10 % nearer, residual 0.11, MAE 0.29 at 160 px). Except on the fine level
# of an oblique set-up (FINE_OBLIQUE): there the streak's wavelengths are so sensitive to the
# geometry that a lamp moved 5 mm sideways — 1.4 mm further from the disc at the tripod's 15° —
# read λ₁ 1.5–2.3 nm off at 2–30× the true capture's cost (synthetic lamps, scratch). Freeing
# it there (the distance's prior scale 0.3), tripod-oblique's combined captures (synthetic lamps;
# 24 on a black cloth, 32 on lit tables) read λ₁ 0.73 → 0.57 and 0.82 → 0.54 nm on average
# (median 0.73 → 0.34, 0.60 → 0.39; 3 and 2 photos worse by more than 0.5 nm, 9 and 8 better;
# at the chosen scale 0.03 the black-cloth set 0.54); phone-distant-lamp's lamp, 2 m away, did
# not move (within 0.05 nm). Near-axis captures read worse with it (phone-near-axis: 5 of 24
# photos 0.3–0.7 nm worse): the rings trade the lamp's distance against the tilt. Nor with the
# generic profile, as the lamp's size (see fit_pose): Kim's real GIF frames, read with it, put
# fewer of their lines on the fitted curve (frame 29: 75 → 68 %) and the joint estimate's r
# against a Planck curve fell 0.42 → 0.23 (at the scale 0.3).
# After each LM fit (coarse and fine) of a near-axis set-up, the cost is tried VALLEY_STEP either
# way (parameter units: degrees, for the step's largest component) along the fit's valley — the
# direction its Jacobian says the cost barely rises in; where one side leaves VALLEY_GAIN less
# unexplained, the step doubles while the cost keeps falling (to VALLEY_REACH), and LM runs again
# from there (numerics.least_squares.valley_step). LM creeps along such a valley with tiny relative
# gains and its tolerance ends it early: pose_errors' phone-near-axis combined capture 3 (disc
# tilted 2.8°, the rainbow in short arcs) stopped at 0.00248 against 0.00211 at the truth, Δu'v'
# 0.04–0.06 on fluorescent lamps; 140 more LM steps reached 0.00222, one search along the valley
# 0.00218. The step was chosen on synthetic lamps (the training prior, `pose_errors --synthetic`):
# that capture alone, 40 lamps, MAE 400–700 / Δu'v' without the search 0.070 / 0.0112, step 0.5
# 0.050 / 0.0062, 1.0 0.058 / 0.0079, 2.0 0.069 / 0.0098. Every set-up's combined row (24 lamps,
# 16 captures): near-axis and cd-default unchanged, tripod-oblique 0.105 -> 0.103,
# phone-distant-lamp 0.125 -> 0.131 with one more refusal (two lamps lost 0.15, one gained 0.12):
# so not where the set-up is oblique.
VALLEY_STEP = 0.5
VALLEY_REACH = 4.0
VALLEY_GAIN = 1e-3
FREE = np.array([0, 1, 2, 3, 4, 5, SIGMA_PARAM])
UNTILTED = np.array([0, 1, 4, 5, SIGMA_PARAM])  # the same without the disc's tilt
FINE_OBLIQUE = np.union1d(FREE, [LAMP_DISTANCE_PARAM])
LOBE_ONLY = np.array([SIGMA_PARAM])  # a capture the photo's thin lines pin (:mod:`.lines`): only the lobe's size
SIZE_HELD = np.setdiff1d(FREE, LOBE_ONLY)  # the capture free, the lobe's size held
LM_ITERATIONS = (30, 12)  # per stage: most of a fit's progress is in its first steps
LM_TOL = (1e-4, 1e-3)  # a step that improves the cost by less than this (relative) ends the stage
PRIOR_WEIGHT = 1e-2  # prior residual scale (a 1-scale departure costs 1e-4 of the photo's energy)
# deg ×6, log lamp distance, log σ. The distance's 0.03 (6 mm at the tripod's 200 mm), chosen on
# synthetic lamps (8 per row, λ₁ mean with the distance held / scale 0.3 / 0.03 / 0.01): tripod lamp
# 5 mm sideways 2.33 / 1.58 / 1.58 / 1.74 nm, disc tilted 3° 0.04 / 0.44 / 0.43 / 0.30, lamp σ 0.01
# 0.69 / 0.86 / 0.84 / 0.76; phone-distant-lamp nominal 1.57 / 1.86 / 1.58 / 1.57, lamp swung 3°
# 1.42 / 1.51 / 1.42 / 1.42. Where the lamp stands at the preset's distance, fitting it costs some
# accuracy (the tilted tripod); the combined captures, lamps off by millimetres, gain (FINE_OBLIQUE).
PRIOR_SCALE = np.array([5.0, 5.0, 3.0, 3.0, 3.0, 3.0, 0.03, 1.0])
# The start strategies in the order they are tried, cheapest first; the fit stops after the second
# or a later tier whose best coarse fit explains the photo (GOOD_COST), see fit_pose. (After the
# first alone it did not: from the preset, LM can end in a neighbouring minimum that explains the
# photo nearly as well — cd-default, camera moved 2 mm: twice the true cost, disc centre 2 px off —
# and the rings' own centre, one tier on, starts in the right one.)
# The escalations whose best fit is also refined on the fine level when it is not the best coarse
# fit: both search far from the other fits (the glint's line, the lamp about the outline's poses),
# and the coarse cost (5 nm profile, colour at full weight) and the fine one can rank such
# captures differently.
FINALISTS = ("glint-line", "outline-lamp")
# The escalations come in three tiers: an oblique disc with no outline first has its lamp sought
# on a grid (lamp-grid), then the near-symmetric captures about the best fit (tilted), each tier
# only while nothing explains the photo; the in-plane valley and the others then start from the
# best so far.
TIERS = (("preset",), ("pattern", "outline", "rings", "glint"), ("colours", "lines"), ("lamp-grid",), ("tilted",),
         ("glint-line", "in-plane", "outline-lamp"))
# An oblique capture's coarse fits within this factor of the best are refined on the fine level
# too: the coarse cost cannot rank neighbouring teeth of the in-plane comb. Version 2's tripod
# photo read with a preset 12.5° off (tests/test_pose_recovery.py): under numpy 2 / Python 3.13
# lamp-grid's fit ended at 0.00242 (λ₁ 3.4 nm off) and the valley's at 0.00239 (0.97 nm); under
# numpy 1.26 at 0.0080 and 0.00241 — which one wins the coarse stage is a matter of last bits;
# on the fine level they are 0.00227 and 0.00204. Synthetic lamps (pose_errors --synthetic, the
# oblique set-ups, 3 lamps): one row 0.022 → 0.021, the rest unchanged, the fit ~5 % slower.
NEAR_TIE = 1.25
GOOD_COST = 0.003  # a coarse fit that leaves less of the photo unexplained needs no escalation
# ...and the near-symmetric captures (tilted) are sought only about a fit that leaves more than
# this, three GOOD_COSTs, unexplained. Synthetic lamps (the training prior, pose_errors
# --synthetic, 24 combined captures per set-up): sought above GOOD_COST, phone-distant-lamp's
# coarse cost preferred a neighbour of the truth (0.0028 against 0.0035 at the truth) on two
# photos, λ₁ 1.7 → 3.3 and 1.2 → 1.6 nm; above 0.01 they are untouched, and the tripod's gains
# (captures 14 and 15: λ₁ 13 → 2.3 and 14 → 0.2 nm) stay.
TILTED_COST = 0.01
EVERY_START = ("tilted",)  # strategies whose every start gets an LM fit: their starting costs do not rank them
# A ``widened`` start is fitted first with the lamp's lobe this many times wider, in turn, then at
# its own size: a wider lobe widens the basin of the capture's cost. Synthetic tripod capture 3
# (lamp-grid's start 3.9° from the true lamp): λ₁ 10.5 nm off after (4,), 0.8 nm after (4, 2),
# the same after (8, 4, 2).
WIDENED = (4.0, 2.0)
# ...nor LM from a start that leaves more than this unexplained: such a start is another capture
# altogether (phone-near-axis: the rings' far centre at 0.46 against 0.0002 fitted), and LM from
# it ran its every iteration to end where it began (bench/bench.md: 130 of 390 ms). 0.3 let the
# pattern's start of phone-distant-lamp's nominal photo (0.21 against 0.0007) run 14 steps to
# 0.18 (100 of its 270 ms). Over pose_errors --lamps 2 (152 fits) no start from above 0.15 ended
# meaningfully below the fit it followed; the farthest that did started at 0.087 (cd-default,
# the rings: 0.00017 against 0.00097).
FAR_START_COST = 0.15
# Where the disc's outline shows, the fit is judged on the pixels inside it (semi-axes × this):
# a lit table, a lamp in the frame or objects around the disc are not the disc's to explain, and
# a wide lobe over them must not look like a rainbow. Elsewhere on the whole photo: a region
# from the preset's capture (tried: its disc widened by 15 mm) cut off the disc of a photo whose
# preset was 12° off (λ₁ 31 nm wrong against 0.7 nm), and each start's own region made the
# starts' costs incomparable (tripod-oblique, disc tilted 3°: a capture 5° off, MAE 0.03 → 0.23).
# A dark disc on a lit table (its outline found from edges) is judged between HUB_MARGIN × its
# hole and DARK_OUTLINE_MARGIN × its outline: the table shows around it and through its hole, and
# that light looked unexplained to every capture — a synthetic tripod photo with its table lit
# left 0.43 of its energy unexplained at the true capture. (The tracks end at 58 of the rim's
# 60 mm. Leaving out the whole hub, to the tracks' inner edge, lost the tripod's glint, which lies
# near the centre and pins the capture: λ₁ 0.5 → 4.5 nm on one photo.)
OUTLINE_MARGIN = 1.1
DARK_OUTLINE_MARGIN = 0.98
HUB_MARGIN = 1.2
# ...and, on the coarse level, every capture must draw its rim where the outline is
# (:class:`_OutlineRows`): the rainbow alone leaves near-symmetries the outline does not.
# tripod-oblique's camera sits 2.5° from the lamp's mirror direction, and a disc turned ~15° about
# the glint, camera and lamp angles shrinking together (13° → 7°), draws nearly the same rainbow;
# its outline's ellipticity differs by 0.018. A found outline's measures
# (:func:`.rim_ellipse.outline_mismatch`) were off by 0.001–0.002 (once 0.01) on the simulator's
# lit tables, so a rim within OUTLINE_DEAD of the outline costs nothing (rows that pulled at those
# errors moved λ₁ by 1–2 nm from where the rainbow alone put it); beyond, each measure costs
# OUTLINE_COST per OUTLINE_TOLERANCE², and the family above (0.013 beyond) 0.01, three GOOD_COSTs.
OUTLINE_DEAD = 0.005
OUTLINE_TOLERANCE = 0.004
OUTLINE_COST = 1e-3
OUTLINE_STEP = 1e-3  # forward-difference step of the rows' Jacobian (parameter units)
# A photo whose best fit leaves more than this of its energy unexplained is not one the
# self-consistency reads alone (the simulator's photos: < 0.04 with every pose error of
# bench/pose_errors.md); there the photo's thin lines are sought (:mod:`.lines`) and, where they
# pin a capture, rule.
EXPLAINED_COST = 0.05


# ... so long as the lines' capture explains the photo nearly as well as the best fit: Kim's
# frames 1.06–1.28× the best cost (a wide lobe over the glow explains a little more, and is
# wrong); a calibration shot's in-camera JPEG (7.6 % unexplained by the right capture) had a
# capture pinned on its noise at 5.6×, which the rule then took.
LINES_COST_RATIO = 2.0


def lines_rule(fits: "list[_Fitted]") -> bool:
    """The fit's answer is the best capture the photo's lines pin (see EXPLAINED_COST)."""
    held = [f for f in fits if f.start.held]
    return bool(fits) and fits[0].cost > EXPLAINED_COST and bool(held) and \
        held[0].cost <= LINES_COST_RATIO * fits[0].cost
_DEBUG = bool(os.environ.get("CDS_POSE_DEBUG"))


@dataclass
class _Level:
    """The photo at one resolution: box-averaged ``factor`` × ``factor``, its pixels' rays
    through their centres in the full photo (so no level shifts the principal point)."""

    rgb: NDArray[np.float64]
    saturated: NDArray[np.bool_] | None
    factor: int
    full_size: tuple[int, int]
    focal_px: float  # of the full photo

    @classmethod
    def of(cls, rgb: NDArray[np.float64], saturated: NDArray[np.bool_] | None, factor: int,
           focal_px: float) -> "_Level":
        height, width = rgb.shape[:2]
        small = box_downsample(rgb, factor)
        sat = None if saturated is None else box_downsample(np.asarray(saturated, np.float64), factor) > 0
        return cls(small, sat, factor, (width, height), focal_px)

    @property
    def flat(self) -> NDArray[np.float64]:
        return self.rgb.reshape(-1, 3)

    @property
    def level_focal(self) -> float:
        return self.focal_px / self.factor

    def rays(self, index: NDArray[np.int64]) -> NDArray[np.float64]:
        rows, cols = np.divmod(index, self.rgb.shape[1])
        f = self.factor
        return camera_rays(rows * f + (f - 1) / 2.0, cols * f + (f - 1) / 2.0, self.full_size, self.focal_px)

    def v_span(self, index: NDArray[np.int64], rel: RelativePose) -> NDArray[np.float64]:
        """How much of the lobe's v each sampled pixel spans, for the capture ``rel``."""
        rows, cols = np.divmod(index, self.rgb.shape[1])
        f = self.factor
        return footprint_v_span(rows * f + (f - 1) / 2.0, cols * f + (f - 1) / 2.0, f, self.full_size,
                                self.focal_px, rel)

    def within(self, outline: Ellipse, hub_share: float) -> NDArray[np.bool_]:
        """Flat mask of the level's pixels inside the disc's outline (times OUTLINE_MARGIN), or
        where the disc is darker than its surround, between DARK_OUTLINE_MARGIN of it and its hub
        (``hub_share``: the hole's radius over the rim's, times HUB_MARGIN)."""
        height, width = self.rgb.shape[:2]
        f = self.factor
        rows = np.repeat(np.arange(height) * f + (f - 1) / 2.0, width)
        cols = np.tile(np.arange(width) * f + (f - 1) / 2.0, height)
        if outline.lit:
            return outline.inside(rows, cols, OUTLINE_MARGIN)
        return outline.inside(rows, cols, DARK_OUTLINE_MARGIN) & ~outline.inside(rows, cols, hub_share)

    def sample(self, count: int, region: NDArray[np.bool_] | None = None) -> NDArray[np.int64]:
        """Flat indices of up to ``count`` pixels (sorted) of ``region`` (all where None): the
        brightest half, where the rainbow is, and a fixed random sample of the rest, where the
        pose must predict darkness; clipped pixels never. A partial sort: a full one of a 1 MP
        photo took 60 ms per call."""
        lum = channel_sum(self.rgb).ravel()
        usable = np.isfinite(lum)
        if region is not None:
            usable &= region
        if self.saturated is not None:
            usable &= ~self.saturated.reshape(-1)
        n_usable = int(np.sum(usable))
        half = min(count // 2, n_usable)
        if half > 0:
            bright = brightest(lum, usable, half)
        else:
            bright = np.zeros(0, dtype=np.int64)
        usable[bright] = False
        rest = np.flatnonzero(usable)
        take = min(count - half, rest.size)
        pick = rest[np.unique(np.random.default_rng(0).integers(0, rest.size, take))] if take else rest[:0]
        return np.sort(np.concatenate([bright, pick])).astype(np.int64)


@dataclass
class _Sample:
    """A level's pixel sample: indices, rays and values, and (once, for the first capture asked)
    each pixel's span of the lobe's v — it changes little between the starts of one photo."""

    level: _Level
    index: NDArray[np.int64]
    rays: NDArray[np.float64]
    spans: NDArray[np.float64] | None = None

    @classmethod
    def of(cls, level: _Level, count: int, region: NDArray[np.bool_] | None = None) -> "_Sample":
        index = level.sample(count, region)
        return cls(level, index, level.rays(index))

    def v_span(self, rel: RelativePose) -> NDArray[np.float64]:
        if self.spans is None:
            self.spans = self.level.v_span(self.index, rel)
        return self.spans


class _OutlineRows:
    """Residual rows that hold a capture's rim to the disc's outline in the photo, beyond what
    an outline is found to (OUTLINE_DEAD, OUTLINE_COST)."""

    def __init__(self, outline: Ellipse, radius_mm: float, focal_px: float, size: tuple[int, int]):
        self.outline, self.radius_mm, self.focal_px, self.size = outline, radius_mm, focal_px, size
        self.scale = math.sqrt(OUTLINE_COST) / OUTLINE_TOLERANCE

    def __call__(self, rel: RelativePose) -> NDArray[np.float64]:
        try:
            drawn = project_circle(rel.disc_centre_mm, rel.disc_normal, self.radius_mm, self.focal_px, self.size)
        except ValueError:  # a rim behind the camera or seen edge-on: as far off as a measure gets
            return np.full(4, self.scale)
        off = outline_mismatch(self.outline, drawn)
        return self.scale * np.sign(off) * np.maximum(np.abs(off) - OUTLINE_DEAD, 0.0)

    def jacobian(self, start: RelativePose, x: NDArray[np.float64], free: NDArray[np.int64]) -> NDArray[np.float64]:
        at = self(apply_params(start, x))
        out = np.empty((at.size, free.size))
        for j, k in enumerate(free):
            moved = x.copy()
            moved[k] += OUTLINE_STEP
            out[:, j] = (self(apply_params(start, moved)) - at) / OUTLINE_STEP
        return out


class _Problem:
    """One stage's least-squares problem around a start: the photo's residuals, the outline's
    where one shows, then the prior's."""

    def __init__(self, sample: _Sample, start: RelativePose, preset: Preset, grid: ProfileGrid,
                 geometry: RayGeometry | None = None, outline: _OutlineRows | None = None):
        level = sample.level
        if geometry is None or not geometry.matches(start):
            geometry = RayGeometry.of(sample.rays, start)
        self.geometry = geometry  # of the whole sample at the start: another lamp size's problem shares it
        glint = _glint(geometry, start.lobe_sigma, level.level_focal)
        kept = ~glint
        keep = np.flatnonzero(kept)
        self.start = start
        self.outline = outline
        self.last_jacobian: NDArray[np.float64] | None = None  # of the last LM step, prior rows included
        self.objective = SelfConsistency(level.flat[sample.index[keep]], sample.rays[keep], preset.disc, grid,
                                         lambda x: apply_params(start, x), start.distance_mm / level.level_focal,
                                         blur_v=sample.v_span(start)[keep], geometry=geometry, subset=kept)

    def cost_at(self, rel: RelativePose) -> float:
        r = self.objective.residuals_at(rel)
        if self.outline is not None:
            r = np.concatenate([r, self.outline(rel)])
        return float(r @ r)

    def fit(self, x0: NDArray[np.float64], iterations: int, tol: float, free: NDArray[np.int64] = FREE
            ) -> tuple[NDArray[np.float64], float]:
        """LM over the ``free`` parameters from ``x0``: (parameters, cost with the prior)."""
        prior_rows = np.zeros((N_PARAMS, free.size))
        prior_rows[free, np.arange(free.size)] = PRIOR_WEIGHT / PRIOR_SCALE[free]

        def full(y: NDArray[np.float64]) -> NDArray[np.float64]:
            z = x0.copy()
            z[free] = y
            return z

        def residuals(y: NDArray[np.float64]) -> NDArray[np.float64]:
            return self.residuals_with_prior(full(y))

        def jacobian(y: NDArray[np.float64]) -> NDArray[np.float64]:
            rows = [self.objective.jacobian(full(y), free)]
            if self.outline is not None:
                rows.append(self.outline.jacobian(self.start, full(y), free))
            self.last_jacobian = np.concatenate([*rows, prior_rows])
            return self.last_jacobian

        before = self.evaluations
        y, cost, _ = levenberg_marquardt(residuals, x0[free], max_iter=iterations, jacobian=jacobian, tol=tol)
        if _DEBUG:
            print(f"  LM {self.evaluations - before} evals, cost {cost:.5f}")
        return full(y), cost

    def residuals_with_prior(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """The photo's residuals at the parameters ``x``, the outline's, then the prior's (what LM
        minimises)."""
        rows = [self.objective(x)]
        if self.outline is not None:
            rows.append(self.outline(apply_params(self.start, x)))
        return np.concatenate([*rows, PRIOR_WEIGHT * x / PRIOR_SCALE])

    def cost_with_prior(self, x: NDArray[np.float64]) -> float:
        r = self.residuals_with_prior(x)
        return float(r @ r)

    def along_valley(self, x: NDArray[np.float64], cost: float, free: NDArray[np.int64] = FREE, stage: int = 1
                     ) -> tuple[NDArray[np.float64], float]:
        """``x`` (cost ``cost``, just fitted over ``free``) or the fit LM finds from further down
        its valley (:func:`..numerics.least_squares.valley_step`, VALLEY_STEP), whichever is lower."""
        jac = self.last_jacobian
        if jac is None or jac.shape[1] != free.size:
            return x, cost

        def moved(y: NDArray[np.float64]) -> NDArray[np.float64]:
            z = x.copy()
            z[free] = y
            return z

        y = valley_step(lambda v: self.cost_with_prior(moved(v)), x[free], cost, jac, VALLEY_STEP, VALLEY_REACH,
                        VALLEY_GAIN)
        if y is None:
            return x, cost
        z, fitted = self.fit(moved(y), LM_ITERATIONS[stage], LM_TOL[stage], free)
        return (z, fitted) if fitted < cost else (x, cost)

    @property
    def evaluations(self) -> int:
        return self.objective.evaluations


def _glint(geometry: RayGeometry, lobe_sigma: float, focal_px: float) -> NDArray[np.bool_]:
    """Rays that see the zero-order glint of a lamp of size ``lobe_sigma`` at the capture of
    ``geometry`` (see :func:`.result.glint_mask`)."""
    hit, geo = geometry.hit, geometry.geo
    out = np.zeros(hit.size, dtype=bool)
    out[hit] = np.hypot(geo.u, geo.v) < ZERO_ORDER_SIGMAS * lobe_sigma + 4.0 / focal_px
    return out


SAME_PX = 0.5  # captures whose disc centre and mirror point land this close in the image...
SAME_DEG = 0.25  # ...and whose disc normal and lamp direction agree this well are one start


def _same_capture(a: RelativePose, b: RelativePose, size: tuple[int, int], focal_px: float) -> bool:
    """Whether two captures look the same in the photo (see SAME_PX, SAME_DEG)."""
    def angle(u: NDArray[np.float64], v: NDArray[np.float64]) -> float:
        c = float(u @ v / (np.linalg.norm(u) * np.linalg.norm(v)))
        return math.degrees(math.acos(min(1.0, max(-1.0, c))))

    if angle(a.disc_normal, b.disc_normal) > SAME_DEG:
        return False
    if angle(a.lamp_mm - a.disc_centre_mm, b.lamp_mm - b.disc_centre_mm) > SAME_DEG:
        return False
    if float(np.hypot(*(project(a.disc_centre_mm, size, focal_px) - project(b.disc_centre_mm, size, focal_px)))) > SAME_PX:
        return False
    ma, mb = mirror_point(a), mirror_point(b)
    if (ma is None) != (mb is None):
        return False
    return ma is None or float(np.hypot(*(project(ma, size, focal_px) - project(mb, size, focal_px)))) <= SAME_PX


@dataclass
class _Fitted:
    cost: float
    start: Start
    params: NDArray[np.float64]

    @property
    def capture(self) -> RelativePose:
        return apply_params(self.start.pose, self.params)


# An outline is the disc's only where its size is within this factor of the preset's disc at its
# distance: a greyscale photo's rings made edges that read as a dark disc 0.45 of the size the
# preset gives (the edges' colour test had no colour to go by), and a fit held to it refused a
# readable photo. A camera 1.6× nearer or farther than the preset says is a different set-up.
OUTLINE_SIZE_FACTOR = 1.6


def disc_sized(outline: Ellipse, preset: Preset, focal_px: float) -> bool:
    """Whether ``outline`` is about the size the preset's disc has in the photo (OUTLINE_SIZE_FACTOR),
    at the camera distance the outline's focal length is read with (inverse.stages)."""
    expected = focal_px * preset.disc.rim_radius_mm / preset.camera.distance_mm
    return 1.0 / OUTLINE_SIZE_FACTOR <= outline.major_px / expected <= OUTLINE_SIZE_FACTOR


def fit_pose(rgb: NDArray[np.floating], preset: Preset, focal_px: float,
             sensitivities: NDArray[np.float64] | None = None, saturated: NDArray[np.bool_] | None = None,
             strategies: Sequence[str] = CHEAP, escalations: Sequence[str] = ESCALATIONS,
             own_colours: bool = True, judge_size: bool = True) -> PoseFit:
    """Disc pose, lamp position and lamp size of any capture from a linear photo (see the module
    docstring). ``saturated`` pixels (clipped, invalid) are left out; with the camera's
    ``sensitivities`` every λ₁ must also have the camera's colour there. ``strategies`` and
    ``escalations`` name the start strategies (:data:`.starts.STRATEGIES`) to use.
    ``own_colours``: ``sensitivities`` are the camera's own (not the generic profile's), so the
    colours may judge what they blur or shift: the lamp's size is judged on the colour blur
    (:func:`_sized`) and fitted in the coarse stage, and an oblique set-up's lamp distance is
    fitted on the fine level (FINE_OBLIQUE). ``judge_size=False`` leaves :func:`_sized` out where
    the caller judges the size on what it reads better (:func:`..inverse.stages.sized_by_readout`)."""
    clock = _Clock()
    rgb = np.asarray(rgb, dtype=np.float64)
    height, width, _ = rgb.shape
    size = (width, height)
    outline = disc_ellipse(rgb, saturated)
    if outline is not None and not disc_sized(outline, preset, focal_px):
        outline = None  # edges along the rainbow's own rings, not the disc's rim
    if outline is not None:
        # room light on the disc but not around it: the photo-wide offset missed it
        rgb = rgb - disc_base(rgb, outline, saturated)
        np.maximum(rgb, 0.0, out=rgb)  # (in place: one fresh photo-sized array, not two)
    factor = box_factor(max(height, width), COARSE_SIDE)
    coarse = _Level.of(rgb, saturated, factor, focal_px)
    fine = _Level.of(rgb, saturated, 1, focal_px)
    clock.lap("levels")
    ctx = StartContext(rgb, saturated, preset, float(focal_px), sensitivities, outline)
    rim = None if outline is None else _OutlineRows(outline, preset.disc.rim_radius_mm, float(focal_px), size)
    levels = {"coarse": (coarse, COARSE_PIXELS), "fine": (fine, FINE_PIXELS)}
    samples: dict[str, _Sample] = {}
    hub = HUB_MARGIN * preset.disc.hole_radius_mm / preset.disc.rim_radius_mm

    def sample_for(level: str) -> _Sample:
        """The level's pixel sample, inside the disc's outline where it shows (one for every start)."""
        if level not in samples:
            lvl, count = levels[level]
            samples[level] = _Sample.of(lvl, count, None if outline is None else lvl.within(outline, hub))
        return samples[level]

    grids: dict[tuple[float, float, float], ProfileGrid] = {}
    evals = 0

    def problem(start: RelativePose, level: str = "coarse", stage: tuple[float, float] = STAGES[0],
                geometry: RayGeometry | None = None) -> _Problem:
        sample = sample_for(level)
        blur = round(colour_blur_nm(preset, start.lobe_sigma, sample.level.level_focal), 1)
        key = (*stage, blur)
        if key not in grids:
            grids[key] = ProfileGrid.with_camera(*GRID_NM, stage[0], sensitivities, blur, stage[1])
        return _Problem(sample, start, preset, grids[key], geometry, rim if level == "coarse" else None)

    def fresh_cost(rel: RelativePose) -> float:
        """The coarse cost of ``rel`` judged on its own, as a start is scored (its glint left out)."""
        p = problem(rel)
        cost = p.cost_at(rel)
        ctx.evaluations += p.evaluations
        return cost

    def held_fit(p: _Problem, base: RelativePose, x: NDArray[np.float64], stage: int
                 ) -> tuple[NDArray[np.float64], float]:
        """LM from a capture the photo's lines pin: every parameter free, kept only where the
        lines stay on its curve (the self-consistency may slide the wavelengths along them, and
        a wide lobe over the glow around them must not pull the curve off); else the lobe's
        size alone."""
        y, cost = p.fit(x, LM_ITERATIONS[stage], LM_TOL[stage], FREE)
        if ctx.ridges is not None and keeps_lines(ctx.ridges, apply_params(base, y), size, focal_px, preset.disc):
            return y, cost
        return p.fit(x, LM_ITERATIONS[stage], LM_TOL[stage], LOBE_ONLY)

    # The coarse stage weighs the camera's colour fully, so where the colours are not the camera's
    # own (the generic profile) a wider lamp, blurring the expected colours, hides their mismatch:
    # camera_files' held-out Sony read two lamps of 30 at σ 0.0082 for 0.003, the disc 2° tilted,
    # MAE 0.36 / 0.40 against 0.086 / 0.081 at the true pose. There the coarse fits hold the start's
    # lamp size (as _sized does not judge it either); the fine stage, colour at 0.3, still fits it.
    held_size = np.array([] if own_colours else [SIGMA_PARAM], dtype=np.int64)
    fine_free = FINE_OBLIQUE if own_colours and not near_axis(preset) else FREE
    fits: list[_Fitted] = []
    visited: list[tuple[RelativePose, float]] = []  # where LM started (cost ∞) and ended (its cost)
    started: list[Start] = []  # the starts LM ran from
    oblique = not near_axis(preset)
    for k, tier in enumerate(TIERS):
        names = [name for name in tier if name in strategies or name in escalations]
        if fits and fits[0].cost <= EXPLAINED_COST:
            names = [name for name in names if name != "lines"]  # the self-consistency has its rainbow
        escalating = any(name in ESCALATIONS for name in tier)
        if escalating and fits and fits[0].cost <= GOOD_COST:
            names = [name for name in names if name == "in-plane"]
        if escalating and fits and fits[0].cost <= TILTED_COST:
            names = [name for name in names if name != "tilted"]
        if not names:
            continue
        if escalating:  # escalations scan the coarse cost around the best fits so far
            judge = problem(fits[0].capture if fits else ctx.nominal())
            ctx.cost = judge.cost_at
            ctx.fresh_cost = fresh_cost
            ctx.found = [Start(f.start.strategy, f.capture) for f in fits] or ctx.found
        new: list[Start] = []
        for name in names:
            new.extend(STRATEGIES[name](ctx))
        if escalating:
            evals += judge.evaluations
        else:
            ctx.found.extend(new)
        scored = []
        for s in new:
            if not escalating and any(math.isfinite(seen_cost) and _same_capture(s.capture, seen, size, focal_px)
                                      for seen, seen_cost in visited):
                continue  # where a fit already ended: LM from here would find what it found (nor is it scored)
            p = problem(s.pose)
            scored.append((p.cost_at(s.capture), s))
            evals += p.evaluations
        scored.sort(key=lambda item: item[0])
        tried = 0
        limit = len(scored) if set(names) <= set(EVERY_START) else TRIED_STARTS
        # the valley's starts are sought with the escalations' cost; their own start's cost (the
        # start's region, the lamp's narrow lobe) reads ~1 at a capture LM takes to 0.002
        valley = names == ["in-plane"]
        for initial, s in scored:
            if tried == limit or (fits and fits[0].cost <= GOOD_COST and initial > FAR_START_COST and not valley):
                break  # (scored is sorted: the rest are farther still)
            if any(initial >= seen_cost and _same_capture(s.capture, seen, size, focal_px)
                   for seen, seen_cost in visited) or any(s.repeats(t) for t in started):
                continue  # LM from here would find what it found from there
            visited.append((s.capture, math.inf))
            started.append(s)
            tried += 1
            if s.widened:
                s, n = _through_wide_lobes(problem, s)
                evals += n
            p = problem(s.pose)
            x = s.params
            if s.held:
                x, cost = held_fit(p, s.pose, x, 0)
                fits.append(_Fitted(cost, s, x))
                visited.append((fits[-1].capture, cost))
                continue
            if not oblique and not escalating:
                # A camera above the disc: first as the preset draws it (disc level, camera looking
                # down, lamp at its height), then with the tilt free. A tilted disc and a lamp moved
                # sideways make much the same rings, and from the preset LM took that trade (cd-default,
                # camera moved 2 mm: disc centre 2 px off at twice the true cost).
                x, _ = p.fit(x, LM_ITERATIONS[0], LM_TOL[0], np.setdiff1d(UNTILTED, held_size))
            free = np.setdiff1d(FREE, held_size)
            x, cost = p.fit(x, LM_ITERATIONS[0], LM_TOL[0], free)
            if not oblique:
                x, cost = p.along_valley(x, cost, free, 0)
            evals += p.evaluations
            fits.append(_Fitted(cost, s, x))
            visited.append((fits[-1].capture, cost))
        fits.sort(key=lambda fit: fit.cost)
        clock.lap("+".join(names))
        if _DEBUG:
            print("tier", k, "scored", [(s.strategy, round(c, 5)) for c, s in scored], "fits", [(f.start.strategy, round(f.cost, 5)) for f in fits])
        # An oblique capture that only the rainbow's colours (or an escalation) explained also gets
        # its in-plane valley followed: there the colour pins the wavelength axis only to a comb of teeth.
        valley_ahead = oblique and ("colours" in tier or escalating) and any("in-plane" in t for t in TIERS[k + 1:])
        if k > 0 and fits and fits[0].cost <= GOOD_COST and not valley_ahead:
            break
        if lines_rule(fits):
            break  # the photo's lines pin the capture: nothing the escalations find can beat them
    evals += ctx.evaluations
    held = [f for f in fits if f.start.held]
    # Where the photo's thin lines pin a capture and nothing explains the photo, the lines are the
    # answer whatever the self-consistency prefers: a lobe widened over the glow around them
    # explains more energy, and is wrong.
    if lines_rule(fits):
        finalists = held[:1]
    else:
        best_of: dict[str, _Fitted] = {}
        for f in fits[1:]:  # (sorted: the first of a strategy is its best)
            best_of.setdefault(f.start.strategy, f)
        finalists = fits[:1] + [best_of[name] for name in FINALISTS if name in best_of]
        if oblique:
            for f in fits[1:]:
                if f.cost <= NEAR_TIE * fits[0].cost and not any(
                        _same_capture(f.capture, g.capture, size, focal_px) for g in finalists):
                    finalists.append(f)
        if oblique and own_colours and fits and fits[0].cost > GOOD_COST:
            sized = _at_start_size([f for f in fits if not f.start.held][:TRIED_STARTS], problem)
            if sized is not None:
                evals += sized[1]
                finalists.append(sized[0])
    finished = []
    for f in finalists:
        p = problem(f.capture, "fine", STAGES[1])
        if LAMP_COLOURS and own_colours and sensitivities is not None and not f.start.held:
            p = _lamp_coloured(p, f.capture, sample_for("fine"), preset, sensitivities,
                               LAMP_WEIGHT_OBLIQUE if oblique else STAGES[1][1])
        if f.start.held:
            x, cost = held_fit(p, f.capture, np.zeros(N_PARAMS), 1)
        else:
            x, cost = p.fit(np.zeros(N_PARAMS), LM_ITERATIONS[1], LM_TOL[1], fine_free)
            if not oblique:
                x, cost = p.along_valley(x, cost)
        evals += p.evaluations
        finished.append(_Fitted(cost, Start(f.start.strategy, f.capture, held=f.start.held), x))
    best = min(finished, key=lambda fit: fit.cost)
    if own_colours and judge_size and sensitivities is not None and not best.start.held:
        best = _sized(best, lambda c, g=None: problem(c, "fine", STAGES[1], g),
                      lambda c, g=None: problem(c, "fine", SIZE_STAGE, g))
    clock.lap("fine")
    rel = best.capture
    scene = scene_from_relative(rel, preset, size, focal_px)
    report = sample_for("fine").index
    total = float(np.sum(fine.flat[report] ** 2))
    colour = None if sensitivities is None else \
        expected_colours(sensitivities, FIT_STEP_NM, colour_blur_nm(preset, rel.lobe_sigma, focal_px))
    value = consistency(rgb, scene, total, step_nm=FIT_STEP_NM, pixels=report, colour=colour)
    null = consistency(rgb, scene, total, step_nm=FIT_STEP_NM, pixels=report, colour=colour, scramble=True)
    centre = tuple(float(v) for v in project(rel.disc_centre_mm, size, focal_px))
    glint = mirror_point(rel)
    ring = tuple(float(v) for v in project(glint, size, focal_px)) if glint is not None else centre
    lines = None if ctx.ridges is None else line_agreement(ctx.ridges, rel, size, focal_px, preset.disc)
    clock.lap("report")
    return PoseFit(center_px=centre, ring_center_px=ring, lobe_sigma=float(rel.lobe_sigma), focal_px=float(focal_px),
                   distance_mm=rel.distance_mm, residual=value, evaluations=evals, null_residual=null,
                   known_scene=scene, timing_ms=clock.laps(), strategy=best.start.strategy,
                   line_share=0.0 if lines is None else lines.share,
                   line_offset_px=math.inf if lines is None else lines.median_px,
                   line_orders=() if lines is None else lines.orders, lines_pinned=best.start.held)


# The lamp's size σ sets how far the rainbow's colours are blurred along λ₁ (d·σ: 5 nm at the
# presets' 0.003, 16 nm for a 0.01 bulb), and LM holds that blur at the start's σ (the colour
# grid is built for it), so a photo's lamp size was never fitted: cd-default under a lamp of σ
# 0.01 read with σ 0.003, residual 0.0022 against 0.0008 at the true size, MAE 400–700 0.18
# against 0.010 (bench/pose_errors.md, "lamp size"). These sizes are tried on the fine level's
# cost; LM then refines the best from there. Not with the generic camera profile: its colours
# are not the camera's, and their mismatch read as a blur (make eval's generic-profile row
# 0.050 -> 0.127 with it).
# A size is taken only where it leaves at most SIZE_GAIN of what the fitted one left unexplained:
# at the presets' own size the cost barely moves with σ (a nominal Planck photo: residual 0.00032
# at 0.003, 0.00031 at 0.0018), and taking the smaller size read a nominal synthetic LED 0.045
# against 0.007 (dev pose bench); the lamp's size stays the preset's unless the photo insists.
SIZE_FACTORS = (0.35, 0.6, 1.7, 3.0)
SIZE_GAIN = 0.7
SIZE_STAGE = (STAGES[1][0], 1.0)  # judged with the camera's colour at full weight: the blur is in the colour


# The colours the coarse stage expects are a flat spectrum's under the lobe's blur; a narrow band
# (a blue LED 25 nm wide, a white LED's pump, a phosphor line) lights a pixel at λ₁ from its
# bright side, so its colour is that of a wavelength nearer the band's peak, and the fit slid the
# capture to match: tripod-oblique's nominal photo of a 460 nm LED read λ₁ 3.3 nm off
# (tests/test_lamp_colours.py), an LSPDD blue LED Δu'v' 0.026 where the true capture reads 0.005.
# The fine stage expects the lamp's own light under the blur, its spectrum as the fine level's
# profile at the coarse fit shows it (:func:`.self_consistency.profile_spd`). Only with the
# camera's own sensitivities (the generic profile's colours are not the camera's). An oblique
# set-up weighs these colours fully, as its coarse stage does: there the colour is what pins the
# wavelength axis, and it is no longer a flat spectrum's guess. Chosen on synthetic spectra (24 of
# the prior's families per set-up, nominal and combined captures, dev runs): as good as a fine fit
# followed by a lamp-coloured one and without its cost; weight 1 against the fine stage's 0.3 read
# the distant lamp's nominal Δu'v' 0.0017 against 0.0023 and tripod's combined 0.0011 against
# 0.0013. A near-axis set-up keeps 0.3: its rings pin the geometry, weight 1 helped there on one
# photo of 24 and tilted a 192 px disc's fit 1.2° off where 0.3 reads 0.8°
# (tests/test_pose_starts.py).
LAMP_COLOURS = True
LAMP_WEIGHT_OBLIQUE = 1.0


def _lamp_coloured(p: _Problem, rel: RelativePose, sample: _Sample, preset: Preset,
                   sensitivities: NDArray[np.float64], weight: float) -> _Problem:
    """The fine problem ``p`` around ``rel`` with the colours of the lamp's light as its profile
    at ``rel`` shows it, at ``weight`` (see :data:`LAMP_COLOURS`); ``p`` itself where the
    profile shows none."""
    blur = round(colour_blur_nm(preset, rel.lobe_sigma, sample.level.level_focal), 1)
    spd = profile_spd(p.objective.profile_at(rel), p.objective.grid, sensitivities, blur)
    if spd is None:
        return p
    grid = ProfileGrid.with_camera(*GRID_NM, STAGES[1][0], sensitivities, blur, weight, spd=spd)
    return _Problem(sample, rel, preset, grid, p.geometry)


# An oblique capture whose coarse search ended without explaining the photo (cost above
# GOOD_COST) also gets its best starts refitted with the lamp's size held at the start's: with
# the size free, coarse LM can shrink the lobe to a thin line that explains a sliver of the streak
# from a capture several degrees off, and stay there. The best of those joins the finalists and
# the fine stage (size free again) judges it with the rest. Chosen on synthetic spectra of the
# training prior (scratch, 25 phone-distant-lamp photos on a black cloth, 16 tripod-oblique, the
# lamp-size rows): two photos fitted 5–9° off with a lobe 4× too small read MAE 0.48 / 0.25 →
# 0.014 / 0.032; the row 0.053 → 0.026, Δu'v' 0.0122 → 0.0031; every other photo within 0.002
# but one tripod photo (0.0148 → 0.0169). Holding the size in every coarse fit instead fixed
# the same two and broke two others (0.046 → 0.117, 0.020 → 0.033).
def _at_start_size(fits: "list[_Fitted]", problem_at) -> tuple[_Fitted, int] | None:
    """The best coarse refit of ``fits``' starts with the lamp's size held, and the evaluations spent."""
    refits, evals = [], 0
    for f in fits:
        p = problem_at(f.start.pose)
        x, cost = p.fit(f.start.params, LM_ITERATIONS[0], LM_TOL[0], SIZE_HELD)
        evals += p.evaluations
        refits.append(_Fitted(cost, f.start, x))
    return (min(refits, key=lambda fit: fit.cost), evals) if refits else None


def _through_wide_lobes(problem_at, start: Start) -> tuple[Start, int]:
    """``start`` moved by LM fits with its lobe widened by each of :data:`WIDENED` in turn (the
    lobe's size held), back at its own size; and the cost evaluations that took."""
    capture, evaluations = start.capture, 0
    sigma = capture.lobe_sigma
    for widen in WIDENED:
        wide = replace(capture, lobe_sigma=sigma * widen)
        p = problem_at(wide)
        y, _ = p.fit(np.zeros(N_PARAMS), LM_ITERATIONS[0], LM_TOL[0], SIZE_HELD)
        evaluations += p.evaluations
        capture = replace(apply_params(wide, y), lobe_sigma=sigma)
    return replace(start, pose=capture, params=np.zeros(N_PARAMS)), evaluations


def _sized(best: _Fitted, problem_at, judge_at) -> _Fitted:
    """``best`` or the capture with another lamp size whose colour blur explains the photo
    better (:data:`SIZE_FACTORS`, judged by ``judge_at``'s cost), refined by LM (``problem_at``).
    The sizes share one evaluation of the geometry (``judge_at(capture, geometry)``): the disc
    and lamp are the same, only the lobe's width changes."""
    capture = best.capture
    judge = judge_at(capture)
    geometry = judge.geometry
    cost = judge.cost_at(capture)
    chosen, bar = None, SIZE_GAIN * cost
    for k in SIZE_FACTORS:
        other = replace(capture, lobe_sigma=capture.lobe_sigma * k)
        c = judge_at(other, geometry).cost_at(other)
        if c < bar:
            bar, chosen = c, other
    if chosen is None:
        return best
    p = problem_at(chosen, geometry)
    x, fitted = p.fit(np.zeros(N_PARAMS), LM_ITERATIONS[1], LM_TOL[1])
    return _Fitted(fitted, Start(best.start.strategy, chosen, held=best.start.held), x) if fitted < best.cost else best


class _Clock:
    def __init__(self) -> None:
        self.t = time.perf_counter()
        self._laps: list[tuple[str, float]] = []

    def lap(self, name: str) -> None:
        now = time.perf_counter()
        self._laps.append((name, (now - self.t) * 1e3))
        self.t = now

    def laps(self) -> tuple[tuple[str, float], ...]:
        return tuple(self._laps)
