"""The inverse in stages — load → pose → readout → spectrum — the same for every caller.

1. **load** (:func:`.load.load_for_estimate`): the photo decoded and linearised at the size the
   estimate reads, a window around a small disc;
2. **pose** (:func:`pose_photo`): the over-exposure refusal, the greyscale-photo camera collapse,
   the focal length (EXIF, else the preset's), a calibration's in-camera processing undone, and
   the pose fit (:mod:`..pose.fit`; its start strategies by name, :data:`..pose.starts.STRATEGIES`);
3. **readout** (:func:`read_posed`): room light measured on the dark disc and removed, the λ₁
   readout, a calibration's gains, the "no rainbow" refusal with what to move, and the forward
   matrix;
4. **spectrum** (:func:`spectrum`): one of the operating points in :data:`OPERATING_POINTS` —
   physics only, physics + prior, or the shipped model (physics + prior, the network, their
   fusion and per-band blend, :func:`fuse`) — for one photo, or for several photos of the same
   lamp at once (:func:`joint_spectrum`: one SPD, each photo at its own brightness), of which one
   photo is the one-photo case.

Colour, confidence and the result are :mod:`.estimate`'s. The estimator, the calibration shot,
dataset building, fusion tuning and the evaluations all run these functions rather than their
own copies of the steps, so a dataset sample and a product estimate of the same photo see
identical features (tests/test_inverse_path.py) and an evaluation measures the product.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..readout.ambient import dark_levels, readout_pixels, rough_offset
from ..calibration.calibration import Calibration, calibration_warning
from ..calibration.censoring import uncensor
from ..photo.clipping import clipped_channels
from ..spectra.cameras import CameraProfile
from ..spectra.grid import MIN_VISIBILITY, N_FEATURES, VISIBLE_NM, feature_bins
from ..scene.capture import Preset, Scene
from ..scene.relative_pose import near_axis
from ..planning.capture_advice import advice_for_photo, coverage_advice
from ..scene.diffraction import LobePixels, PixelDiffraction
from ..errors import CDSpectraError, NoDiscError, PhotoError
from ..readout.forward_matrix import bin_response, feature_matrix
from ..photo.images import ExifInfo, LinearImage
from ..spectrum.model import SpectralModel, model_inputs
from ..pose.fit import fit_pose
from ..pose.lines import on_curve
from ..pose.result import PoseFit
from ..pose.rim_ellipse import disc_ellipse, focal_px_from_outline
from ..readout.readout import Readout, extract_readout
from ..spectrum.track_edges import dark_edges_dropped
from ..spectrum.joint import JointSolve, edge_floors, joint_solve, usable
from ..spectrum.tails import TailSettings, widen_std, with_tails
from ..spectrum.solve import (LINE_ALLOWANCE, PRIOR_STRENGTH, SMOOTHNESS, GaussianPrior, Rows, blend_bands,
                             physics_solve, prior_solve, rows_for, solve_fused, solve_physics, solve_prior)
from ..pose.starts import CHEAP, ESCALATIONS
from .result import METHOD_MODEL, METHOD_PHYSICS, METHOD_PRIOR

MIN_RAINBOW_CONTRAST = 0.3  # the fitted disc must explain the photo far better than a misplaced one
# A capture pinned by thin lines (a small lamp: the self-consistency is flat a few px away) needs
# less, but some: where its lines include the first order, the rainbow they hold must explain
# the photo better than the same colours dealt out at random. Kim's frames pinned by first-order
# lines: 0.09–0.59; a colourful photo without a disc whose blobs' edges a curve was moved
# through: 0.00. (Lines of only higher orders put no first order on the tracks to judge.)
MIN_PINNED_CONTRAST = 0.05
MIN_VALID_BINS = 10  # λ₁ bins (5 nm each) a readout needs before a spectrum is worth solving for
# Of 400–700 nm the first order must show this much on the tracks: with less, the spectrum is
# mostly the prior's guess (a photo of 2nd–5th orders, a first order half in the infrared).
MIN_COVERAGE_NM = 150.0
MAX_SATURATED_SHARE = 0.9  # a photo clipped almost everywhere holds no rainbow to read
# The lamp's size σ sets the forward matrix's blur along λ₁ (d·σ: 5 nm at the presets' 0.003, 16 nm
# for a 0.01 bulb). Under a coaxial lamp over a level disc (cd-default) the lobe lights the whole
# disc, so σ shows only in that blur, and the pose fit's self-consistency cannot judge it: its free λ₁ profile takes up a line's
# width whatever σ is (:func:`..pose.fit._sized` judges the colour, which moves little). Synthetic
# cd-default photos (6 prior families × σ 0.001/0.006/0.01, dev sweep) kept σ 0.003 for 12 of 18,
# a tri-phosphor lamp of σ 0.01 reading MAE 0.35 (0.023 at the true σ). The readout's misfit does
# judge it: a spectrum blurred by the wrong σ cannot give the photo's colour at each λ₁ (a blurred
# line keeps its own colour off its centre); σ 9 % off left 3–4× the true σ's misfit. So σ is
# searched on that misfit here: kept where the fit's own σ explains the readout to SIZE_EXPLAINED ×
# its noise, else steps of SIZE_STEP (up to SIZE_RANGE) downhill to bracket the least, then a
# golden-section search to SIZE_TOLERANCE; taken where it leaves at most SIZE_MISFIT_GAIN of the
# fit's misfit. On those 18 photos σ 0.006 and 0.01 were then read within 2 %, σ 0.001 as
# 0.0007–0.001 (finer blur than the readout's: the misfit is flat there), and the MAE went 0.066 ->
# 0.020 (0.020 at the true pose); the six at σ 0.003 kept it (MAE 0.011 both). Only where the
# lobe lights every track pixel at any σ (a coaxial lamp over a level disc): elsewhere σ also
# chooses which pixels are read, so two sizes' misfits are not of one readout (a cd-default photo
# tilted 5° went to σ 0.0007 at a 0.12 misfit; tripod-oblique σ 0.01 photos to 0.0024, MAE 0.036
# -> 0.133), and the lobe's width there gives σ to the pose fit (σ 0.001–0.01 read within 4 % on
# 68 of 71 synthetic photos of phone-near-axis, tripod-oblique and phone-distant-lamp; a
# synthetic RGB LED up to 20 % off). Oblique presets are not tried at all (it would cost a read).
SIZE_STEP = 1.6
SIZE_RANGE = 4.5
# misfit / noise at the true σ: 1.1–3.2 (12 synthetic cd-default photos at 512 px), 3.6–4.6 (two at
# 768 px); with σ 9–11 % off 7–13
SIZE_EXPLAINED = 5.0
SIZE_TOLERANCE = 0.03  # the golden-section search stops at this width in log σ
SIZE_MISFIT_GAIN = 0.7
SIZE_SAME_PIXELS = 0.02  # a size whose lobe lights more or fewer readout pixels than this share reads another readout
SIZE_SMOOTHNESS = 1e-2 * SMOOTHNESS
# The forward matrix blurs each pixel's colour over the pixel's own footprint (and d·σ), not over
# more: where a JPEG's subsampled chroma is read finer than the file holds it (image.colour_px > 1:
# a 4:2:0 file at full size), every colour is spread over two pixels more than the readout's model
# has, which the search would read as a larger lamp. The slow test_joint_estimate photos (256 px
# 4:2:0 JPEGs, lamp σ 0.003, one pixel ≈ 10 nm of λ₁): at the true pose the misfit fell from 6.8
# at σ 0.003 to 3.0 at 0.006 (read 0.006, the joint brightness ratio off); the same frame as a
# 4:4:4 JPEG was least at 0.003–0.004 (2.0), as a PNG at 0.003 (0.5), and the 4:2:0 file decoded
# at half size (one chroma sample per pixel) at 0.003 (1.7). Such photos keep the pose fit's σ.
# An 8-bit photo whose rainbow peaks below this share of full scale (sRGB code ≈ 25) is mostly
# quantisation: at 0.5 % exposure the physics-only MAE rose from 0.004 to 0.13 (CIE A), and at
# 0.3 % the rainbow is no longer found (bench/reliability.md).
DIM_LEVEL_8BIT = 0.01

# The photo's brightest part for that test: this share of its usable pixels lies above it. A
# rainbow may cover a few hundred pixels of a megapixel (the demo photo read with the wrong
# preset: 99.5th percentile 0.003, told "very dark" although its rainbow peaks at 0.8).
BRIGHTEST_SHARE = 1e-4


def brightest_level(rgb: NDArray[np.float64], excluded: NDArray[np.bool_]) -> float:
    """The level BRIGHTEST_SHARE of the usable (not clipped, valid) pixels' channels reach."""
    usable = rgb[~np.asarray(excluded)]
    if usable.size == 0:
        return 0.0
    return float(np.quantile(usable, 1.0 - BRIGHTEST_SHARE))


