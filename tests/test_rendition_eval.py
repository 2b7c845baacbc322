"""The rendition coverage measurement (``make eval-rendition``, ``make eval``'s column): what
counts as covered, and how the draws' length and factor are chosen — on small made-up cases."""

from __future__ import annotations

import math

import colour
import numpy as np

from cd_spectra_addon.core.rendition.result import rendition
from cd_spectra_addon.core.spectra.grid import N_BANDS, resample_to_grid
from training.evaluation import rendition_coverage as rc
from training.evaluation.evaluate import RENDITION_FIGURES, rendition_scores, rendition_summary


def _illuminant(name: str) -> np.ndarray:
    sd = colour.SDS_ILLUMINANTS[name]
    spd = resample_to_grid(sd.wavelengths, sd.values)
    return spd / spd.max()


def test_a_range_covers_its_own_spd_and_not_a_far_one() -> None:
    spd = _illuminant("FL11")
    estimate = rendition(spd, np.full(N_BANDS, 0.01))
    own = rendition_scores(estimate, spd)
    assert all(own[f"covered_{k}"] == 1.0 and own[f"error_{k}"] < 1e-6 for k in RENDITION_FIGURES), own
    other = rendition_scores(estimate, _illuminant("A"))  # Ra 100 against a triphosphor's ~83
    assert other["covered_cri_ra"] == 0.0 and other["error_cri_ra"] > 10


def test_figures_undefined_on_either_side_are_not_scored() -> None:
    spd = _illuminant("D65")
    green = np.exp(-0.5 * ((np.linspace(380, 780, N_BANDS) - 530) / 10) ** 2)  # far from white
    rows = [rendition_scores(rendition(green, np.full(N_BANDS, 0.01)), spd),
            rendition_scores(None, spd),  # an estimate made with --no-rendition
            rendition_scores(rendition(spd, np.full(N_BANDS, 0.01)), spd)]
    assert math.isnan(rows[0]["covered_cri_ra"]) and math.isnan(rows[1]["covered_cri_ra"])
    summary = rendition_summary(rows)
    assert summary["cri_ra"]["n"] == 1 and summary["cri_ra"]["coverage"] == 1.0


def test_the_choice_is_the_narrowest_pair_that_reaches_the_goal_else_the_best_worst_coverage() -> None:
    def row(nm: float, k: float, cov: float, width: float) -> dict:
        return {"correlation_nm": nm, "std_scale": k,
                **{key: {"coverage": cov, "median_width": width} for key in rc.HEADLINE}}

    rows = [row(10, 1.0, 0.85, 1.0), row(40, 1.0, 0.92, 5.0), row(40, 1.5, 0.97, 8.0)]
    assert rc.choose(rows) == (40.0, 1.0)
    assert rc.choose([row(10, 1.0, 0.80, 1.0), row(80, 2.0, 0.88, 9.0)]) == (80.0, 2.0)


def test_coverage_grows_with_the_factor_on_spd_std() -> None:
    """A wider draw never covers less: the lever the choice turns, checked on made-up estimates
    (the truth an estimate with a smooth error)."""
    rng = np.random.default_rng(0)
    cases = []
    for name in ("FL2", "FL11", "LED-B3", "LED-RGB1", "FL7"):
        truth = _illuminant(name)
        tilt = 1 + 0.08 * rng.standard_normal() * np.linspace(-1, 1, N_BANDS)
        cases.append({"spd": truth * tilt, "std": np.full(N_BANDS, 0.01), "truth": truth})
    narrow, wide = rc.coverage(cases, 40.0, 1.0), rc.coverage(cases, 40.0, 4.0)
    for key in rc.HEADLINE:
        assert wide[key]["coverage"] >= narrow[key]["coverage"]
        assert wide[key]["median_width"] > narrow[key]["median_width"]
    assert narrow["undefined_truth"] == 0


def test_the_shipped_pair_is_one_of_the_candidates() -> None:
    """The report marks the product's (length, factor) among the candidates it measures."""
    assert rc.SHIPPED[0] in rc.CANDIDATES_NM and rc.SHIPPED[1] in rc.CANDIDATE_SCALES
