"""Calibration shot: one photo of a known lamp fixes this camera + disc + geometry's gains.

The forward model knows a CD and a camera only approximately: a real disc's groove depth, a
camera unit's channel gains and a few nm of shift in its curves all change the profile by a
smooth factor per λ₁ bin and channel. Photographing a lamp whose SPD is known — a household
incandescent or halogen bulb (≈ CIE A, Planck at 2856 K), daylight, or any SPD a meter measured
— measures that factor directly: gain = measured profile / profile the model predicts for the
known SPD. Stored as a small JSON profile and divided out of later photos' profiles. A second
shot under a lamp of another colour (a bulb and daylight) measures the bins the first leaves dark.
"""

from __future__ import annotations

import json
import math
import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .camera_pipeline import CameraPipeline
from ..atomic_files import write_json
from ..errors import CDSpectraError
from ..spectra.grid import FEATURE_LAMBDA_NM, N_FEATURES, WAVELENGTHS_NM
from ..user_folders import ENV_DIR, calibration_dir, set_default_directory

GAIN_LIMITS = (0.2, 5.0)
MIN_SIGNAL = 0.03  # bins whose predicted signal is below 3 % of the peak keep gain 1
# After an in-camera pipeline is undone, gamut clipping leaves a per-bin bias that is the same
# for every lamp (each λ₁ bin is nearly monochromatic and clipping is homogeneous) but large in
# a weak channel: a clipped negative red at 450 nm reads 11× its true value under CIE A and D65
# alike, and it changes from bin to bin. Such calibrations keep gains down to 0.1 % of the peak,
# within 1/50..50, smoothed over ±1 bin only. Chosen on 16 synthetic SPDs of the training prior
# (`camera_files --synthetic`; in-camera JPEG MAE 0.033 → 0.027, HEIC 0.028 → 0.019 against
# 3 % / ±2 bins), never on the evaluation lamps.
PIPELINE_GAIN_LIMITS = (0.02, 50.0)
PIPELINE_MIN_SIGNAL = 0.001
PIPELINE_SMOOTH_BINS = 1
SMOOTH_BINS = 2  # gains are smoothed over ±2 bins (±10 nm of λ₁)
GAIN_ROUNDS = 20  # several shots: alternations between the gains and each shot's brightness
# How well a calibration explains its own photo: the weighted RMS of (measured − predicted) /
# peak over the bins, the known lamp scaled to the photo, before any gains. Above this the
# model of the camera (its processing, its sensitivities) cannot undo what the photo shows and
# the gains are doing the work for this one lamp only. 3× the worst of the calibration's own
# family (training/simulation/camera_pipelines.py, the typical and three sampled renderings,
# a CIE A shot, 192 px: 0.4–1.5 %; raw files 0.2–0.3 %), never chosen on held-out renderings or lamps.
EXPLAIN_LIMIT = 0.05
POOR_CALIBRATION_CONFIDENCE = 0.6
# Two or more known lamps: each is read with the calibration the others give (the leave-one-out
# cross-check, :func:`..inverse.calibration_shot.cross_check`). Above this MAE 400–700 on a
# held-out known lamp the calibration's model of the camera does not carry over to other lamps.
# Set like EXPLAIN_LIMIT: 3× the worst of the calibration's own family (the typical and three
# sampled renderings of training/simulation/camera_pipelines.py, JPEG 4:2:0 of a CIE A and a D65
# shot, the Canon profile, 192 px, 2 noise draws: 0.012–0.040, one draw 0.088; raw files
# 0.002–0.005; `make eval-cross-check`, bench/cross_check_family.md), never chosen on held-out
# renderings or lamps. Judged only where the camera's
# profile is measured: with the generic profile each lamp alone must also measure the camera's
# sensitivities, which one warm lamp cannot (a phone's own-family JPEGs: D65 read from the bulb's
# calibration 0.10–0.15, the bulb from daylight's 0.09–0.36), so there it is reported, not judged.
CROSS_CHECK_FAMILY_WORST = 0.088
CROSS_CHECK_LIMIT = 3.0 * CROSS_CHECK_FAMILY_WORST