__all__ = ["Posed", "Reading", "Spectrum", "pose_photo", "read_posed", "read_photo", "spectrum", "joint_spectrum",
           "network_estimate", "network_say", "fuse", "OPERATING_POINTS", "model_prior", "fusion_settings", "band_weight", "fuse_rows",
           "tail_settings", "tailed",
           "focal_px_for", "focal_px_of", "focal_px_options", "EXIF_FOCAL_AGREEMENT", "physics_spd", "network_inputs",
           "covered_nm", "focal_px_from_photo",
           "series_focal_px", "profile_residual", "relative_noise", "sized_by_readout", "MIN_RAINBOW_CONTRAST", "MIN_COVERAGE_NM", "MAX_SATURATED_SHARE", "DIM_LEVEL_8BIT"]


@dataclass
class Posed:
    """A photo after the pose stage: what the readout needs, in the photo's loaded pixels."""

    image: LinearImage
    preset: Preset
    camera: CameraProfile  # the sensitivities solved with (collapsed to grey for a greyscale photo)
    generic_camera: bool
    calibration: Calibration | None
    rgb: NDArray[np.float64]  # camera-native linear RGB (a calibration's in-camera processing undone)
    excluded: NDArray[np.bool_]  # clipped or not-a-number pixels
    clipped_share: float
    focal_px: float
    focal_source: str  # "exif", "exif-35mm", "outline", "series outline", "preset" or "given"
    fit: PoseFit
    timing_ms: dict[str, float] = field(default_factory=dict)
    # A calibrated in-camera file: its linear display RGB (tone curve undone, matrix not) and
    # the channels it clipped (low, high), which the readout reads as bounds.
    display: NDArray[np.float64] | None = None
    clipped: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None
    # The readout at ``fit`` where the pose stage already read it (the lamp-size search):
    # read_posed gives it back rather than reading again (only for this very fit and photo).
    reading: Reading | None = field(default=None, repr=False, compare=False)


@dataclass
class Reading:
    """Everything the solve needs about one photo: its pose and its readout with the forward matrix."""

    posed: Posed
    scene: Scene
    readout: Readout  # after the calibration's gains, when there is one
    uncalibrated: Readout  # as measured (what a calibration shot fits its gains to)
    response: NDArray[np.float64]  # R[bin, λ] without the camera
    matrix: NDArray[np.float64]  # (NB, 3, 81) feature forward matrix with the solving camera
    ambient: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))  # offset removed per channel
    ambient_uneven: float = 0.0  # how much more that offset is on one half of the disc (ambient.dark_levels)
    timing_ms: dict[str, float] = field(default_factory=dict)

    @property
    def fit(self) -> PoseFit:
        return self.posed.fit

    @property
    def camera(self) -> CameraProfile:
        return self.posed.camera

    @property
    def generic_camera(self) -> bool:
        return self.posed.generic_camera

    @property
    def focal_px(self) -> float:
        return self.posed.focal_px

    @property
    def focal_source(self) -> str:
        return self.posed.focal_source

    @property
    def calibration(self) -> Calibration | None:
        return self.posed.calibration


def focal_px_for(image: LinearImage, preset: Preset) -> tuple[float, str]:
    """Focal length in loaded pixels and where it came from.

    EXIF FocalLength × FocalPlaneXResolution is exact for the sensor's pixels; the 35 mm
    equivalent assumes the long side spans 36 mm; otherwise the preset's field of view.
    """
    return focal_px_of(image.exif, image.rgb.shape[1], image.scale, image.displayed_size, preset)


def focal_px_of(exif: ExifInfo, width: int, scale: float, displayed_size: tuple[int, int],
                preset: Preset) -> tuple[float, str]:
    """:func:`focal_px_for` of an image ``width`` loaded pixels wide at ``scale`` original pixels
    per loaded one, from a photo of ``displayed_size``: known before the pixels are decoded."""
    found = _exif_focals(exif, scale, displayed_size)
    if found:
        return found[0]
    cam = preset.camera
    return cam.focal_length_mm / cam.sensor_width_mm * width, "preset"


# The EXIF's two focal lengths (FocalLength × FocalPlaneXResolution, in the sensor's pixels, and
# the 35 mm equivalent over the photo's long side) agree within this factor in a camera's own
# file (a 4:3 sensor's diagonal-based equivalent is 4 % off the long side's). Beyond it the photo
# was resized (the first is stale: an app that keeps the EXIF, a 1024 px copy of the sample photo
# read 2× its lens and no white light at all) or cropped (the second is) after it was taken.
EXIF_FOCAL_AGREEMENT = 1.15


