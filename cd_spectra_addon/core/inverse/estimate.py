"""Photo → SPD: the whole inverse, with the reasons a result should or should not be trusted.

1. load and linearise (:mod:`.images`), focal length in pixels from EXIF or the preset;
2. capture geometry and the λ₁ readout (:mod:`.analysis`), optional calibration gains;
3. physics: a non-negative MAP solve against the forward matrix under the synthetic prior;
4. the learned model (:mod:`.model`) refines it into the final SPD and its uncertainty;
5. confidence from what could go wrong — clipping, missing bins, a geometry the fit could not
   explain, an SPD that does not reproduce the photo — each with a plain-language warning;
6. colour: xy, CCT, Duv and the emission colour in the scene's working space (:mod:`.colour`);
7. colour rendition (CIE 13.3 Ra, R1–R14; TM-30 Rf, Rg, hue bins; peak and dominant wavelength),
   each with a 90 % range drawn from the SPD's uncertainty (:mod:`..rendition.result`) — skipped
   when the caller asks for spectra only.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..rendition.result import rendition as rendition_figures
from ..spectra import colour
from ..spectra.colour import DEFAULT_WORKING_SPACE
from .stages import (BRIGHTEST_SHARE, DIM_LEVEL_8BIT, profile_residual, relative_noise, MIN_COVERAGE_NM, OPERATING_POINTS, Reading, Spectrum, pose_photo, read_posed,
                     spectrum)
from ..calibration.calibration import (POOR_CALIBRATION_CONFIDENCE, Calibration, calibration_check,
                                       calibration_warning, load_calibration)
from ..calibration.camera_fit import CameraPrior, camera_prior
from ..spectra.cameras import DEFAULT_CAMERA, GENERIC_CAMERA, CameraProfile, camera_from_exif, camera_names, load_camera
from ..scene.capture import DEFAULT_PRESET, Preset, Scene, load_preset
from ..scene.relative_pose import near_axis
from ..planning.capture_advice import capture_angles, coverage_advice, oblique_advice
from ..readout.colour_check import wavelength_shift_nm
from ..errors import CDSpectraError
from .load import load_for_estimate
from ..photo.images import LinearImage
from ..spectrum.model import SpectralModel, load_model
from ..pose.result import PoseFit, colour_blur_nm
from ..readout.readout import Readout
from .result import METHOD_MODEL, DiscFit, Estimate
from ..spectra.grid import WAVELENGTHS_NM

AUTO = "auto"  # the camera profile from the photo's EXIF
# The general-pose fit models a camera aimed a few degrees off (issue 10: camera ±3° costs no
# accuracy in bench/pose_errors.md), but it cannot tell such a camera from a cropped photo, whose
# principal point is no longer the image centre; before the aim was fitted, a disc 4 / 8 / 16 mm
# off the centre at 210 mm (1 / 2 / 4°) cost 0.004 → 0.03 / 0.07 / 0.14 (bench/reliability.md).
# Beyond a few degrees the photo is flagged and its confidence falls to the floor.
AIM_OK_DEG = 4.0
AIM_SPAN_DEG = 3.0
# The wavelength axis against the camera's own colours (colour_check): on synthetic spectra at
# the true pose |shift| stayed below 2.1 nm (99th percentile, 192 photos of the four set-ups);
# a pose 0.3° off read 3-17 nm. Judged with the estimated lamp's colours (issue 21) the shift
# follows the fit's own λ₁ error (synthetic, 96 photos: r(|shift|, Δu'v') 0.58–0.96).
COLOUR_SHIFT_OK_NM = 2.5
COLOUR_SHIFT_SPAN_NM = 7.5
# Camera or lamp angle from the disc's axis this far from the preset's (a tilted disc moves both):
# up to 3° the fit recovers the spectrum (bench/pose_errors.md); at 5° of tilt it failed on the
# near-axis set-ups (MAE ×10) with every other check passing.
POSE_OK_DEG = 3.5
POSE_SPAN_DEG = 4.0
# The rainbow's colour blur along λ₁ (lamp size d·σ and a pixel's span, as a std): past this the
# spectrum's narrow features, and so its peak, are blurred away, and the confidence scales by
# BLUR_OK_NM / blur. Every preset's own lamp passes with a margin: phone-distant-lamp's, the
# widest, is 9.8 nm (10.1 with a 512 px photo's pixels), and fitted sizes scatter a few per cent
# about it (at 10 nm its nominal photos were told to use a smaller lamp than the preset's). On
# synthetic spectra (`pose_errors --synthetic --no-truth --lamps 4`, 304 estimates) the
# confidence's correlation with the error went -0.29 -> -0.35 (10 nm: -0.354, 11: -0.348); a lamp
# of σ 0.01 (16 nm) read 0.09-0.14 against 0.02-0.03 at the presets' sizes.
BLUR_OK_NM = 11.0
# The estimate's own uncertainty: its mean std over 400–700 nm as a share of its peak (the
# model's posterior: widest for lines, narrow bands and filter edges the blur hides; 1 % vs 5 %
# noise on one photo barely moved it). Where the pose and photo checks pass, this is what the
# error still turns on: on synthetic spectra of the training prior (96 photos of the four
# set-ups, nominal and combined errors) it correlated with the MAE at r 0.52–0.68; its median
# was 0.037. Past SPREAD_OK the confidence falls by SPREAD_SLOPE per unit (pooled
# r(confidence, MAE) −0.45 → −0.64; (0.03, 8): −0.68 but nominal photos' confidence
# 0.93 → 0.87); past SPREAD_WARN (2 of the 96: a line lamp, a metal-halide lamp) the user is
# told. The model's operating point only.
SPREAD_OK = 0.04
SPREAD_SLOPE = 8.0
SPREAD_WARN = 0.075
# An uncalibrated in-camera JPEG's error was ~5× a raw file's (issue 11, bench/camera_files.md).
PROCESSED_CONFIDENCE = 0.5
# A calibrated in-camera file's bins at full scale (share of 400–700 nm with > 5 % of their
# weight at code ≥ HIGH_CODE) beyond which it is told it is over-exposed. Chosen on the
# calibration's own family (typical rendering, CIE A calibration, 6 LSPDD lamps, scratch): as
# the camera meters it 0.016–0.049 of the bins (MAE 0.022), 1/3 stop brighter 0.033–0.18 (0.026),
# 2× 0.08–0.46 (0.031), 4× 0.21–0.67 (0.046).
FULL_SCALE_WARN = 0.1
# What a spectrum leaves of the readout unexplained (profile_residual beyond NOISE_MARGIN × the
# readout's own noise) says best how far off the estimate is: a spectrum through the right
# capture and camera leaves ~0.1 % (median 0.0013 over 320 synthetic pose-error photos), a wrong
# pose, profile or centre 0.5-1.5 %. The confidence scales by RESIDUAL_OK / residual, floored at
# RESIDUAL_FLOOR. Chosen on synthetic spectra of the training prior only (scratch; correlation of
# confidence with MAE 400–700): 320 pose-error photos (`pose_errors --synthetic --lamps 4`)
# -0.35 -> -0.50, 144 photos under eval's robustness conditions (12 lamps) -0.02 -> -0.49; OK
# 0.002 / 0.003 gave -0.51 / -0.48 and -0.46 / -0.51, floor 0.5 -0.49 / -0.38. A JPEG read at
# its own size keeps its 4:2:0 chroma's blur, which the forward model does not: a 256 px one leaves
# 0.6-1 % at the true capture (0.07 % as PNG) and reads ~1.4x worse; one reduced 2x, 0.12 %.
RESIDUAL_OK = 0.0025
RESIDUAL_FLOOR = 0.2
RESIDUAL_WARN = 0.005  # told from here (confidence × 0.5)
NOISE_MARGIN = 2.0
# An offset this large (share of full scale) is worth telling: it costs 8-bit levels and may
# not be uniform.
AMBIENT_WARN = 0.01
# A room-light offset costs the confidence its share of the file's levels (AMBIENT_COST per unit),
# not more: measured on the disc's dark part and subtracted, a uniform offset left the error as it
# was (synthetic spectra of the training prior, `pose_errors --synthetic --lamps 8 --no-truth`,
# 638 photos: ambient 3 % / 5 % read ×1.00–1.02 nominal's MAE on every set-up); room light that
# is not uniform is measured apart (UNEVEN_WARN below: the unexplained residual does not see it, a
# 0–16 % gradient read ×1.5–2.1 the MAE at a residual of 0). At 5 per unit (before) those photos
# lost 15–25 % of their confidence for nothing:
# r(confidence, MAE) over the 638 −0.746 → −0.763 at 1 (within each lamp −0.360 → −0.371).
# An offset below zero stays at 5: the dark parts were clipped away before the file was written.
AMBIENT_COST = 1.0
BLACK_LEVEL_COST = 5.0
# What one subtracted offset leaves: room light brighter on one side of the disc (the dark
# pixels' medians of its two halves differ by this share of full scale, ambient.dark_levels).
# Synthetic, cd-default at 384 px, two lamps, 4–8 % room light with a gradient across the frame
# (scratch): 0.004–0.007 read as a uniform offset did, 0.012 within ±20 % of it, 0.026 ×1.5–2.1
# the MAE. Told from UNEVEN_WARN; the confidence falls by UNEVEN_COST per unit beyond it.
UNEVEN_WARN = 0.01
UNEVEN_COST = 25.0
# The share of the photo's energy the fitted capture leaves unexplained past which the photo is
# told that the rainbow does not match a CD seen from the preset's geometry.
GEOMETRY_WARN = 0.15
LOW_SNR = 30.0  # a readout's peak over its median noise below which the user is told to expose longer
# The photo's rainbow level (_rainbow_level) over the readout's peak: 0.67–1.30 on synthetic
# photos of every set-up whose capture was found (nominal, combined errors, a lamp of σ 0.001),
# 850–1090 where the fit put its rainbow on the dark disc (phone-distant-lamp on a black cloth, two
# of 18 photos of captures 1, 10, 11; scratch). Past MISPLACED_RATIO the photo is not called dark.
MISPLACED_RATIO = 10.0
RAINBOW_CHROMA = 0.5  # (max − min) / max of a pixel's channels that counts as the rainbow's colour
MISPLACED_CONFIDENCE = 0.1
Progress = Callable[[float, str], None]

__all__ = ["AUTO", "estimate_image", "estimate_photo", "camera_for", "camera_prior_for", "resolve_camera",
           "solving_camera", "PhotoReading", "read_image", "photo_checks", "profile_residual", "disc_fit",
           "estimate_result", "resolved_model", "resolved_calibration"]


def camera_for(name: str, model: SpectralModel | None) -> tuple[CameraProfile, bool]:
    """The sensitivities to solve with and whether they are the generic (unknown camera) ones."""
    if name == GENERIC_CAMERA:
        if model is None or "generic_camera" not in model.metadata:
            raise CDSpectraError("the generic camera profile comes with the model, which is not available")
        return CameraProfile(GENERIC_CAMERA, np.asarray(model.metadata["generic_camera"], dtype=np.float64)), True
    return load_camera(name), False


def camera_prior_for(model: SpectralModel | None) -> CameraPrior:
    """The prior over camera sensitivities whose mean is ``model``'s generic profile: its
    training cameras (all shipped profiles without a model that names them)."""
    cameras = (model.metadata.get("cameras") or {}) if model is not None else {}
    names = [n for n in cameras.get("train", []) if n in camera_names()] if isinstance(cameras, dict) else []
    return camera_prior(names or camera_names())


def solving_camera(camera: CameraProfile, generic: bool, calibration: Calibration | None
                   ) -> tuple[CameraProfile, bool]:
    """The sensitivities a photo is solved with, and whether to call them generic: a calibration
    that measured the camera's own sensitivities replaces the profile, and the network is told
    the camera is known (generic + calibration, 30 synthetic SPDs of the training prior,
    `camera_files --synthetic`: MAE 0.016 told "known", 0.023 told "generic")."""
    if calibration is None or calibration.sensitivities is None:
        return camera, generic
    return CameraProfile(camera.name, calibration.sensitivities), False


def resolve_camera(name: str, image: LinearImage, model: SpectralModel | None
                   ) -> tuple[CameraProfile, bool, str, str | None]:
    """(sensitivities, generic?, profile name, warning) for ``name``; ``"auto"`` picks the
    profile from the photo's EXIF Make/Model, else the generic profile (the default camera's
    without a model) with a warning that says so."""
    if name != AUTO:
        cam, generic = camera_for(name, model)
        return cam, generic, name, None
    found = camera_from_exif(image.exif.make, image.exif.model)
    if found:
        cam, generic = camera_for(found, model)
        return cam, generic, found, None
    has_generic = model is not None and "generic_camera" in model.metadata
    fallback = GENERIC_CAMERA if has_generic else DEFAULT_CAMERA
    who = " ".join(p for p in (image.exif.make, image.exif.model) if p) or "not named in the photo's EXIF"
    note = (f"the camera ({who}) is not one of the {len(camera_names())} camera profiles: using the "
            f"{'generic' if has_generic else DEFAULT_CAMERA.replace('_', ' ')} profile — pick the nearest camera, "
            "or take a calibration shot, for the best accuracy")
    cam, generic = camera_for(fallback, model)
    return cam, generic, fallback, note


def _bin_share(readout: Readout, mask: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Per λ₁ bin, the share of the readout's pixel weight (Σ visibility²) that ``mask`` flags."""
    px = readout.pixels
    flagged = np.asarray(mask).reshape(-1)[px.index]
    vis2 = px.visibility ** 2
    n = readout.lambda_nm.size
    total = np.bincount(readout.pixel_bin, weights=vis2, minlength=n).astype(np.float64)  # int64 if empty
    hit = np.bincount(readout.pixel_bin, weights=vis2 * flagged, minlength=n).astype(np.float64)
    return np.divide(hit, total, out=np.zeros_like(total), where=total > 0)