__all__ = ["ENV_DIR", "Calibration", "calibration_dir", "set_default_directory", "fit_gains", "unexplained_share",
           "calibration_warning", "calibration_check", "EXPLAIN_LIMIT", "POOR_CALIBRATION_CONFIDENCE",
           "CROSS_CHECK_LIMIT", "cross_check_worst", "cross_check_summary",
           "save_calibration", "load_calibration", "list_calibrations"]


@dataclass(frozen=True)
class Calibration:
    name: str
    gains: NDArray[np.float64]  # (NB, 3)
    preset: str
    camera: str
    metadata: dict[str, Any]
    # The in-camera processing (white balance, matrix, tone curve) of a JPEG/HEIC calibration
    # shot, undone before the readout of every photo calibrated with it; None for raw/linear.
    pipeline: CameraPipeline | None = None
    # The camera's own (81, 3) sensitivities, fitted from the shot (:mod:`.camera_fit`) when it
    # was made with the generic profile; later photos are solved with them. None: the profile's.
    sensitivities: NDArray[np.float64] | None = None

    def to_json(self) -> dict[str, Any]:
        extra: dict[str, Any] = {} if self.pipeline is None else {"pipeline": self.pipeline.to_json()}
        if self.sensitivities is not None:
            extra["sensitivities"] = np.round(self.sensitivities, 6).tolist()
        return {"name": self.name, "preset": self.preset, "camera": self.camera,
                "feature_lambda_nm": FEATURE_LAMBDA_NM.tolist(), "gains": np.round(self.gains, 6).tolist(),
                **self.metadata, **extra}




def _by_shot(measured: NDArray[np.float64], valid: NDArray[np.bool_], predicted: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.bool_], NDArray[np.float64]]:
    """(S, NB, 3), (S, NB), (S, NB, 3): one shot's (NB, 3) arrays as a stack of one."""
    m, v, p = np.asarray(measured, np.float64), np.asarray(valid, bool), np.asarray(predicted, np.float64)
    return (m[None], v[None], p[None]) if m.ndim == 2 else (m, v, p)


