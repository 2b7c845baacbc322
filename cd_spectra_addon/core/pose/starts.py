"""Where the pose fit starts: named strategies, each proposing captures from what the photo shows.

A start is a :class:`~..scene.relative_pose.RelativePose` and a parameter vector around it
(:func:`~..scene.relative_pose.apply_params`). Cheap strategies run on every photo; the fit asks
the expensive ones (:data:`ESCALATIONS`) only when no cheap start ends in a fit that explains the
photo. Each is a plain function of a :class:`StartContext`, registered in :data:`STRATEGIES` by
name, so an evaluation can run or leave out any of them by name and a test can check each alone.

- ``preset``: the capture the preset describes, seen by this camera.
- ``pattern``: the same, turned about the lens so the photo's bright pattern lines up with the
  predicted one (an FFT correlation on a small image).
- ``outline``: where the disc's outline shows (room light), the two poses its ellipse allows
  (:mod:`.rim_ellipse`), the lamp kept where the preset puts it relative to the disc.
- ``rings``: for a camera above the disc, the rings' 180° symmetry centre read as the lamp's mirror
  point, or as the disc centre.
- ``glint``: where the zero-order glint is seen (clipped), the preset's capture with the disc
  tilted so that it mirrors the lamp there.
- ``lines``: each of those moved until the curve where the disc sends light to the lens (v = 0,
  every order) passes through the photo's thin bright lines (:mod:`.lines`): a small lamp's
  lines are a few px wide and the self-consistency is flat a few px away from them.
- ``colours``: each of those moved by the rainbow's own colours (:mod:`.streak_colours`): each
  bright pixel's hue names its λ₁, a smooth fit good from far away.
- ``glint-line`` (escalation): where the zero-order glint is seen (clipped), captures that mirror
  the lamp exactly there, with the disc centre sought along the arcs' axis through it.
- ``in-plane`` (escalation): the lamp and the disc turned about the normal of the plane of
  incidence, scanned along the valley the photo's colours leave there.
- ``outline-lamp`` (escalation): where the disc's outline shows, each pose it allows with the
  lamp's direction sought on a grid: the outline pins the disc, the rainbow then the lamp.
- ``lamp-grid`` (escalation): an oblique disc with no outline: the lamp's direction sought on a
  grid, each capture aimed where its bright pattern lines up with the photo's.
- ``tilted`` (escalation): an oblique disc with no outline: the best fit so far with the disc
  tilted either way, the near-symmetric captures LM cannot cross to.
"""

from __future__ import annotations

import math
from functools import cached_property
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..numerics.fft import fast_length
from ..photo.resample import box_downsample, box_factor, channel_sum
from ..planning.capture_advice import glint_px
from ..scene.capture import Preset, Scene
from ..scene.diffraction import pixel_diffraction
from ..scene.kernel import turn_between
from ..scene.relative_pose import (LAMP_DISTANCE_PARAM, N_PARAMS, RelativePose, aimed_at, apply_params,
                                   near_axis, nominal_scene, relative_pose, scene_from_relative, turned_in_plane, with_glint_at,
                                   with_disc_centre_at, with_lamp_mirrored_at)
from .lines import Ridges, line_fit, ridge_pixels
from .rim_ellipse import Ellipse, circle_poses
from .result import colour_blur_nm
from .streak_colours import colour_wavelengths, streak_fit

__all__ = ["Start", "StartContext", "STRATEGIES", "CHEAP", "ESCALATIONS", "axis_of_arcs"]

