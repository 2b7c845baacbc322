"""A camera's in-camera rendering, modelled so that a calibration shot can undo it.

What a camera or phone does between the sensor and a JPEG/HEIC, in the order it does it:

1. white balance: per-channel gains;
2. a 3×3 matrix from camera RGB to the display space (sRGB), often with extra saturation;
   spectral colours fall outside the display gamut and are clipped to [0, 1];
3. a tone curve: the sRGB encoding plus a picture-style contrast curve;
4. 8- or 10-bit codes (the loader decodes them with the standard sRGB curve).

:class:`CameraPipeline` is steps 1–3 with the white balance folded into the matrix and the tone
curve as a monotone piecewise-linear map between sRGB-encoded values, so ``to_file`` gives the
linear values :func:`.images.load_photo` returns for such a file and ``to_native`` undoes it.
Clipping cannot be undone; everything else can. The family is wider than one order of steps:
the curve on each channel or on luminance (every channel scaled alike, as raw converters keep
hue), and colours outside the gamut clipped per channel or compressed towards their luminance.

:func:`fit_pipeline` fits the matrix and the curve from one photo of a known lamp taken with
the same settings (fixed white balance): every rainbow pixel's camera-native RGB is predicted
by the forward model (the readout's bin value for the known SPD × the pixel's amplitude), so
a few thousand pixels of many colours and intensities pin nine matrix entries and the curve;
each member of the family is fitted and one is kept only where it explains the photo clearly
better than the per-channel, clipping one. The fit is refined between linear values, each
weighted by the noise measured at its level: the sensor's noise comes before the curve, and
between encoded values the curve's steep toe turns it into a bias the fitted curve follows.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import CDSpectraError
from ..numerics.least_squares import levenberg_marquardt
from ..photo.clipping import HIGH_CODE, LOW_CODE
from ..photo.srgb import srgb_decode, srgb_encode, srgb_encode_slope

__all__ = ["CameraPipeline", "PipelineFit", "fit_pipeline", "fit_pipeline_checked", "compress_gamut", "CURVE_KNOTS",
           "FAMILY", "GAMUTS", "LUMA", "TONES"]

TONES = ("channel", "luminance")
GAMUTS = ("clip", "compress")
LUMA = np.array([0.2126, 0.7152, 0.0722])  # linear sRGB (Rec. 709) luminance

CURVE_KNOTS = 12  # knots of the fitted tone curve over the encoded range [0, 1]
MAX_FIT_PIXELS = 8000
# Weight of the curve's second differences (keeps knots without data tame). Chosen on 30
# synthetic SPDs (`camera_files --synthetic`, one CIE A calibration each): in-camera JPEG MAE
# 0.038 / 0.031 / 0.033 / 0.033 and phone HEIC 0.020 / 0.018 / 0.018 / 0.018 at 0.02 / 0.005 /
# 0.002 / 0.0005; 0.1 was worse (0.040, 0.027).
SMOOTHNESS = 0.005
MIN_FIT_PIXELS = 200
FIT_ITERATIONS = 100  # Levenberg–Marquardt iterations at most (the fit usually stops far sooner)
FIT_TOLERANCE = 1e-10  # ... or once an iteration improves the cost by less than this share
# The family's other members (tone curve, gamut mapping), each fitted from the per-channel,
# clipping fit; one replaces the best so far where it leaves at most FAMILY_GAIN of its cost
# (members agree on grey and in gamut: the margin keeps noise from choosing).
FAMILY = (("luminance", "clip"), ("channel", "compress"), ("luminance", "compress"))
FAMILY_GAIN = 0.8
FAMILY_ITERATIONS = 40
FAMILY_PIXELS = 3000  # ... on this many of the fit's pixels
FAMILY_TOLERANCE = 1e-6
# The linear refit's residuals are weighted by the noise measured on the first (encoded) pass's
# residuals, in this many groups of the model's level (:func:`_noise_weights`), each of at least
# NOISE_GROUP_MIN values.
NOISE_LEVELS = 8
NOISE_GROUP_MIN = 25
FAMILY_STEP = 1e-5  # their forward-difference step (matrix entries and log curve increments)
_ROOT_GRID = np.linspace(0.0, 1.0, 16385)  # √(file value): the grid of the inverse curve's table


@dataclass(frozen=True)
class CameraPipeline:
    """camera-native linear RGB → the linear RGB a loaded in-camera file holds."""

    matrix: NDArray[np.float64]  # (3, 3) white balance × colour matrix (× exposure scale)
    curve_in: NDArray[np.float64]  # (K,) sRGB-encoded value before the tone curve, increasing 0..1
    curve_out: NDArray[np.float64]  # (K,) sRGB-encoded value after it (the file's code / max), increasing
    # "channel": the curve on each display channel; "luminance": on the display luminance, every
    # channel scaled by the one factor it gives (hue-preserving contrast, as raw converters do).
    tone: str = "channel"
    # "clip": a colour outside the display gamut clipped per channel (the others exact);
    # "compress": moved towards its own luminance until no channel is negative, and scaled
    # down where a channel passes full scale (hue kept, saturation given up). Not undone: the
    # channel at the floor is read as a bound, the others as they are (saturation is lost).
    gamut: str = "clip"

    def __post_init__(self) -> None:
        m = np.asarray(self.matrix, dtype=np.float64)
        xin, xout = np.asarray(self.curve_in, np.float64), np.asarray(self.curve_out, np.float64)
        if m.shape != (3, 3) or not np.all(np.isfinite(m)) or not np.linalg.cond(m) < 1e8:
            raise CDSpectraError("a camera pipeline needs an invertible, finite 3×3 matrix")
        if xin.ndim != 1 or xin.shape != xout.shape or xin.size < 2 or not (
                np.all(np.isfinite(xin)) and np.all(np.isfinite(xout))
                and np.all(np.diff(xin) > 0) and np.all(np.diff(xout) > 0)):
            raise CDSpectraError("a camera pipeline's tone curve must be finite and strictly increasing")
        if self.tone not in TONES:
            raise CDSpectraError(f"a camera pipeline's tone curve applies to one of {TONES}, not {self.tone!r}")
        if self.gamut not in GAMUTS:
            raise CDSpectraError(f"a camera pipeline's gamut mapping is one of {GAMUTS}, not {self.gamut!r}")

    def _curve_linear(self, linear: NDArray[np.float64]) -> NDArray[np.float64]:
        """The tone curve between linear values (decoded → encoded → curve → decoded)."""
        coded = np.interp(srgb_encode(np.clip(linear, 0.0, 1.0)), self.curve_in, self.curve_out)
        return srgb_decode(np.clip(coded, 0.0, 1.0))

    def to_file(self, native: NDArray[np.floating]) -> NDArray[np.float64]:
        """Forward: (..., 3) camera-native linear → file linear (gamut-clipped, tone-mapped)."""
        display = np.asarray(native, np.float64) @ self.matrix.T
        if self.gamut == "compress":
            display = compress_gamut(display)
        if self.tone == "luminance":
            display = np.clip(display, 0.0, None)
            y = np.maximum(display @ LUMA, 1e-12)
            return np.clip(display * (self._curve_linear(y) / y)[..., None], 0.0, 1.0)
        return self._curve_linear(np.clip(display, 0.0, 1.0))

    def to_display(self, file_linear: NDArray[np.floating]) -> NDArray[np.float64]:
        """The tone curve undone: (..., 3) loaded file values → linear display RGB, where the
        camera clipped (and where a clipped channel is a bound: :mod:`..photo.clipping`).

        One table lookup on √value (the curve is the same for every channel): the sRGB curve's
        powers on a whole photo cost ~1 s for 0.7 MP; the table agrees to 1e-5 of full scale.
        A luminance curve: the file's luminance through the table, every channel scaled by it."""
        values = np.asarray(file_linear, np.float64)
        if self.tone == "luminance":
            y = np.maximum(values @ LUMA, 1e-12)
            return values * (self._untone(y) / y)[..., None]
        return self._untone(values)

    def _untone(self, file_linear: NDArray[np.float64]) -> NDArray[np.float64]:
        pos = np.sqrt(np.clip(file_linear, 0.0, 1.0)) * (_ROOT_GRID.size - 1)
        i = np.minimum(pos.astype(np.intp), _ROOT_GRID.size - 2)  # a uniform grid: no search
        table = self._display_table
        lo = table[i]
        return lo + (table[i + 1] - lo) * (pos - i)

    @cached_property
    def _display_table(self) -> NDArray[np.float64]:
        coded = srgb_encode(_ROOT_GRID ** 2)
        return srgb_decode(np.clip(np.interp(coded, self.curve_out, self.curve_in), 0.0, 1.0))

    def display_to_native(self, display: NDArray[np.floating]) -> NDArray[np.float64]:
        """The matrix undone: (..., 3) linear display RGB → camera-native linear."""
        return np.asarray(display, np.float64) @ np.linalg.inv(self.matrix).T

    def to_native(self, file_linear: NDArray[np.floating]) -> NDArray[np.float64]:
        """Inverse: (..., 3) loaded file values → camera-native linear (exact where nothing clipped)."""
        return self.display_to_native(self.to_display(file_linear))

    def to_json(self) -> dict[str, Any]:
        data = {"matrix": np.round(self.matrix, 8).tolist(), "curve_in": np.round(self.curve_in, 6).tolist(),
                "curve_out": np.round(self.curve_out, 6).tolist()}
        if self.tone != "channel":
            data["tone"] = self.tone
        if self.gamut != "clip":
            data["gamut"] = self.gamut
        return data

    @classmethod
    def from_json(cls, data: Any) -> CameraPipeline:
        try:
            return cls(np.asarray(data["matrix"], np.float64), np.asarray(data["curve_in"], np.float64),
                       np.asarray(data["curve_out"], np.float64), str(data.get("tone", "channel")),
                       str(data.get("gamut", "clip")))
        except (KeyError, TypeError, ValueError) as exc:
            raise CDSpectraError(f"the calibration's camera pipeline is unreadable: {exc}") from exc