def fit_gains(measured: NDArray[np.float64], valid: NDArray[np.bool_], predicted: NDArray[np.float64],
              min_signal: float = MIN_SIGNAL, limits: tuple[float, float] = GAIN_LIMITS,
              smooth_bins: int = SMOOTH_BINS) -> NDArray[np.float64]:
    """Per-bin, per-channel gains measured / predicted (predicted scaled to the photo first),
    smoothed, limited, and 1 where the known lamp gives too little signal to tell.

    Several shots (arrays (S, NB, 3), ``valid`` (S, NB): lamps of different colours, same camera
    and set-up): a bin's gain is Σ measured / Σ predicted over the shots (and ±``smooth_bins``)
    where each is strong, each shot relative to its peak — so the bins one lamp leaves dark are
    measured by another, and a shot's exposure does not decide its weight. Each shot's
    brightness is refitted to the gains (they tilt a shot's own least-squares scale), so that
    bins measured by different lamps are on one scale. One shot: measured / predicted, as ever."""
    m, v, p = _by_shot(measured, valid, predicted)
    ys, qs, strongs = [], [], []
    for mk, vk, pk in zip(m, v, p):
        ok = vk[:, None] & (pk > 0)
        scale = float(np.sum(mk[ok] * pk[ok]) / max(np.sum(pk[ok] ** 2), 1e-300))
        if scale <= 0:
            raise CDSpectraError("the calibration photo shows no light where the known lamp should")
        pred = pk * scale
        peak = float(pred.max())
        strong = ok & (pred > min_signal * peak)
        ys.append(np.where(strong, mk, 0.0) / peak)
        qs.append(np.where(strong, pred, 0.0) / peak)
        strongs.append(strong)
    strong_any = np.any(strongs, axis=0)
    window = np.ones(2 * smooth_bins + 1)

    def smoothed(rel: list[float]) -> NDArray[np.float64]:
        num, den = sum(y / r for y, r in zip(ys, rel)), sum(qs)
        out = np.ones_like(num)
        for c in range(3):
            n_c = np.convolve(num[:, c], window, mode="same")
            d_c = np.convolve(den[:, c], window, mode="same")
            out[:, c] = np.where(d_c > 0, n_c / np.where(d_c > 0, d_c, 1.0), 1.0)
        return out

    rel = [1.0] * len(ys)  # each shot's brightness relative to its least-squares scale
    for _ in range(GAIN_ROUNDS if len(ys) > 1 else 0):
        gains = smoothed(rel)
        rel = [float(np.sum(y) / max(float(np.sum(np.where(st, gains * q, 0.0))), 1e-300))
               for y, q, st in zip(ys, qs, strongs)]
        if not all(math.isfinite(r) and r > 0 for r in rel):
            # Undone values whose sum over a shot's bright bins is not positive (a processing fit
            # gone wrong): its brightness has no logarithm, and NaN gains would follow.
            raise CDSpectraError("a calibration photo reads no light where its known lamp is bright once its "
                                 "processing is undone: the fitted model of the camera does not fit these photos")
        mean = float(np.exp(np.mean(np.log(rel))))  # only ratios are measured; dark bins stay at 1
        rel = [r / mean for r in rel]
    gains = np.where(strong_any, smoothed(rel), 1.0)
    # Normalise so the gains only reshape: the median strong gain is 1.
    med = float(np.median(gains[strong_any])) if np.any(strong_any) else 1.0
    return np.clip(gains / med, *limits)


def unexplained_share(measured: NDArray[np.float64], valid: NDArray[np.bool_], predicted: NDArray[np.float64]) -> float:
    """What a calibration leaves unexplained in its own photo: the signal-weighted RMS of
    measured − s·predicted over the valid bins, relative to the peak (s: least squares).
    Several shots (as in :func:`fit_gains`): each with its own s and peak, each weighing alike."""
    m, v, p = _by_shot(measured, valid, predicted)
    total = 0.0
    for mk, vk, pk in zip(m, v, p):
        ok = vk[:, None] & np.isfinite(mk) & np.isfinite(pk)
        y, q = mk[ok], pk[ok]
        if y.size == 0 or not np.any(q > 0):
            return 1.0
        q = q / float(np.max(np.abs(q)))  # scale-free, and q·q cannot underflow (q ~ 1e-299: s was 0)
        s = float(y @ q) / max(float(q @ q), 1e-300)
        peak = float(np.max(np.abs(y))) or 1.0
        w = np.abs(q) / max(float(np.sum(np.abs(q))), 1e-300)
        total += float(np.sum(w * ((y - s * q) / peak) ** 2)) / m.shape[0]
    return float(np.sqrt(total))


def calibration_check(calibration: Calibration) -> dict[str, Any]:
    """How well ``calibration`` explains its own photo, for a result: the share of the rainbow's
    signal it leaves unexplained (judged against :data:`EXPLAIN_LIMIT`), and for an in-camera
    file the RMS, in 8-bit codes, its fitted processing leaves on the photo's pixels (not judged:
    it grows with the sensor's noise and the tone curve's slope — 2.9–4.8 codes over the
    calibration's own family of renderings at 1 % noise — so it tells a bad fit only from
    another fit of the same photo)."""
    meta = calibration.metadata
    out: dict[str, Any] = {"name": calibration.name}
    for key in ("unexplained", "processing_rms_codes"):
        value = meta.get(key)
        if isinstance(value, (int, float)) and math.isfinite(value):
            out[key] = float(value)
    if "unexplained" in out:
        out["explains_its_photo"] = out["unexplained"] <= EXPLAIN_LIMIT
    checks = meta.get("cross_check")
    if isinstance(checks, list) and checks:
        out["cross_check"] = checks
        if _cross_check_judged(calibration):
            worst = cross_check_worst(calibration)
            out["reads_other_lamps"] = worst is not None and worst <= CROSS_CHECK_LIMIT
    return out


