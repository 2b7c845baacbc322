"""The rainbow as lines: where a small lamp's light leaves the disc, whatever its colours say.

Under a small lamp (a filament, an LED a few mm across, far away) the disc shows thin lines, a
few pixels wide, and a pose a few pixels off explains none of them: the self-consistency cost
(:mod:`.self_consistency`) is flat until the predicted lobe touches the line, so from a start
10 px away it has nothing to follow. The lines' *position* does not need their colour: every
order m of every wavelength leaves a point of the tracks only where the tangential part of
ωi + ωo vanishes (v = 0, the grating equation along the tracks), so the curve v = 0 through the
bright thin pixels is the same for the first order, the higher orders and the zero-order glint.
A real camera's colours can mislead (a phone renders 380–400 nm as magenta, a GIF's palette
drops the greens); the geometry cannot.

So: find the thin bright structures (a grey-level top-hat: the photo minus its opening with a
square a few % of the image across, which removes the lit table, the disc's base and anything
wider than a line), keep those that fall on the disc's tracks, and move the capture until v = 0
passes through them, each residual in pixels (v over its change per pixel), robust (Cauchy) so
that other lines — a reflection of the lamp in the table, the disc's edge — barely pull.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from ..numerics.least_squares import cauchy, levenberg_marquardt
from ..photo.resample import box_downsample, box_factor, channel_sum
from ..scene.capture import Disc
from ..scene.kernel import camera_rays
from ..scene.relative_pose import N_PARAMS, RelativePose, apply_params, ray_diffraction

__all__ = ["Ridges", "ridge_pixels", "line_offsets_px", "line_fit", "line_agreement", "keeps_lines", "LineAgreement", "LineFit", "LINE_PX",
           "on_curve"]

LINE_SIDE = 600  # the lines are found on an image of about this size (a 24 MP photo: 10 × 10 blocks)
OPENING_SHARE = 0.025  # the top-hat's square, as a share of the image's long side (15 px at LINE_SIDE)
RIDGE_SHARE = 0.03  # at most this share of the image's pixels are taken as line pixels...
RIDGE_NOISE = 6.0  # ...and only those this many robust noise levels above their surround
MAX_RIDGES = 2500  # the brightest kept (the fit's cost grows with them)
MIN_RIDGES = 12
LINE_PX = 3.0  # a line pixel within this of the predicted curve is on it (the Cauchy scale)
STEP = 1e-3  # finite-difference step of the parameters (deg, log)
# What the lines alone do not pin stays near the start: the lamp's distance (the curve barely
# moves with it) above all. Scales: aim ×2, tilt ×2 (deg), lamp direction ×2 (deg), log distance.
PRIOR_SCALE = np.array([8.0, 8.0, 5.0, 5.0, 10.0, 10.0, 0.3])
PRIOR_WEIGHT = 1.0  # a departure of one scale costs as much as every line pixel one Cauchy scale off
COLOUR_NM = 15.0  # a colour wavelength this far from every order of its pixel's λ₁ is a miss (Cauchy scale)
COLOUR_TRUSTED_NM = (430.0, 650.0)  # outside, cameras render a wavelength by leaks (violet as magenta)
COLOUR_WEIGHT = 1.0  # a pixel's colour counts as much as its position (per pixel, at unit weights)
ORDER_SHARE = 0.05  # an order counts as seen where this share of the line pixels show it in 400–700 nm
PINNED_SHARE = 0.6
PINNED_MEDIAN_PX = 0.6 * LINE_PX
LINE_PARAMS = np.arange(7)  # every parameter but the lamp's size, which the curve does not see


@dataclass(frozen=True)
class Ridges:
    """Thin bright pixels of a photo: positions (row, col) in the photo's pixels, their camera
    rays and weights (top-hat height over the noise, capped)."""

    rows: NDArray[np.float64]
    cols: NDArray[np.float64]
    rays: NDArray[np.float64]
    weight: NDArray[np.float64]
    values: NDArray[np.float64]  # (n, 3) linear RGB, box-averaged over the ridge pixel
    step_px: float  # the photo pixels one ridge pixel spans (its level's box size)

    def __len__(self) -> int:
        return int(self.rows.size)

    def subset(self, keep: NDArray[np.bool_] | NDArray[np.int64]) -> "Ridges":
        return Ridges(self.rows[keep], self.cols[keep], self.rays[keep], self.weight[keep], self.values[keep],
                      self.step_px)


def _running(a: NDArray[np.float64], size: int, axis: int, reduce: str) -> NDArray[np.float64]:
    """Running min or max over ``size`` samples along ``axis`` (edges padded by repetition)."""
    half = size // 2
    pad = [(0, 0), (0, 0)]
    pad[axis] = (half, size - 1 - half)
    windows = sliding_window_view(np.pad(a, pad, mode="edge"), size, axis=axis)
    return windows.min(axis=-1) if reduce == "min" else windows.max(axis=-1)


def top_hat(lum: NDArray[np.float64], size: int) -> NDArray[np.float64]:
    """``lum`` minus its grey opening with a ``size`` square: what is narrower than the square."""
    opened = _running(_running(lum, size, 0, "min"), size, 1, "min")
    opened = _running(_running(opened, size, 0, "max"), size, 1, "max")
    return lum - opened


def ridge_pixels(rgb: NDArray[np.floating], focal_px: float) -> Ridges | None:
    """The photo's thin bright structures (None where there are too few to be lines).

    Clipped pixels are kept: a line's position survives clipping. The noise level is the
    top-hat's median absolute value (most of a photo is flat)."""
    height, width = rgb.shape[:2]
    factor = box_factor(max(height, width), LINE_SIDE)
    small_rgb = box_downsample(np.nan_to_num(np.asarray(rgb, dtype=np.float64)), factor)
    small = channel_sum(small_rgb)
    size = max(5, int(round(OPENING_SHARE * max(small.shape))) | 1)
    hat = top_hat(small, size)
    noise = float(np.median(np.abs(hat))) + 1e-6 * float(np.max(small, initial=0.0)) + 1e-12
    level = max(RIDGE_NOISE * noise, float(np.quantile(hat, 1.0 - RIDGE_SHARE)))
    flat = hat.ravel()
    index = np.flatnonzero(flat > level)
    if index.size < MIN_RIDGES:
        return None
    if index.size > MAX_RIDGES:
        index = index[np.argpartition(-flat[index], MAX_RIDGES - 1)[:MAX_RIDGES]]
    r, c = np.divmod(index, small.shape[1])
    rows = r * factor + (factor - 1) / 2.0
    cols = c * factor + (factor - 1) / 2.0
    weight = np.minimum(flat[index] / level, 4.0)
    return Ridges(rows.astype(np.float64), cols.astype(np.float64),
                  camera_rays(rows, cols, (width, height), focal_px), weight, small_rgb.reshape(-1, 3)[index],
                  float(factor))


