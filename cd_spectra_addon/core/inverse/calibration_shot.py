"""Calibration shots through the product's own inverse path: photos of known lamps → gains.

Kept apart from :mod:`.calibration` (the profile data, its fit and its files) because it runs
the estimator's stages — :func:`.stages.read_photo` — which themselves apply calibrations:
the same pose fit, masks, focal length and "no rainbow" refusal as an estimate, so a photo that
could not be estimated cannot become a calibration either. One shot or several (lamps of
different colours, same camera, disc and set-up): one implementation, :func:`fit_shots`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .stages import Reading, read_photo
from ..calibration.calibration import (PIPELINE_GAIN_LIMITS, PIPELINE_MIN_SIGNAL, PIPELINE_SMOOTH_BINS, Calibration, fit_gains,
                          new_metadata, save_calibration, unexplained_share)
from ..calibration.camera_fit import CameraPrior, fit_sensitivities
from ..calibration.camera_pipeline import FAMILY, CameraPipeline, PipelineFit, fit_pipeline, fit_pipeline_checked
from ..spectra.cameras import GENERIC_CAMERA, CameraProfile
from ..scene.capture import DEFAULT_PRESET, Preset, load_preset
from ..errors import CDSpectraError, NoDiscError
from .load import load_for_estimate
from .estimate import AUTO, camera_prior_for, estimate_image, resolve_camera, resolved_model
from ..spectra.colour import compare_spds
from ..readout.forward_matrix import feature_matrix
from ..photo.clipping import clipped_channels
from ..photo.images import LinearImage
from ..spectrum.model import load_model
from ..spectra.grid import WAVELENGTHS_NM

# In-camera file of a camera without a profile: rounds of (processing, sensitivities). Phone HEIC
# of cameras unlike the 52, 30 synthetic SPDs (`camera_files --synthetic`): MAE 0.133 / 0.081 /
# 0.076 / 0.070 / 0.076 after 1 / 3 / 5 / 8 / 16 rounds; ~0.1 s a round for a 192-px photo.
PIPELINE_CAMERA_ROUNDS = 8
# One in-camera calibration shot is posed again on its values with the processing fitted so far
# undone, up to POSE_ROUNDS times; a round's pose replaces the one before only where its
# processing leaves at most POSE_GAIN of that one's RMS on the shot
# (:attr:`.camera_pipeline.PipelineFit.rms_codes`). Posed on the file's tone-curved values alone,
# a CIE A JPEG (Canon profile, `typical` rendering, 192 px read from a photo 2× or 4× that per
# side) sometimes takes a wrong capture: draw 99 put the lamp 5 mm nearer the disc (205 for
# 210 mm, from a start its lines suggested), others the lamp too large (lobe σ 0.0036–0.0040 for
# 0.0030); its processing then fitted 5.8–6.1 codes RMS (3.5–3.7 with the lamp too large)
# against 2.8–3.3 (2.98 on the true capture), and estimates with it read MAE 0.04–0.12 against
# 0.01 — the three far-worse JPEG rows of bench/camera_files.md were that draw. Posed again they
# fit 2.8–3.2 codes and read 0.007–0.013 (4 lamps).
# POSE_GAIN, chosen on synthetic shots only (CIE A; the typical and 4 sampled renderings of the
# calibration's family × JPEG 4:2:0 / 4:2:2 / HEIC, 2× and 4×, 2 draws; and draws 99–106 of the
# typical rendering's three formats; 64 shots): the best re-posed RMS over the
# found one was 0.91–1.06 where the found pose was right (noise), 0.43–0.85 where it was wrong.
# Taking every lower RMS instead (no margin) moved held-out renderings of bench/camera_files.md's
# camera_renderings section by up to 5× (a processing outside the family misleads the undone
# values): a round must be clearly better.
POSE_ROUNDS = 2
POSE_GAIN = 0.88

__all__ = ["POSE_ROUNDS", "POSE_GAIN", "Shot", "LampPhoto", "fit_calibration", "fit_shots", "calibrate_shots",
           "cross_check", "gains_from_image", "measure_calibration",
           "measure_shots", "calibrate_photo", "calibrate_photos"]


@dataclass(frozen=True)
class Shot:
    """One loaded calibration photo and the SPD (any scale) of the known lamp that lit it."""

    image: LinearImage
    spd: NDArray[np.float64]


@dataclass(frozen=True)
class LampPhoto:
    """A calibration photo file, its known lamp's SPD and that lamp's name (for the profile)."""

    path: str | Path
    spd: NDArray[np.float64]
    lamp: str = ""


def _label(image: LinearImage, k: int, n: int) -> str:
    """How messages name a shot: its file, else its place among the shots."""
    return image.path or ("the calibration photo" if n == 1 else f"calibration photo {k + 1}")


def _check_reference(reference_spd: NDArray[np.float64], where: str = "") -> NDArray[np.float64]:
    ref = np.asarray(reference_spd, dtype=np.float64)
    if ref.shape != WAVELENGTHS_NM.shape or not np.all(np.isfinite(ref)) or ref.max() <= 0 or ref.min() < 0:
        raise CDSpectraError(f"{where}{': ' if where else ''}the known lamp's spectrum must be 81 finite, "
                             "non-negative values on 380–780 nm")
    return ref


def _check_alike(shots: Sequence[Shot], pipeline: bool | None) -> None:
    """Shots of one camera, all in-camera renderings or none: else the profile would mix two."""
    n = len(shots)
    first = shots[0].image
    for k, shot in enumerate(shots[1:], 1):
        image = shot.image
        names = [" ".join(p for p in (i.exif.make, i.exif.model) if p).strip() for i in (first, image)]
        if all(names) and names[0].lower() != names[1].lower():
            raise CDSpectraError(f"{_label(image, k, n)}: taken with {names[1]}, but {_label(first, 0, n)} with "
                                 f"{names[0]} — a calibration is of one camera: take every shot with it")
        if pipeline is None and image.processed != first.processed:
            kinds = ("an in-camera rendering (JPEG/HEIC)", "a camera-native file")
            raise CDSpectraError(f"{_label(image, k, n)} is {kinds[not image.processed]} but {_label(first, 0, n)} "
                                 f"is {kinds[not first.processed]} — take every shot in the same format and settings")


def _read(shot: Shot, k: int, n: int, preset: Preset, camera: CameraProfile, generic_camera: bool,
          undo: Calibration | None = None, processed: bool = False) -> Reading:
    """One shot posed and read (on its values with ``undo``'s processing undone, when given);
    with several, a refusal names the file it is about. A refused in-camera shot (``processed``,
    or read through ``undo``) is told its colours may be the cause: the fit places wavelengths by
    the rainbow's colours, which the camera's processing — not known yet, or known only from the
    first shot — moves (a phone's D65 shot through the Canon D30's real rendering was told to move
    the lamp closer, the set-up being the preset's; bench/camera_files.md)."""
    where = "" if n == 1 else _label(shot.image, k, n)
    prefix = "" if not where else where + ": "
    try:
        return read_photo(shot.image, preset, camera, generic_camera=generic_camera, calibration=undo)
    except NoDiscError as exc:
        caution = ""
        if (processed or shot.image.processed or undo is not None) and "camera-processed" not in str(exc):
            so_far = ", with the processing fitted from the first shot undone," if undo is not None else ""
            caution = (f" (a camera-processed shot: its colours{so_far} can mislead the fit and that advice — "
                       "shoot RAW, or fix the white balance and turn off picture styles)")
        raise NoDiscError(f"{'' if where in str(exc) else prefix}{exc}{caution} — calibration needs a photo of the "
                          "disc lit by the known lamp, taken like the later photos") from exc
    except CDSpectraError as exc:
        if not where or where in str(exc):
            raise
        raise CDSpectraError(f"{prefix}{exc}") from exc


def _pixel_pairs(image: LinearImage, reading: Reading, camera: CameraProfile, ref: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], ...]:
    """(observed, predicted, low, high) per rainbow pixel: the file's values, the camera-native
    RGB the forward model predicts for the known lamp (bin value × the pixel's amplitude), and
    the channels the camera clipped (bounds)."""
    readout = reading.uncalibrated
    predicted = np.einsum("bcl,l->bc", feature_matrix(reading.response, camera), ref)
    bins = readout.pixel_bin
    index = readout.pixels.index
    low, high = (m.reshape(-1, 3)[index] for m in clipped_channels(image.rgb, image.saturated))
    # Pixels the readout left out as saturated are read too: their clipped channels are bounds.
    use = readout.valid[bins] & ((readout.pixel_weight > 0) | np.asarray(image.saturated).reshape(-1)[index])
    observed = np.asarray(image.rgb, np.float64).reshape(-1, 3)[index]
    return observed[use], predicted[bins[use]] * readout.pixels.amplitude[use, None], low[use], high[use]


def _exposure(pipeline: CameraPipeline, pairs: tuple[NDArray[np.float64], ...], where: str) -> float:
    """A shot's exposure in ``pipeline``'s native units: least squares of the file's values,
    undone, on the prediction, over the pixels with no clipped channel."""
    observed, predicted, low, high = pairs
    ok = ~np.any(low | high, axis=1)
    native, p = pipeline.to_native(observed[ok]), predicted[ok]
    e = float(np.sum(native * p) / max(float(np.sum(p * p)), 1e-300))
    if not (np.isfinite(e) and e > 0):
        raise CDSpectraError(f"{where}: its colours do not match its known lamp at all — is it the right lamp?")
    return e


def _undo(pipeline: CameraPipeline, preset: Preset, camera: CameraProfile, bins: int) -> Calibration:
    """A calibration that only undoes ``pipeline`` (gains 1)."""
    return Calibration("pipeline", np.ones((bins, 3)), preset.name, camera.name, {}, pipeline)


def _fit_processing(shots: Sequence[Shot], readings: Sequence[Reading], camera: CameraProfile,
                    refs: Sequence[NDArray[np.float64]], fitted: CameraPipeline | None,
                    basis: CameraPipeline | None = None, judge: bool = True, noise_weighted: bool = True
                    ) -> PipelineFit:
    """The in-camera processing from every shot's pixel pairs at once, with how well it fits them. Each shot has its own
    exposure: the later shots' predictions are put in the first's units through the processing
    fitted so far (at the start, ``basis``: the first shot's alone), then all pairs are fitted together.
    ``judge``: the rendering family's members are tried (else only the member ``fitted`` has, or
    the per-channel, clipping one); ``noise_weighted``: :func:`.camera_pipeline.fit_pipeline_checked`'s."""
    if judge:
        family = FAMILY
    else:  # later rounds refit the member chosen
        family = () if fitted is None else ((fitted.tone, fitted.gamut),)
    pairs = [_pixel_pairs(s.image, r, camera, ref) for s, r, ref in zip(shots, readings, refs)]
    if len(pairs) > 1:
        basis = fitted or basis or fit_pipeline(pairs[0][0], pairs[0][1], low=pairs[0][2], high=pairs[0][3],
                                                family=family, noise_weighted=noise_weighted)
        n = len(shots)
        e0 = _exposure(basis, pairs[0], _label(shots[0].image, 0, n))
        pairs = [(o, p * (_exposure(basis, (o, p, lo, hi), _label(shots[k].image, k, n)) / e0), lo, hi)
                 for k, (o, p, lo, hi) in enumerate(pairs)]
    observed, predicted, low, high = (np.concatenate(part) for part in zip(*pairs))
    return fit_pipeline_checked(observed, predicted, low=low, high=high, family=family, noise_weighted=noise_weighted)


def _posed_on_processing(shots: Sequence[Shot], firsts: list[Reading], preset: Preset, camera: CameraProfile,
                         generic_camera: bool, refs: Sequence[NDArray[np.float64]], judge: bool = True,
                         noise_weighted: bool = True) -> tuple[PipelineFit, list[Reading]]:
    """The first shot's processing and the shots' poses to calibrate with (``firsts[0]``: the
    first shot read on its file's values).

    One shot: the pose found on the file's values, and its processing; then, up to
    :data:`POSE_ROUNDS` times, the shot posed again on its values with that processing undone
    (as a later photo calibrated by it is posed) and the processing refitted — kept only where
    it leaves at most :data:`POSE_GAIN` of the RMS of the pose it would replace (a clearly better
    fit: a wrong pose, not noise), the rounds stopping at the first that is not.
    Several shots (as before): the first's processing as found, every shot posed once on its
    values with it undone (a D65 JPEG posed as found fitted worse than CIE A's; see
    :func:`fit_shots`)."""
    n = len(shots)
    found = _fit_processing(shots[:1], firsts[:1], camera, refs[:1], None, judge=judge, noise_weighted=noise_weighted)
    bins = firsts[0].response.shape[0]
    if n > 1:
        undo = _undo(found.pipeline, preset, camera, bins)
        return found, [_read(s, k, n, preset, camera, generic_camera, undo) for k, s in enumerate(shots)]
    best = (found, firsts)
    for _ in range(POSE_ROUNDS):
        try:
            undo = _undo(best[0].pipeline, preset, camera, bins)
            posed = [_read(shots[0], 0, 1, preset, camera, generic_camera, undo)]
            candidate = _fit_processing(shots[:1], posed, camera, refs[:1], None, judge=judge,
                                        noise_weighted=noise_weighted)
        except CDSpectraError:
            break  # posed on undone values, the disc was lost: keep what was found
        if not candidate.rms_codes <= POSE_GAIN * best[0].rms_codes:
            break
        best = (candidate, posed)
    return best


def fit_shots(shots: Sequence[Shot], preset: Preset, camera: CameraProfile, generic_camera: bool = False,
              pipeline: bool | None = None, prior: CameraPrior | None = None, name: str = "calibration",
              metadata: dict[str, Any] | None = None) -> tuple[Calibration, list[Reading]]:
    """The calibration one or more loaded photos of known lamps give (same camera, disc and
    set-up; lamps of different colours sample the camera where one lamp cannot), and each
    photo's analysis with it.

    In order: for in-camera files (``pipeline`` None: when the loader judged them processed) the
    camera's matrix and tone curve (:func:`.camera_pipeline.fit_pipeline`, every shot's pixels
    together), which later photos then have undone before their readout; with a camera ``prior``
    the camera's own sensitivities (:func:`.camera_fit.fit_sensitivities`, every shot: for the
    generic profile, which is nobody's camera); last, per-bin gains for what is left, over every
    shot's bins (:func:`.calibration.fit_gains`). Each shot is posed and read on its own."""
    if not shots:
        raise CDSpectraError("a calibration needs at least one photo of a known lamp")
    n = len(shots)
    refs = [_check_reference(s.spd, _label(s.image, k, n) if n > 1 else "") for k, s in enumerate(shots)]
    _check_alike(shots, pipeline)
    processed = shots[0].image.processed if pipeline is None else pipeline
    # In-camera files: only the first is read on the file's values; the others are read with its
    # processing undone (as later photos are), which is all the calibration uses of them. Read as
    # found as well, each cost a pose fit, and a phone's D65 JPEG (generic profile, the
    # calibration's typical rendering, 192 px) lost its rainbow there and refused the calibration
    # over a reading it never used. (That pair is still refused, later: its processing fit finds
    # the bulb's colours unlike CIE A.)
    firsts = [_read(s, k, n, preset, camera, generic_camera, processed=processed)
              for k, s in enumerate(shots[:1] if processed else shots)]
    basis, chosen = None, None
    total = PIPELINE_CAMERA_ROUNDS if processed and prior is not None else 1
    # With the camera's sensitivities fitted too, the rendering family (camera_pipeline.FAMILY) is
    # judged in the last round only, on the camera's own fitted colours; the rounds before it fit
    # the per-channel, clipping member. Judged in the first round, on the generic profile's
    # colours, a member that absorbs their error won: the typical (per-channel, clipping)
    # rendering of the Foveon and the Pentax Q took a luminance curve in some calibration draws,
    # and camera_files' phone HEIC of cameras unlike the 52 + CIE A read MAE 0.051 mean over 9
    # draws against 0.038 before the family existed (8a2b7eb); 30 synthetic lamps
    # (`camera_files --synthetic`, 3 draws): 0.0779 -> 0.0602 median with the judge deferred.
    # The cost: the rounds before the last bend the fitted sensitivities towards the per-channel
    # member, so a true luminance curve no longer wins there either — the held-out `luma-curve`
    # rendering of the N900 (camera_renderings) is now read through a per-channel curve (its
    # processing RMS 3.4 codes against 3.55 with the luminance curve), CIE A + D65 0.026 -> 0.036,
    # while `curve-first` (a per-channel curve) no longer takes a luminance one: 0.035 -> 0.030.
    # One shot of a camera with free sensitivities barely tells the two curves apart.
    deferred = total > 1
    # Nor, then, is the processing refitted between linear values weighted by the measured noise
    # (camera_pipeline.fit_pipeline_checked's noise_weighted): against the generic profile's
    # colours the residual it measures is that profile's error, not noise. Weighted in every
    # round, camera_files' phone HEIC of cameras unlike the 52 + CIE A (`--synthetic`, 3 draws)
    # read MAE 0.201 against 0.047, four of its photos refused.
    if processed:
        # Several in-camera files: each is posed again on its values with the first's processing
        # undone, as a later photo calibrated by it is (one shot: only where that fits it clearly
        # better, :func:`_posed_on_processing`). A tone curve bends the
        # rainbow's profile: posed as found, a simulated D65 JPEG (`ordinary` rendering, Canon
        # profile, 192 px) fitted worse than CIE A's in 4 of 6 noise draws (pose residual
        # 0.057–0.063 against 0.048; one took the lamp for one 4.5× too large), its calibration
        # leaving 1.9–3.2 % unexplained against 0.5 %; that draw posed on undone values: residual
        # 0.005, 0.6 % with CIE A. One CIE A shot: see POSE_ROUNDS.
        chosen, firsts = _posed_on_processing(shots, firsts, preset, camera, generic_camera, refs, judge=not deferred,
                                              noise_weighted=not deferred)
        basis = chosen.pipeline
    analyses, own = list(firsts), camera
    fitted, sensitivities, fit_check = None, None, chosen
    # With both to fit, alternately: the processing fitted against the generic camera's colours
    # bends its tone curve to absorb their error, which the camera's own fitted sensitivities
    # then undo round by round (see PIPELINE_CAMERA_ROUNDS).
    # A round that fails after the first keeps the round before it: a phone's CIE A + D65 JPEGs
    # (generic profile, the calibration's typical rendering, 95 % of the rainbow's pixels with a
    # clipped channel) drifted round by round until the bulb's undone values came out negative and
    # the calibration was refused as "is it the right lamp?" (see ``rounds`` in the metadata).
    rounds, previous = 0, None
    for r in range(total):
        try:
            if processed:
                judge = r == total - 1 if deferred else fitted is None
                if n == 1 and fitted is None and chosen is not None:
                    fit_check = chosen  # the first shot's processing on its poses: already fitted
                else:
                    fit_check = _fit_processing(shots, firsts, own, refs, fitted, basis, judge=judge,
                                                noise_weighted=not deferred)
                fitted = fit_check.pipeline
                undo = _undo(fitted, preset, camera, firsts[0].response.shape[0])
                analyses = [read_photo(s.image, preset, camera, generic_camera=generic_camera, calibration=undo,
                                       fit=first.fit, known_spd=ref) for s, first, ref in zip(shots, firsts, refs)]
            if prior is not None:
                sensitivities = fit_sensitivities([a.uncalibrated for a in analyses], [a.response for a in analyses],
                                                  refs, prior)
                own = CameraProfile(camera.name, sensitivities)
        except CDSpectraError:
            if previous is None:
                raise
            fit_check, fitted, analyses, sensitivities, own = previous
            break
        rounds += 1
        previous = (fit_check, fitted, analyses, sensitivities, own)
    if sensitivities is not None:
        analyses = [replace(a, posed=replace(a.posed, camera=own), matrix=feature_matrix(a.response, own))
                    for a in analyses]
    predicted = np.stack([np.einsum("bcl,l->bc", a.matrix, ref) for a, ref in zip(analyses, refs)])
    values = np.stack([a.uncalibrated.values for a in analyses])
    valid = np.stack([a.uncalibrated.valid for a in analyses])
    limits = {} if fitted is None else {"min_signal": PIPELINE_MIN_SIGNAL, "limits": PIPELINE_GAIN_LIMITS,
                                           "smooth_bins": PIPELINE_SMOOTH_BINS}
    gains = fit_gains(values, valid, predicted, **limits)
    meta = {**dict(metadata or {}), "unexplained": round(unexplained_share(values, valid, predicted), 4)}
    if fit_check is not None:  # how well the processing explains the shots' pixels, 8-bit codes RMS
        meta["processing_rms_codes"] = round(float(fit_check.rms_codes), 2)
    if processed and prior is not None:
        meta["rounds"] = rounds  # of PIPELINE_CAMERA_ROUNDS (processing, sensitivities) kept
    return Calibration(name, gains, preset.name, camera.name, meta, fitted, sensitivities), analyses


def calibrate_shots(shots: Sequence[Shot], preset: Preset, camera: str, model: Any, name: str = "calibration",
                    metadata: dict[str, Any] | None = None, labels: Sequence[str] = ()
                    ) -> tuple[Calibration, list[Reading]]:
    """What ``calibrate`` makes of loaded shots: the camera resolved as an estimate resolves it
    (``camera`` a profile name or "auto"; for the generic profile its sensitivities are fitted),
    :func:`fit_shots`, and with two or more known lamps the leave-one-out :func:`cross_check`
    (``labels`` name the lamps), stored as the calibration's ``cross_check``."""
    if not shots:
        raise CDSpectraError("a calibration needs at least one photo of a known lamp")
    cam, generic, _, _ = resolve_camera(camera, shots[0].image, model)
    prior = camera_prior_for(model) if generic else None
    cal, analyses = fit_shots(shots, preset, cam, generic, prior=prior, name=name, metadata=metadata)
    if len(shots) > 1:
        cal.metadata["cross_check"] = cross_check(shots, preset, cam, generic, prior, camera, model, labels)
    return cal, analyses


def cross_check(shots: Sequence[Shot], preset: Preset, cam: CameraProfile, generic: bool,
                prior: CameraPrior | None, camera: str, model: Any, labels: Sequence[str] = ()
                ) -> list[dict[str, Any]]:
    """Each known lamp read with the calibration the others give, as a later photo is read
    (:func:`estimate_image`), against its known SPD: whether the calibration's model of the
    camera carries over to a lamp it was not fitted on. A calibration explains its own photo by
    construction (a tone curve, gains per bin), so only another lamp can show that it learned
    the lamp instead of the camera. One entry per shot: ``held_out``, ``mae_400_700`` and
    ``delta_uv_prime``, or ``error`` where the others alone could not calibrate or read it."""
    out: list[dict[str, Any]] = []
    n = len(shots)
    for k, shot in enumerate(shots):
        label = labels[k] if k < len(labels) else f"lamp {k + 1}"
        others = [s for j, s in enumerate(shots) if j != k]
        try:
            held_cal, _ = fit_shots(others, preset, cam, generic, prior=prior, name=f"without {label}")
            est = estimate_image(shot.image, preset=preset, camera=camera, calibration=held_cal, model=model,
                                 rendition=False)
        except CDSpectraError as exc:
            out.append({"held_out": label, "error": str(exc)})
            continue
        m = compare_spds(est.spd, shot.spd)
        out.append({"held_out": label, "mae_400_700": round(float(m["mae_400_700"]), 4),
                    "delta_uv_prime": round(float(m["delta_uv_prime"]), 5), "from": n - 1})
    return out


def fit_calibration(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset, camera: CameraProfile,
                    generic_camera: bool = False, pipeline: bool | None = None, prior: CameraPrior | None = None,
                    name: str = "calibration", metadata: dict[str, Any] | None = None
                    ) -> tuple[Calibration, Reading]:
    """The calibration one loaded photo of a known lamp gives, and the photo's analysis with it
    (:func:`fit_shots` with one shot)."""
    cal, analyses = fit_shots([Shot(image, reference_spd)], preset, camera, generic_camera, pipeline, prior, name,
                              metadata)
    return cal, analyses[0]


def gains_from_image(image: LinearImage, reference_spd: NDArray[np.float64], preset: Preset,
                     camera: CameraProfile, generic_camera: bool = False) -> tuple[NDArray[np.float64], Reading]:
    """Per-bin gains only (no pipeline, no fitted camera): for camera-native photos with a
    measured profile, and the gains-only baseline."""
    cal, analysis = fit_calibration(image, reference_spd, preset, camera, generic_camera, pipeline=False)
    return cal.gains, analysis


def _model_if_needed(camera: str) -> Any:
    """The shipped model when the generic profile may be needed (it carries it), else None."""
    if camera == GENERIC_CAMERA:
        return load_model()
    if camera == AUTO:
        try:
            return load_model()
        except CDSpectraError:
            return None  # resolve_camera falls back to the default camera's profile
    return None


def _shipped_or_none() -> Any:
    try:
        return resolved_model("shipped")
    except CDSpectraError:
        return None


def _load(path: str | Path, preset: Preset, n: int) -> LinearImage:
    """A calibration photo loaded as an estimate loads it; with several, a refusal names the file."""
    try:
        return load_for_estimate(path, preset)
    except CDSpectraError as exc:
        if n == 1 or str(path) in str(exc):
            raise
        raise CDSpectraError(f"{path}: {exc}") from exc


def measure_shots(photos: Sequence[LampPhoto], name: str, preset: str = DEFAULT_PRESET, camera: str = ""
                  ) -> Calibration:
    """Calibration ``name`` from photo files of lamps whose SPDs are known (one, or several of
    different colours with the same camera, disc and set-up): the in-camera pipeline when the
    files are in-camera renderings, the camera's own sensitivities when its profile is the
    generic one (the camera is not one of the profiles), then the gains. The profile records
    each photo and its lamp (``shots``)."""
    if not photos:
        raise CDSpectraError("a calibration needs at least one photo of a known lamp")
    n = len(photos)
    for k, p in enumerate(photos):  # before the photos are read: the cheaper mistake first
        _check_reference(p.spd, str(p.path) if n > 1 else "")
    camera = camera or AUTO
    preset_obj = load_preset(preset)
    images = [_load(p.path, preset_obj, n) for p in photos]  # read as the later photos will be
    model = _model_if_needed(camera)
    _, _, camera, _ = resolve_camera(camera, images[0], model)
    lamps = [p.lamp or "reference SPD" for p in photos]
    metadata = new_metadata(" + ".join(str(p.path) for p in photos), " + ".join(lamps))
    if n > 1 and model is None:  # the cross-check reads each lamp as an estimate will: with the shipped model
        model = _shipped_or_none()
    cal, analyses = calibrate_shots([Shot(image, p.spd) for image, p in zip(images, photos)], preset_obj, camera,
                                    model, name=name, metadata=metadata,
                                    labels=[p.lamp or str(p.path) for p in photos])
    cal.metadata["rainbow_contrast"] = float(min(a.fit.rainbow_contrast for a in analyses))
    cal.metadata["shots"] = [{"photo": str(p.path), "reference": lamp,
                              "rainbow_contrast": round(float(a.fit.rainbow_contrast), 4)}
                             for p, lamp, a in zip(photos, lamps, analyses)]
    if cal.pipeline is not None:
        cal.metadata["processed"] = images[0].processed_reason or "fitted on request"
    return replace(cal, camera=camera)


def measure_calibration(path: str | Path, reference_spd: NDArray[np.float64], name: str,
                        preset: str = DEFAULT_PRESET, camera: str = "", reference_name: str = "") -> Calibration:
    """Calibration ``name`` from one photo file of a lamp whose SPD is known (:func:`measure_shots`)."""
    return measure_shots([LampPhoto(path, reference_spd, reference_name)], name, preset, camera)


def calibrate_photos(photos: Sequence[LampPhoto], name: str, preset: str = DEFAULT_PRESET, camera: str = "",
                     directory: Path | None = None) -> Path:
    """Measure this camera + disc + set-up's gains (and, for in-camera JPEG/HEIC, its
    processing; for a camera without a profile, its sensitivities) from photos of lamps whose
    SPDs are known; save as calibration ``name``."""
    return save_calibration(measure_shots(photos, name, preset, camera), directory)


def calibrate_photo(path: str | Path, reference_spd: NDArray[np.float64], name: str, preset: str = DEFAULT_PRESET,
                    camera: str = "", directory: Path | None = None, reference_name: str = "") -> Path:
    """:func:`calibrate_photos` with one photo."""
    return calibrate_photos([LampPhoto(path, reference_spd, reference_name)], name, preset, camera, directory)