PATTERN_SIDE = 256  # the bright pattern is lined up on an image of about this size
ARCS_STRENGTH = 0.05  # below this the rainbow is full rings: the disc centre is the glint's
# The disc centre along the arcs' axis (glint-line). A tilt of θ under a near-axis camera puts the
# centre D·tan θ from the glint: 24 mm is 6.5° at 210 mm. The coarse cost's valley in that offset
# is ~2 mm wide, so it is sampled every half millimetre and its bottom found by a parabola.
GLINT_LINE_MM = 24.0
GLINT_LINE_STEP_MM = 0.5
AIM_GRID_DEG = 0.15  # the line's best turned this far about the lens either way (glint centroid error)...
AIM_GRID_STEP_DEG = 0.05  # ...in these steps
# The in-plane valley; chosen on synthetic spectra (sample_spds), never on the evaluation's lamps.
SWING_DEG = 12.0  # the lamp's in-plane angle scanned this far either way
SWING_STEP_DEG = 0.5  # the coarse cost's teeth in that angle are ~0.5° wide at the bottom, ~1.5° apart
SWUNG_STARTS = 2  # the deepest teeth of that scan are followed along the tilt
TILT_DEG = 6.0  # ...this far either way
TILT_STEP_DEG = 0.5
VALLEY_STEP_DEG = 0.25  # the swing sampled this far either side of the valley's line at each tilt
# The lamp's direction about an outline's pose (outline-lamp): the preset's ±LAMP_GRID_DEG in
# LAMP_GRID_STEP_DEG for a lamp LAMP_GRID_WIDEN× larger, then ±LAMP_GRID_STEP_DEG about the best in
# LAMP_FINE_STEP_DEG at the lamp's own size. A synthetic tripod capture on a lit table had its lamp
# 5.3° from where the preset puts it about the outline's disc; at the lamp's own size the 3° grid
# stepped over its valley under a broad lamp (tests/test_outline_pose.py).
LAMP_GRID_DEG = 12.0
LAMP_GRID_STEP_DEG = 3.0
LAMP_FINE_STEP_DEG = 1.0
LAMP_GRID_WIDEN = 4.0
# The lamp's direction without an outline (lamp-grid): (the photo's side in px, the grid's reach
# and step in degrees, the lobe widened by) per level. The first reaches the combined
# errors (lamp ±3° and 5 mm, the disc ±3°: up to ~9° relative to the disc) with a lobe wide
# enough that a 1.5° step does not step over a capture's pattern; the second refines the
# GRID_KEEP best. At 64 px a pattern costs 0.5 ms, at 128 px 3.6 ms: 169 + 3 × 49 of them.
GRID_LEVELS = ((64, 9.0, 1.5, 4.0), (128, 1.5, 0.5, 2.0))
GRID_KEEP = 3
# The near-symmetric captures tried about a fit that does not explain the photo (tilted): the
# capture 3 above sat 2.6° off; chosen on synthetic lamps (the training prior), never on the
# evaluation's lamps.
TILTED_DEG = 2.5


@dataclass(frozen=True)
class Start:
    strategy: str
    pose: RelativePose
    params: NDArray[np.float64] = field(default_factory=lambda: np.zeros(N_PARAMS))
    held: bool = False  # the geometry is pinned by the photo's lines: the fit moves only the lobe's size
    widened: bool = False  # LM first fits it with the lobe widened (fit.WIDENED): a far start's broader basin

    @property
    def capture(self) -> RelativePose:
        return apply_params(self.pose, self.params)

    def repeats(self, other: "Start") -> bool:
        """The same start exactly (base capture, parameters, pinning): a fit from it finds what
        the other's found (the pattern found no shift: the preset's start again)."""
        a, b = self.pose, other.pose
        return (self.held == other.held and a.lobe_sigma == b.lobe_sigma and np.array_equal(self.params, other.params)
                and all(np.array_equal(getattr(a, name), getattr(b, name))
                        for name in ("disc_centre_mm", "disc_normal", "lamp_mm", "disc_x")))


Cost = Callable[[RelativePose], float]