def _exif_focals(exif: ExifInfo, scale: float, displayed_size: tuple[int, int]) -> list[tuple[float, str]]:
    """The EXIF's focal lengths in loaded pixels: the sensor's ("exif"), then the 35 mm
    equivalent's ("exif-35mm"), each where its tags hold a finite positive value."""
    out = []
    if exif.focal_length_mm and exif.focal_plane_px_per_mm:
        value = exif.focal_length_mm * exif.focal_plane_px_per_mm / scale
        if math.isfinite(value) and value > 0:
            out.append((value, "exif"))
    if exif.focal_length_35mm:
        value = exif.focal_length_35mm / 36.0 * max(displayed_size) / scale  # a window keeps the pitch
        if math.isfinite(value) and value > 0:
            out.append((value, "exif-35mm"))
    return out


def focal_px_options(image: LinearImage) -> list[tuple[float, str]]:
    """The EXIF's focal lengths where they disagree (see EXIF_FOCAL_AGREEMENT): the pose stage
    fits the photo with each and keeps the one that explains it. One or none where they agree."""
    found = _exif_focals(image.exif, image.scale, image.displayed_size)
    if len(found) == 2 and max(found[0][0], found[1][0]) > EXIF_FOCAL_AGREEMENT * min(found[0][0], found[1][0]):
        return found
    return found[:1]


# The outline's focal length is believed within this factor of the preset's lens (a phone's 26 mm
# against a 50 mm or a 13 mm lens); beyond it the outline found is not the disc's.
OUTLINE_FOCAL_RANGE = 3.0


def focal_px_from_photo(image: LinearImage, preset: Preset, preset_focal_px: float) -> tuple[float, str]:
    """A photo without a focal length in its EXIF (a GIF, a screenshot, a stripped file): from the
    disc's outline where it shows and the preset's camera distance ("outline"), else the preset's
    lens ("preset")."""
    rgb = np.asarray(image.rgb, dtype=np.float64)
    outline = disc_ellipse(rgb, np.asarray(image.saturated) | np.asarray(image.invalid))
    if outline is None:
        return preset_focal_px, "preset"
    try:
        focal = focal_px_from_outline(outline, preset.disc.rim_radius_mm, preset.camera.distance_mm,
                                      (rgb.shape[1], rgb.shape[0]))
    except ValueError:
        return preset_focal_px, "preset"
    if not (preset_focal_px / OUTLINE_FOCAL_RANGE <= focal <= preset_focal_px * OUTLINE_FOCAL_RANGE):
        return preset_focal_px, "preset"
    return focal, "outline"


def series_focal_px(images: Sequence[LinearImage], preset: Preset) -> float | None:
    """One focal length for photos taken with one lens and zoom (the frames of a GIF or a video,
    a burst) that carry none in their EXIF: the median of the disc outline's focal length over the
    frames where the outline shows (:func:`focal_px_from_photo`); None where it shows in none.
    A frame whose disc edge is dark against a dark table then borrows its neighbours' lens."""
    found = []
    for image in images:
        preset_focal, source = focal_px_for(image, preset)
        if source != "preset":
            continue
        focal, source = focal_px_from_photo(image, preset, preset_focal)
        if source == "outline":
            found.append(focal * image.scale)  # in the file's pixels: frames may load at other scales
    return float(np.median(found)) if found else None


def _with_gains(readout: Readout, calibration: Calibration | None) -> Readout:
    if calibration is None:
        return readout
    gains = calibration.gains
    return replace(readout, values=readout.values / gains, noise=readout.noise / gains)


def pose_photo(
    image: LinearImage,
    preset: Preset,
    camera: CameraProfile,
    *,
    generic_camera: bool = False,
    calibration: Calibration | None = None,
    focal_px: float | None = None,
    fit: PoseFit | None = None,
    series_focal: float | None = None,
    strategies: Sequence[str] = CHEAP,
    escalations: Sequence[str] = ESCALATIONS,
) -> Posed:
    """The pose stage (see the module doc). ``fit`` skips the pose fit (training reuses fits of
    its capture geometries; an evaluation injects pose errors); ``focal_px`` overrides EXIF;
    ``strategies``/``escalations`` name the pose fit's starts. Raises :class:`PhotoError` for a
    photo clipped almost everywhere."""
    t0 = time.perf_counter()
    clipped = float(np.mean(image.saturated))
    if clipped > MAX_SATURATED_SHARE:
        raise PhotoError(f"{image.path or 'the photo'}: over-exposed, {100 * clipped:.0f}% of the photo is clipped "
                         "at full scale — use a much shorter exposure (or dim the lamp)")
    if image.is_grey:
        camera = CameraProfile(camera.name, np.repeat(camera.sensitivities.sum(axis=1, keepdims=True) / 3.0, 3,
                                                      axis=1))
    source = "given"
    if focal_px is None:
        focal_px, source = focal_px_for(image, preset)
        if source == "preset" and series_focal is not None:
            focal_px, source = series_focal / image.scale, "series outline"
        elif source == "preset":
            focal_px, source = focal_px_from_photo(image, preset, focal_px)
    rgb = np.asarray(image.rgb, dtype=np.float64)
    display, clipped_masks = None, None
    if calibration is not None and calibration.pipeline is not None:
        # Undo the camera's tone curve, then its matrix (JPEG/HEIC); what it clipped stays a bound.
        display = calibration.pipeline.to_display(rgb)
        rgb = calibration.pipeline.display_to_native(display)
        clipped_masks = clipped_channels(image.rgb, image.saturated)
    excluded = np.asarray(image.saturated) | np.asarray(image.invalid)
    fitted = fit is None
    # the lamp's size on the readout (see SIZE_STEP); only on the camera's own colours: not with
    # the generic profile nor from a processed file, calibrated or not (their colour mismatch
    # reads as a blur: with it a two-shot calibration of synthetic in-camera JPEGs read a cool
    # lamp at 1.5× one shot's MAE, tests/test_calibration_shots.py), nor where a caller gave the
    # fit; nor where each pixel's colour is blurred beyond the pixel (see SIZE_SMOOTHNESS). There
    # the pose fit leaves its own judge of the size out (its colour blur moves little under a
    # coaxial lamp; 24 MP cd-default JPEG: 15 ms of its 130).
    by_readout = (fitted and near_axis(preset) and not generic_camera and not image.is_grey
                  and not image.processed and image.colour_px <= 1.0)
    # Nor does the pose fit judge a processed file's lamp size on its colour blur (fit_pose's
    # _sized, which takes another size only where it explains the photo clearly better): a
    # rendering's gamut clipping and saturation blur the rainbow's colours as a larger lamp does.
    # A held-out rendering (camera_renderings' `ordinary`, CIE A calibration, 192 px) read an LED
    # at σ 0.009 for the preset's 0.003 (blur 15 nm for 5), and the solve deconvolved that blur
    # into one-bin spikes: MAE 0.27, read 0.012 without the judge. On the calibration's own
    # family of renderings (training/simulation/camera_pipelines.py, the typical and a sampled
    # one, 10 lamps each) nothing moved; holding σ in the coarse fit as well made them worse
    # (0.020 -> 0.023, 0.032 -> 0.033), so only the judge is left out.
    judge_size = not by_readout and not image.processed
    if fit is None:
        offset = rough_offset(rgb, excluded)
        linear = rgb - offset if np.any(offset != 0.0) else rgb  # a dark room's photo: no copy
        fit = fit_pose(linear, preset, focal_px, sensitivities=camera.sensitivities,
                       saturated=excluded, strategies=strategies, escalations=escalations,
                       own_colours=not generic_camera, judge_size=judge_size)
        options = focal_px_options(image) if source.startswith("exif") else []
        if len(options) > 1:
            # resized or cropped after it was taken: the focal length that explains the photo
            for other, other_source in options:
                if other == focal_px:
                    continue
                alt = fit_pose(linear, preset, other, sensitivities=camera.sensitivities, saturated=excluded,
                               strategies=strategies, escalations=escalations, own_colours=not generic_camera,
                               judge_size=judge_size)
                if alt.residual < fit.residual:
                    fit, focal_px, source = alt, other, other_source
            source = {"exif": "exif, cropped", "exif-35mm": "exif-35mm, resized"}[source]
    posed = Posed(image=image, preset=preset, camera=camera, generic_camera=generic_camera, calibration=calibration,
                  rgb=rgb, excluded=excluded, clipped_share=clipped, focal_px=float(focal_px), focal_source=source,
                  fit=fit, display=display, clipped=clipped_masks)
    if by_readout:
        # The readout read at the kept size goes with the fit, so that read_posed does not read it again.
        fit, reading = sized_by_readout(posed)
        posed = replace(posed, fit=fit, reading=reading)
    posed.timing_ms["pose"] = (time.perf_counter() - t0) * 1e3
    return posed


