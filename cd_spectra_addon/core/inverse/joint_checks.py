"""How far to trust a joint estimate, photo by photo and together.

Each photo's own checks (:func:`.estimate.photo_checks`) run against the joint SPD, except
coverage: what counts is the union of the photos' 400–700 nm. Two things only a set of photos
can show are flagged as well: a photo the joint SPD does not reproduce although its own solve
does (another lamp, or a misfitted capture) — it is given less say and the SPD solved again —
and a photo whose fitted brightness is far from the others' (a very different exposure, or
another lamp or set-up).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..calibration.calibration import Calibration
from ..planning.capture_advice import capture_angles
from ..scene.capture import Preset
from ..spectrum.model import SpectralModel
from .estimate import PhotoReading, disc_fit, photo_checks, profile_residual
from .stages import Spectrum, joint_spectrum, model_prior, physics_spd

# A photo the joint SPD reproduces worse than INCONSISTENT_RATIO × its own solve does (and worse
# than RESIDUAL_FLOOR of its peak) does not fit the others. On synthetic sets of one lamp (48
# spectra; 150 + 300 mm, 150 + 210 + 300 mm, one set-up at two exposures) that ratio stayed
# ≤ 2.6 (99th percentile 2.4); with a photo of another lamp among two of the right one, the other
# lamp's photo read 15× (median) and the right ones 6.6×.
RESIDUAL_FLOOR = 0.02
INCONSISTENT_RATIO = 3.0
# Brightness this many times the median of the others' (either way): more than three stops.
SCALE_SPREAD = 10.0
SAY_POWER = 2.0
COVERAGE_OK = 0.95  # the single estimate's own threshold

__all__ = ["PhotoFit", "review", "alone_residuals", "settled_spectrum", "joint_confidence", "covered_ranges",
           "union_coverage", "photo_entry",
           "RESIDUAL_FLOOR", "INCONSISTENT_RATIO", "SCALE_SPREAD"]


@dataclass(frozen=True)
class PhotoFit:
    """How one photo sits with the joint SPD."""

    residual: float  # the joint SPD against this photo's features (profile residual)
    alone: float  # this photo's own physics + prior solve against them
    brightness: float  # fitted brightness ÷ the median of the other photos' (1 for a lone photo)
    weight: float  # its say in the solve (1, or less where it does not fit the others)

    @property
    def inconsistent(self) -> bool:
        return self.residual > _limit(self)

    @property
    def brightness_outlier(self) -> bool:
        return not (1.0 / SCALE_SPREAD <= self.brightness <= SCALE_SPREAD)


def review(photos: Sequence[PhotoReading], result: Spectrum, model: SpectralModel | None,
           weights: Sequence[float] | None = None, alone: Sequence[float] | None = None) -> list[PhotoFit]:
    """Each photo against the joint SPD (its say: ``weights``, default 1; ``alone``: each photo's
    own residual, when already known)."""
    own = list(alone) if alone is not None else alone_residuals(photos, model)
    scales = result.scales
    fits = []
    for k, photo in enumerate(photos):
        reading = photo.reading
        residual = profile_residual(reading.readout, reading.matrix, result.spd)
        others = [s for j, s in enumerate(scales) if j != k and s > 0]
        brightness = float(scales[k] / np.median(others)) if others and scales[k] > 0 else 1.0
        fits.append(PhotoFit(residual, own[k], brightness, 1.0 if weights is None else float(weights[k])))
    return fits


def alone_residuals(photos: Sequence[PhotoReading], model: SpectralModel | None) -> list[float]:
    """How well each photo's own physics + prior solve reproduces it."""
    prior = model_prior(model)
    out = []
    for photo in photos:
        reading = photo.reading
        own = physics_spd(reading, prior)
        out.append(profile_residual(reading.readout, reading.matrix, own) if np.any(own > 0) else 1.0)
    return out