def _v_per_px(ridges: Ridges, rel: RelativePose, size: tuple[int, int], focal_px: float, pitch_um: float
              ) -> NDArray[np.float64]:
    """|∇v| per photo pixel at each ridge pixel for the capture ``rel`` (∞ off the disc plane)."""
    base = ray_diffraction(ridges.rays, rel, pitch_um)
    dx = ray_diffraction(camera_rays(ridges.rows, ridges.cols + 1.0, size, focal_px), rel, pitch_um)
    dy = ray_diffraction(camera_rays(ridges.rows + 1.0, ridges.cols, size, focal_px), rel, pitch_um)
    ok = base.hit & dx.hit & dy.hit
    grad = np.hypot(dx.v - base.v, dy.v - base.v)
    return np.where(ok & (grad > 0), grad, np.inf)


def on_tracks(ridges: Ridges, rel: RelativePose, disc: Disc) -> NDArray[np.bool_]:
    """Ridge pixels that the capture ``rel`` puts on the disc's grating (the data area, widened
    by 2 mm: a start a few px off must not lose the line's ends)."""
    d = ray_diffraction(ridges.rays, rel, disc.pitch_um)
    return d.hit & (d.radius_mm >= disc.grating_r_min_mm - 2.0) & (d.radius_mm <= disc.grating_r_max_mm + 2.0)


