"""A camera's spectral sensitivities fitted from photos of the disc: the generic profile made specific.

Why: the generic profile (the mean of the training cameras) is wrong for any one camera by a few
nm and a few per cent per channel, and the forward matrix R[bin, λ]·S_c(λ) spreads that error
over several nm of every bin — per-bin gains measured on one lamp cannot undo it for another.
But the readout is *linear in the sensitivities* for a known lamp E:

    value[b, c] = Σ_λ R[b, λ] · E(λ) · S_c(λ)

so a calibration shot of a known lamp measures the camera itself (~60 valid bins × 3 channels
against 81 values per channel). A photo of an *unknown* lamp cannot: it fixes only the
products S_c(λ)·E(λ), so a factor common to the three channels moves freely between camera and
lamp — and that factor, not the channels' ratios, is most of what the generic profile gets
wrong for a camera unlike the training cameras (bench/camera_prior.md).

The fit is a MAP estimate under a Gaussian prior per channel built from measured cameras (the
model's training cameras: their mean is the generic profile): their sample covariance, plus a
smooth squared-exponential term so that a camera outside their span — a phone — can still be
followed where the data say so. Non-negative (:func:`.nnls.nnls_normal`), with free per-channel
offsets like the spectral solve (:func:`.solve.system`). Pure numpy.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from ..spectra.cameras import load_camera
from ..errors import CDSpectraError
from ..numerics.nnls import nnls_normal
from ..readout.readout import Readout
from ..spectrum.solve import MODEL_ERROR_FLOOR
from ..spectra.grid import WAVELENGTHS_NM

# Smooth term of the prior (per channel, on max-1 sensitivities): lets a fit leave the span of
# the measured cameras. Chosen on camera curves alone, never on lamps: each training camera
# recovered from a simulated CIE A shot with a prior built from the *other brands* only
# (training/learning/tune_camera_prior.py, bench/camera_prior.md).
SMOOTH_AMPLITUDE = 0.3
SMOOTH_LENGTH_NM = 10.0
SCALE_ROUNDS = 3  # alternations between the sensitivities and the photo's unknown scale

__all__ = ["CameraPrior", "camera_prior", "fit_sensitivities"]


@dataclass(frozen=True)
class CameraPrior:
    """Gaussian prior on (81, 3) max-1 sensitivities: mean and precision (243, 243) of the
    channel-major curves (R, then G, then B)."""

    mean: NDArray[np.float64]
    precision: NDArray[np.float64]
    names: tuple[str, ...] = ()

    @classmethod
    def from_profiles(cls, profiles: Sequence[NDArray[np.float64]], names: Sequence[str] = ()) -> CameraPrior:
        x = np.asarray(profiles, dtype=np.float64)
        if x.ndim != 3 or x.shape[1:] != (WAVELENGTHS_NM.size, 3) or x.shape[0] < 2 or not np.all(np.isfinite(x)):
            raise CDSpectraError("a camera prior needs at least two finite (81, 3) sensitivity curves")
        lam = WAVELENGTHS_NM
        smooth = SMOOTH_AMPLITUDE ** 2 * np.exp(-0.5 * ((lam[:, None] - lam[None, :]) / SMOOTH_LENGTH_NM) ** 2)
        n = lam.size
        # Channels independent: a joint covariance measured the same (leave-one-out, held-out
        # cameras) with 3× the numbers to trust from 39 cameras.
        cov = np.zeros((3 * n, 3 * n))
        for c in range(3):
            block = slice(c * n, (c + 1) * n)
            cov[block, block] = np.cov(x[:, :, c].T) + smooth
        precision = np.linalg.inv(cov + 1e-8 * np.eye(3 * n))
        return cls(x.mean(axis=0), precision, tuple(names))


@lru_cache(maxsize=8)
def _prior_of(names: tuple[str, ...]) -> CameraPrior:
    return CameraPrior.from_profiles([load_camera(n).sensitivities for n in names], names)


def camera_prior(names: Sequence[str]) -> CameraPrior:
    """The prior from shipped camera profiles (cached): for the product, the model's training
    cameras, so its mean is the model's generic profile."""
    return _prior_of(tuple(sorted(names)))