def profile_residual(readout: Readout, matrix: NDArray[np.float64], spd: NDArray[np.float64]) -> float:
    """How far ``spd``, at the brightness that fits best, is from reproducing the photo's
    features: RMS over the valid features relative to the largest (1 where none is valid)."""
    valid = readout.valid
    if not np.any(valid):
        return 1.0
    p, m = np.einsum("bcl,l->bc", matrix, spd)[valid], readout.values[valid]
    scale = float(np.sum(p * m) / max(np.sum(p * p), 1e-300))
    return float(np.sqrt(np.mean((scale * p - m) ** 2)) / max(float(np.max(np.abs(m))), 1e-300))


def relative_noise(readout: Readout) -> float:
    """RMS noise of the valid features relative to the largest, the scale of
    :func:`profile_residual` (0 where none is valid): how much misfit the noise alone explains."""
    valid = readout.valid
    if not np.any(valid):
        return 0.0
    top = max(float(np.max(np.abs(readout.values[valid]))), 1e-300)
    return float(np.sqrt(np.mean(readout.noise[valid] ** 2))) / top


def _with_size(posed: Posed, sigma: float) -> PoseFit:
    """The posed photo's fit with the lamp of size ``sigma`` (the same disc, camera and lamp)."""
    fit = posed.fit
    height, width = posed.rgb.shape[:2]
    scene = fit.scene(posed.preset, (width, height))
    light = replace(scene.preset.light, lobe_sigma=float(sigma))
    return replace(fit, lobe_sigma=float(sigma), known_scene=Scene(replace(scene.preset, light=light), scene.pose))


def _lit_pixels(scene: Scene) -> int:
    """How many pixels the readout would read in ``scene``: on the tracks, lit by the lobe to
    MIN_VISIBILITY, λ₁ on the feature grid."""
    px = readout_pixels(scene).pixels
    b = feature_bins(px.lambda1_nm)
    return int(np.sum(px.on_tracks & (px.visibility >= MIN_VISIBILITY) & (b >= 0) & (b < N_FEATURES)))