def settled_spectrum(photos: Sequence[PhotoReading], method: str, model: SpectralModel | None,
                     fusion: tuple[float, float] | None = None) -> tuple[Spectrum, list[PhotoFit]]:
    """The joint spectrum, with the photos that do not fit the others given less say.

    One photo at a time: a photo of another lamp pulls the joint SPD towards itself, so the
    photos of the right lamp misfit too until it has less say. Of the photos that misfit, the
    one left out that leaves the others fitting best is taken (with two photos, the worse
    fitting one); a flagged photo's say is (its residual threshold ÷ its residual)², from its
    residual against the latest SPD."""
    readings = [p.reading for p in photos]
    alone = alone_residuals(photos, model)
    result = joint_spectrum(readings, method, model, fusion)
    fits = review(photos, result, model, alone=alone)
    weights = np.ones(len(photos))
    flagged: set[int] = set()
    for _ in range(len(photos) - 1):
        fresh = [k for k, f in enumerate(fits) if f.inconsistent and k not in flagged]
        if not fresh:
            break
        flagged.add(_culprit(photos, fresh, fits, weights, method, model, fusion, alone))
        for k in flagged:
            weights[k] = min(weights[k], (_limit(fits[k]) / fits[k].residual) ** SAY_POWER)
        result = joint_spectrum(readings, method, model, fusion, weights)
        fits = review(photos, result, model, weights, alone)
    return result, fits


def _culprit(photos: Sequence[PhotoReading], candidates: list[int], fits: list[PhotoFit],
             weights: NDArray[np.float64], method: str, model: SpectralModel | None, fusion: tuple[float, float] | None,
             alone: Sequence[float]) -> int:
    """The misfitting photo whose leaving out makes the others fit best (worst misfit among the
    remaining photos, residual ÷ threshold); the worst misfit itself where only two have a say."""
    if len(candidates) == 1 or np.sum(weights > 0) <= 2:
        return max(candidates, key=lambda k: fits[k].residual / _limit(fits[k]))
    readings = [p.reading for p in photos]
    best, best_misfit = candidates[0], np.inf
    for k in candidates:
        trial = weights.copy()
        trial[k] = 0.0
        rest = review(photos, joint_spectrum(readings, method, model, fusion, trial), model, trial, alone)
        misfit = max(f.residual / _limit(f) for j, f in enumerate(rest) if j != k and trial[j] > 0)
        if misfit < best_misfit:
            best, best_misfit = k, misfit
    return best


def _limit(fit: PhotoFit) -> float:
    return max(RESIDUAL_FLOOR, INCONSISTENT_RATIO * fit.alone)


def covered_ranges(valid: NDArray[np.bool_], lambda_nm: NDArray[np.float64], low: float = 380.0,
                   high: float = 780.0) -> list[tuple[float, float]]:
    """The wavelength ranges (bin centres, within [low, high]) where ``valid`` holds."""
    inside = (lambda_nm >= low) & (lambda_nm <= high)
    ranges: list[tuple[float, float]] = []
    for i in np.flatnonzero(valid & inside):
        lam = float(lambda_nm[i])
        if ranges and i > 0 and valid[i - 1] and inside[i - 1]:
            ranges[-1] = (ranges[-1][0], lam)
        else:
            ranges.append((lam, lam))
    return ranges


def union_coverage(photos: Sequence[PhotoReading]) -> tuple[float, NDArray[np.bool_], NDArray[np.float64]]:
    """Share of 400–700 nm that at least one photo reads, that union, and the bins' wavelengths."""
    lam = photos[0].reading.readout.lambda_nm
    union = np.zeros(lam.size, dtype=bool)
    for photo in photos:
        union |= photo.reading.readout.valid
    core = (lam >= 400) & (lam <= 700)
    return float(np.mean(union[core])), union, lam


def _name(photo: PhotoReading) -> str:
    return Path(str(photo.image.path)).name or "a photo"


def _spans(ranges: Sequence[tuple[float, float]]) -> str:
    return ", ".join(f"{lo:.0f}–{hi:.0f} nm" for lo, hi in ranges) or "nothing"