def compress_gamut(display: NDArray[np.floating]) -> NDArray[np.float64]:
    """(..., 3) linear display RGB with each colour that has a negative channel moved towards
    its own luminance until its lowest channel is 0, then each with a channel past full scale
    scaled down until it is not (what a "compress" pipeline does first: hue kept)."""
    d = np.asarray(display, np.float64)
    y = np.maximum(d @ LUMA, 1e-12)[..., None]
    lowest = d.min(axis=-1, keepdims=True)
    keep = np.where(lowest < 0, y / np.maximum(y - lowest, 1e-12), 1.0)
    out = y + (d - y) * keep
    top = out.max(axis=-1, keepdims=True)
    return np.where(top > 1.0, out / np.maximum(top, 1e-12), out)


@dataclass(frozen=True)
class PipelineFit:
    """A fitted pipeline and how well it explains the photo it was fitted from."""

    pipeline: CameraPipeline
    # RMS of the fit's residual (file value − model) over the fitted pixels' channels, in 8-bit
    # codes of the sRGB-encoded file (a clipped channel counts only where the model crosses its
    # bound): 8-bit rounding, sensor noise and JPEG leave ~2–3; a wrong pose of the shot or a
    # processing outside the family leaves more (see calibration_shot.POSE_ROUNDS).
    rms_codes: float
    pixels: int