def _unexplained(readout: Readout, residual: float) -> float:
    """``residual`` (:func:`profile_residual`) beyond what the readout's noise explains: a dim or
    noisy photo's misfit is not a wrong capture."""
    noise = NOISE_MARGIN * relative_noise(readout)
    return math.sqrt(max(residual * residual - noise * noise, 0.0))


def _rainbow_level(rgb: NDArray[np.float64], excluded: NDArray[np.bool_]) -> float:
    """The level the brightest BRIGHTEST_SHARE of the photo's strongly coloured pixels reach (the
    rainbow's: a lit table, room light or a grey label around the disc is not coloured)."""
    usable = rgb[~np.asarray(excluded)]
    top = np.max(usable, axis=1) if usable.size else np.zeros(0)
    coloured = top[(top - np.min(usable, axis=1)) > RAINBOW_CHROMA * top] if usable.size else top
    return float(np.quantile(coloured, 1.0 - BRIGHTEST_SHARE)) if coloured.size else 0.0


def geometry_mismatch(preset: Preset) -> str:
    """The warning for a photo no capture near the preset's explains, with what to check on
    this kind of set-up (an oblique one has no axis to put camera and lamp on)."""
    check = ("that camera and lamp are on the disc's axis" if near_axis(preset)
             else f"where camera and lamp stand — {oblique_advice(preset, None)}")
    return ("the rainbow does not match a CD seen from the preset's geometry — check that the preset matches the "
            f"capture, and {check}")


