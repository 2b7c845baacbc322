"""Several photos of one lamp → one SPD (``estimate --joint``).

A θ sweep, the frames of a GIF or a video, photos from several positions: each photo shows a
different stretch of 400–700 nm at its own brightness, so together they cover more, with less
noise, than any one of them. Each photo goes through the product's own stages
(:func:`.estimate.read_image`: camera, pose, readout), the next one loading in the background
(:func:`.batch.prefetched`); photos the stages refuse are reported, not fatal, unless none is
read. A photo whose first order holds too little of 400–700 nm for a reading of its own is read
all the same and used for the stretch it holds, so long as the photos together hold enough
(:data:`PART_MIN_COVERAGE_NM`). The spectrum stage then solves one SPD from all readouts at
once, each photo at its own fitted brightness (:func:`.stages.joint_spectrum`, :mod:`..spectrum.joint`); the learned model
reads each photo, and its per-photo answers are averaged by their uncertainty
(:func:`.stages.network_estimate`) before the same fusion as for one photo. A photo the joint
SPD does not reproduce is given less say and the SPD solved again (:mod:`.joint_checks`).

One photo gives exactly the single estimate (plus the ``joint`` field).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..calibration.calibration import Calibration
from ..errors import CDSpectraError, NoDiscError, PhotoError
from ..photo.images import LinearImage
from ..rendition.result import rendition as rendition_figures
from ..pose.result import PoseFit
from ..scene.capture import DEFAULT_PRESET, Preset, load_preset
from ..spectra.colour import DEFAULT_WORKING_SPACE
from ..spectrum.model import SpectralModel
from .batch import frame_file, prefetched, series_lenses
from .estimate import AUTO, PhotoReading, estimate_result, read_image, resolved_calibration, resolved_model
from .joint_checks import joint_confidence, photo_entry, settled_spectrum
from .result import METHOD_MODEL, Estimate
from .stages import MIN_COVERAGE_NM, OPERATING_POINTS, covered_nm

Progress = Callable[[float, str], None]
# What a photo of the set may fail with and still leave the others: the photo's own content or
# file. Anything else (an unknown camera, a broken model, a bug) concerns every photo.
REFUSALS = (PhotoError, NoDiscError, OSError)

# A photo whose first order shows less of 400–700 nm than MIN_COVERAGE_NM is refused alone: its
# spectrum would be mostly the prior's guess. Among photos of the same lamp its stretch is sound
# data - its rainbow was found, so its pose is fitted, and the others supply the rest - so it is
# read down to this (the readout's own minimum: MIN_VALID_BINS bins of 5 nm) and used; the photos
# together must still hold MIN_COVERAGE_NM. One photo alone is held to MIN_COVERAGE_NM.
PART_MIN_COVERAGE_NM = 50.0

__all__ = ["estimate_joint", "REFUSALS", "PART_MIN_COVERAGE_NM"]


def _presets(preset: str | Preset | Sequence[str | Preset], count: int) -> list[Preset]:
    if isinstance(preset, (str, Path, Preset)):
        one = preset if isinstance(preset, Preset) else load_preset(preset)
        return [one] * count
    presets = [p if isinstance(p, Preset) else load_preset(p) for p in preset]
    if len(presets) != count:
        raise CDSpectraError(f"{len(presets)} presets for {count} photos: give one preset, or one per photo")
    return presets


def _length(stretches: Sequence[tuple[float, float]]) -> float:
    return float(sum(b - a for a, b in stretches))


def _spans(stretches: Sequence[tuple[float, float]]) -> str:
    return ", ".join(f"{a:.0f}–{b:.0f} nm" for a, b in stretches) or "none of 400–700 nm"


def _union(held: Sequence[Sequence[tuple[float, float]]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for lo, hi in sorted(s for stretches in held for s in stretches):
        if out and lo <= out[-1][1] + 1e-6:
            out[-1] = (out[-1][0], max(out[-1][1], hi))
        else:
            out.append((lo, hi))
    return out


def _name(photo: PhotoReading) -> str:
    return Path(str(photo.image.path)).name or "a photo"


def _refusal(source: str, error: BaseException) -> dict[str, Any]:
    message = str(error)
    name = Path(source).name or source
    return {"source": source, "used": False, "refused": message if name in message else f"{name}: {message}"}


def estimate_joint(
    photos: Sequence[str | Path | LinearImage],
    *,
    preset: str | Preset | Sequence[str | Preset] = DEFAULT_PRESET,
    camera: str = AUTO,
    calibration: str | Calibration | None = None,
    working_space: str = DEFAULT_WORKING_SPACE,
    model: SpectralModel | None | str = "shipped",
    progress: Progress | None = None,
    method: str = METHOD_MODEL,
    fusion: tuple[float, float] | None = None,
    fits: Sequence[PoseFit | None] | None = None,
    rendition: bool = True,
) -> Estimate:
    """One SPD from several photos (paths or loaded images) of the same lamp.

    ``preset``: one for every photo, or one per photo; ``camera`` is resolved per photo (``auto``:
    each photo's EXIF); ``fits`` skip the pose fit per photo (tests, evaluations); ``rendition=False`` skips
    the colour-rendition figures. The result is
    the single estimate's, its disc and capture fields the reference photo's (the one with the
    most features), with ``extra["joint"]``: every photo given, read or refused, with its pose,
    fitted brightness, say, coverage, the stretch of 400–700 nm its first order holds
    (``held_nm``; ``partial``: why that is too little alone), residual and checks. Raises
    CDSpectraError where no photo is read (the photo's own error, for one photo), or where the
    photos together hold less than a reading needs.
    """
    if method not in OPERATING_POINTS:
        raise CDSpectraError(f"unknown method {method!r}; known: {', '.join(OPERATING_POINTS)}")
    if not photos:
        raise CDSpectraError("no photos to estimate from")
    t0 = time.perf_counter()
    report = progress or (lambda _f, _m: None)
    presets = _presets(preset, len(photos))
    mdl, cal = resolved_model(model), resolved_calibration(calibration)
    read: list[PhotoReading] = []
    read_presets: list[Preset] = []
    load_ms: list[float] = []
    entries: list[dict[str, Any] | int] = []  # a refusal, or the index of a photo read
    errors: list[BaseException] = []
    total = len(photos)
    least = MIN_COVERAGE_NM if total == 1 else PART_MIN_COVERAGE_NM
    lenses = series_lenses(photos, presets)
    for k, loaded in enumerate(prefetched(photos, presets)):
        report(0.8 * k / total, f"photo {k + 1} of {total}: {Path(loaded.source).name}")
        try:
            if loaded.error is not None:
                raise loaded.error
            assert loaded.image is not None
            photo = read_image(loaded.image, presets[k], camera, cal, mdl, fit=None if fits is None else fits[k],
                               min_coverage_nm=least, series_focal=lenses.get(frame_file(photos[k])))
        except REFUSALS as exc:
            errors.append(exc)
            entries.append(_refusal(loaded.source, exc))
            continue
        entries.append(len(read))
        read.append(photo)
        read_presets.append(presets[k])
        load_ms.append(loaded.load_ms)
    if not read:
        if total == 1:
            raise errors[0]
        reasons = "; ".join(str(e["refused"]) for e in entries if isinstance(e, dict))
        raise PhotoError(f"none of the {total} photos could be read: {reasons}")
    held = [covered_nm(p.reading.uncalibrated) for p in read]  # each photo's first order in 400–700 nm
    union = _union(held)
    if _length(union) < MIN_COVERAGE_NM:  # only where several were given: one photo is refused alone
        each_ = "; ".join([f"{_name(p)} holds {_spans(h)}" for p, h in zip(read, held)]
                          + [str(e["refused"]) for e in entries if isinstance(e, dict)])
        raise PhotoError(f"the {total} photos together hold only {_spans(union)} of 400–700 nm in the first order "
                         f"({_length(union):.0f} nm; a reading needs {MIN_COVERAGE_NM:.0f} nm): {each_}")
    partial = [None if _length(h) >= MIN_COVERAGE_NM else
               f"{_name(p)} holds only {_spans(h)} of 400–700 nm in the first order ({_length(h):.0f} nm): too "
               f"little for a reading of its own (that needs {MIN_COVERAGE_NM:.0f} nm), used for that stretch"
               for p, h in zip(read, held)]
    report(0.8, "Solving for the spectrum")
    t2 = time.perf_counter()
    result, fits_ = settled_spectrum(read, method, mdl, fusion)
    t3 = time.perf_counter()
    report(0.9, "Colour")
    confidence, warnings, stats, each = joint_confidence(read, result.spd, read_presets, cal, fits_)
    refused = [e for e in entries if isinstance(e, dict)]
    warnings = [f"left out {e['refused']}" for e in refused] + [n for n in partial if n] + warnings
    ref = result.solved.reference if result.solved is not None and result.solved.reference >= 0 else 0
    timing: dict[str, float] = {"load": sum(load_ms)}
    for p in read:
        for key, value in p.reading.timing_ms.items():
            timing[key] = timing.get(key, 0.0) + value
    timing["spectrum"] = (t3 - t2) * 1e3
    cameras = sorted({p.camera for p in read})
    estimate = estimate_result(read[ref], result, confidence, warnings, stats, read_presets[ref], cal, mdl, method,
                               working_space, timing, camera=", ".join(cameras))
    photos_json = [e if isinstance(e, dict) else
                   {**photo_entry(read[e], read_presets[e], fits_[e], each[e], float(result.scales[e]), load_ms[e]),
                    "held_nm": [list(s) for s in held[e]], "partial": partial[e]}
                   for e in entries]
    estimate.extra["joint"] = {
        "photos": photos_json, "given": total, "used": sum(1 for e in photos_json if e["used"]),
        "refused": len(refused), "reference": str(read[ref].image.path),
        "coverage_400_700": stats.get("coverage_400_700"), "held_nm": [list(s) for s in union],
        "brightness_rounds": 0 if result.solved is None else result.solved.rounds,
        "brightness_converged": True if result.solved is None else result.solved.converged,
    }
    t4 = time.perf_counter()
    estimate.rendition = rendition_figures(estimate.spd, estimate.spd_std) if rendition else None
    t5 = time.perf_counter()
    estimate.timing_ms.update({"colour": (t4 - t3) * 1e3, **({"rendition": (t5 - t4) * 1e3} if rendition else {}),
                               "total": (t5 - t0) * 1e3})
    report(1.0, "Done")
    return estimate