def fit_sensitivities(readout: Readout | Sequence[Readout],
                      response: NDArray[np.float64] | Sequence[NDArray[np.float64]],
                      spd: NDArray[np.float64] | Sequence[NDArray[np.float64]], prior: CameraPrior
                      ) -> NDArray[np.float64]:
    """The camera's (81, 3) sensitivities, max 1, that best explain ``readout`` for a lamp of
    spectrum ``spd`` (any scale) whose readout response without the camera is ``response``
    (NB, 81), under ``prior``. Refuses (CDSpectraError) a readout with no light in it.

    Several shots of lamps of different colours (sequences of readouts, responses and SPDs, in
    the same order) share the one camera, each with its own exposure and ambient offsets: where
    one lamp is dark (CIE A below 450 nm) another measures the curves."""
    single = isinstance(readout, Readout)
    readouts = [readout] if single else list(readout)
    responses = [response] if single else list(response)  # type: ignore[list-item]
    spds = [spd] if single else list(spd)  # type: ignore[list-item]
    if not readouts or not len(readouts) == len(responses) == len(spds):
        raise CDSpectraError("each calibration shot needs its readout, its response and its lamp's SPD")
    n = WAVELENGTHS_NM.size
    mean = prior.mean
    rows, ys, sigmas, exposure = [], [], [], []
    for ro, resp, lamp in zip(readouts, responses, spds):
        lamp = np.clip(np.asarray(lamp, dtype=np.float64), 0.0, None)
        valid = ro.valid
        r = np.asarray(resp, dtype=np.float64)[valid] * lamp[None, :]  # (nv, 81): per unit S_c(λ)
        y = ro.values[valid]
        scale = float(np.max(np.abs(y))) if y.size else 0.0
        if scale <= 0 or not np.any(r > 0) or not np.all(np.isfinite(y)):
            raise CDSpectraError("the photo shows no light to fit the camera's sensitivities from")
        sigma = np.sqrt(ro.noise[valid] ** 2 + (MODEL_ERROR_FLOOR * scale) ** 2)
        # The photo's scale s: y ≈ s · F(S). Start from the prior mean, then alternate.
        pred = np.stack([r @ mean[:, c] for c in range(3)], axis=1)
        s = float(np.sum(pred * y / sigma ** 2) / max(np.sum(pred ** 2 / sigma ** 2), 1e-300))
        if not s > 0:
            raise CDSpectraError("the photo's colours do not match the known lamp at all: is it the right lamp?")
        rows.append(r)
        ys.append(y)
        sigmas.append(sigma)
        exposure.append(s)
    s = exposure[0]
    ratio = [e / s for e in exposure]  # each shot's exposure relative to the first's
    m = mean.T.reshape(-1)
    prec_m = prior.precision @ m
    n_off = 6 * len(rows)
    t = s * m
    for _ in range(SCALE_ROUNDS):
        gram, rhs = _normal_equations(rows, ys, sigmas, ratio)
        gram[:3 * n, :3 * n] += prior.precision / (s * s)  # T ~ N(s·m, s²·C)
        rhs[:3 * n] += prec_m / s
        gram += 1e-12 * np.trace(gram[:3 * n, :3 * n]) / (3 * n) * np.eye(3 * n + n_off)
        x = nnls_normal(gram, rhs)
        t = x[:3 * n]
        # The scale that makes the fitted curves most probable under the prior (closed form in 1/s).
        num, den = float(t @ prec_m), float(t @ prior.precision @ t)
        if num > 0 and den > 0:
            s = den / num
        ratio = _exposure_ratios(rows, ys, sigmas, t.reshape(3, n).T, x[3 * n:], ratio)
    fitted = t.reshape(3, n).T
    peak = float(fitted.max())
    if not peak > 0 or not np.all(np.isfinite(fitted)):
        raise CDSpectraError("the camera's sensitivities could not be fitted from this photo")
    return fitted / peak


def _normal_equations(rows: list[NDArray[np.float64]], ys: list[NDArray[np.float64]],
                      sigmas: list[NDArray[np.float64]], ratio: list[float]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Gram matrix and right-hand side of the weighted data term. Unknowns: T = s·S (channel-
    major, 3n), then per shot ± an offset per channel; shot k's rows are scaled by its exposure
    ratio; rows channel-major within each shot."""
    n = WAVELENGTHS_NM.size
    n_off = 6 * len(rows)
    gram = np.zeros((3 * n + n_off, 3 * n + n_off))
    rhs = np.zeros(3 * n + n_off)
    for k, (r, y, sigma) in enumerate(zip(rows, ys, sigmas)):
        nv = r.shape[0]
        a = np.zeros((3 * nv, 3 * n + n_off))
        for c in range(3):
            a[c * nv:(c + 1) * nv, c * n:(c + 1) * n] = ratio[k] * r
            a[c * nv:(c + 1) * nv, 3 * n + 6 * k + c] = 1.0
            a[c * nv:(c + 1) * nv, 3 * n + 6 * k + 3 + c] = -1.0
        w = 1.0 / sigma.T.reshape(-1)
        a *= w[:, None]
        gram += a.T @ a
        rhs += a.T @ (y.T.reshape(-1) * w)
    return gram, rhs


def _exposure_ratios(rows: list[NDArray[np.float64]], ys: list[NDArray[np.float64]],
                     sigmas: list[NDArray[np.float64]], curves: NDArray[np.float64], offsets: NDArray[np.float64],
                     ratio: list[float]) -> list[float]:
    """Each later shot's exposure relative to the first's, refitted (weighted least squares)
    to the curves just fitted; the first's stays 1 (it sets the scale of T)."""
    out = [ratio[0]]
    for k in range(1, len(rows)):
        q = rows[k] @ curves  # (nv, 3) at the first shot's exposure
        off = offsets[6 * k:6 * k + 3] - offsets[6 * k + 3:6 * k + 6]
        w = 1.0 / sigmas[k] ** 2
        num, den = float(np.sum(w * q * (ys[k] - off))), float(np.sum(w * q * q))
        out.append(num / den if num > 0 and den > 0 else ratio[k])
    return out
