"""Several photos of one lamp → one SPD (``estimate --joint``).

A θ sweep, the frames of a GIF or a video, photos from several positions: each photo shows a
different stretch of 400–700 nm at its own brightness, so together they cover more, with less
noise, than any one of them. Each photo goes through the product's own stages
(:func:`.estimate.read_image`: camera, pose, readout), the next one loading in the background
(:func:`.batch.prefetched`); photos the stages refuse are reported, not fatal, unless none is
read. The spectrum stage then solves one SPD from all readouts at once, each photo at its own
fitted brightness (:func:`.stages.joint_spectrum`, :mod:`..spectrum.joint`); the learned model
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
from ..pose.result import PoseFit
from ..scene.capture import DEFAULT_PRESET, Preset, load_preset
from ..spectra.colour import DEFAULT_WORKING_SPACE
from ..spectrum.model import SpectralModel
from .batch import prefetched
from .estimate import AUTO, PhotoReading, estimate_result, read_image, resolved_calibration, resolved_model
from .joint_checks import joint_confidence, photo_entry, settled_spectrum
from .result import METHOD_MODEL, Estimate
from .stages import OPERATING_POINTS

Progress = Callable[[float, str], None]
# What a photo of the set may fail with and still leave the others: the photo's own content or
# file. Anything else (an unknown camera, a broken model, a bug) concerns every photo.
REFUSALS = (PhotoError, NoDiscError, OSError)

__all__ = ["estimate_joint", "REFUSALS"]


def _presets(preset: str | Preset | Sequence[str | Preset], count: int) -> list[Preset]:
    if isinstance(preset, (str, Path, Preset)):
        one = preset if isinstance(preset, Preset) else load_preset(preset)
        return [one] * count
    presets = [p if isinstance(p, Preset) else load_preset(p) for p in preset]
    if len(presets) != count:
        raise CDSpectraError(f"{len(presets)} presets for {count} photos: give one preset, or one per photo")
    return presets


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
) -> Estimate:
    """One SPD from several photos (paths or loaded images) of the same lamp.

    ``preset``: one for every photo, or one per photo; ``camera`` is resolved per photo (``auto``:
    each photo's EXIF); ``fits`` skip the pose fit per photo (tests, evaluations). The result is
    the single estimate's, its disc and capture fields the reference photo's (the one with the
    most features), with ``extra["joint"]``: every photo given, read or refused, with its pose,
    fitted brightness, say, coverage, residual and checks. Raises CDSpectraError where no photo
    is read (the photo's own error, for one photo).
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
    for k, loaded in enumerate(prefetched(photos, presets)):
        report(0.8 * k / total, f"photo {k + 1} of {total}: {Path(loaded.source).name}")
        try:
            if loaded.error is not None:
                raise loaded.error
            assert loaded.image is not None
            photo = read_image(loaded.image, presets[k], camera, cal, mdl, fit=None if fits is None else fits[k])
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
    report(0.8, "Solving for the spectrum")
    t2 = time.perf_counter()
    result, fits_ = settled_spectrum(read, method, mdl, fusion)
    t3 = time.perf_counter()
    report(0.9, "Colour")
    confidence, warnings, stats, each = joint_confidence(read, result.spd, read_presets, cal, fits_)
    refused = [e for e in entries if isinstance(e, dict)]
    warnings = [f"left out {e['refused']}" for e in refused] + warnings
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
                   photo_entry(read[e], read_presets[e], fits_[e], each[e], float(result.scales[e]), load_ms[e])
                   for e in entries]
    estimate.extra["joint"] = {
        "photos": photos_json, "given": total, "used": sum(1 for e in photos_json if e["used"]),
        "refused": len(refused), "reference": str(read[ref].image.path),
        "coverage_400_700": stats.get("coverage_400_700"),
        "brightness_rounds": 0 if result.solved is None else result.solved.rounds,
        "brightness_converged": True if result.solved is None else result.solved.converged,
    }
    t4 = time.perf_counter()
    estimate.timing_ms.update({"colour": (t4 - t3) * 1e3, "total": (t4 - t0) * 1e3})
    report(1.0, "Done")
    return estimate