def line_offsets_px(ridges: Ridges, rel: RelativePose, size: tuple[int, int], focal_px: float, disc: Disc
                    ) -> NDArray[np.float64]:
    """Each ridge pixel's distance (photo px) from the capture's curve v = 0, to first order
    (v over its gradient); ∞ off the disc plane."""
    v = ray_diffraction(ridges.rays, rel, disc.pitch_um).v
    return np.abs(v) / _v_per_px(ridges, rel, size, focal_px, disc.pitch_um)


@dataclass(frozen=True)
class LineAgreement:
    """How the photo's thin lines sit on a capture's curve v = 0 (see :func:`line_agreement`)."""

    share: float  # weighted share of the ridge pixels on the tracks within LINE_PX of the curve
    median_px: float  # their median distance from it (photo px; ∞ where none)
    orders: tuple[int, ...]  # the diffraction orders those pixels show in 400–700 nm
    pixels: int  # ridge pixels on the tracks


def line_agreement(ridges: Ridges, rel: RelativePose, size: tuple[int, int], focal_px: float, disc: Disc
                   ) -> LineAgreement:
    """Where the capture ``rel`` puts the photo's lines: on its curve or not, and in which
    orders (a line with no first order in 400–700 nm is the higher orders: the first is off
    the disc, or in the infrared)."""
    keep = on_tracks(ridges, rel, disc)
    if not np.any(keep):
        return LineAgreement(0.0, math.inf, (), 0)
    sub = ridges.subset(keep)
    off = line_offsets_px(sub, rel, size, focal_px, disc)
    inlier = off <= LINE_PX
    share = float(np.sum(sub.weight[inlier]) / np.sum(sub.weight))
    if not np.any(inlier):
        return LineAgreement(share, math.inf, (), int(keep.sum()))
    lam1 = ray_diffraction(sub.rays[inlier], rel, disc.pitch_um).lambda1_nm
    orders = tuple(m for m in range(1, disc.max_order + 3)
                   if np.mean((lam1 / m >= 400.0) & (lam1 / m <= 700.0)) >= ORDER_SHARE)
    return LineAgreement(share, float(np.median(off[inlier])), orders, int(keep.sum()))


def on_curve(share: float, median_px: float) -> bool:
    """Most of the photo's lines on the tracks lie on a capture's curve: that capture shows them
    as a disc's diffraction orders (PINNED_SHARE, PINNED_MEDIAN_PX)."""
    return share >= PINNED_SHARE and median_px <= PINNED_MEDIAN_PX


def keeps_lines(ridges: Ridges, rel: RelativePose, size: tuple[int, int], focal_px: float, disc: Disc) -> bool:
    """The capture ``rel`` still has the photo's lines on its curve (as a pinning fit must)."""
    agreement = line_agreement(ridges, rel, size, focal_px, disc)
    return on_curve(agreement.share, agreement.median_px)


@dataclass(frozen=True)
class LineFit:
    """A capture moved onto the photo's lines: the parameters (around ``start``) and how well."""

    params: NDArray[np.float64]
    on_line: float  # weighted share of the ridge pixels on the tracks that lie within LINE_PX of the curve
    median_px: float  # median distance of those inliers from the curve (photo px)
    evaluations: int

    @property
    def pins_geometry(self) -> bool:
        """Most of the lines on the tracks lie on the curve: the photo is one of thin lines and
        their position, not the self-consistency (flat a few px away), pins the capture."""
        return on_curve(self.on_line, self.median_px)