def joint_confidence(photos: Sequence[PhotoReading], spd: NDArray[np.float64], presets: Sequence[Preset],
                     calibration: Calibration | None, fits: Sequence[PhotoFit]
                     ) -> tuple[float, list[str], dict[str, Any], list[tuple[float, list[str], dict]]]:
    """(confidence, warnings, joint checks, each photo's (confidence, warnings, checks)).

    One photo: exactly its own checks. Several: each photo's checks without coverage, averaged
    with each photo's say in the solve (its weight × its valid features), times the single
    estimate's coverage factor for the union and the squared share of the features that kept
    their full say; warnings every photo shares are said once, the
    others name their photo."""
    if len(photos) == 1:
        own = photo_checks(photos[0], spd, presets[0], calibration)
        return own[0], list(own[1]), own[2], [own]
    each = [photo_checks(p, spd, preset, calibration, coverage_check=False) for p, preset in zip(photos, presets)]
    say = np.array([f.weight * float(np.sum(p.reading.readout.valid)) for p, f in zip(photos, fits)])
    scores = np.array([c for c, _, _ in each])
    score = float(np.sum(say * scores) / np.sum(say)) if np.sum(say) > 0 else float(np.min(scores))
    # The share of the photos' features that agree with the joint SPD (full say), squared like
    # the coverage factor: each photo's own checks hardly see a photo of another lamp, whose
    # say the solve has cut (with a warm bulb's photo among two of an LED, the checks averaged
    # 0.99 while the MAE rose from 0.013 to 0.053; tests/test_joint_estimate.py).
    bins = np.array([float(np.sum(p.reading.readout.valid)) for p in photos])
    agreement = float(np.sum(say) / np.sum(bins)) if np.sum(bins) > 0 else 0.0
    score *= max(0.1, agreement * agreement)
    coverage, union, lam = union_coverage(photos)
    warnings: list[str] = []
    if coverage < COVERAGE_OK:
        missing = covered_ranges(~union, lam, 400.0, 700.0)
        warnings.append(f"only {100 * coverage:.0f}% of 400–700 nm is visible in the {len(photos)} photos together "
                        f"(missing: {_spans(missing)}) — add a photo whose rainbow covers that, with the camera or "
                        "lamp placed elsewhere (see the capture guide)")
        score *= max(0.1, coverage * coverage)
    shared = set.intersection(*(set(w) for _, w, _ in each))
    warnings += [w for w in each[0][1] if w in shared]
    for photo, fit, (_, own_warnings, _) in zip(photos, fits, each):
        name = _name(photo)
        if fit.inconsistent or fit.weight < 1.0:
            say = f"; it was given {fit.weight:.2f} of a photo's say" if fit.weight < 1.0 else ""
            warnings.append(f"{name}: the joint spectrum does not reproduce it (residual {100 * fit.residual:.1f}% "
                            f"against {100 * fit.alone:.1f}% on its own) — it may show another lamp, or its capture "
                            f"was misfitted{say}")
        if fit.brightness_outlier:
            factor = fit.brightness if fit.brightness > 1 else 1.0 / fit.brightness
            warnings.append(f"{name} reads {factor:.0f}× {'brighter' if fit.brightness > 1 else 'dimmer'} than the "
                            "other photos for the same spectrum: fine if its exposure was changed that much, otherwise "
                            "it shows another lamp or lamp distance, or its capture was misfitted")
        warnings += [f"{name}: {w}" for w in own_warnings if w not in shared]
    stats = {"coverage_400_700": coverage,
             "profile_residual": float(max(f.residual for f in fits)),
             "photos_used": len(photos),
             "inconsistent_photos": int(sum(f.inconsistent or f.weight < 1.0 for f in fits)),
             "agreement": agreement}
    return float(np.clip(score, 0.0, 1.0)), warnings, stats, each


def photo_entry(photo: PhotoReading, preset: Preset, fit: PhotoFit, checks: tuple[float, list[str], dict],
                scale: float, load_ms: float) -> dict[str, Any]:
    """What the result's ``joint.photos`` says about one photo that was read."""
    reading = photo.reading
    readout, pose = reading.readout, reading.fit
    camera_deg, lamp_deg, _ = capture_angles(reading.scene)
    return {
        "source": str(photo.image.path), "used": fit.weight > 0 and scale > 0, "refused": None,
        "brightness": fit.brightness, "scale": float(scale), "weight": fit.weight,
        "coverage_nm": [[lo, hi] for lo, hi in covered_ranges(readout.valid, readout.lambda_nm)],
        "coverage_400_700": float(checks[2].get("coverage_400_700", 0.0)),
        "residual": fit.residual, "residual_alone": fit.alone, "inconsistent": fit.inconsistent,
        "confidence": float(checks[0]), "warnings": list(checks[1]), "checks": checks[2],
        "camera": photo.camera, "preset": preset.name,
        "pose": {"center_px": list(photo.image.to_original(*pose.center_px)), "distance_mm": float(pose.distance_mm),
                 "camera_angle_deg": float(camera_deg), "lamp_angle_deg": float(lamp_deg),
                 "lobe_sigma": float(pose.lobe_sigma), "geometry_residual": float(pose.residual),
                 "rainbow_contrast": float(pose.rainbow_contrast), "strategy": pose.strategy,
                 "focal_px_source": reading.focal_source},
        "disc": disc_fit(photo, preset).to_json(),
        "timing_ms": {"load": load_ms, **reading.timing_ms},
    }
