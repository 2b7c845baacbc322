"""Per-pixel diffraction coordinate of a :class:`~.capture.Scene`: which wavelength each pixel's
first order shows, and how visible the lobe is there (the geometry is :mod:`.kernel`'s).

For a disc point with unit vectors ωi (to the lamp) and ωo (to the camera), the first order
lights up where |(ωi + ωo)·r̂| = λ/d, and only while the tangential part v = (ωi + ωo)·t̂ is
within the lobe width σ. So λ₁ = d·|u| is the feature coordinate that makes photos taken at
different distances, offsets and tilts comparable, and exp(−v²/2σ²) says which pixels carry
the spectrum at all (full rings for a coaxial lamp, two short streaks for a lamp beside the lens).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .capture import Scene
from .kernel import diffraction_along

__all__ = ["PixelDiffraction", "pixel_diffraction", "SURVEY_BLOCK", "BlockSurvey", "survey_blocks", "LobePixels",
           "lobe_pixels"]


@dataclass(frozen=True)
class PixelDiffraction:
    """Arrays over the selected pixels (flattened)."""

    index: NDArray[np.int64]  # flat pixel index into the (H, W) image
    lambda1_nm: NDArray[np.float64]  # first-order wavelength d·|u|
    visibility: NDArray[np.float64]  # exp(−v² / 2σ²)
    gain: NDArray[np.float64]  # irradiance · G/w² relative to the lamp's irradiance at the disc centre
    radius_mm: NDArray[np.float64]  # distance from the disc centre on the disc
    on_tracks: NDArray[np.bool_]  # inside the grating annulus
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    points_c: NDArray[np.float64]  # (3, n) world positions on the disc (metres), component-major
    view_c: NDArray[np.float64]  # (3, n) unit directions to the camera

    @property
    def points(self) -> NDArray[np.float64]:
        """(n, 3) world positions on the disc (metres)."""
        return self.points_c.T

    @property
    def view(self) -> NDArray[np.float64]:
        """(n, 3) unit directions to the camera."""
        return self.view_c.T

    @property
    def amplitude(self) -> NDArray[np.float64]:
        """What a unit of λ₁-profile becomes at this pixel: visibility × geometric gain."""
        return self.visibility * self.gain

    def select(self, which: NDArray[np.intp] | NDArray[np.bool_]) -> PixelDiffraction:
        """The pixels at positions ``which`` (indices, or a mask over the pixels), by ``np.take``
        along the pixel axis (the last one, also for the component-major vectors)."""
        sel = np.flatnonzero(which) if np.asarray(which).dtype == bool else which
        return PixelDiffraction(**{k: np.take(v, sel, axis=-1) for k, v in self.__dict__.items()})


# Pixels evaluated per pass of the kernel: its ~45 array steps then work on arrays that stay in
# the CPU's cache (a 24 MP photo's 300 000 pixels at 750 × 500: 45 → 29 ms on the build machine);
# the values are the same, element by element.
PIXEL_CHUNK = 32768


def pixel_diffraction(scene: Scene, index: NDArray[np.int64] | None = None,
                      rows: NDArray[np.float64] | None = None,
                      cols: NDArray[np.float64] | None = None) -> PixelDiffraction:
    """λ₁ and lobe visibility at pixel centres (all pixels on the disc, or the given ones).

    ``rows``/``cols`` may give sub-pixel sample positions for the pixels in ``index``. The
    geometry is :func:`.kernel.diffraction_along` in the world frame; only pixels whose ray meets
    the disc annulus are kept.
    """
    width, height = scene.preset.camera.image_size_px
    if index is None:
        index = np.arange(width * height, dtype=np.int64)
    index = np.asarray(index, dtype=np.int64)
    if rows is None or cols is None:
        rows, cols = np.divmod(index, width)
    if index.size > PIXEL_CHUNK:
        parts = [_pixel_diffraction(scene, index[i:i + PIXEL_CHUNK], rows[i:i + PIXEL_CHUNK], cols[i:i + PIXEL_CHUNK])
                 for i in range(0, index.size, PIXEL_CHUNK)]
        return PixelDiffraction(**{k: np.concatenate([getattr(p, k) for p in parts], axis=-1)
                                   for k in PixelDiffraction.__dataclass_fields__})
    return _pixel_diffraction(scene, index, rows, cols)


def _pixel_diffraction(scene: Scene, index: NDArray[np.int64], rows: NDArray[np.float64] | NDArray[np.int64],
                       cols: NDArray[np.float64] | NDArray[np.int64]) -> PixelDiffraction:
    """One pass of :func:`pixel_diffraction`."""
    dirs = scene.pixel_rays(rows, cols)
    hit, geo = diffraction_along(dirs, scene.camera_position, scene.disc_center, scene.disc_normal,
                                 scene.light_position)
    disc = scene.preset.disc
    radius_mm = geo.radius * 1e3
    on_disc = (radius_mm >= disc.hole_radius_mm) & (radius_mm <= disc.rim_radius_mm)
    keep = np.flatnonzero(on_disc)
    sigma = scene.preset.light.lobe_sigma
    u, v = geo.u[keep], geo.v[keep]
    radius_mm = radius_mm[keep]
    return PixelDiffraction(
        index=index[np.flatnonzero(hit)[keep]],
        lambda1_nm=np.abs(u) * disc.pitch_um * 1e3,
        visibility=np.exp(-(v * v) / (2.0 * sigma * sigma)),
        gain=geo.gain[keep],
        radius_mm=radius_mm,
        on_tracks=(radius_mm >= disc.grating_r_min_mm) & (radius_mm <= disc.grating_r_max_mm),
        u=u,
        v=v,
        points_c=np.take(geo.points_c, keep, axis=1),
        view_c=np.take(geo.view_c, keep, axis=1),
    )


# --- evaluating only the pixels that can matter ----------------------------------------------
#
# Most of a disc photo is far from the first-order lobe: with the lamp beside the lens or an
# oblique set-up, 1–10 % of the disc's pixels are within reach of MIN_VISIBILITY. The kernel is
# evaluated first at the corners of blocks of SURVEY_BLOCK × SURVEY_BLOCK pixels; from those, each
# block gets conservative bounds of |u|, |v| and the radius over its pixel centres, and the
# kernel is then evaluated per pixel only in blocks where a caller's question has no certain
# answer. The values are the kernel's own, pixel for pixel (tests/test_pixel_survey.py).
SURVEY_BLOCK = 8
# Inside a block, a smooth field departs from the bilinear interpolation of its corners (which
# stays within their range) by at most B²/8·(|f_xx| + |f_yy|), i.e. (Δ²_across + Δ²_down)/8 in
# second differences of the corner grid. A block's bounds widen its corners' range by
# SURVEY_SLACK × (Δ²_across + Δ²_down), the largest in its 5 × 5 neighbourhood of corners: 8× that
# bound where the curvature is steady, and still more than it where the curvature doubles from
# one block to the next (towards the hole, where it grows like 1/r³, blocks are then evaluated
# pixel by pixel).
SURVEY_SLACK = 1.0
_MARGIN = 1e-6  # relative: thresholds are compared with this much room for rounding


@dataclass(frozen=True)
class BlockSurvey:
    """Conservative bounds per block of pixels (arrays of shape (blocks down, blocks across)).

    ``unsure`` blocks (a corner ray misses the disc's plane) have no bounds: callers evaluate
    them pixel by pixel."""

    scene: Scene
    block: int
    abs_u: tuple[NDArray[np.float64], NDArray[np.float64]]  # (low, high) of |u|
    abs_v: tuple[NDArray[np.float64], NDArray[np.float64]]  # (low, high) of |v|
    radius_mm: tuple[NDArray[np.float64], NDArray[np.float64]]
    unsure: NDArray[np.bool_]

    def may_be_on_disc(self) -> NDArray[np.bool_]:
        disc = self.scene.preset.disc
        lo, hi = self.radius_mm
        return self.unsure | ((hi >= disc.hole_radius_mm * (1 - _MARGIN)) & (lo <= disc.rim_radius_mm * (1 + _MARGIN)))

    def pixel_index(self, blocks: NDArray[np.bool_]) -> NDArray[np.int64]:
        """Flat indices, ascending, of the image's pixels in the selected blocks."""
        width, height = self.scene.preset.camera.image_size_px
        b = self.block
        mask = np.repeat(np.repeat(blocks, b, axis=0), b, axis=1)[:height, :width]
        return np.flatnonzero(mask)


def survey_blocks(scene: Scene, block: int = SURVEY_BLOCK) -> BlockSurvey:
    """Bounds of |u|, |v| and the radius per block, from the kernel at the blocks' corners."""
    width, height = scene.preset.camera.image_size_px
    ny, nx = -(-height // block), -(-width // block)
    rows = np.arange(ny + 1, dtype=np.float64) * block - 0.5  # corners enclose the pixel centres
    cols = np.arange(nx + 1, dtype=np.float64) * block - 0.5
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    hit, geo = diffraction_along(scene.pixel_rays(rr.ravel(), cc.ravel()), scene.camera_position,
                                 scene.disc_center, scene.disc_normal, scene.light_position)
    unsure = np.ones((ny + 1) * (nx + 1), dtype=bool)
    unsure[hit] = False
    unsure = unsure.reshape(ny + 1, nx + 1)
    unsure = unsure[:-1, :-1] | unsure[1:, :-1] | unsure[:-1, 1:] | unsure[1:, 1:]

    def bounds(values: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        f = np.zeros((ny + 1) * (nx + 1))
        f[hit] = values
        f = f.reshape(ny + 1, nx + 1)
        corners = np.stack([f[:-1, :-1], f[1:, :-1], f[:-1, 1:], f[1:, 1:]])
        curve = np.zeros_like(f)
        curve[:, 1:-1] += np.abs(f[:, :-2] - 2.0 * f[:, 1:-1] + f[:, 2:])
        curve[1:-1, :] += np.abs(f[:-2, :] - 2.0 * f[1:-1, :] + f[2:, :])
        padded = np.pad(curve, 2, mode="edge")
        near = np.max(np.stack([padded[i: i + ny, j: j + nx] for i in range(5) for j in range(5)]), axis=0)
        slack = SURVEY_SLACK * near
        return corners.min(axis=0) - slack, corners.max(axis=0) + slack

    def magnitude(lo_hi: tuple[NDArray[np.float64], NDArray[np.float64]]) -> tuple[NDArray[np.float64],
                                                                                   NDArray[np.float64]]:
        lo, hi = lo_hi
        return np.where(lo > 0, lo, np.where(hi < 0, -hi, 0.0)), np.maximum(np.abs(lo), np.abs(hi))

    return BlockSurvey(scene=scene, block=block, abs_u=magnitude(bounds(geo.u)), abs_v=magnitude(bounds(geo.v)),
                       radius_mm=bounds(geo.radius * 1e3), unsure=unsure)


@dataclass(frozen=True)
class LobePixels:
    """The disc's pixels sorted by what the readout asks of them (see :func:`lobe_pixels`)."""

    pixels: PixelDiffraction  # evaluated: every pixel that may be read, or may be dark (ascending index)
    dark: NDArray[np.int64]  # not evaluated: on-track pixels certainly dark and clear of the glint (ascending)
    survey: BlockSurvey
    evaluated: NDArray[np.bool_]  # the blocks whose pixels are in ``pixels``
    clear_uv: float

    def hub(self, radius_mm: float) -> NDArray[np.int64]:
        """Flat indices (in no particular order) of every disc pixel closer to the centre than
        ``radius_mm`` and clear of the glint (hypot(u, v) ≥ ``clear_uv``): the same pixels
        :func:`pixel_diffraction` would give, with the kernel evaluated only in blocks where
        the radius or the glint is uncertain."""
        survey, disc = self.survey, self.survey.scene.preset.disc
        r_lo, r_hi = survey.radius_mm
        maybe = survey.may_be_on_disc() & (survey.unsure | (r_lo < radius_mm * (1 + _MARGIN)))
        certain = (~survey.unsure & (r_lo > disc.hole_radius_mm * (1 + _MARGIN)) & (r_hi < radius_mm * (1 - _MARGIN))
                   & (np.hypot(survey.abs_u[0], survey.abs_v[0]) > self.clear_uv * (1 + _MARGIN)) & ~self.evaluated)
        extra = pixel_diffraction(survey.scene, survey.pixel_index(maybe & ~certain & ~self.evaluated))

        def inside(px: PixelDiffraction) -> NDArray[np.int64]:
            at = np.flatnonzero(px.radius_mm < radius_mm)
            return px.index[at[~(np.hypot(px.u[at], px.v[at]) < self.clear_uv)]]

        return np.concatenate([inside(self.pixels), inside(extra), survey.pixel_index(certain)])


def lobe_pixels(scene: Scene, min_visibility: float | None, dark_below: float | None = None, clear_uv: float = 0.0,
                lambda_nm: tuple[float, float] = (0.0, np.inf), block: int = SURVEY_BLOCK) -> LobePixels:
    """The kernel evaluated only where it is needed to tell, of the scene's pixels on the tracks,
    those with visibility ≥ ``min_visibility`` and λ₁ within ``lambda_nm`` (all of them are in
    ``pixels``, with exactly the values :func:`pixel_diffraction` gives, in its order) and, with
    ``dark_below``, those with visibility < ``dark_below`` and hypot(u, v) ≥ ``clear_uv`` (in
    ``pixels`` or ``dark``). The same pixels as :func:`pixel_diffraction` over the whole image,
    at a fraction of the cost where the lobe covers a fraction of the disc."""
    survey = survey_blocks(scene, block)
    disc = scene.preset.disc
    sigma = scene.preset.light.lobe_sigma

    def v_at(visibility: float) -> float:  # |v| where the visibility is ``visibility``
        return sigma * float(np.sqrt(-2.0 * np.log(visibility)))

    v_lo, v_hi = survey.abs_v
    r_lo, r_hi = survey.radius_mm
    tracks = survey.unsure | ((r_hi >= disc.grating_r_min_mm * (1 - _MARGIN))
                              & (r_lo <= disc.grating_r_max_mm * (1 + _MARGIN)))
    need = survey.unsure.copy()
    if min_visibility is not None:
        u_lo, u_hi = survey.abs_u
        per_u = disc.pitch_um * 1e3  # λ₁ = d·|u|
        need |= (tracks & (v_lo <= v_at(min_visibility) * (1 + _MARGIN))
                 & (u_hi * per_u >= lambda_nm[0] * (1 - _MARGIN)) & (u_lo * per_u <= lambda_nm[1] * (1 + _MARGIN)))
    certain = np.zeros_like(need)
    if dark_below is not None:
        certain = (~survey.unsure & (v_lo > v_at(dark_below) * (1 + _MARGIN))
                   & (np.hypot(survey.abs_u[0], v_lo) > clear_uv * (1 + _MARGIN))
                   & (r_lo > disc.grating_r_min_mm * (1 + _MARGIN)) & (r_hi < disc.grating_r_max_mm * (1 - _MARGIN)))
        need |= tracks & (v_hi >= v_at(dark_below) * (1 - _MARGIN)) & ~certain
    evaluated = need & ~certain
    return LobePixels(pixels=pixel_diffraction(scene, survey.pixel_index(evaluated)),
                      dark=survey.pixel_index(certain), survey=survey, evaluated=evaluated, clear_uv=clear_uv)
