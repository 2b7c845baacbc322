"""The learned half of the inverse: model inputs, and the ONNX model that maps them to an SPD.

The network sees what physics already knows — the λ₁ readout (normalised), which bins are
valid, saturated or noisy, the camera's sensitivities, the physics-only solution and the fitted
lamp size — and returns a non-negative, peak-normalised SPD with a per-wavelength uncertainty.
The input layout is defined here once, for training and for inference; its hash is stored in
the model's metadata so a model built for another layout is refused instead of misread.

onnxruntime is imported, and the session created, on first use only (enabling the add-on must
stay instant), then cached.
"""

from __future__ import annotations

import hashlib
import json
import math
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import ModelError
from ..validation import check_number
from ..readout.readout import Readout
from ..spectra.grid import FEATURE_LAMBDA_NM, N_BANDS, N_FEATURES, WAVELENGTHS_NM

MODEL_DIR = Path(__file__).resolve().parents[3] / "models"
MODEL_NAME = "cd_spectra"
SIGMA_REF = 0.003

# (name, length) in order: the model input vector.
INPUT_LAYOUT: tuple[tuple[str, int], ...] = (
    ("profile", N_FEATURES * 3),  # the readout: values / peak valid value, 0 where invalid (name fixed by layout_hash)
    ("valid", N_FEATURES),
    ("snr", N_FEATURES),  # log10(peak / noise) / 4, 0 where invalid
    ("saturated", N_FEATURES),
    ("camera", N_BANDS * 3),  # sensitivities, max 1
    ("physics", N_BANDS),  # physics-only SPD, peak 1
    ("scalars", 3),  # log(σ / 0.003), generic-camera flag, geometry residual
)
INPUT_SIZE = sum(n for _, n in INPUT_LAYOUT)

__all__ = ["MODEL_DIR", "INPUT_LAYOUT", "INPUT_SIZE", "layout_hash", "model_inputs", "SpectralModel",
           "load_model"]


def layout_hash() -> str:
    blob = json.dumps({"layout": INPUT_LAYOUT, "features": FEATURE_LAMBDA_NM.tolist(),
                       "wavelengths": WAVELENGTHS_NM.tolist()}).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


def model_inputs(
    readout: Readout,
    camera_sensitivities: NDArray[np.float64],
    physics_spd: NDArray[np.float64],
    lobe_sigma: float,
    generic_camera: bool,
    geometry_residual: float,
) -> NDArray[np.float32]:
    """The input vector for one photo (float32, INPUT_SIZE)."""
    # Absurd profiles (a tiny peak beside huge invalid values) overflow here; the result is
    # cleaned below, so numpy's warnings would only be noise in Blender's console.
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        values = np.where(readout.valid[:, None], readout.values, 0.0)
        peak = float(np.max(values)) if np.any(readout.valid) else 0.0
        scale = peak if peak > 0 else 1.0
        noise = np.mean(readout.noise, axis=1)
        snr = np.where(readout.valid, np.log10(scale / np.maximum(noise, 1e-6 * scale)) / 4.0, 0.0)
        phys_peak = float(np.max(physics_spd))
        physics = physics_spd / phys_peak if phys_peak > 0 else np.zeros(N_BANDS)
        parts = [
            (values / scale).ravel(),
            readout.valid.astype(np.float64),
            snr,
            readout.saturated_fraction,
            np.asarray(camera_sensitivities, dtype=np.float64).ravel(),
            physics,
            np.array([math.log(max(lobe_sigma, 1e-6) / SIGMA_REF), float(generic_camera),
                      float(np.clip(geometry_residual, 0.0, 1.0))]),
        ]
    out = np.nan_to_num(np.concatenate(parts), nan=0.0, posinf=0.0, neginf=0.0)
    limit = float(np.finfo(np.float32).max)
    return np.where(np.abs(out) <= limit, out, 0.0).astype(np.float32)  # as before, without the overflow warning


