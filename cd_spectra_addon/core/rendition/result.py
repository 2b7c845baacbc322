"""What a meter shows, from an estimate: the rendition figures, each with the range the
estimate's uncertainty allows, and what they are in the JSON, the text and a comparison.

:func:`rendition` computes the figures of the estimate's SPD and of SPDs drawn from its
uncertainty (:mod:`.uncertainty`) in one batch (:mod:`.figures`). Each figure's range is the
5–95 % interval of the drawn SPDs' values, widened to include the estimate's own value (an
asymmetric error can put it just outside) and, for a fidelity figure near its ceiling of 100,
up to 100 (:data:`CEILING`): a 90 % interval, as the ≥ 90 % coverage asked of it
on real lamps. A range wider than :data:`TOO_WIDE` does not tell a good lamp from a poor one
and is flagged instead of being read as a value.

Not computed, with the reason in the JSON (:data:`NOT_COMPUTED`): CIE R15 (colour-science has
no data for that JIS sample) and EBU TLCI-2012 (colour-science has no implementation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CDSpectraError
from ..spectra.colour import cct_duv
from .figures import Figures, figures
from .uncertainty import CORRELATION_NM, STD_SCALE, draw_spds

__all__ = ["DEFAULT_SAMPLES", "DEFAULT_SEED", "INTERVAL_PERCENT", "TOO_WIDE", "CEILING", "NOT_COMPUTED", "CCT_RANGE_K",
           "CIE_13_3_MAX_DUV", "HEADLINE", "Rendition", "rendition", "rendition_of", "figure_values", "compare_rendition",
           "summary_text", "format_figure"]

DEFAULT_SAMPLES = 100  # SPDs drawn per estimate: the 5 % and 95 % points from 100 draws move by ±0.2 σ
DEFAULT_SEED = 0
INTERVAL_PERCENT = (5.0, 95.0)
# The widest a 90 % range may be and still mean something: a span that crosses a class a buyer
# cares about (Ra 80 / 90, R9 > 0, Rf 85 / 90, Rg 95–110) would not tell them apart.
TOO_WIDE: dict[str, float] = {
    "cri_ra": 20.0, "cri_r9": 40.0, "cri_ri": 40.0, "tm30_rf": 20.0, "cie2017_rf": 20.0, "tm30_rg": 20.0,
    "tm30_rf_hj": 30.0, "tm30_rcs_hj": 30.0, "tm30_rhs_hj": 0.3,
    "peak_wavelength_nm": 50.0, "dominant_wavelength_nm": 30.0,
}
# Fidelity figures score the reference illuminant itself 100 and anything else less, so an
# estimate near 100 (a near-Planckian lamp) is near a maximum: almost every drawn SPD scores
# lower, the 95 % point of the draws sits at the estimate, and a truth between the estimate and
# 100 — closer to its own reference — falls outside. Where 100 lies within the draws' spread
# below the estimate (mirrored above it), the range reaches 100. Rg and the chroma shifts have
# no such ceiling.
CEILING: dict[str, float] = {"cri_ra": 100.0, "cri_r9": 100.0, "cri_ri": 100.0, "tm30_rf": 100.0,
                             "cie2017_rf": 100.0, "tm30_rf_hj": 100.0}
NOT_COMPUTED: dict[str, str] = {
    "cri_r15": "CIE 13.3 defines R1–R14; R15 (JIS Z 8726's Japanese skin sample) is not in colour-science's "
               "test colour samples, so it is not computed",
    "tlci": "EBU TLCI-2012 is not computed: colour-science (0.4.6) has no implementation of it",
}
CCT_RANGE_K = (1000.0, 25000.0)  # TM-30's and CIE 224's reference range
CIE_13_3_MAX_DUV = 5.4e-3  # CIE 13.3's limit on the distance from the Planckian locus (ΔC in uv)
HEADLINE = ("cri_ra", "cri_r9", "tm30_rf", "tm30_rg")  # what a meter shows first
_LABELS = {"cri_ra": "Ra", "cri_r9": "R9", "tm30_rf": "Rf", "tm30_rg": "Rg", "cie2017_rf": "Rf (CIE 2017)",
           "peak_wavelength_nm": "peak", "dominant_wavelength_nm": "dominant wavelength",
           "cri_ri": "R1–R14", "tm30_rf_hj": "Rf,hj", "tm30_rcs_hj": "Rcs,hj", "tm30_rhs_hj": "Rhs,hj"}


def figure_values(f: Figures) -> dict[str, NDArray[np.float64]]:
    """The named figures of a batch: (n,) or (n, k) arrays, by their JSON keys."""
    return {
        "cri_ra": f.cri_ra, "cri_r9": f.cri_r9, "cri_ri": f.cri_ri,
        "tm30_rf": f.fidelity.rf, "cie2017_rf": f.fidelity.rf, "tm30_rg": f.fidelity.rg,
        "tm30_rf_hj": f.fidelity.rf_hj, "tm30_rcs_hj": f.fidelity.rcs_hj, "tm30_rhs_hj": f.fidelity.rhs_hj,
        "peak_wavelength_nm": f.peak_wavelength_nm, "dominant_wavelength_nm": f.dominant_wavelength_nm,
    }


def _json_number(value: float) -> float | None:
    return float(value) if math.isfinite(float(value)) else None


def _json(value: NDArray[np.float64] | float) -> Any:
    arr = np.asarray(value, dtype=np.float64)
    return _json_number(arr) if arr.ndim == 0 else [_json(v) for v in arr]


@dataclass(frozen=True)
class Rendition:
    """The figures of one SPD, and (with an uncertainty) their ranges."""

    values: dict[str, Any]  # key → float or list (JSON-ready; None where undefined)
    cvg_reference_hue_deg: list[float | None]
    cvg_test_xy: list[list[float | None]]
    ranges: dict[str, Any] = field(default_factory=dict)  # key → [low, high] (lists for per-sample figures)
    too_wide: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    samples: int = 0
    seed: int = DEFAULT_SEED
    correlation_nm: float = CORRELATION_NM
    std_scale: float = STD_SCALE

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"defined": True, **self.values,
                               "tm30_cvg": {"reference_hue_deg": self.cvg_reference_hue_deg,
                                            "test_xy": self.cvg_test_xy}}
        if self.samples:
            out.update(ranges=self.ranges, too_wide=list(self.too_wide),
                       interval=(f"{INTERVAL_PERCENT[0]:g}–{INTERVAL_PERCENT[1]:g} % of {self.samples} SPDs drawn "
                                 f"from spd ± {self.std_scale:g} × spd_std, "
                                 + (f"correlated over {self.correlation_nm:g} nm" if self.correlation_nm > 0
                                    else "independent per 5 nm sample") + f", seed {self.seed}"),
                       samples=self.samples, seed=self.seed, correlation_nm=self.correlation_nm,
                       std_scale=self.std_scale, interval_percent=list(INTERVAL_PERCENT))
        out.update(notes=list(self.notes), not_computed=dict(NOT_COMPUTED))
        return out


def _undefined(reason: str) -> dict[str, Any]:
    return {"defined": False, "reason": reason, "not_computed": dict(NOT_COMPUTED)}


def _defined_for(spd: NDArray[np.float64]) -> tuple[str | None, list[str]]:
    """(why the figures are undefined for this light, or None; notes on their use)."""
    cct, duv = cct_duv(spd)
    if cct is None or duv is None:
        return ("the light is too far from white for colour rendering (CRI and TM-30 compare it with a white "
                "reference; its CCT is undefined)"), []
    if not CCT_RANGE_K[0] <= cct <= CCT_RANGE_K[1]:
        return (f"the light's CCT ({cct:.0f} K) is outside the {CCT_RANGE_K[0]:.0f}–{CCT_RANGE_K[1]:.0f} K "
                "that CIE 224 and TM-30 define references for"), []
    notes = []
    if abs(duv) > CIE_13_3_MAX_DUV:
        notes.append(f"Duv {duv:+.4f} is beyond CIE 13.3's ±{CIE_13_3_MAX_DUV} from the Planckian locus: Ra and "
                     "R1–R14 are only indicative for this light")
    return None, notes


def rendition(spd: ArrayLike, std: ArrayLike | None = None, *, samples: int = DEFAULT_SAMPLES,
              seed: int = DEFAULT_SEED, correlation_nm: float = CORRELATION_NM,
              std_scale: float = STD_SCALE) -> dict[str, Any]:
    """The estimate's ``"rendition"`` JSON object: figures of ``spd`` (81 samples), and with its
    one-sigma ``std`` their ranges from ``samples`` drawn SPDs (:mod:`.uncertainty`).
    ``{"defined": false, "reason"}`` for a light the figures do not apply to. CDSpectraError for
    an SPD no colour can be computed of."""
    result = rendition_of(spd, std, samples=samples, seed=seed, correlation_nm=correlation_nm, std_scale=std_scale)
    return result.to_json() if isinstance(result, Rendition) else _undefined(result)


def rendition_of(spd: ArrayLike, std: ArrayLike | None = None, *, samples: int = DEFAULT_SAMPLES,
                 seed: int = DEFAULT_SEED, correlation_nm: float = CORRELATION_NM,
                 std_scale: float = STD_SCALE) -> Rendition | str:
    """:class:`Rendition`, or the reason the figures are undefined for this light."""
    mean = np.asarray(spd, dtype=np.float64)
    if mean.ndim != 1:
        raise CDSpectraError(f"rendition takes one SPD of 81 values; got shape {mean.shape}")
    why, notes = _defined_for(mean)  # validates the SPD too (CDSpectraError with the reason)
    if why is not None:
        return why
    n = int(samples) if std is not None else 0
    if std is not None and n < 10:
        raise CDSpectraError(f"ranges need at least 10 drawn SPDs; got {samples}")
    batch = mean[None] if n == 0 else np.concatenate([mean[None], draw_spds(mean, std, n, seed, correlation_nm,
                                                                             std_scale)])
    peak = batch.max(axis=1)
    batch = batch[peak > 0]  # a draw clipped to nothing is no light: left out (the estimate itself has a peak)
    f = figures(batch)
    values = figure_values(f)
    central = {k: v[0] for k, v in values.items()}
    ranges, too_wide = {}, []
    if n:
        for key, arr in values.items():
            lo, hi, wide = _range(arr[1:], central[key], TOO_WIDE[key], CEILING.get(key))
            ranges[key] = [_json(lo), _json(hi)]
            if wide:
                too_wide.append(key)
    return Rendition(values={k: _json(v) for k, v in central.items()},
                     cvg_reference_hue_deg=_json(f.fidelity.cvg_reference_hue[0]),
                     cvg_test_xy=_json(f.fidelity.cvg_test[0]), ranges=ranges, too_wide=tuple(too_wide),
                     notes=tuple(notes), samples=n, seed=int(seed), correlation_nm=float(correlation_nm),
                     std_scale=float(std_scale))


def _quantile(ordered: NDArray[np.float64], count: NDArray[np.int64], q: float) -> NDArray[np.float64]:
    """numpy's default (linear) quantile of each column's first ``count`` values of ``ordered``
    (sorted, NaN last) — nanquantile without its per-column loop."""
    pos = q * np.maximum(count - 1, 0)
    below = np.floor(pos).astype(np.int64)
    above = np.minimum(below + 1, np.maximum(count - 1, 0))
    low = np.take_along_axis(ordered, below[None], axis=0)[0]
    high = np.take_along_axis(ordered, above[None], axis=0)[0]
    return np.where(count > 0, low + (pos - below) * (high - low), np.nan)


def _range(draws: NDArray[np.float64], central: NDArray[np.float64], limit: float, ceiling: float | None = None
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """(low, high, too wide?) of a figure's draws (m,) or (m, k): the interval's quantiles widened
    to include the central value, and up to the figure's ``ceiling`` where the estimate is closer
    to it than the draws spread below (see :data:`CEILING`); too wide where wider than ``limit``,
    or where more than a tenth of the draws have no value (a hue bin left empty, a light that is no
    longer white)."""
    finite = np.isfinite(draws)
    count = finite.sum(axis=0)
    ordered = np.sort(np.where(finite, draws, np.nan), axis=0)
    lo = np.fmin(_quantile(ordered, count, INTERVAL_PERCENT[0] / 100), central)
    hi = np.fmax(_quantile(ordered, count, INTERVAL_PERCENT[1] / 100), central)
    if ceiling is not None:
        hi = np.where(ceiling - central <= central - lo, np.fmax(hi, ceiling), hi)
    # An estimate without a value (a hue bin it leaves empty) gets no range either, however many
    # draws have one: fmin/fmax above would give a range around nothing (hypothesis found a
    # two-line SPD whose Rg range was [88, …] with no Rg).
    undefined = ~np.isfinite(central)
    lo, hi = np.where(undefined, np.nan, lo), np.where(undefined, np.nan, hi)
    missing = count < 0.9 * draws.shape[0]
    wide = bool(np.any(missing) or np.any(~np.isfinite(hi - lo)) or np.any(hi - lo > limit))
    return lo, hi, wide


# --- what people read ---------------------------------------------------------------------------

_DIGITS = {"peak_wavelength_nm": 0, "dominant_wavelength_nm": 0}


def format_figure(data: dict[str, Any], key: str) -> str:
    """One figure as text: "83 [80, 85]" (value [90 % range]); "83 [30, 95]: range too wide" when
    flagged; "—" where undefined. Wavelengths get " nm"."""
    value = data.get(key)
    if not isinstance(value, (int, float)):
        return "—"
    unit = " nm" if key.endswith("_nm") else ""
    digits = _DIGITS.get(key, 0)
    text = f"{value:.{digits}f}{unit}".replace("-", "−")
    bounds = (data.get("ranges") or {}).get(key)
    if bounds and all(isinstance(b, (int, float)) for b in bounds) and bounds[0] != bounds[1]:
        text += f" [{bounds[0]:.{digits}f}, {bounds[1]:.{digits}f}]".replace("-", "−")
    if key in (data.get("too_wide") or ()):
        text += ": range too wide to mean anything"
    return text


def summary_text(data: dict[str, Any] | None) -> list[str]:
    """Lines for people: the headline figures with their 90 % ranges, peak and dominant
    wavelength, the flags and notes. Empty for an estimate made without rendition."""
    if not data:
        return []
    if not data.get("defined", False):
        return [f"no colour rendition: {data.get('reason', 'not computed')}"]
    head = ", ".join(f"{_LABELS[k]} {format_figure(data, k)}" for k in HEADLINE)
    lines = [head, f"peak {format_figure(data, 'peak_wavelength_nm')}, dominant wavelength "
                   f"{format_figure(data, 'dominant_wavelength_nm')}"]
    if data.get("ranges"):
        lines.append(f"[ ] = 90 % range from the estimate's uncertainty; TLCI not computed (no implementation in "
                     "colour-science)")
    wide = [_LABELS.get(k, k) for k in data.get("too_wide") or () if k not in HEADLINE + ("peak_wavelength_nm",
                                                                                      "dominant_wavelength_nm")]
    if wide:
        lines.append("ranges too wide to mean anything: " + ", ".join(wide))
    return lines + [str(n) for n in data.get("notes") or ()]


def compare_rendition(estimate: dict[str, Any], reference_spd: ArrayLike) -> dict[str, Any]:
    """An estimate's rendition JSON against a reference SPD (a meter's): the reference's figures,
    estimate − reference for each, and whether the reference lies within the estimate's range.
    ``{"defined": false, "reason"}`` where either side has no figures."""
    ref = rendition(reference_spd)
    if not estimate.get("defined", False) or not ref.get("defined", False):
        why = estimate.get("reason") if not estimate.get("defined", False) else f"reference: {ref.get('reason')}"
        return {"defined": False, "reason": why or "no rendition"}
    out: dict[str, Any] = {"defined": True, "reference": {}, "difference": {}, "within_range": {}}
    for key in TOO_WIDE:
        est, truth = estimate.get(key), ref.get(key)
        out["reference"][key] = truth
        out["difference"][key] = _difference(est, truth)
        bounds = (estimate.get("ranges") or {}).get(key)
        if bounds is not None:
            out["within_range"][key] = _within(bounds, truth)
    return out


def _difference(est: Any, truth: Any) -> Any:
    if isinstance(est, list) and isinstance(truth, list):
        return [_difference(a, b) for a, b in zip(est, truth)]
    if isinstance(est, (int, float)) and isinstance(truth, (int, float)):
        return float(est) - float(truth)
    return None


def _within(bounds: Any, truth: Any) -> Any:
    if not (isinstance(bounds, (list, tuple)) and len(bounds) == 2):
        return None
    lo, hi = bounds
    if isinstance(truth, list):
        if not (isinstance(lo, list) and isinstance(hi, list)):
            return None
        return [_within([a, b], t) for a, b, t in zip(lo, hi, truth)]
    if not all(isinstance(v, (int, float)) for v in (lo, hi, truth)):
        return None
    return bool(lo <= truth <= hi)