def _confidence(readout: Readout, matrix: NDArray[np.float64], spd: NDArray[np.float64], analysis: Reading,
                image: LinearImage | None, generic: bool, focal_source: str,
                preset: Preset | None = None, coverage_check: bool = True) -> tuple[float, list[str], dict]:
    """0–1 and plain-language reasons, from checks that each catch one way of going wrong.
    ``coverage_check=False`` leaves 400–700 nm coverage to the caller (a joint estimate judges
    the photos' union)."""
    warnings: list[str] = []
    score = 1.0
    preset = preset or analysis.scene.preset
    lam = readout.lambda_nm
    core = (lam >= 400) & (lam <= 700)
    coverage = float(np.mean(readout.valid[core]))
    # The readout leaves out clipped and NaN/Inf pixels alike; only clipping is over-exposure.
    clipped = readout.saturated_fraction if image is None or not np.any(image.invalid) else \
        _bin_share(readout, image.saturated)
    sat_core = float(np.mean(clipped[core] > 0.05))
    # A calibrated in-camera file's readout keeps its full-scale pixels as bounds (the loader's
    # saturation mask is not applied there), so its over-exposure is counted on the file itself:
    # the rainbow's pixels with a channel at full scale (code ≥ HIGH_CODE).
    bounds = analysis.posed.clipped
    bound_core = 0.0 if bounds is None else \
        float(np.mean(_bin_share(readout, np.any(bounds[1], axis=-1))[core] > 0.05))
    # Re-render the readout from the estimate and compare with the photo.
    valid = readout.valid
    meas = readout.values
    residual = profile_residual(readout, matrix, spd)
    stats = {"profile_residual": residual, "coverage_400_700": coverage, "saturated_bins": sat_core,
             "geometry_residual": float(analysis.fit.residual)}
    blur = colour_blur_nm(analysis.scene.preset, analysis.scene.preset.light.lobe_sigma, analysis.focal_px)
    stats["colour_blur_nm"] = blur
    # Told last: where the pose is doubted, the fitted lamp size is part of that capture, and the
    # pose's own warnings name the fix to try first.
    blurred = None
    if blur > BLUR_OK_NM:
        blurred = (f"the rainbow's colours are blurred over about {blur:.0f} nm (the lamp looks large from the disc, "
                   "or the disc spans few pixels): the spectrum's narrow features, and so its peak, are uncertain "
                   "— use a smaller lamp (or a card with a small hole in front of it), or fill more of the frame "
                   "with the disc")
        score *= max(0.3, BLUR_OK_NM / blur)
    shift = wavelength_shift_nm(readout, analysis.camera.sensitivities, blur, spd)
    stats["colour_shift_nm"] = shift  # None (JSON null) with too few bins to tell
    if shift is not None and abs(shift) > COLOUR_SHIFT_OK_NM:
        warnings.append(f"the rainbow's colours put its wavelengths {abs(shift):.0f} nm {'below' if shift > 0 else 'above'} "
                        "where the fitted capture does (a green pixel cannot be 620 nm): the pose or the camera profile "
                        "is off — check the camera choice, and that the set-up matches the preset")
        score *= max(0.3, 1.0 - (abs(shift) - COLOUR_SHIFT_OK_NM) / COLOUR_SHIFT_SPAN_NM)
    fitted, nominal = capture_angles(analysis.scene), capture_angles(Scene(preset))
    departure = max(abs(fitted[0] - nominal[0]), abs(fitted[1] - nominal[1]))
    stats["pose_departure_deg"] = departure
    if departure > POSE_OK_DEG:
        warnings.append(f"the photo was taken about {departure:.0f}° away from the set-up's angles (camera "
                        f"{fitted[0]:.0f}°, lamp {fitted[1]:.0f}° from the disc's axis; preset {nominal[0]:.0f}° and "
                        f"{nominal[1]:.0f}°, a tilted disc counts too): the fit covers that, but less surely — "
                        "lay the disc flat and place camera and lamp as the preset says")
        score *= max(0.4, 1.0 - (departure - POSE_OK_DEG) / POSE_SPAN_DEG)
    if sat_core > 0.02:
        warnings.append(f"over-exposed: {100 * sat_core:.0f}% of the visible rainbow is clipped — use a shorter exposure")
        score *= max(0.2, 1.0 - 2.0 * sat_core)
    elif bound_core > FULL_SCALE_WARN:
        # Read as bounds, not lost; but a camera that clips before its matrix (LibRaw, after its
        # white balance) spoils the other channels too, which a bound cannot tell.
        warnings.append(f"over-exposed: {100 * bound_core:.0f}% of the visible rainbow has a channel at full scale "
                        "(blinking highlights), read only as bounds — use a shorter exposure")
        score *= max(0.5, 1.0 - bound_core)
    stats["full_scale_bins"] = bound_core
    if coverage_check and coverage < 0.95:
        where = coverage_advice(preset, analysis.scene)
        warnings.append(f"only {100 * coverage:.0f}% of 400–700 nm is visible on the disc — {where}")
        # Squared: the missing part of 400–700 nm comes from the prior alone (lamp 45 mm beside
        # the lens: 38 % coverage, MAE 0.37 at confidence 0.42 with a linear penalty).
        score *= max(0.1, coverage * coverage)
    if image is not None and np.any(image.invalid):
        bad = float(np.mean(_bin_share(readout, image.invalid)[core]))
        stats["invalid_share"] = bad
        warnings.append(f"{100 * bad:.1f}% of the rainbow's pixels are not numbers (NaN/Inf) and were ignored — "
                        "check the raw conversion or the EXR export")
        score *= max(0.2, 1.0 - 2.0 * bad)
    ambient, below = float(np.max(analysis.ambient)), float(np.min(analysis.ambient))
    stats["ambient_offset"] = ambient if ambient >= -below else below
    uneven = stats["ambient_uneven"] = float(analysis.ambient_uneven)
    # Only where the capture explains the photo: a capture in the wrong place takes rainbow for
    # the dark part, and the geometry's warning says what to fix.
    if uneven > UNEVEN_WARN and analysis.fit.residual <= GEOMETRY_WARN:
        warnings.append(f"the room light is uneven: the disc's dark part reads {100 * uneven:.1f}% of full scale more "
                        "on one side than on the other, and only its average could be subtracted — darken the room, "
                        "or shade the disc from the other lights")
        score *= max(0.3, 1.0 - UNEVEN_COST * (uneven - UNEVEN_WARN))
    if ambient >= AMBIENT_WARN:
        warnings.append(f"room light (or the camera's black level) adds {100 * ambient:.1f}% of full scale to the "
                        "whole photo: it was measured on the dark part of the disc and subtracted — a darker room "
                        "is more accurate")
        score *= max(0.5, 1.0 - AMBIENT_COST * ambient)
    elif below <= -AMBIENT_WARN:
        warnings.append(f"the photo's dark parts read {100 * -below:.1f}% of full scale below zero (a black level "
                        "subtracted too far, or twice): it was measured on the dark part of the disc and added back "
                        "— check the raw conversion's black level")
        score *= max(0.5, 1.0 + BLACK_LEVEL_COST * below)
    # A very dark 8-bit rainbow first: it also inflates the geometry and readout residuals below.
    peak = float(np.max(meas[valid])) if np.any(valid) else 0.0
    noise = float(np.median(readout.noise[valid])) if np.any(valid) else 1.0
    snr = peak / max(noise, 1e-12)
    stats["snr"] = snr
    # ...unless the photo is bright and only the fitted capture's rainbow is dark: then the fit put
    # the rainbow where the disc is dark, and exposure advice would be wrong (looked at only for a
    # dim readout: the photo's level costs a pass over its pixels).
    misplaced = False
    if peak < DIM_LEVEL_8BIT or snr < LOW_SNR:
        level = stats["photo_level"] = _rainbow_level(analysis.posed.rgb, analysis.posed.excluded)
        misplaced = level >= DIM_LEVEL_8BIT and level > MISPLACED_RATIO * peak
    if misplaced:
        warnings.append(f"the rainbow is bright in the photo ({100 * level:.0f}% of full scale) but dark where the "
                        f"fitted capture puts it ({100 * peak:.1f}%): the exposure is fine, the capture was not found — "
                        "the spectrum is not the lamp's")
        score *= MISPLACED_CONFIDENCE
    elif image is not None and image.encoding.endswith("-8") and 0 < peak < DIM_LEVEL_8BIT:
        warnings.append(f"the rainbow is very dark (its brightest part is {100 * peak:.1f}% of full scale), so 8-bit "
                        "rounding limits the accuracy — use a longer exposure or save 16-bit/raw")
        score *= max(0.2, peak / DIM_LEVEL_8BIT)
    fit = analysis.fit
    width, height = analysis.scene.preset.camera.image_size_px
    off_px = math.hypot(fit.center_px[0] - (height - 1) / 2.0, fit.center_px[1] - (width - 1) / 2.0)
    aim_deg = math.degrees(math.atan2(off_px, fit.focal_px))
    stats["disc_offset_mm"] = off_px * fit.distance_mm / fit.focal_px
    stats["aim_off_deg"] = aim_deg
    if aim_deg > AIM_OK_DEG:
        warnings.append(f"the disc is not centred: the camera is aimed {aim_deg:.0f}° away from the disc's centre — aim "
                        "it at the centre (a cropped photo also moves it: use the whole frame)")
        score *= max(0.2, 1.0 - (aim_deg - AIM_OK_DEG) / AIM_SPAN_DEG)
    if analysis.fit.residual > GEOMETRY_WARN:
        warnings.append(geometry_mismatch(preset))
        score *= max(0.2, 1.0 - 2.0 * (analysis.fit.residual - GEOMETRY_WARN))
    unexplained = _unexplained(readout, residual)
    stats["unexplained"] = unexplained
    if unexplained > RESIDUAL_WARN:
        warnings.append(f"the recovered spectrum leaves {100 * unexplained:.1f}% of the rainbow unexplained (a spectrum "
                        "read through the right capture and camera leaves about 0.1%): the set-up, the camera profile "
                        "or the file's processing (a small JPEG keeps its colours at half its size) is not what the "
                        "estimate assumed — treat it as approximate")
    score *= float(np.clip(RESIDUAL_OK / max(unexplained, 1e-12), RESIDUAL_FLOOR, 1.0))
    if snr < LOW_SNR and not misplaced:
        warnings.append("low signal: the rainbow is dim or noisy — use a longer exposure or a brighter lamp")
        score *= max(0.2, snr / LOW_SNR)
    if generic:
        warnings.append("generic camera profile: pick your camera (or calibrate) for the best accuracy")
        score *= 0.85
    if focal_source == "preset":
        warnings.append("no focal length in the photo's EXIF: assuming the preset's field of view")
        score *= 0.8
    elif focal_source == "series outline":
        warnings.append("no focal length in the photo's EXIF: taken from the disc's outline in the other frames "
                        "of its file and the preset's camera distance")
        score *= 0.9
    elif focal_source in ("exif-35mm, resized", "exif, cropped"):
        kind = "resized" if focal_source.endswith("resized") else "cropped"
        used = "35 mm equivalent" if kind == "resized" else "focal length over the sensor's pixel size"
        warnings.append(f"the photo's EXIF gives two focal lengths that disagree: it was {kind} after it was taken; "
                        f"its {used} explains the photo and is used — read the camera's own file where you can")
        score *= 0.9
    elif focal_source == "outline":
        warnings.append("no focal length in the photo's EXIF: taken from the disc's outline and the preset's "
                        "camera distance")
        score *= 0.9
    if image is not None and image.is_grey:
        warnings.append("the photo is greyscale: colour is what separates wavelengths — use the colour photo")
        score *= 0.3
    if blurred:
        warnings.append(blurred)
    return float(np.clip(score, 0.0, 1.0)), warnings, stats