@dataclass
class SpectralModel:
    """A loaded model: the onnxruntime session and its metadata."""

    path: Path
    metadata: dict[str, Any]
    _session: Any

    @property
    def version(self) -> str:
        return str(self.metadata.get("version", ""))

    def predict(self, inputs: NDArray[np.float32]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """(spd, std) for a batch (N, INPUT_SIZE) or one input vector."""
        x = np.asarray(inputs, dtype=np.float32)
        single = x.ndim == 1
        x = np.atleast_2d(x)
        if x.shape[1] != INPUT_SIZE:
            raise ModelError(f"model input has {x.shape[1]} values, expected {INPUT_SIZE}")
        try:
            spd, log_std = self._session.run(["spd", "log_std"], {"inputs": x})
        except Exception as exc:  # onnxruntime's own exception types (a graph that fails at run time)
            raise ModelError(f"model {self.path.name} failed to run: {exc}") from exc
        if np.shape(spd) != (x.shape[0], N_BANDS) or np.shape(log_std) != (x.shape[0], N_BANDS):
            raise ModelError(f"model {self.path.name} returned {np.shape(spd)} values for {x.shape[0]} input(s); "
                             f"expected {N_BANDS} per input (380–780 nm in 5 nm steps)")
        spd = np.nan_to_num(np.asarray(spd, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
        std = np.exp(np.clip(np.asarray(log_std, dtype=np.float64), -12.0, 3.0))
        return (spd[0], std[0]) if single else (spd, std)


_CACHE: dict[Path, SpectralModel] = {}
_LOCK = threading.Lock()


def _read_metadata(onnx_path: Path) -> dict[str, Any]:
    side = onnx_path.with_suffix(".json")
    try:
        meta = json.loads(side.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise ModelError(f"model metadata {side.name} is missing next to {onnx_path.name}") from exc
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ModelError(f"model metadata {side.name} is unreadable: {exc}") from exc
    if not isinstance(meta, dict):
        raise ModelError(f"model metadata {side.name} is not a JSON object")
    if meta.get("layout_hash") != layout_hash():
        raise ModelError(
            f"model {onnx_path.name} was built for another input layout "
            f"({meta.get('layout_hash')!r}, this add-on needs {layout_hash()!r}); reinstall the add-on or rebuild the model")
    # The arrays the estimator uses straight from the metadata: a wrong shape here would
    # otherwise surface as a numpy broadcasting error deep inside the solve.
    expected = {("prior", "mean"): (N_BANDS,), ("prior", "covariance"): (N_BANDS, N_BANDS),
                ("generic_camera",): (N_BANDS, 3)}
    for keys, shape in expected.items():
        value: Any = meta
        for key in keys:
            value = value.get(key) if isinstance(value, dict) else None
        if value is None and keys[0] not in meta:
            continue  # optional: without it the estimator does without the prior / generic camera
        try:
            array = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError):
            array = np.zeros(0)
        if array.shape != shape or not np.all(np.isfinite(array)):
            raise ModelError(f"model metadata {side.name}: {'.'.join(keys)} should be {shape} finite numbers; "
                             "the metadata does not match the model — reinstall the add-on or rebuild the model")
    fusion = meta.get("fusion")
    if fusion is not None:  # strength and floor of the estimator's final solve
        if not isinstance(fusion, dict):
            raise ModelError(f"model metadata {side.name}: fusion should hold a non-negative strength and floor, "
                             f"not {fusion!r} — reinstall the add-on or rebuild the model")
        for key in ("strength", "floor", "calibrated_strength", "calibrated_floor"):
            check_number(f"model metadata {side.name}: fusion.{key}", fusion.get(key, 0.05), at_least=0.0,
                         error=lambda message: ModelError(f"{message} — reinstall the add-on or rebuild the model"))
        for key in ("band_weight", "calibrated_band_weight"):  # w(λ): network (1) vs physics + prior (0)
            if key not in fusion:
                continue
            try:
                weight = np.asarray(fusion[key], dtype=np.float64)
            except (TypeError, ValueError):
                weight = np.zeros(0)
            if weight.shape != (N_BANDS,) or not np.all(np.isfinite(weight)) or np.any((weight < 0) | (weight > 1)):
                raise ModelError(f"model metadata {side.name}: fusion.{key} should be {N_BANDS} numbers in 0–1 — "
                                 "reinstall the add-on or rebuild the model")
    tails = meta.get("tails")
    if tails is not None:  # χ²/row of a Planck fit at which the blind tails are Planck's (spectrum.tails)
        ok = isinstance(tails, dict)
        try:
            lo, hi = (float(tails["thermal_chi2"]), float(tails["other_chi2"])) if ok else (0.0, -1.0)
            t_max = float(tails.get("max_temperature_k") or 1e9) if ok else 0.0
        except (KeyError, TypeError, ValueError):
            lo, hi, t_max = 0.0, -1.0, 0.0
        if not (np.isfinite(lo) and np.isfinite(hi) and 0.0 <= lo <= hi and t_max > 0):
            raise ModelError(f"model metadata {side.name}: tails should hold 0 ≤ thermal_chi2 ≤ other_chi2 (and a "
                             f"positive max_temperature_k, if any), not "
                             f"{tails!r} — reinstall the add-on or rebuild the model")
    return meta


def _signature_ok(session: Any) -> bool:
    """One input "inputs" (…, INPUT_SIZE) and outputs "spd", "log_std" whose length, where the
    file fixes it, is N_BANDS (a dynamic length is checked on every predict)."""
    inputs = {i.name: list(i.shape or []) for i in session.get_inputs()}
    outputs = {o.name: list(o.shape or []) for o in session.get_outputs()}
    if set(inputs) != {"inputs"} or not inputs["inputs"] or inputs["inputs"][-1] != INPUT_SIZE:
        return False
    if not {"spd", "log_std"} <= set(outputs):
        return False
    return all(not outputs[k] or not isinstance(outputs[k][-1], int) or outputs[k][-1] == N_BANDS
               for k in ("spd", "log_std"))


def load_model(path: str | Path | None = None) -> SpectralModel:
    """The model at ``path`` (default: the shipped one), loaded once per process."""
    onnx_path = Path(path) if path is not None else MODEL_DIR / f"{MODEL_NAME}.onnx"
    onnx_path = onnx_path.resolve()
    with _LOCK:
        cached = _CACHE.get(onnx_path)
        if cached is not None:
            return cached
        if not onnx_path.is_file():
            raise ModelError(f"model file {onnx_path} is missing; run `make model` or reinstall the add-on")
        meta = _read_metadata(onnx_path)
        try:
            import onnxruntime as ort  # lazy: seconds of import time nobody should pay at enable
        except ImportError as exc:
            raise ModelError("onnxruntime is not available; install the extension build for your platform") from exc
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        options.log_severity_level = 3
        try:
            session = ort.InferenceSession(str(onnx_path), sess_options=options,
                                           providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own exception types for bad files
            raise ModelError(f"model file {onnx_path.name} is not a valid ONNX model: {exc}") from exc
        if not _signature_ok(session):
            raise ModelError(f"model file {onnx_path.name} does not have the inputs/outputs this add-on expects")
        model = SpectralModel(path=onnx_path, metadata=meta, _session=session)
        _CACHE[onnx_path] = model
        return model