@dataclass
class StartContext:
    """What the strategies look at: the photo (linear, offset removed), its clipped pixels, the
    preset, the camera and the cheapest available cost of a capture (``cost``, set by the fit)."""

    rgb: NDArray[np.float64]
    saturated: NDArray[np.bool_] | None
    preset: Preset
    focal_px: float
    sensitivities: NDArray[np.float64] | None
    outline: Ellipse | None
    cost: Cost | None = None
    fresh_cost: Cost | None = None  # the coarse cost of a capture judged on its own (its glint left out), as starts are scored
    evaluations: int = 0
    ridges: Ridges | None = None  # the photo's thin bright lines, found once (``lines``)
    found: list[Start] = field(default_factory=list)  # every start proposed so far

    @property
    def size(self) -> tuple[int, int]:
        return (self.rgb.shape[1], self.rgb.shape[0])

    def nominal(self) -> RelativePose:
        return relative_pose(nominal_scene(self.preset, self.size, self.focal_px))

    @cached_property
    def small(self) -> tuple[NDArray[np.float64], int]:
        """The photo's brightness box-averaged to about PATTERN_SIDE, less its median, and the
        factor: what the pattern, the rings and the arcs are read from (once per photo)."""
        height, width = self.rgb.shape[:2]
        factor = box_factor(max(height, width), PATTERN_SIDE)
        lum = channel_sum(box_downsample(self.rgb, factor))
        return np.clip(lum - np.median(lum), 0.0, None), factor


def preset_start(ctx: StartContext) -> list[Start]:
    return [Start("preset", ctx.nominal())]


def _expected_pattern(scene: Scene) -> NDArray[np.float64]:
    """Where the scene puts first-order light of 420–680 nm (amplitude per pixel, image-shaped)."""
    width, height = scene.preset.camera.image_size_px
    px = pixel_diffraction(scene)
    keep = px.on_tracks & (px.lambda1_nm > 420) & (px.lambda1_nm < 680)
    out = np.zeros(width * height)
    out[px.index[keep]] = px.amplitude[keep]
    return out.reshape(height, width)


def _correlation_peak(photo_lum: NDArray[np.float64], pattern: NDArray[np.float64]) -> tuple[float, float, float]:
    """The photo's bright pattern correlated with the predicted one: the peak, and the (rows,
    cols) by which the photo's pattern is displaced from the predicted one there."""
    h, w = photo_lum.shape
    shape = (fast_length(2 * h), fast_length(2 * w))  # ≥ 2×: no shift wraps onto another
    a = np.fft.rfft2(photo_lum, s=shape)
    b = np.fft.rfft2(pattern, s=shape)
    corr = np.fft.irfft2(a * np.conj(b), s=shape)
    r, c = np.unravel_index(int(np.argmax(corr)), corr.shape)
    peak = float(corr[r, c])
    r = r - shape[0] if r >= h else r
    c = c - shape[1] if c >= w else c
    return peak, float(r), float(c)


def _small(ctx: StartContext) -> tuple[NDArray[np.float64], int]:
    return ctx.small


def pattern_start(ctx: StartContext) -> list[Start]:
    nominal = ctx.nominal()
    lum, factor = _small(ctx)
    sh, sw = lum.shape
    predicted = _expected_pattern(scene_from_relative(nominal, ctx.preset, (sw, sh), ctx.focal_px / factor))
    _, dr, dc = _correlation_peak(lum, predicted)
    return [Start("pattern", nominal, _aimed_by(np.zeros(N_PARAMS), dr * factor, dc * factor, ctx.focal_px))]


def _aimed_by(x: NDArray[np.float64], rows: float, cols: float, focal_px: float) -> NDArray[np.float64]:
    """``x`` with the camera turned the other way from how the photo's pattern moved (px)."""
    x = x.copy()
    x[0] = -math.degrees(math.atan2(rows, focal_px))
    x[1] = -math.degrees(math.atan2(cols, focal_px))
    return x


def symmetry_centre(lum: NDArray[np.floating]) -> tuple[float, float]:
    """Centre of 180° symmetry (row, col) of a non-negative image: the autoconvolution
    (I * I)(s) peaks at s = 2c when I is point-symmetric about c (sub-pixel by parabolas)."""
    img = np.clip(np.asarray(lum, dtype=np.float64) - np.median(lum), 0, None)
    h, w = img.shape
    shape = (fast_length(2 * h), fast_length(2 * w))  # ≥ 2×: the autoconvolution does not wrap
    spec = np.fft.rfft2(img, s=shape)
    conv = np.fft.irfft2(spec * spec, s=shape)
    peak = np.unravel_index(int(np.argmax(conv)), conv.shape)
    out = []
    for axis, p in enumerate(peak):
        idx = list(peak)
        shift = 0.0
        if 0 < p < conv.shape[axis] - 1:
            idx[axis] = p - 1
            left = conv[tuple(idx)]
            idx[axis] = p + 1
            right = conv[tuple(idx)]
            denom = left - 2 * conv[peak] + right
            shift = 0.0 if denom >= 0 else 0.5 * (left - right) / denom
        out.append((p + shift) / 2.0)
    return out[0], out[1]


