"""Calibration shot: one photo of a known lamp fixes this camera + disc + geometry's gains.

The forward model knows a CD and a camera only approximately: a real disc's groove depth, a
camera unit's channel gains and a few nm of shift in its curves all change the profile by a
smooth factor per λ₁ bin and channel. Photographing a lamp whose SPD is known — a household
incandescent or halogen bulb (≈ CIE A, Planck at 2856 K), daylight, or any SPD a meter measured
— measures that factor directly: gain = measured profile / profile the model predicts for the
known SPD. Stored as a small JSON profile and divided out of later photos' profiles.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .camera_pipeline import CameraPipeline
from .errors import CDSpectraError
from .readout import FEATURE_LAMBDA_NM, N_FEATURES
from .spectral_grid import WAVELENGTHS_NM, peak_normalise
from .user_folders import ENV_DIR, calibration_dir, set_default_directory

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

# CIE daylight basis S0, S1, S2 at 380–780 nm / 10 nm (CIE 015:2018 Table 6), for the
# "daylight" reference of a calibration shot; interpolated to 5 nm.
_S_WL = np.arange(380.0, 781.0, 10.0)
_S0 = np.array([63.4, 65.8, 94.8, 104.8, 105.9, 96.8, 113.9, 125.6, 125.5, 121.3, 121.3, 113.5, 113.1,
                110.8, 106.5, 108.8, 105.3, 104.4, 100.0, 96.0, 95.1, 89.1, 90.5, 90.3, 88.4, 84.0, 85.1,
                81.9, 82.6, 84.9, 81.3, 71.9, 74.3, 76.4, 63.3, 71.7, 77.0, 65.2, 47.7, 68.6, 65.0])
_S1 = np.array([38.5, 35.0, 43.4, 46.3, 43.9, 37.1, 36.7, 35.9, 32.6, 27.9, 24.3, 20.1, 16.2, 13.2,
                8.6, 6.1, 4.2, 1.9, 0.0, -1.6, -3.5, -3.5, -5.8, -7.2, -8.6, -9.5, -10.9, -10.7, -12.0,
                -14.0, -13.6, -12.0, -13.3, -12.9, -10.6, -11.6, -12.2, -10.2, -7.8, -11.2, -10.4])
_S2 = np.array([3.0, 1.2, -1.1, -0.5, -0.7, -1.2, -2.6, -2.9, -2.8, -2.6, -2.6, -1.8, -1.5, -1.3,
                -1.2, -1.0, -0.5, -0.3, 0.0, 0.2, 0.5, 2.1, 3.2, 4.1, 4.7, 5.1, 6.7, 7.3, 8.6, 9.8,
                10.2, 8.3, 9.6, 8.5, 7.0, 7.6, 8.0, 6.7, 5.2, 7.4, 6.8])

__all__ = ["ENV_DIR", "Calibration", "KNOWN_LAMPS", "known_lamp_spd", "calibration_dir", "set_default_directory", "fit_gains",
           "save_calibration", "load_calibration", "list_calibrations"]


def planck_spd(temperature_k: float) -> NDArray[np.float64]:
    lam = WAVELENGTHS_NM * 1e-9
    c2 = 1.4387769e-2
    return peak_normalise(1.0 / (lam ** 5 * (np.exp(c2 / (lam * temperature_k)) - 1.0)))


def daylight_spd(cct_k: float) -> NDArray[np.float64]:
    """CIE daylight illuminant at a correlated colour temperature (4000–25000 K)."""
    t = float(cct_k)
    if not 4000 <= t <= 25000:
        raise CDSpectraError("daylight calibration needs a CCT between 4000 and 25000 K")
    if t <= 7000:
        xd = -4.6070e9 / t ** 3 + 2.9678e6 / t ** 2 + 0.09911e3 / t + 0.244063
    else:
        xd = -2.0064e9 / t ** 3 + 1.9018e6 / t ** 2 + 0.24748e3 / t + 0.23704
    yd = -3.0 * xd * xd + 2.870 * xd - 0.275
    m = 0.0241 + 0.2562 * xd - 0.7341 * yd
    m1 = (-1.3515 - 1.7703 * xd + 5.9114 * yd) / m
    m2 = (0.0300 - 31.4424 * xd + 30.0717 * yd) / m
    spd = _S0 + m1 * _S1 + m2 * _S2
    return peak_normalise(np.interp(WAVELENGTHS_NM, _S_WL, spd))


KNOWN_LAMPS: dict[str, str] = {
    "incandescent": "Household incandescent or halogen bulb (CIE A, 2856 K)",
    "daylight": "Direct sun / daylight (CIE D55)",
    "daylight-d65": "Overcast daylight (CIE D65)",
}


def known_lamp_spd(name: str) -> NDArray[np.float64]:
    if name == "incandescent":
        return planck_spd(2856.0)
    if name == "daylight":
        return daylight_spd(5503.0)
    if name == "daylight-d65":
        return daylight_spd(6504.0)
    raise CDSpectraError(f"unknown reference lamp {name!r}; choose one of {', '.join(KNOWN_LAMPS)} or an SPD file")


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

    def to_json(self) -> dict[str, Any]:
        extra = {} if self.pipeline is None else {"pipeline": self.pipeline.to_json()}
        return {"name": self.name, "preset": self.preset, "camera": self.camera,
                "feature_lambda_nm": FEATURE_LAMBDA_NM.tolist(), "gains": np.round(self.gains, 6).tolist(),
                **self.metadata, **extra}




def fit_gains(measured: NDArray[np.float64], valid: NDArray[np.bool_], predicted: NDArray[np.float64],
              min_signal: float = MIN_SIGNAL, limits: tuple[float, float] = GAIN_LIMITS,
              smooth_bins: int = SMOOTH_BINS) -> NDArray[np.float64]:
    """Per-bin, per-channel gains measured / predicted (predicted scaled to the photo first),
    smoothed, limited, and 1 where the known lamp gives too little signal to tell."""
    ok = valid[:, None] & (predicted > 0)
    scale = float(np.sum(measured[ok] * predicted[ok]) / max(np.sum(predicted[ok] ** 2), 1e-300))
    if scale <= 0:
        raise CDSpectraError("the calibration photo shows no light where the known lamp should")
    pred = predicted * scale
    strong = ok & (pred > min_signal * pred.max())
    raw = np.where(strong, measured / np.where(strong, pred, 1.0), 1.0)
    weight = strong.astype(float) * pred
    gains = np.ones_like(raw)
    for c in range(3):
        num = np.convolve(raw[:, c] * weight[:, c], np.ones(2 * smooth_bins + 1), mode="same")
        den = np.convolve(weight[:, c], np.ones(2 * smooth_bins + 1), mode="same")
        gains[:, c] = np.where(den > 0, num / np.where(den > 0, den, 1.0), 1.0)
    gains = np.where(strong, gains, 1.0)
    # Normalise so the gains only reshape: the median strong gain is 1.
    med = float(np.median(gains[strong])) if np.any(strong) else 1.0
    return np.clip(gains / med, *limits)


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
        path = folder / f"{_safe_name(calibration.name)}.json"
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".tmp-", suffix=".json")
        with os.fdopen(fd, "w", encoding="utf-8") as handle:
            json.dump(calibration.to_json(), handle, indent=1)
            handle.write("\n")
        os.replace(tmp, path)
    except OSError as exc:
        raise CDSpectraError(f"cannot write the calibration profile to {folder}: {exc.strerror or exc}") from exc
    return path


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
    meta = {k: v for k, v in data.items()
            if k not in ("name", "gains", "feature_lambda_nm", "preset", "camera", "pipeline")}
    limits = GAIN_LIMITS if pipeline is None else PIPELINE_GAIN_LIMITS
    return Calibration(str(data.get("name", path.stem)), np.clip(gains, *limits), str(data.get("preset", "")),
                       str(data.get("camera", "")), meta, pipeline)


def list_calibrations(directory: Path | None = None) -> list[str]:
    folder = Path(directory) if directory else calibration_dir()
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.glob("*.json") if not p.name.startswith("."))


def new_metadata(photo: str, reference: str) -> dict[str, Any]:
    return {"photo": photo, "reference": reference, "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
            "format": 1, "note": "gains = measured / predicted profile, per λ₁ bin and channel; an optional "
            "'pipeline' (in-camera matrix and tone curve) is undone before the profile is read"}