@dataclass(frozen=True)
class PhotoReading:
    """One photo through the pose and readout stages, with what its checks need to know."""

    image: LinearImage
    reading: Reading
    camera: str  # the profile's name as the result reports it
    camera_note: str | None  # why that profile was picked, when the photo did not say


def resolved_model(model: SpectralModel | None | str) -> SpectralModel | None:
    """``model`` as given: "shipped", a path, a loaded model, or None (physics and prior only)."""
    if model == "shipped":
        return load_model()
    return load_model(model) if isinstance(model, (str, Path)) else model


def resolved_calibration(calibration: str | Path | Calibration | None) -> Calibration | None:
    return load_calibration(calibration) if isinstance(calibration, (str, Path)) else calibration


def read_image(image: LinearImage, preset: Preset, camera: str, calibration: Calibration | None,
               model: SpectralModel | None, *, focal_px: float | None = None, fit: PoseFit | None = None,
               progress: Progress | None = None, min_coverage_nm: float = MIN_COVERAGE_NM,
               series_focal: float | None = None) -> PhotoReading:
    """The camera profile for the photo, then the pose and readout stages (:mod:`.stages`;
    ``min_coverage_nm``: the first order's share of 400–700 nm below which it is refused;
    ``series_focal``: the lens of the photo's series, file pixels, where its EXIF has none)."""
    report = progress or (lambda _f, _m: None)
    cam, generic, name, note = resolve_camera(camera, image, model)
    if calibration is not None and calibration.sensitivities is not None:
        cam, generic = solving_camera(cam, generic, calibration)
        note = None  # the calibration measured the camera: no "not one of the profiles" warning
    report(0.2, "Finding the disc")
    posed = pose_photo(image, preset, cam, generic_camera=generic, calibration=calibration, focal_px=focal_px,
                       fit=fit, series_focal=series_focal)
    report(0.5, "Reading the rainbow")
    return PhotoReading(image, read_posed(posed, min_coverage_nm=min_coverage_nm), name, note)