def rings_starts(ctx: StartContext) -> list[Start]:
    """A camera above the disc (near-axis presets): the rings' 180° symmetry centre is where the
    disc mirrors the lamp. Three readings of it: the lamp moved so its mirror point is there (the
    lamp placed off its stated spot); the camera aimed so the disc centre is there (a camera
    turned); and, where the rainbow's outer edge shows a circle (the tracks end at their outer
    radius), the disc centre at that circle's centre with the lamp mirrored at the symmetry
    centre (a camera moved sideways). Why: a coaxial lamp 5 mm off moves the rings' centre
    2.5 mm, and a start with the rings centred elsewhere settles in a wrong ring (cd-default,
    lamp swung 3°: lamp fitted on the far side, λ₁ 2.6 nm off); a camera moved 2 mm sideways
    was read from the preset as a tilted disc with the lamp moved (disc centre 2 px off)."""
    if not near_axis(ctx.preset):
        return []
    lum, factor = _small(ctx)
    r, c = symmetry_centre(lum)

    def full(rc: tuple[float, float]) -> tuple[float, float]:
        return ((rc[0] + 0.5) * factor - 0.5, (rc[1] + 0.5) * factor - 0.5)

    rings = full((r, c))
    nominal = ctx.nominal()
    out = []
    moved = with_lamp_mirrored_at(nominal, rings, ctx.size, ctx.focal_px)
    if moved is not None:
        out.append(Start("rings", moved))
    out.append(Start("rings", aimed_at(nominal, rings, ctx.size, ctx.focal_px)))
    edge = outer_edge_centre(lum, (r, c))
    if edge is not None:
        shifted = with_disc_centre_at(nominal, full(edge), ctx.size, ctx.focal_px)
        shifted = shifted and with_lamp_mirrored_at(shifted, rings, ctx.size, ctx.focal_px)
        if shifted is not None:
            out.append(Start("rings", shifted))
    return out


EDGE_LEVEL = 0.15  # of the photo's bright level: where the rainbow ends
EDGE_SECTORS = 36
MIN_EDGE_SECTORS = 18  # a circle needs edge points around most of it (full rings, not streaks)


def outer_edge_centre(lum: NDArray[np.float64], around: tuple[float, float]) -> tuple[float, float] | None:
    """Centre (row, col) of the circle through the rainbow's outermost bright pixel in each of
    EDGE_SECTORS directions from ``around`` (a least-squares circle, Kåsa's), or None where too
    few directions show an edge (streaks, not rings)."""
    top = float(np.percentile(lum, 99.5))
    if not top > 0:
        return None
    rows, cols = np.nonzero(lum > EDGE_LEVEL * top)
    if rows.size < EDGE_SECTORS:
        return None
    dy, dx = rows - around[0], cols - around[1]
    radius = np.hypot(dy, dx)
    sector = ((np.arctan2(dy, dx) + math.pi) / (2 * math.pi) * EDGE_SECTORS).astype(np.int64) % EDGE_SECTORS
    order = np.lexsort((radius, sector))
    last = np.ones(order.size, dtype=bool)
    last[:-1] = sector[order][1:] != sector[order][:-1]
    edge = order[last]
    if edge.size < MIN_EDGE_SECTORS:
        return None
    x, y = cols[edge].astype(np.float64), rows[edge].astype(np.float64)
    a = np.stack([2 * x, 2 * y, np.ones_like(x)], axis=1)
    sol, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    return float(sol[1]), float(sol[0])