def _colour_terms(ridges: Ridges, colours: tuple[NDArray[np.float64], NDArray[np.float64]] | None,
                  inliers: NDArray[np.bool_]) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The ridge pixels whose colour names a wavelength the camera's hue pins well: their
    indices, those wavelengths and √weights (from how sharply the colour pins λ)."""
    if colours is None:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    lam, sharp = colours
    use = inliers & (sharp > 0) & (lam >= COLOUR_TRUSTED_NM[0]) & (lam <= COLOUR_TRUSTED_NM[1])
    idx = np.flatnonzero(use)
    if idx.size < MIN_RIDGES:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    w = np.minimum(np.sqrt(sharp[idx] / np.median(sharp[idx])), 3.0) * np.sqrt(ridges.weight[idx])
    return idx, lam[idx], COLOUR_WEIGHT * w / np.sqrt(np.mean(w * w))


def order_error_nm(lambda1_nm: NDArray[np.float64], colour_nm: NDArray[np.float64], max_order: int
                   ) -> NDArray[np.float64]:
    """How far each pixel's colour wavelength is from the nearest order m ≤ ``max_order`` of its
    λ₁ (λ₁/m): an overlapping order must not count as a miss."""
    err = np.full(lambda1_nm.shape, np.inf)
    for m in range(1, max_order + 1):
        err = np.minimum(err, np.abs(lambda1_nm / m - colour_nm))
    return err


def line_fit(ridges: Ridges, start: RelativePose, x0: NDArray[np.float64], size: tuple[int, int],
             focal_px: float, disc: Disc, rounds: int = 3,
             colours: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None) -> LineFit | None:
    """The capture (``start`` moved by parameters from ``x0``) whose curve v = 0 passes through
    the ridge pixels on its tracks; None where too few ridge pixels fall on the tracks.

    A few rounds: which pixels lie on the tracks, and each one's v per pixel, are fixed within a
    round (they change little) and recomputed between rounds, the Cauchy scale shrinking from
    4·LINE_PX to LINE_PX so that a start 20 px away is first pulled in and then held to the line.

    ``colours`` (each ridge pixel's colour wavelength and how sharply its hue pins it, from
    :func:`.streak_colours.colour_wavelengths`) join in the last round, for the pixels then on
    the line: the curve's position barely depends on how far the camera and the lamp are from
    the disc's axis, the wavelengths along it very much (a degree moves them ~20 nm), and
    the hue's blue–green and green–red turns name them whatever the camera's white balance."""
    x = np.asarray(x0, dtype=np.float64).copy()
    evaluations = 0
    for k in range(rounds):
        rel = apply_params(start, x)
        keep = on_tracks(ridges, rel, disc)
        if int(np.sum(keep)) < MIN_RIDGES:
            return None
        sub = ridges.subset(keep)
        scale_px = LINE_PX * 4.0 ** ((rounds - 1 - k) / max(1, rounds - 1))
        per_px = _v_per_px(sub, rel, size, focal_px, disc.pitch_um)
        finite = np.isfinite(per_px)
        sub, per_px = sub.subset(finite), per_px[finite]
        root_w = np.sqrt(sub.weight / np.mean(sub.weight))
        prior_w = PRIOR_WEIGHT * math.sqrt(len(sub)) / PRIOR_SCALE
        if k == rounds - 1:
            sub_colours = None if colours is None else (colours[0][keep][finite], colours[1][keep][finite])
            near = np.abs(ray_diffraction(sub.rays, rel, disc.pitch_um).v / per_px) <= 2.0 * LINE_PX
            c_idx, c_lam, c_w = _colour_terms(sub, sub_colours, near)
        else:
            c_idx, c_lam, c_w = np.zeros(0, np.int64), np.zeros(0), np.zeros(0)

        def residuals(y: NDArray[np.float64], sub: Ridges = sub, per_px: NDArray[np.float64] = per_px,
                      root_w: NDArray[np.float64] = root_w, scale: float = scale_px,
                      prior_w: NDArray[np.float64] = prior_w, c_idx: NDArray[np.int64] = c_idx,
                      c_lam: NDArray[np.float64] = c_lam, c_w: NDArray[np.float64] = c_w) -> NDArray[np.float64]:
            z = np.zeros(N_PARAMS)
            z[LINE_PARAMS] = y
            d = ray_diffraction(sub.rays, apply_params(start, z), disc.pitch_um)
            off = np.where(d.hit, d.v / per_px, 1e3)
            err = order_error_nm(d.lambda1_nm[c_idx], c_lam, disc.max_order)
            return np.concatenate([root_w * cauchy(off / scale), c_w * cauchy(np.minimum(err, 1e3) / COLOUR_NM),
                                   prior_w * y])

        y, _, n = levenberg_marquardt(residuals, x[LINE_PARAMS], steps=np.full(LINE_PARAMS.size, STEP),
                                      max_iter=25)
        evaluations += n
        x[LINE_PARAMS] = y
    agreement = line_agreement(ridges, apply_params(start, x), size, focal_px, disc)
    if agreement.pixels == 0:
        return None
    return LineFit(x, agreement.share, agreement.median_px, evaluations)