def photo_checks(photo: PhotoReading, spd: NDArray[np.float64], preset: Preset,
                 calibration: Calibration | None, coverage_check: bool = True) -> tuple[float, list[str], dict]:
    """Confidence (0–1), warnings and the checks' numbers for one photo read with ``spd``: the
    readout checks, then the camera, calibration and processed-file warnings."""
    analysis, image, camera = photo.reading, photo.image, photo.camera
    cal = calibration
    confidence, warnings, stats = _confidence(analysis.readout, analysis.matrix, spd, analysis, image,
                                              analysis.generic_camera, analysis.focal_source, preset,
                                              coverage_check)
    if photo.camera_note:  # says more than the plain "generic camera profile" warning
        warnings = [w for w in warnings if not w.startswith("generic camera profile")] + [photo.camera_note]
        confidence *= 1.0 if analysis.generic_camera else 0.85
    if cal is not None and cal.camera not in ("", AUTO, camera):
        warnings.append(f"calibration {cal.name!r} was made with the {cal.camera} profile but this estimate uses "
                        f"{camera}: its gains are relative to that profile — pick the same camera")
        confidence *= 0.85
    poor = None if cal is None else calibration_warning(cal)
    if poor:
        warnings.append(poor)
        confidence *= POOR_CALIBRATION_CONFIDENCE
    if image.processed and cal is None:
        warnings.append(f"this file was processed by the camera or an editor ({image.processed_reason}): white "
                        "balance, a colour matrix and a tone curve change the rainbow's colours, so the spectrum "
                        "is only approximate — shoot RAW, or take one calibration shot of a known lamp with the same "
                        "camera settings (fixed white balance) and use it")
        confidence *= PROCESSED_CONFIDENCE
    elif image.processed and cal.pipeline is None:
        warnings.append(f"this file was processed by the camera ({image.processed_reason}) but calibration "
                        f"{cal.name!r} holds per-bin gains only, which cannot undo a colour matrix and tone curve: "
                        "calibrate again from a photo taken the same way as this one (same file type and settings)")
        confidence *= PROCESSED_CONFIDENCE
    elif not image.processed and cal is not None and cal.pipeline is not None:
        warnings.append(f"calibration {cal.name!r} was made from an in-camera JPEG/HEIC and undoes that camera "
                        "processing, but this file is unprocessed (raw/linear): use a calibration made from the "
                        "same kind of file")
        confidence *= PROCESSED_CONFIDENCE
    return confidence, warnings, stats