def outline_starts(ctx: StartContext) -> list[Start]:
    if ctx.outline is None:
        return []
    nominal = ctx.nominal()
    out = []
    for centre, normal in circle_poses(ctx.outline, ctx.preset.disc.rim_radius_mm, ctx.focal_px, ctx.size):
        turn = turn_between(nominal.disc_normal, normal)
        lamp = centre + turn @ (nominal.lamp_mm - nominal.disc_centre_mm)
        out.append(Start("outline", RelativePose(centre, normal, lamp, nominal.lobe_sigma, turn @ nominal.disc_x)))
    return out


def outline_lamp_starts(ctx: StartContext) -> list[Start]:
    """Each pose the disc's outline allows, with the lamp's direction (turned about the disc's
    centre) where the cost is lowest on a grid. Why: from the outline's pose with the preset's
    lamp, neither LM nor the colours' move finds the rainbow when the lamp stands a few degrees
    off (tripod-oblique: a 3° move of the lamp turns the streak ~50° in the image)."""
    if ctx.fresh_cost is None:
        return []
    cost = ctx.fresh_cost
    out = []
    for start in outline_starts(ctx):
        wide = replace(start.pose, lobe_sigma=start.pose.lobe_sigma * LAMP_GRID_WIDEN)
        turn = _lowest(cost, wide, np.zeros(2), LAMP_GRID_DEG, LAMP_GRID_STEP_DEG)
        turn = _lowest(cost, start.pose, turn, LAMP_GRID_STEP_DEG, LAMP_FINE_STEP_DEG)
        out.append(Start("outline-lamp", apply_params(start.pose, _lamp_turned(turn))))
    return out


def lamp_grid_starts(ctx: StartContext) -> list[Start]:
    """An oblique set-up whose disc shows no outline: the lamp's direction on a grid about the
    preset's, each capture aimed (as ``pattern``) where its bright pattern lines up best with the
    photo's; the GRID_KEEP best lined up (peak of the correlation over the pattern's norm), found
    on a coarse grid and refined on a finer one (:data:`GRID_LEVELS`). Their LM fits first pass
    through a widened lobe (``Start.widened``).

    Why: on the tripod the camera stands 2.5° from the lamp's mirror direction, and a lamp or a
    disc 2–4° off turns the streak by tens of degrees in the image, so ``pattern``'s shift alone
    lines up the wrong blob (pose_errors' tripod combined capture 3: its start 6° further off than
    the preset's) and LM from there, or from the colours' move, settled 25° off (λ₁ 47 nm)."""
    if near_axis(ctx.preset) or ctx.outline is not None:
        return []
    nominal = ctx.nominal()
    lum, factor = _small(ctx)
    best: list[tuple[float, NDArray[np.float64], tuple[float, float]]] = []
    for side, reach, step, widen in GRID_LEVELS:
        k = max(1, int(round(max(lum.shape) / side)))
        small = box_downsample(lum[..., None], k)[..., 0]
        size = (small.shape[1], small.shape[0])
        wide = replace(nominal, lobe_sigma=nominal.lobe_sigma * widen)
        offsets = np.arange(-reach, reach + 1e-9, step)
        found = []
        for around in [np.zeros(2)] if not best else [turn for _, turn, _ in best]:
            for turn in (around + (a, b) for a in offsets for b in offsets):
                scene = scene_from_relative(apply_params(wide, _lamp_turned(turn)), ctx.preset, size,
                                            ctx.focal_px / (factor * k))
                pattern = _expected_pattern(scene)
                norm = float(np.linalg.norm(pattern))
                if norm > 0:
                    peak, dr, dc = _correlation_peak(small, pattern)
                    found.append((peak / norm, turn, (dr * k * factor, dc * k * factor)))
        found.sort(key=lambda item: -item[0])
        best = found[:GRID_KEEP]
    return [Start("lamp-grid", nominal, _aimed_by(_lamp_turned(turn), *shift, ctx.focal_px), widened=True)
            for _, turn, shift in best]