def cross_check_summary(calibration: Calibration) -> str | None:
    """One line on the leave-one-out cross-check for the user (None without one)."""
    checks = calibration.metadata.get("cross_check")
    if not isinstance(checks, list) or not checks:
        return None
    parts = [f"{c.get('held_out')} {c['mae_400_700']:.3f}" if isinstance(c.get("mae_400_700"), (int, float))
             else f"{c.get('held_out')} could not be read ({c.get('error', 'no reading')})" for c in checks]
    judged = (f"at most {CROSS_CHECK_LIMIT:.3f} is expected" if _cross_check_judged(calibration) else
              "not judged: the camera's sensitivities were fitted, which one lamp alone measures poorly")
    return ("cross-check, each known lamp read with the calibration the others give (mean absolute error "
            f"400–700 nm, peak 1): {'; '.join(parts)} — {judged}")


def _cross_check_judged(calibration: Calibration) -> bool:
    """Whether the cross-check is judged against :data:`CROSS_CHECK_LIMIT`: only where the
    calibration did not have to fit the camera's sensitivities (see there)."""
    return calibration.sensitivities is None


def cross_check_worst(calibration: Calibration) -> float | None:
    """The worst MAE 400–700 of the calibration's leave-one-out cross-check (None: no
    cross-check, or none of its lamps could be read — itself a failed check, judged by the caller)."""
    checks = calibration.metadata.get("cross_check")
    if not isinstance(checks, list):
        return None
    values = [c.get("mae_400_700") for c in checks if isinstance(c, dict)]
    finite = [float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)]
    return max(finite) if finite else None


def calibration_warning(calibration: Calibration) -> str | None:
    """The user's warning when ``calibration`` could not explain its own photo, or (two or more
    known lamps) could not read one of its lamps from the others (None when it did both)."""
    share = calibration.metadata.get("unexplained")
    if not isinstance(share, (int, float)) or share <= EXPLAIN_LIMIT:
        return _cross_check_warning(calibration)
    what = ("the camera's processing of this file" if calibration.pipeline is not None
            else "this camera and disc")
    rms = calibration.metadata.get("processing_rms_codes")
    fit = (f"; the fitted processing misses its pixels by {rms:.1f} of 255 codes RMS"
           if isinstance(rms, (int, float)) and math.isfinite(rms) else "")
    return (f"calibration {calibration.name!r} cannot explain its own photo ({100 * share:.0f}% of the rainbow's "
            f"signal is left unexplained, {100 * EXPLAIN_LIMIT:.0f}% at most is expected{fit}): the model of {what} "
            "does not fit, so estimates with it are unreliable — shoot RAW, or turn off the camera's HDR, local tone "
            "mapping and vivid or creative picture styles, fix the white balance, and calibrate again")


def _cross_check_warning(calibration: Calibration) -> str | None:
    checks = calibration.metadata.get("cross_check")
    if not isinstance(checks, list) or not checks or not _cross_check_judged(calibration):
        return None
    worst = cross_check_worst(calibration)
    if worst is not None and worst <= CROSS_CHECK_LIMIT:
        return None
    if worst is None:
        what = "none of its known lamps could be read with the calibration the others give"
    else:
        bad = max((c for c in checks if isinstance(c.get("mae_400_700"), (int, float))),
                  key=lambda c: c["mae_400_700"])
        what = (f"read with the calibration its other lamps give, {bad.get('held_out', 'one known lamp')} came out "
                f"{worst:.3f} off (mean absolute error 400–700 nm, peak 1; {CROSS_CHECK_LIMIT:.3f} at most is expected)")
    return (f"calibration {calibration.name!r} does not carry over from one known lamp to another: {what}. Its "
            "model of the camera fits the lamps it saw but not other light, so estimates with it are unreliable — "
            "shoot RAW, or turn off the camera's HDR, local tone mapping and vivid or creative picture styles, fix "
            "the white balance, and calibrate again")


