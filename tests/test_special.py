"""The core's special functions against the standard library's (math.erf, statistics.NormalDist)
and scipy's, over their whole useful range."""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np
import pytest

from cd_spectra_addon.core.numerics.special import erf, erfc, norm_ppf

X = np.concatenate([np.linspace(-6.0, 6.0, 2401), [0.0, -0.0, 1e-9, -1e-9, 12.0, -12.0, 40.0, -40.0]])
P = np.concatenate([np.linspace(1e-6, 1 - 1e-6, 2001), [1e-12, 1e-9, 0.02425, 0.5, 1 - 0.02425, 1 - 1e-9]])


def test_erf_and_erfc_match_math_within_the_fits_error():
    ref_erf = np.array([math.erf(v) for v in X])
    ref_erfc = np.array([math.erfc(v) for v in X])
    assert np.max(np.abs(erf(X) - ref_erf)) < 1.2e-7
    # erfc's error is relative: it stays accurate far into the tail, where erfc ≈ 1e-16.
    tail = ref_erfc > 1e-300
    assert np.max(np.abs(erfc(X)[tail] / ref_erfc[tail] - 1.0)) < 1.2e-7
    assert np.array_equal(erfc(X), np.where(X >= 0, erfc(X), 2.0 - erfc(-X)))  # erfc(−x) = 2 − erfc(x)


def test_erf_is_odd_and_bounded_and_keeps_shape():
    nonzero = X != 0.0  # erf(±0) is the fit's −3e-8, the same for both signs
    assert np.array_equal(erf(-X[nonzero]), -erf(X[nonzero]))
    assert np.all(np.abs(erf(X)) <= 1.0)
    assert erf(np.zeros((2, 3))).shape == (2, 3)
    assert float(erf(0.0)) == pytest.approx(0.0, abs=1.2e-7) and float(erf(np.inf)) == 1.0 and float(erf(-np.inf)) == -1.0


def test_norm_ppf_matches_the_standard_library():
    ref = np.array([NormalDist().inv_cdf(float(p)) for p in P])
    assert np.max(np.abs(norm_ppf(P) - ref)) < 1.2e-8  # Acklam: |error| < 1.2e-9 relative to |z| ≤ 7
    assert np.all(np.isfinite(norm_ppf([0.0, 1.0])))  # clipped to 1e-12 from the ends, not ±inf


def test_norm_ppf_is_odd_about_one_half():
    """Φ⁻¹(1 − p) = −Φ⁻¹(p): the upper tail once divided by the lower tail's denominator."""
    p = np.linspace(1e-9, 0.5, 1001)
    assert np.max(np.abs(norm_ppf(1.0 - p) + norm_ppf(p))) < 1e-8


def test_against_scipy():
    special = pytest.importorskip("scipy.special")
    assert np.max(np.abs(erf(X) - special.erf(X))) < 1.2e-7
    assert np.max(np.abs(norm_ppf(P) - special.ndtri(P))) < 1.2e-8