def tilted_starts(ctx: StartContext) -> list[Start]:
    """An oblique set-up whose disc shows no outline: the best fit so far with the disc tilted
    TILTED_DEG (the tilt that keeps the glint) either way about each image axis, each fitted
    through a widened lobe (``Start.widened``).

    Why: a disc tilted a few degrees, its lamp turned twice as far, draws nearly the same streak,
    and LM stays in whichever of those basins it entered: pose_errors' tripod combined capture 3
    (synthetic lamps) fitted 2.6° off in the disc's normal at 18× the true capture's cost, with a
    cost barrier between. Only an outline (``outline-lamp``) tells them apart directly."""
    if near_axis(ctx.preset) or ctx.outline is not None or not ctx.found:
        return []
    best = ctx.found[0].capture
    out = []
    for axis in (2, 3):
        for sign in (1.0, -1.0):
            x = np.zeros(N_PARAMS)
            x[axis] = sign * TILTED_DEG
            out.append(Start("tilted", apply_params(best, x), widened=True))
    return out


def _lamp_turned(turn: NDArray[np.float64]) -> NDArray[np.float64]:
    x = np.zeros(N_PARAMS)
    x[4:6] = turn
    return x


def _lowest(cost: Cost, base: RelativePose, around: NDArray[np.float64], reach: float, step: float
            ) -> NDArray[np.float64]:
    """The lamp's turn (x[4:6] of apply_params) on a square grid about ``around`` where ``cost``
    of ``base`` so turned is lowest."""
    offsets = np.arange(-reach, reach + 1e-9, step)
    grid = [around + (a, b) for a in offsets for b in offsets]
    costs = [cost(apply_params(base, _lamp_turned(t))) for t in grid]
    return grid[int(np.argmin(costs))]


def colour_starts(ctx: StartContext) -> list[Start]:
    """Every start found so far, moved so each bright pixel's colour matches its λ₁."""
    if ctx.sensitivities is None:
        return []
    half = box_downsample(ctx.rgb, 2)
    half_sat = None if ctx.saturated is None else box_downsample(np.asarray(ctx.saturated, np.float64), 2) > 0
    out = []
    for s in list(ctx.found):
        y, n = streak_fit(half, ctx.preset, ctx.focal_px / 2.0, s.pose, s.params, ctx.sensitivities, half_sat)
        ctx.evaluations += n
        out.append(Start(f"colours ({s.strategy})", s.pose, y))
    return out


def line_starts(ctx: StartContext) -> list[Start]:
    """Every start found so far, moved onto the photo's thin lines (where it has them). Where the
    lines do not pin the capture, the lamp keeps the start's distance: the line fit moves it
    freely (the curve barely depends on it), and LM, which holds the distance, could not take a
    wrong one back (synthetic tripod photos: the lamp moved 3–7 mm off its 200 mm, λ₁ 3.6 nm off
    at 10× the true capture's cost; tests/test_lamp_distance.py)."""
    if ctx.ridges is None:
        ctx.ridges = ridge_pixels(ctx.rgb, ctx.focal_px)
    if ctx.ridges is None:
        return []
    colours = None
    if ctx.sensitivities is not None:
        blur = colour_blur_nm(ctx.preset, ctx.nominal().lobe_sigma, ctx.focal_px / ctx.ridges.step_px)
        colours = colour_wavelengths(ctx.ridges.values, ctx.sensitivities, blur)
    out = []
    for s in list(ctx.found):
        fit = line_fit(ctx.ridges, s.pose, s.params, ctx.size, ctx.focal_px, ctx.preset.disc, colours=colours)
        if fit is None:
            continue
        ctx.evaluations += fit.evaluations
        params = fit.params
        if not fit.pins_geometry:
            params = params.copy()
            params[LAMP_DISTANCE_PARAM] = s.params[LAMP_DISTANCE_PARAM]
        out.append(Start(f"lines ({s.strategy})", s.pose, params, held=fit.pins_geometry))
    return out


def glint_starts(ctx: StartContext) -> list[Start]:
    """Where the zero-order glint is seen (clipped), the preset's capture with the disc tilted so
    that it mirrors the lamp exactly there: a tilted disc read off its glint. (The glint's line,
    an escalation, also slides the disc centre along the arcs.)"""
    glint = _seen_glint(ctx)
    if glint is None:
        return []
    tilted = with_glint_at(ctx.nominal(), glint, ctx.size, ctx.focal_px)
    return [] if tilted is None else [Start("glint", tilted)]