def _safe_name(name: str) -> str:
    stem = re.sub(r"[^\w.+-]+", "_", name.strip(), flags=re.UNICODE).strip("._")
    if not stem:
        raise CDSpectraError("a calibration profile needs a name")
    return stem[:80]


def save_calibration(calibration: Calibration, directory: Path | None = None) -> Path:
    """Write ``<dir>/<name>.json`` atomically; returns the path."""
    folder = Path(directory) if directory else calibration_dir()
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CDSpectraError(f"cannot write the calibration profile to {folder}: {exc.strerror or exc}") from exc
    return write_json(folder / f"{_safe_name(calibration.name)}.json", calibration.to_json(), indent=1)


def load_calibration(name_or_path: str | Path, directory: Path | None = None) -> Calibration:
    path = Path(name_or_path)
    if not path.suffix:
        path = (Path(directory) if directory else calibration_dir()) / f"{_safe_name(str(name_or_path))}.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        gains = np.asarray(data["gains"], dtype=np.float64)
        lam = np.asarray(data["feature_lambda_nm"], dtype=np.float64)
    except FileNotFoundError as exc:
        raise CDSpectraError(f"no calibration profile {path.stem!r} in {path.parent}") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise CDSpectraError(f"calibration profile {path.name} is unreadable: {exc}") from exc
    if gains.shape != (N_FEATURES, 3) or not np.allclose(lam, FEATURE_LAMBDA_NM) or not np.all(np.isfinite(gains)):
        raise CDSpectraError(f"calibration profile {path.name} was made by another version; calibrate again")
    try:
        pipeline = CameraPipeline.from_json(data["pipeline"]) if data.get("pipeline") is not None else None
    except CDSpectraError as exc:
        raise CDSpectraError(f"calibration profile {path.name}: {exc}") from exc
    sensitivities = _sensitivities(data.get("sensitivities"), path.name)
    meta = {k: v for k, v in data.items()
            if k not in ("name", "gains", "feature_lambda_nm", "preset", "camera", "pipeline", "sensitivities")}
    limits = GAIN_LIMITS if pipeline is None else PIPELINE_GAIN_LIMITS
    return Calibration(str(data.get("name", path.stem)), np.clip(gains, *limits), str(data.get("preset", "")),
                       str(data.get("camera", "")), meta, pipeline, sensitivities)


def _sensitivities(value: Any, file_name: str) -> NDArray[np.float64] | None:
    """A profile's fitted camera sensitivities (absent in profiles written before they existed)."""
    if value is None:
        return None
    try:
        sens = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        sens = np.zeros(0)
    if sens.shape != (WAVELENGTHS_NM.size, 3) or not np.all(np.isfinite(sens)) or sens.min() < 0 or sens.max() <= 0:
        raise CDSpectraError(f"calibration profile {file_name}: its camera sensitivities are not 81 × 3 finite, "
                             "non-negative values — calibrate again")
    return sens / sens.max()


def list_calibrations(directory: Path | None = None) -> list[str]:
    folder = Path(directory) if directory else calibration_dir()
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.json") if not p.name.startswith("."))


def new_metadata(photo: str, reference: str) -> dict[str, Any]:
    return {"photo": photo, "reference": reference, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "format": 1, "note": "gains = measured / predicted profile, per λ₁ bin and channel; an optional "
            "'pipeline' (in-camera matrix and tone curve) is undone before the profile is read; optional "
            "'sensitivities' (the camera's, fitted from the shot) replace the camera profile's"}