def sized_by_readout(posed: Posed) -> tuple[PoseFit, Reading | None]:
    """The posed photo's fit with the lamp size whose forward matrix lets a spectrum explain the
    readout best (see SIZE_STEP), and the reading at that fit (None where it was refused); the
    fit itself where its own size explains the readout to SIZE_EXPLAINED × its noise, where the
    lobe does not light the same pixels at every size tried, or where no size beats its own by
    SIZE_MISFIT_GAIN.

    Every size is judged on the one readout read at the fit's own σ, only the forward matrix
    redone: where the lobe lights the same pixels, another σ's readout differs only by the lobe's
    weights (two synthetic cd-default photos, σ 0.0015–0.02: misfit within 0.1 of each size's own
    readout's, 2.15 against 2.10 at the least). The lit pixels are counted at the walk's steps
    only: the golden section lies between two of them, and the lit area grows with σ. On the
    tests/test_lamp_size.py photos (384 and 512 px, σ 0.001–0.01) the same σ to 0.7 % in 0.55–0.70
    s where each size read its own readout took 0.91–1.09 s."""
    x0, step = math.log(posed.fit.lobe_sigma), math.log(SIZE_STEP)
    try:
        reading0 = read_posed(replace(posed, reading=None))
    except NoDiscError:
        return posed.fit, None
    readout = reading0.readout
    valid = readout.valid
    if not np.any(valid):
        return posed.fit, reading0
    noise = max(relative_noise(readout), 1e-12)
    height, width = posed.rgb.shape[:2]

    def misfit(matrix: NDArray[np.float64]) -> float:
        """The readout's misfit by the spectrum that explains it best through ``matrix``, in units of
        its noise. The solve is barely smoothed: the smoothness a full solve asks for is taken up
        by a smaller σ (a synthetic tri-phosphor lamp of σ 0.003 read least at 0.0026, of σ 0.01
        at 0.0095)."""
        spd = physics_solve(readout, matrix, smoothness=SIZE_SMOOTHNESS)
        return profile_residual(readout, matrix, spd) / noise

    m0 = misfit(reading0.matrix)
    if m0 <= SIZE_EXPLAINED:
        return posed.fit, reading0
    n0 = _lit_pixels(reading0.scene)
    tried = {x0: m0}  # log σ → misfit

    def same(x: float, count: bool = True) -> bool:
        """Tries log σ ``x``; False where that size's lobe lights other pixels than the fit's."""
        scene = _with_size(posed, math.exp(x)).scene(posed.preset, (width, height))
        tried[x] = misfit(feature_matrix(bin_response(scene, readout), posed.camera))
        return not count or abs(_lit_pixels(scene) - n0) <= SIZE_SAME_PIXELS * n0

    steps = {0: x0}  # the walk's sizes by step
    for k in (-1, 1):
        steps[k] = x0 + k * step
        if not same(steps[k]):
            return posed.fit, reading0
    way = 1 if tried[steps[1]] < tried[steps[-1]] else -1
    k, last = way, int(math.floor(math.log(SIZE_RANGE) / step))
    while tried[steps[k]] < tried[steps[k - way]] and abs(k) < last:  # downhill, to the range's end
        steps[k + way] = x0 + (k + way) * step
        if not same(steps[k + way]):
            return posed.fit, reading0
        k += way
    least = min(steps, key=lambda j: tried[steps[j]])
    if least - 1 in steps or least + 1 in steps:
        # golden-section search between the least misfit's neighbours: the misfit is a narrow V
        # in σ (σ 9 % off: 3–4× the true σ's), too sharp and lopsided for a parabola's vertex. At
        # the range's end, between it and the step before (a σ 0.01 lamp fitted at 0.003 walked
        # to the end, 0.0123, and read MAE 0.10 there, 0.03 searched).
        lo, hi = steps.get(least - 1, steps[least]), steps.get(least + 1, steps[least])
        ratio = (math.sqrt(5.0) - 1.0) / 2.0
        c, d = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        same(c, count=False)
        same(d, count=False)
        while hi - lo > SIZE_TOLERANCE:
            if tried[c] < tried[d]:
                hi, d = d, c
                c = hi - ratio * (hi - lo)
                x = c
            else:
                lo, c = c, d
                d = lo + ratio * (hi - lo)
                x = d
            same(x, count=False)
    at = min(tried, key=lambda v: tried[v])
    if at == x0 or tried[at] > SIZE_MISFIT_GAIN * m0:
        return posed.fit, reading0
    fit = _with_size(posed, math.exp(at))
    try:  # the kept size's own readout, for read_posed to give back
        return fit, read_posed(replace(posed, fit=fit, reading=None))
    except NoDiscError:
        return fit, None


def rainbow_found(fit: PoseFit) -> bool:
    """The fitted capture shows a CD's rainbow: explained by it (MIN_RAINBOW_CONTRAST), or its
    thin lines pinned it and hold a first order that explains the photo (MIN_PINNED_CONTRAST) or
    only higher orders (then the refusal says so)."""
    if fit.rainbow_contrast >= MIN_RAINBOW_CONTRAST:
        return True
    return fit.lines_pinned and (fit.rainbow_contrast >= MIN_PINNED_CONTRAST or 1 not in fit.line_orders)


def covered_nm(readout: Readout) -> list[tuple[float, float]]:
    """The stretches of 400–700 nm that first-order pixels on the tracks show, clipped or not
    (bin edges, nm)."""
    step = float(readout.lambda_nm[1] - readout.lambda_nm[0])
    # A clipped bin is held too: the first order lands there, and over-exposure has its own warning.
    held = (readout.weight > 0) | (readout.saturated_fraction > 0)
    seen = held & (readout.lambda_nm >= VISIBLE_NM[0]) & (readout.lambda_nm <= VISIBLE_NM[1])
    out: list[tuple[float, float]] = []
    for lam in readout.lambda_nm[seen]:
        lo, hi = max(float(lam) - step / 2, VISIBLE_NM[0]), min(float(lam) + step / 2, VISIBLE_NM[1])
        if out and lo <= out[-1][1] + 1e-6:
            out[-1] = (out[-1][0], hi)
        else:
            out.append((lo, hi))
    return out


def _processed_hint(posed: Posed) -> str:
    """For a camera-processed file read without a calibration of its processing (or with one that
    cannot explain its own photo), why the geometry advice of a refusal may be wrong: the fit places
    the wavelengths by the rainbow's colours, which the camera's white balance, matrix and curve
    move. Empty otherwise. (A phone's D65 JPEG was told its lamp stood 61 mm off; a phone's photos
    through a real camera's rendering — the Canon D30's, bench/camera_files.md — were refused with
    advice to move the lamp closer, the set-up being the preset's.)"""
    image, cal = posed.image, posed.calibration
    if not image.processed:
        return ""
    if cal is None or cal.pipeline is None:
        return ("a camera-processed file — JPEG, HEIC, GIF — read without a calibration of its processing: its "
                "colours can mislead the fit and the advice — calibrate with a photo of a known lamp taken the same "
                "way, or shoot RAW")
    if calibration_warning(cal) is not None:
        return (f"a camera-processed file read with calibration {cal.name!r}, which cannot explain the processing of "
                "its own photo: the colours can mislead the fit and the advice — shoot RAW, or fix the white balance, "
                "turn off picture styles and calibrate again")
    return ""


def _coverage_refusal(name: str, fit: PoseFit, stretches: list[tuple[float, float]], advice: str,
                      needed_nm: float = MIN_COVERAGE_NM) -> str:
    """The message for a photo whose rainbow is found but shows too little of 400–700 nm."""
    total = sum(b - a for a, b in stretches)
    held = ("only " + ", ".join(f"{a:.0f}–{b:.0f} nm" for a, b in stretches)) if stretches else "none of 400–700 nm"
    seen = ""
    if fit.line_orders and 1 not in fit.line_orders:
        seen = f"; its lines are the disc's {_ordinals(fit.line_orders)} order{'s' if len(fit.line_orders) > 1 else ''}"
    needs = (f"a reading needs {needed_nm:.0f} nm" if needed_nm >= MIN_COVERAGE_NM else
             f"a photo of a joint estimate needs {needed_nm:.0f} nm")
    return (f"{name}: the rainbow is found but its first order on the disc's tracks holds {held} "
            f"({total:.0f} nm; {needs} of 400–700){seen} — {advice}")