def _seen_glint(ctx: StartContext) -> tuple[float, float] | None:
    if ctx.saturated is None or not np.any(ctx.saturated):
        return None
    return glint_px(ctx.rgb, np.asarray(ctx.saturated))


def axis_of_arcs(lum: NDArray[np.float64], centre: tuple[float, float], r_min: float, r_max: float
                 ) -> tuple[float, float]:
    """Angle of the line the rainbow concentrates on, and how strongly (0 = full rings, 1 = two
    thin streaks), from the second angular harmonic of the energy around ``centre``."""
    rows, cols = np.indices(lum.shape)
    dy, dx = rows - centre[0], cols - centre[1]
    r = np.hypot(dx, dy)
    sel = (r >= r_min) & (r <= r_max)
    w = lum[sel]
    total = float(w.sum())
    if total <= 0:
        return 0.0, 0.0
    phase = np.exp(2j * np.arctan2(-dy[sel], dx[sel]))
    harmonic = complex(np.sum(w * phase)) / total
    return 0.5 * math.atan2(harmonic.imag, harmonic.real), abs(harmonic)


def _line_bases(ctx: StartContext) -> list[RelativePose]:
    """The captures the glint's line and the in-plane valley are sought from: the preset's, and
    the best start so far of the cheap strategies. Not lamp-grid's or tilted's: a version-2
    tripod photo read with a preset 12.5° off (tests/test_pose_recovery.py) had lamp-grid's fit
    at 0.004 of its energy unexplained; the valley followed from there ended at 0.0017 with λ₁
    4.0 nm off, from the colours' fit at 0.0024 with 0.9 nm — the coarse cost cannot rank those."""
    bases = [ctx.nominal()]
    cheap = [s for s in ctx.found if s.strategy.split(" ")[0] in CHEAP]
    if cheap:
        bases.append(cheap[0].capture)
    return bases


def glint_line_starts(ctx: StartContext) -> list[Start]:
    """Where the clipped glint is, captures that mirror the lamp exactly there; the disc centre
    sought along the arcs' axis through it (the deepest point of ``ctx.cost`` on each line).

    Why: a disc tilted 5° under a near-axis camera puts the glint ~18 mm from the disc centre and
    the rings become arcs about it. A centre 2 mm off along the arcs costs 20–30× the true one,
    and LM from there settles 0.3° off in the aim, where the track edges cut the rings in the
    wrong places (synthetic spectra: λ₁ 1 nm off, MAE 0.26 against 0.06 from the true pose)."""
    glint = _seen_glint(ctx) if ctx.cost is not None else None
    if glint is None:
        return []
    lum, factor = _small(ctx)
    out = []
    for base in _line_bases(ctx):
        px_per_mm = ctx.focal_px / base.distance_mm
        g_small = ((glint[0] + 0.5) / factor - 0.5, (glint[1] + 0.5) / factor - 0.5)
        angle, strength = axis_of_arcs(lum, g_small, 15 * px_per_mm / factor, 60 * px_per_mm / factor)
        axis = (-math.sin(angle), math.cos(angle)) if strength >= ARCS_STRENGTH else None
        found = _deepest_on_line(ctx, base, glint, axis, px_per_mm)
        if found is not None:
            out.append(Start("glint-line", found))
    return out