def _noise_weights(residual: NDArray[np.float64], model: NDArray[np.float64], use: NDArray[np.bool_]
                   ) -> NDArray[np.float64]:
    """1 / each value's noise, as a fit's own linear ``residual`` measures it at its encoded
    ``model`` level: the mean square residual of the values in ``use`` in NOISE_LEVELS groups
    of equal count by level, interpolated between the groups' median levels. Measured, not
    assumed: the sensor's noise is the same at every linear level, a file's rounding the same
    at every code, a JPEG's chroma error largest on saturated colours. Scaled so the typical
    value weighs as an encoded residual would (the curve's smoothness keeps its weight);
    uniform where too few values tell."""
    to_linear = 1.0 / srgb_encode_slope(srgb_decode(model))
    level, res = model[use], residual[use]
    if level.size < NOISE_LEVELS * NOISE_GROUP_MIN:
        return np.full_like(model, float(np.median(1.0 / to_linear)))
    groups = np.array_split(np.argsort(level, kind="stable"), NOISE_LEVELS)
    centres = np.maximum.accumulate(np.array([np.median(level[g]) for g in groups]))
    variance = np.array([np.mean(res[g] ** 2) for g in groups])
    variance = np.maximum(variance, 1e-6 * float(variance.max()) + 1e-300)
    weight = 1.0 / np.sqrt(np.interp(model, centres, variance))
    return weight / float(np.median(weight * to_linear))