def disc_fit(photo: PhotoReading, preset: Preset) -> DiscFit:
    """Where the disc is in the photo's original pixels."""
    fit, image, focal_px = photo.reading.fit, photo.image, photo.reading.focal_px
    s = image.scale
    return DiscFit(
        center_px=image.to_original(*fit.center_px),
        radius_px=preset.disc.rim_radius_mm * focal_px / fit.distance_mm * s,
        hole_radius_px=preset.disc.hole_radius_mm * focal_px / fit.distance_mm * s,
        px_per_mm=focal_px / fit.distance_mm * s,
    )


def spectrum_spread(spd: NDArray[np.float64], std: NDArray[np.float64]) -> float:
    """The mean std of ``spd`` over 400–700 nm as a share of its peak; 0 where it has none."""
    band = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
    peak = float(np.max(spd, initial=0.0))
    s = np.asarray(std, dtype=np.float64)[band]
    s = s[np.isfinite(s)]
    return float(np.mean(s)) / peak if s.size and peak > 0 else 0.0


def estimate_result(photo: PhotoReading, result: Spectrum, confidence: float, warnings: list[str],
                    stats: dict, preset: Preset, calibration: Calibration | None, model: SpectralModel | None,
                    method: str, working_space: str, timing: dict[str, float], camera: str | None = None
                    ) -> Estimate:
    """The result of a spectrum with its checks: colour, the disc of ``photo`` and the extra
    fields (a joint estimate reports its reference photo's, and adds its own)."""
    spd, std, e_phys = result.spd, result.std, result.physics
    if result.fallback:
        warnings.append("the model returned no usable spectrum for this photo: showing the physics-only estimate")
        confidence *= 0.5
    # Only the model's std was measured against the error; the physics solve's is the bare
    # posterior, several times wider than its error (a fallback is already marked down).
    if method == METHOD_MODEL and not result.fallback:
        spread = stats["spd_spread_400_700"] = spectrum_spread(spd, std)
        if spread > SPREAD_OK:
            confidence *= max(0.3, 1.0 - SPREAD_SLOPE * (spread - SPREAD_OK))
        if spread > SPREAD_WARN:
            warnings.append(f"the spectrum's shape is uncertain: ±{100 * spread:.0f}% of its peak on average over "
                            "400–700 nm (the band around the curve) — its sharp features (lines, a narrow LED band, a "
                            "filter's edge) are narrower than the rainbow resolves; a smaller lamp (or a card with a "
                            "small hole in front of it) and a disc filling more of the frame sharpen it")
    light = colour.spectral_colour(spd, working_space)
    if light.out_of_gamut:
        warnings.append(f"the lamp's colour is outside {working_space}: the light colour is clipped to the gamut")
    analysis, image = photo.reading, photo.image
    height, width = image.rgb.shape[:2]
    return Estimate(
        spd=spd, spd_std=std, xy=light.xy, cct_k=light.cct_k, duv=light.duv,
        rgb_scene_linear=tuple(float(c) for c in light.rgb), confidence=confidence, warnings=warnings,
        disc=disc_fit(photo, preset), timing_ms=timing, source=str(image.path), preset=preset.name,
        camera=camera or photo.camera, calibration=None if calibration is None else calibration.name,
        model_version=(model.version if model else "") + ("" if method == METHOD_MODEL else f" ({method} only)"),
        working_space=working_space,
        extra={"physics_spd": [float(v) for v in e_phys / e_phys.max()], "focal_px_source": analysis.focal_source,
               "lobe_sigma": float(analysis.scene.preset.light.lobe_sigma), "checks": stats,
               "image_size_px": [width, height],
               "ring_center_px": list(image.to_original(*analysis.fit.ring_center_px)),
               **({} if calibration is None else {"calibration_check": calibration_check(calibration)})},
        wavelength_nm=WAVELENGTHS_NM.copy(),
    )