def _ordinals(orders: Sequence[int]) -> str:
    names = {1: "1st", 2: "2nd", 3: "3rd"}
    words = [names.get(m, f"{m}th") for m in orders]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def read_posed(posed: Posed, pixels: PixelDiffraction | None = None,
               min_coverage_nm: float = MIN_COVERAGE_NM,
               known_spd: NDArray[np.float64] | None = None) -> Reading:
    """The readout stage (see the module doc). ``pixels`` are the fitted scene's per-pixel
    diffraction coordinates when the caller already has them (a cache: they depend on the scene
    alone); ``known_spd``, the lamp when it is known (a calibration shot: clipped channels are
    resolved against it). Raises :class:`NoDiscError` where no CD rainbow is found, or where its
    first order holds less than ``min_coverage_nm`` of 400–700 nm, saying what to move. A joint
    estimate lowers that: another photo supplies the rest (:mod:`.joint`)."""
    t1 = time.perf_counter()
    cached = posed.reading
    if (cached is not None and pixels is None and known_spd is None and min_coverage_nm == MIN_COVERAGE_NM
            and cached.posed.fit is posed.fit and cached.posed.rgb is posed.rgb
            and cached.posed.excluded is posed.excluded and cached.posed.camera is posed.camera
            and cached.posed.calibration is posed.calibration and cached.posed.display is posed.display):
        return replace(cached, posed=posed, timing_ms={**posed.timing_ms, **{
            k: v for k, v in cached.timing_ms.items() if k in ("readout", "forward")}})
    image, rgb, excluded, fit = posed.image, posed.rgb, posed.excluded, posed.fit
    height, width, _ = rgb.shape
    scene = fit.scene(posed.preset, (width, height))
    # Without a cache, the kernel is evaluated only where the lobe can be visible or the dark
    # is uncertain: the same readout and offset as from every pixel (tests/test_pixel_survey.py).
    lobe: PixelDiffraction | LobePixels = readout_pixels(scene) if pixels is None else pixels
    ambient, uneven = dark_levels(rgb, scene, excluded, lobe)
    per_pixel = lobe.pixels if isinstance(lobe, LobePixels) else lobe
    response = None
    if posed.display is not None and posed.calibration is not None and posed.calibration.pipeline is not None:
        measured, response = _censored_readout(posed, scene, per_pixel, ambient, known_spd)
    else:
        measured = extract_readout(rgb - ambient if np.any(ambient) else rgb, excluded, scene, per_pixel)
    t2 = time.perf_counter()
    response = bin_response(scene, measured) if response is None else response
    matrix = feature_matrix(response, posed.camera)
    gains = None if posed.calibration is None else posed.calibration.gains[..., None]
    measured = dark_edges_dropped(measured, matrix if gains is None else matrix * gains, known_spd)
    readout = _with_gains(measured, posed.calibration)
    found = rainbow_found(fit)
    stretches = covered_nm(measured)
    # Thin lines on the fitted capture's curves are a disc's diffraction orders even where they
    # explain little of a dark photo (Kim's DVD frames 9–13: 0.6–0.8 px off, "no CD rainbow found"):
    # a photo that shows them is told what its first order holds, not that there is no rainbow.
    seen = found or on_curve(fit.line_share, fit.line_offset_px)
    if seen and sum(b - a for a, b in stretches) < min_coverage_nm:
        name = Path(image.path).name or "the photo"
        advice, caution = coverage_advice(posed.preset, scene), _processed_hint(posed)
        if caution:  # after the geometry advice, which is right where the colours are
            advice = f"{advice} — unless the colours misled the fit: {caution}"
        raise NoDiscError(_coverage_refusal(name, fit, stretches, advice, min_coverage_nm))
    if int(np.sum(readout.valid)) < MIN_VALID_BINS or not found:
        name = Path(image.path).name or "the photo"
        hint = ""
        if posed.clipped_share > 0.2:
            hint = f" ({100 * posed.clipped_share:.0f}% of the photo is clipped: try a shorter exposure)"
        elif image.encoding.endswith("-8") and brightest_level(rgb, excluded) < DIM_LEVEL_8BIT:
            hint = " (the photo is very dark: try a longer exposure)"
        elif caution := _processed_hint(posed):
            hint = f" ({caution})"
        advice = advice_for_photo(posed.preset, scene, found, rgb, excluded,
                                  posed.focal_px)
        raise NoDiscError(f"no CD rainbow found in {name}{hint}: {advice}")
    t3 = time.perf_counter()
    return Reading(posed=posed, scene=scene, readout=readout, uncalibrated=measured, response=response,
                   matrix=matrix, ambient=ambient, ambient_uneven=uneven,
                   timing_ms={**posed.timing_ms, "readout": (t2 - t1) * 1e3, "forward": (t3 - t2) * 1e3})


def _censored_readout(posed: Posed, scene: Scene, pixels: PixelDiffraction, ambient: NDArray[np.float64],
                      known_spd: NDArray[np.float64] | None) -> tuple[Readout, NDArray[np.float64]]:
    """A calibrated in-camera file's native readout, read in its display space with clipped
    channels as bounds (:mod:`..calibration.censoring`), and its bin response."""
    pipeline = posed.calibration.pipeline  # type: ignore[union-attr]
    display = posed.display - ambient @ pipeline.matrix.T if np.any(ambient) else posed.display
    measured = extract_readout(display, posed.image.invalid, scene, pixels, clipped=posed.clipped)
    response = bin_response(scene, measured)
    gains = posed.calibration.gains  # type: ignore[union-attr]
    return uncensor(measured, pipeline.matrix, feature_matrix(response, posed.camera), gains, known_spd,
                    compressed=pipeline.gamut == "compress"), response


def read_photo(image: LinearImage, preset: Preset, camera: CameraProfile, *,
               pixels: PixelDiffraction | None = None, known_spd: NDArray[np.float64] | None = None,
               **pose_options: Any) -> Reading:
    """Pose and readout stages in one call (``pose_options``: those of :func:`pose_photo`)."""
    return read_posed(pose_photo(image, preset, camera, **pose_options), pixels, known_spd=known_spd)


def physics_spd(reading: Reading, prior: tuple[GaussianPrior, NDArray[np.float64]] | None) -> NDArray[np.float64]:
    """The physics solve in the photo's units: under the Gaussian prior (with its precision
    matrix) when given, else smoothness-regularised only. The network's input: without the
    estimate's line pass (:data:`LINE_ALLOWANCE`), as the network was trained."""
    if prior is not None:
        return prior_solve(reading.readout, reading.matrix, prior[0], precision=prior[1])
    return physics_solve(reading.readout, reading.matrix)


def network_inputs(reading: Reading, physics: NDArray[np.float64]) -> NDArray[np.float32]:
    """The learned model's input vector for this photo (layout: :data:`..spectrum.model.INPUT_LAYOUT`)."""
    return model_inputs(reading.readout, reading.camera.sensitivities, physics,
                        reading.scene.preset.light.lobe_sigma, reading.generic_camera, reading.fit.residual)


# --------------------------------------------------------------------------- the spectrum stage