def _curve(params: NDArray[np.float64]) -> NDArray[np.float64]:
    """Knot outputs from log increments: strictly increasing from 0."""
    return np.concatenate([[0.0], np.cumsum(np.exp(params))])


def fit_pipeline(observed: NDArray[np.floating], predicted: NDArray[np.floating],
                 weight: NDArray[np.floating] | None = None, low: NDArray[np.bool_] | None = None,
                 high: NDArray[np.bool_] | None = None,
                 family: tuple[tuple[str, str], ...] = FAMILY, noise_weighted: bool = True) -> CameraPipeline:
    """:func:`fit_pipeline_checked`'s pipeline."""
    return fit_pipeline_checked(observed, predicted, weight, low, high, family, noise_weighted).pipeline


def fit_pipeline_checked(observed: NDArray[np.floating], predicted: NDArray[np.floating],
                         weight: NDArray[np.floating] | None = None, low: NDArray[np.bool_] | None = None,
                         high: NDArray[np.bool_] | None = None,
                         family: tuple[tuple[str, str], ...] = FAMILY, noise_weighted: bool = True) -> PipelineFit:
    """The pipeline that best maps ``predicted`` camera-native RGB (N, 3), known up to one scale,
    to the ``observed`` loaded file values (N, 3) of the same pixels.

    Residuals are taken in the sRGB-encoded domain, where 8-bit codes have uniform steps; a
    small smoothness penalty on the curve's slopes keeps knots beyond the data tame. ``low`` /
    ``high`` (N, 3) mark channels the camera clipped (:mod:`..photo.clipping`): censored, they
    only penalise a model that comes out above the floor's code / below the full-scale code.
    ``family``: the members (tone, gamut) tried besides the per-channel, clipping one (a
    calibration that refits the same photo keeps the member it chose first). ``noise_weighted``:
    refit between linear values weighted by the measured noise (see the comment in the body);
    off where the residual is not noise but a known misfit (the generic camera's colours).
    Returns it with the RMS it leaves on these pixels (:class:`PipelineFit`).
    Refuses (CDSpectraError) when too few pixels carry light to fit 9 + K parameters."""
    obs = np.asarray(observed, np.float64).reshape(-1, 3)
    pred = np.asarray(predicted, np.float64).reshape(-1, 3)
    w = np.ones(obs.shape[0]) if weight is None else np.asarray(weight, np.float64).reshape(-1)
    lo = np.zeros(obs.shape, bool) if low is None else np.asarray(low, bool).reshape(-1, 3)
    hi = np.zeros(obs.shape, bool) if high is None else np.asarray(high, bool).reshape(-1, 3)
    ok = np.all(np.isfinite(obs), axis=1) & np.all(np.isfinite(pred), axis=1) & (w > 0) & (pred.sum(axis=1) > 0)
    obs, pred, w, lo, hi = obs[ok], pred[ok], w[ok], lo[ok], hi[ok]
    if obs.shape[0] < MIN_FIT_PIXELS:
        raise CDSpectraError(f"only {obs.shape[0]} rainbow pixels to fit the camera's processing from "
                             f"(need {MIN_FIT_PIXELS}): use a brighter, larger calibration photo")
    if obs.shape[0] > MAX_FIT_PIXELS:
        pick = np.random.default_rng(0).choice(obs.shape[0], MAX_FIT_PIXELS, replace=False)
        obs, pred, w, lo, hi = obs[pick], pred[pick], w[pick], lo[pick], hi[pick]
    pred = pred / float(np.max(pred))
    target = srgb_encode(np.clip(obs, 0.0, 1.0))
    target = np.where(lo, LOW_CODE / 255.0, np.where(hi, HIGH_CODE / 255.0, target))  # the bounds
    target_lin = srgb_decode(target)
    sw = np.sqrt(w / w.mean())[:, None]
    knots = np.linspace(0.0, 1.0, CURVE_KNOTS)
    # Start: identity curve, the linear least-squares matrix from native to file-linear.
    m0, *_ = np.linalg.lstsq(pred * sw, np.clip(obs, 0, 1) * sw, rcond=None)
    x0 = np.concatenate([m0.T.reshape(-1), np.log(np.diff(knots))])

    n, k = obs.shape[0], knots.size
    steps = np.diff(knots)
    penalty = SMOOTHNESS * np.sqrt(n)
    # First each value's residual between encoded values (where 8-bit codes have uniform steps);
    # then, with ``noise_weighted``, between linear values, where the sensor's noise is unbiased
    # (between encoded values the curve's steep toe turns that noise into a bias, which the fit
    # bends the curve's toe to follow), each divided by the noise measured at its level on the
    # first fit's residuals (:func:`_noise_weights`).
    linear, noise_w = False, np.ones_like(target)

    def parts(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
        display = pred @ x[:9].reshape(3, 3).T
        clipped = (display <= 0.0) | (display >= 1.0)
        display = np.clip(display, 0.0, 1.0)
        coded = srgb_encode(display)
        seg = np.clip(np.searchsorted(knots, coded, side="right") - 1, 0, k - 2)
        frac = (coded - knots[seg]) / steps[seg]
        out = _curve(x[9:])
        return display, clipped, coded, seg, frac, out

    def active(model: NDArray[np.float64], t: NDArray[np.float64] = target, low: NDArray[np.bool_] = lo,
               high: NDArray[np.bool_] = hi) -> NDArray[np.bool_]:
        """Where a residual counts: every value; a bound only where the model crosses it."""
        return ~((low & (model <= t)) | (high & (model >= t)))

    def model_of(x: NDArray[np.float64]) -> NDArray[np.float64]:
        _, _, _, seg, frac, out = parts(x)
        return out[seg] + (out[seg + 1] - out[seg]) * frac

    def residual(x: NDArray[np.float64]) -> NDArray[np.float64]:
        model = model_of(x)
        smooth = penalty * np.diff(x[9:] - np.log(steps))
        diff = (srgb_decode(model) - target_lin) * noise_w if linear else model - target
        return np.concatenate([(np.where(active(model), diff, 0.0) * sw).reshape(-1), smooth])

    def jacobian(x: NDArray[np.float64]) -> NDArray[np.float64]:
        display, clipped, _, seg, frac, out = parts(x)
        model = out[seg] + (out[seg + 1] - out[seg]) * frac
        on = active(model)
        # d (weighted linear residual) / d encoded model; 1 for encoded residuals
        to_linear = noise_w / srgb_encode_slope(srgb_decode(model)) if linear else np.ones_like(model)
        slope = (out[seg + 1] - out[seg]) / steps[seg]
        dcode = srgb_encode_slope(display)
        gain = np.where(clipped | ~on, 0.0, slope * dcode * to_linear) * sw  # (N, 3)
        jac = np.zeros((3 * n + k - 2, 9 + k - 1))
        for c in range(3):
            jac[c:3 * n:3, 3 * c:3 * c + 3] = gain[:, c:c + 1] * pred
        inc = np.exp(x[9:])  # d out[i] / d x[j] = inc[j] for j < i
        j_idx = np.arange(k - 1)
        rows = (j_idx[None, None, :] < seg[..., None]) + (j_idx[None, None, :] == seg[..., None]) * frac[..., None]
        jac[:3 * n, 9:] = (rows * inc * (sw * on * to_linear)[..., None]).reshape(3 * n, k - 1)
        for j in range(k - 2):
            jac[3 * n + j, 9 + j] = -penalty
            jac[3 * n + j, 10 + j] = penalty
        return jac

    x, _, _ = levenberg_marquardt(residual, x0, max_iter=FIT_ITERATIONS, jacobian=jacobian, tol=FIT_TOLERANCE)
    if noise_weighted:
        model = model_of(x)
        linear = True
        noise_w = _noise_weights(srgb_decode(model) - target_lin, model, active(model) & ~lo & ~hi)
        x, _, _ = levenberg_marquardt(residual, x, max_iter=FIT_ITERATIONS, jacobian=jacobian, tol=FIT_TOLERANCE)
    best = CameraPipeline(x[:9].reshape(3, 3), knots, _curve(x[9:]))

    def rms_codes(model: NDArray[np.float64], t: NDArray[np.float64], on: NDArray[np.bool_],
                  weight: NDArray[np.float64]) -> float:
        """The residual of the encoded values (8-bit codes RMS; bounds count only where crossed)."""
        data = np.where(on, model - t, 0.0) * weight
        return float(255.0 * np.sqrt(np.mean(data * data)))

    best_rms = rms_codes(model_of(x), target, active(model_of(x)), sw)

    # The wider family, from the same start: a curve on luminance (hue-preserving contrast),
    # gamut compression instead of clipping. Another member is kept only where it explains the
    # photo clearly better. Forward differences (these couple the three channels) on a subset
    # of the pixels, where the per-channel fit's cost is taken again to compare.
    sub = np.sort(np.random.default_rng(1).choice(n, min(n, FAMILY_PIXELS), replace=False))
    p_s, t_s, w_s, lo_s, hi_s = pred[sub], target[sub], sw[sub], lo[sub], hi[sub]
    tl_s, nw_s = target_lin[sub], noise_w[sub]

    def family_model(xl: NDArray[np.float64], tone: str, gamut: str) -> NDArray[np.float64]:
        display = p_s @ xl[:9].reshape(3, 3).T
        if gamut == "compress":
            display = compress_gamut(display)
        curve = _curve(xl[9:])
        if tone == "luminance":
            display = np.clip(display, 0.0, None)
            y = np.maximum(display @ LUMA, 1e-12)
            coded = np.interp(srgb_encode(np.clip(y, 0.0, 1.0)), knots, curve)
            return srgb_encode(np.clip(display * (srgb_decode(np.clip(coded, 0.0, 1.0)) / y)[:, None], 0.0, 1.0))
        return np.interp(srgb_encode(np.clip(display, 0.0, 1.0)), knots, curve)

    def family_residual(xl: NDArray[np.float64], tone: str, gamut: str) -> NDArray[np.float64]:
        model = family_model(xl, tone, gamut)
        on = active(model, t_s, lo_s, hi_s)
        smooth = penalty * np.sqrt(sub.size / n) * np.diff(xl[9:] - np.log(steps))
        diff = (srgb_decode(model) - tl_s) * nw_s if linear else model - t_s
        return np.concatenate([(np.where(on, diff, 0.0) * w_s).reshape(-1), smooth])

    r0 = family_residual(x, "channel", "clip")
    best_cost = float(r0 @ r0)
    for tone, gamut in family:
        if (tone, gamut) == ("channel", "clip"):
            continue
        xl, cost_l, _ = levenberg_marquardt(lambda v, t=tone, g=gamut: family_residual(v, t, g), x,
                                            np.full(x.size, FAMILY_STEP), max_iter=FAMILY_ITERATIONS,
                                            tol=FAMILY_TOLERANCE)
        if cost_l < (FAMILY_GAIN if len(family) > 1 else 1.0) * best_cost:
            best, best_cost = CameraPipeline(xl[:9].reshape(3, 3), knots, _curve(xl[9:]), tone, gamut), cost_l
            model_l = family_model(xl, tone, gamut)
            best_rms = rms_codes(model_l, t_s, active(model_l, t_s, lo_s, hi_s), w_s)
    return PipelineFit(best, best_rms if np.isfinite(best_rms) else float("inf"), int(n))