def _deepest_on_line(ctx: StartContext, base: RelativePose, glint: tuple[float, float],
                     axis: tuple[float, float] | None, px_per_mm: float) -> RelativePose | None:
    assert ctx.cost is not None
    size, f = ctx.size, ctx.focal_px

    def at(t: float) -> RelativePose | None:
        a = (0.0, 0.0) if axis is None else axis
        centre = (glint[0] + t * px_per_mm * a[0], glint[1] + t * px_per_mm * a[1])
        return with_glint_at(aimed_at(base, centre, size, f), glint, size, f)

    offsets = np.zeros(1) if axis is None else np.arange(-GLINT_LINE_MM, GLINT_LINE_MM + 1e-9, GLINT_LINE_STEP_MM)
    candidates = [(float(t), at(float(t))) for t in offsets]
    candidates = [(t, rel) for t, rel in candidates if rel is not None]
    if not candidates:
        return None
    costs = np.array([ctx.cost(rel) for _, rel in candidates])
    k = int(np.argmin(costs))
    best = (float(costs[k]), candidates[k][1])
    if 0 < k < costs.size - 1:
        curve = costs[k - 1] + costs[k + 1] - 2.0 * costs[k]
        if curve > 0:
            shift = 0.5 * (costs[k - 1] - costs[k + 1]) / curve
            rel = at(candidates[k][0] + shift * GLINT_LINE_STEP_MM)
            if rel is not None:
                c = ctx.cost(rel)
                best = (c, rel) if c < best[0] else best
    # The clipped glint's centroid is ~2 px (0.1°) off the mirror point, and a 0.1° aim alone
    # costs more than the pose's whole misfit: the best is turned about the lens on a small grid.
    steps = np.arange(-AIM_GRID_DEG, AIM_GRID_DEG + 1e-9, AIM_GRID_STEP_DEG)
    for a in steps:
        for b in steps:
            if a == 0.0 and b == 0.0:
                continue
            x = np.zeros(N_PARAMS)
            x[0], x[1] = a, b
            rel = apply_params(best[1], x)
            c = ctx.cost(rel)
            best = (c, rel) if c < best[0] else best
    return best[1]


def in_plane_starts(ctx: StartContext) -> list[Start]:
    """The deepest point of the cost's valley in the two in-plane angles about the preset's
    capture and the best start so far (:func:`.relative_pose.turned_in_plane`).

    Why: on an oblique streak a degree of the lamp's (or the disc's) in-plane angle slides the
    wavelength axis by ~40 nm, and the camera's colour along the streak makes the cost a comb of
    valleys ~0.5° wide in the lamp's angle. Along the valley (tilt and swing together keep the
    wavelength axis) the cost is flat and bumpy, and LM stops where it enters it. So: scan the
    swing at zero tilt, then follow each of the deepest SWUNG_STARTS teeth along the tilt, the
    swing re-centred at each step by a parabola through three samples."""
    if ctx.cost is None:
        return []
    out = []
    for base in _line_bases(ctx):
        found = _valley(ctx.cost, base)
        if found is not None:
            out.append(Start("in-plane", found))
    return out


def _valley(cost_of: Cost, base: RelativePose) -> RelativePose | None:
    if turned_in_plane(base, 0.0, 0.0) is None:
        return None

    def cost(tilt: float, swing: float) -> float:
        rel = turned_in_plane(base, tilt, swing)
        assert rel is not None
        return cost_of(rel)

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
                if curve > 0:
                    shift = float(np.clip(0.5 * h * (c[0] - c[2]) / curve, -h, h))
                    low = c[1] - 0.25 * (c[0] - c[2]) * shift / h
                else:
                    k = int(np.argmin(c))
                    low, shift = c[k], (k - 1) * h
                swing += shift
                if best is None or low < best[0]:
                    best = (low, float(tilt), swing)
    if best is None:
        return None
    return turned_in_plane(base, best[1], best[2])


STRATEGIES: dict[str, Callable[[StartContext], list[Start]]] = {
    "preset": preset_start,
    "pattern": pattern_start,
    "outline": outline_starts,
    "rings": rings_starts,
    "glint": glint_starts,
    "colours": colour_starts,
    "lines": line_starts,
    "glint-line": glint_line_starts,
    "in-plane": in_plane_starts,
    "outline-lamp": outline_lamp_starts,
    "lamp-grid": lamp_grid_starts,
    "tilted": tilted_starts,
}
CHEAP = ("preset", "pattern", "outline", "rings", "glint", "colours", "lines")
ESCALATIONS = ("lamp-grid", "tilted", "glint-line", "in-plane", "outline-lamp")