@dataclass(frozen=True)
class Spectrum:
    """An operating point's answer: the SPD (peak 1, finite, non-negative), its uncertainty
    (NaN where the operating point gives none), the physics solve it started from (peak 1), and
    for several photos each one's brightness relative to the reference photo (0: no say)."""

    spd: NDArray[np.float64]
    std: NDArray[np.float64]
    physics: NDArray[np.float64]
    fallback: bool = False  # the network gave nothing usable: the physics solve is shown
    scales: NDArray[np.float64] = field(default_factory=lambda: np.ones(1))  # each photo's fitted brightness
    solved: JointSolve | None = None  # the physics solve behind it (its rows, reference photo, rounds)


def model_prior(model: SpectralModel | None) -> tuple[GaussianPrior, NDArray[np.float64]] | None:
    """The Gaussian prior (and its precision) that comes with ``model``, cached on it."""
    if model is None or "prior" not in model.metadata:
        return None
    cached = model.metadata.get("_prior_cache")
    if cached is None:
        p = model.metadata["prior"]
        prior = GaussianPrior(np.asarray(p["mean"]), np.asarray(p["covariance"]))
        cached = (prior, prior.precision())
        model.metadata["_prior_cache"] = cached
    return cached


def fusion_settings(model: SpectralModel, calibrated: bool = False) -> tuple[float, float]:
    """(strength, floor) of the final solve, chosen on synthetic photos when the model was built:
    a calibrated photo's camera is known better, so it may trust the photo more."""
    f = model.metadata.get("fusion") or {}
    if calibrated and "calibrated_strength" in f:
        return float(f["calibrated_strength"]), float(f.get("calibrated_floor", 0.05))
    return float(f.get("strength", 0.0)), float(f.get("floor", 0.05))


def band_weight(model: SpectralModel, calibrated: bool = False) -> NDArray[np.float64] | None:
    """w(λ) of the network against physics + prior (1 = network), chosen per band on synthetic
    photos when the model was built; None (the network everywhere) for a model without one."""
    f = model.metadata.get("fusion") or {}
    w = f.get("calibrated_band_weight") if calibrated and "calibrated_band_weight" in f else f.get("band_weight")
    return None if w is None else np.asarray(w, dtype=np.float64)


def tail_settings(model: SpectralModel | None) -> TailSettings | None:
    """When the blind tails follow a Planck curve (:mod:`..spectrum.tails`), chosen on synthetic
    spectra when the model was built; None (the solve's own tails) for a model without one."""
    return None if model is None else TailSettings.from_metadata(model.metadata.get("tails"))