def estimate_image(
    image: LinearImage,
    *,
    preset: str | Preset = DEFAULT_PRESET,
    camera: str = AUTO,
    calibration: str | Calibration | None = None,
    working_space: str = DEFAULT_WORKING_SPACE,
    model: SpectralModel | None | str = "shipped",
    focal_px: float | None = None,
    progress: Progress | None = None,
    method: str = METHOD_MODEL,
    fit: PoseFit | None = None,
    fusion: tuple[float, float] | None = None,
    rendition: bool = True,
    series_focal: float | None = None,
) -> Estimate:
    """Estimate from an already loaded photo (see :func:`estimate_photo`).

    ``method``: one of :data:`.stages.OPERATING_POINTS` — "model" (physics + prior + network, the
    product), "prior" (physics under the Gaussian prior only) or "physics" (smoothness-regularised
    physics only), the benchmark's operating points. ``fusion`` overrides the model's (strength,
    floor). ``rendition=False`` skips the colour-rendition figures (bulk runs that want spectra only).
    ``series_focal``: the lens of the photo's series (file pixels; the frames of a GIF), used where
    the EXIF has none.
    """
    if method not in OPERATING_POINTS:
        raise CDSpectraError(f"unknown method {method!r}; known: {', '.join(OPERATING_POINTS)}")
    t0 = time.perf_counter()
    report = progress or (lambda _f, _m: None)
    preset_obj = preset if isinstance(preset, Preset) else load_preset(preset)
    mdl = resolved_model(model)
    cal = resolved_calibration(calibration)
    photo = read_image(image, preset_obj, camera, cal, mdl, focal_px=focal_px, fit=fit, progress=progress,
                       series_focal=series_focal)
    report(0.6, "Solving for the spectrum")
    t2 = time.perf_counter()
    result = spectrum(photo.reading, method, mdl, fusion)
    t3 = time.perf_counter()
    report(0.9, "Colour")
    confidence, warnings, stats = photo_checks(photo, result.spd, preset_obj, cal)
    timing = {"load": 0.0, **photo.reading.timing_ms, "spectrum": (t3 - t2) * 1e3}
    estimate = estimate_result(photo, result, confidence, warnings, stats, preset_obj, cal, mdl, method,
                               working_space, timing)
    t4 = time.perf_counter()
    figures = rendition_figures(estimate.spd, estimate.spd_std) if rendition else None
    t5 = time.perf_counter()
    estimate.rendition = figures
    estimate.timing_ms.update({"colour": (t4 - t3) * 1e3, **({"rendition": (t5 - t4) * 1e3} if rendition else {}),
                               "total": (t5 - t0) * 1e3})
    report(1.0, "Done")
    return estimate


def estimate_photo(
    path: str | Path,
    *,
    preset: str | Preset = DEFAULT_PRESET,
    camera: str = AUTO,
    calibration: str | Calibration | None = None,
    working_space: str = DEFAULT_WORKING_SPACE,
    model: SpectralModel | None | str = "shipped",
    progress: Progress | None = None,
    method: str = METHOD_MODEL,
    rendition: bool = True,
) -> Estimate:
    """The lamp's SPD from a CD photo (JPEG/PNG/TIFF/EXR). Raises CDSpectraError subclasses with
    a message for the user on bad input; never returns NaN. ``rendition=False`` skips the
    colour-rendition figures."""
    report = progress or (lambda _f, _m: None)
    report(0.0, "Reading the photo")
    t0 = time.perf_counter()
    preset_obj = preset if isinstance(preset, Preset) else load_preset(preset)
    image = load_for_estimate(path, preset_obj)
    load_ms = (time.perf_counter() - t0) * 1e3
    result = estimate_image(image, preset=preset_obj, camera=camera, calibration=calibration,
                            working_space=working_space, model=model, progress=progress, method=method,
                            rendition=rendition)
    result.timing_ms["load"] = load_ms
    result.timing_ms["total"] += load_ms
    return result