def tailed(spd: NDArray[np.float64], std: NDArray[np.float64], rows: Rows, settings: TailSettings | None
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``spd`` with the blind tails of :func:`..spectrum.tails.with_tails` and ``std`` widened
    beyond the camera (peak 1); both unchanged without settings."""
    if settings is None:
        return spd, std
    out, planck_tail, _, thermal = with_tails(spd, rows, settings)
    return out, widen_std(std, out, planck_tail, thermal)


def fuse(reading: Reading, physics: NDArray[np.float64], net: NDArray[np.float64], std: NDArray[np.float64],
         strength: float, floor: float, weight: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """The model operating point's final SPD from its parts: the network's SPD (and uncertainty)
    fused with the photo's features, then blended per band with physics + prior by ``weight``.
    Fusion tuning calls this with candidate settings; the estimator with the model's own."""
    return fuse_rows(rows_for(reading.readout, reading.matrix), physics, net, std, strength, floor, weight)


def fuse_rows(rows: Rows, physics: NDArray[np.float64], net: NDArray[np.float64], std: NDArray[np.float64],
              strength: float, floor: float, weight: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """:func:`fuse` against weighted rows: one photo's, or several photos' stacked (a joint estimate)."""
    spd = solve_fused(rows, net, std, strength, floor) if strength > 0 else net
    if weight is not None and np.any(weight < 1.0):
        spd = blend_bands(rows, spd, physics, weight)
    return spd


def _finished(spd: NDArray[np.float64], std: NDArray[np.float64], physics: NDArray[np.float64],
              solved: JointSolve) -> Spectrum:
    spd = np.nan_to_num(np.clip(spd, 0.0, None), nan=0.0, posinf=0.0)
    fallback = not spd.max() > 0  # nothing usable (all zero, negative or NaN)
    if fallback:
        spd = physics
    return Spectrum(spd=spd / spd.max(), std=np.nan_to_num(std, nan=0.25, posinf=1.0), physics=physics,
                    fallback=fallback, scales=solved.scales, solved=solved)


def _joint(readings: Sequence[Reading], prior: tuple[GaussianPrior, NDArray[np.float64]] | None,
           weights: Sequence[float] | None) -> JointSolve:
    """The physics solve of every reading at once (:func:`physics_spd` for one), with each
    photo's brightness; raises where no photo holds a usable rainbow signal."""
    floors = edge_floors([r.readout.valid for r in readings])
    photos = [rows_for(r.readout, r.matrix, floor=f) for r, f in zip(readings, floors)]
    if prior is None:
        solve: Callable[[Rows], NDArray[np.float64]] = solve_physics
    else:
        strength = PRIOR_STRENGTH * photo_count(photos, weights)

        def solve(rows: Rows) -> NDArray[np.float64]:
            return solve_prior(rows, prior[0], strength, precision=prior[1], lines=LINE_ALLOWANCE)
    solved = joint_solve(photos, solve, weights)
    if not np.any(solved.spd > 0):
        which = "the photo holds" if len(readings) == 1 else "none of the photos holds"
        raise PhotoError(f"{which} no usable rainbow signal (is the lamp on and the disc lit?)")
    return solved


def photo_count(photos: Sequence[Rows], weights: Sequence[float] | None) -> float:
    """How many photos' worth of features the solve holds (their weights' sum): the priors are
    weighed against one photo's worth. Their strengths were chosen for one photo, whose errors
    are mostly the forward model's rather than noise; two photos of one set-up share those, so
    a prior of fixed strength would count for half as much against them. On synthetic pairs
    of one set-up at two exposures, a fixed strength made the joint estimate worse than either
    photo alone (MAE 400–700 0.049 against 0.044 / 0.047, 24 spectra); with it, a photo given
    twice gives exactly its own estimate."""
    return float(sum(1.0 if weights is None else float(weights[k]) for k, rows in enumerate(photos)
                     if usable(rows) and (weights is None or weights[k] > 0)))


def _physics_point(readings: Sequence[Reading], model: SpectralModel | None, calibrated: bool,
                   fusion: tuple[float, float] | None, weights: Sequence[float] | None) -> Spectrum:
    return _solved(readings, None, weights)


def _prior_point(readings: Sequence[Reading], model: SpectralModel | None, calibrated: bool,
                 fusion: tuple[float, float] | None, weights: Sequence[float] | None) -> Spectrum:
    return _solved(readings, model_prior(model), weights, tail_settings(model))


def _solved(readings: Sequence[Reading], prior: tuple[GaussianPrior, NDArray[np.float64]] | None,
            weights: Sequence[float] | None, tails: TailSettings | None = None) -> Spectrum:
    solved = _joint(readings, prior, weights)
    e = solved.spd / solved.spd.max()
    spd, std = tailed(e, np.full(e.shape, np.nan), solved.rows, tails)
    return _finished(spd, std, e, solved)


def network_estimate(readings: Sequence[Reading], model: SpectralModel, weights: Sequence[float] | None = None
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The network's SPD and uncertainty for the lamp: per photo (the network reads one photo's
    features), then, for several, their per-wavelength average weighted by 1/std² (and by
    ``weights``).

    The uncertainty is, per wavelength, the smallest of the photos' std/√weight. The photos
    show the same lamp to the same network, so its errors are shared rather than independent:
    not shrunk by √(number of photos). Nor may a photo that sees a band poorly make the joint
    less sure there than the photo that sees it well (a quadrature or harmonic mean did: on the
    150 + 300 mm pair of tests/test_joint_estimate.py, 620–700 nm read 0.049 jointly against
    0.038 from the 150 mm photo, which alone sees the red). A photo given less say counts as
    that much less sure."""
    prior = model_prior(model)
    nets, stds, say = [], [], []
    for k, reading in enumerate(readings):
        w = 1.0 if weights is None else float(weights[k])
        e = physics_spd(reading, prior) if w > 0 else np.zeros(1)
        if np.any(e > 0):
            net, std = model.predict(network_inputs(reading, e))
            nets.append(net)
            stds.append(std)
            say.append(w)
    if len(nets) == 1:
        return nets[0], stds[0]
    if not nets:
        raise PhotoError("none of the photos holds a usable rainbow signal (is the lamp on and the disc lit?)")
    net_arr = np.clip(np.nan_to_num(np.asarray(nets, dtype=np.float64), nan=0.0, posinf=0.0), 0.0, None)
    peak = net_arr.max(axis=1, keepdims=True)
    net_arr = np.divide(net_arr, peak, out=np.zeros_like(net_arr), where=peak > 0)
    std_arr = np.asarray(stds, dtype=np.float64) / np.where(peak > 0, peak, 1.0)  # in each SPD's own units
    std_arr = np.maximum(np.nan_to_num(std_arr, nan=1.0, posinf=1.0), 1e-6)
    say_arr = np.maximum(np.asarray(say, dtype=np.float64), 1e-12)[:, None]
    inv = say_arr / std_arr ** 2
    return (inv * net_arr).sum(axis=0) / inv.sum(axis=0), np.min(std_arr / np.sqrt(say_arr), axis=0)


def network_say(readings: Sequence[Reading], weights: Sequence[float] | None) -> list[float]:
    """Each photo's say in the network's answer: its weight where its first order holds a
    reading's worth of 400–700 nm (:data:`MIN_COVERAGE_NM`), else none - to the network such a
    photo is mostly the prior's guess, as it is to a reading of its own, though its features are
    sound data for the joint solve (:mod:`.joint` reads such photos for their stretch only). On
    a rendered pair, the 300 mm photo (400–612 nm) with a 125 mm one that holds only 578–700 nm:
    MAE 0.108 with the short photo's network answer averaged in, 0.015 under the prior alone.
    Every photo keeps its say where none holds that much."""
    say = [1.0 if weights is None else float(weights[k]) for k in range(len(readings))]
    full = [w if sum(b - a for a, b in covered_nm(r.uncalibrated)) >= MIN_COVERAGE_NM else 0.0
            for r, w in zip(readings, say)]
    return full if any(w > 0 for w in full) else say


def _model_point(readings: Sequence[Reading], model: SpectralModel | None, calibrated: bool,
                 fusion: tuple[float, float] | None, weights: Sequence[float] | None) -> Spectrum:
    if model is None:
        return _prior_point(readings, model, calibrated, fusion, weights)
    solved = _joint(readings, model_prior(model), weights)
    e = solved.spd
    net, std = network_estimate(readings, model, network_say(readings, weights))
    strength, floor = fusion or fusion_settings(model, calibrated)
    strength *= photo_count([rows_for(r.readout, r.matrix) for r in readings], weights)
    spd = fuse_rows(solved.rows, e, net, std, strength, floor, band_weight(model, calibrated))
    spd, std = tailed(spd, std, solved.rows, tail_settings(model))
    return _finished(spd, std, e / e.max(), solved)


OperatingPoint = Callable[[Sequence[Reading], "SpectralModel | None", bool, "tuple[float, float] | None",
                           "Sequence[float] | None"], Spectrum]
# The benchmark's operating points, by the names estimates report (METHOD_* in .result). Each
# takes the readings of one or several photos of the same lamp: one photo is the one-photo case.
OPERATING_POINTS: dict[str, OperatingPoint] = {
    METHOD_PHYSICS: _physics_point,  # smoothness-regularised physics only
    METHOD_PRIOR: _prior_point,  # physics under the synthetic Gaussian prior
    METHOD_MODEL: _model_point,  # physics + prior, the network, their fusion and per-band blend (the product)
}


def spectrum(reading: Reading, method: str, model: SpectralModel | None,
             fusion: tuple[float, float] | None = None) -> Spectrum:
    """The spectrum stage: the operating point ``method`` (see :data:`OPERATING_POINTS`).
    ``fusion`` overrides the model's (strength, floor)."""
    return joint_spectrum([reading], method, model, fusion)


def joint_spectrum(readings: Sequence[Reading], method: str, model: SpectralModel | None,
                   fusion: tuple[float, float] | None = None, weights: Sequence[float] | None = None) -> Spectrum:
    """The spectrum stage for several photos of the same lamp (:mod:`..spectrum.joint`): one SPD,
    each photo at its own fitted brightness (``Spectrum.scales``); ``weights`` scale each photo's
    say. One photo gives exactly :func:`spectrum`."""
    point = OPERATING_POINTS.get(method)
    if point is None:
        raise CDSpectraError(f"unknown method {method!r}; known: {', '.join(OPERATING_POINTS)}")
    if not readings:
        raise CDSpectraError("no photo to estimate from")
    calibrated = any(r.calibration is not None for r in readings)
    return point(readings, model, calibrated, fusion, weights)
