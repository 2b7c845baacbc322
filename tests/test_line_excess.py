"""``solve.line_excess``: what the solve's line pass reads as a narrow line (issue 21)."""

import numpy as np
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.inverse.stages import model_prior
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.spectrum.solve import LINE_ALLOWANCE, LINE_WINDOW, Rows, line_excess, solve_prior

N = WAVELENGTHS_NM.size


def test_a_single_bin_line_stands_out_by_its_height_and_nothing_else_does():
    spd = np.full(N, 0.3)
    spd[20] += 0.9
    ex = line_excess(spd)
    assert abs(ex[20] - 0.9) < 1e-12
    assert np.all(np.delete(ex, 20) == 0)


def test_a_band_wider_than_the_window_barely_stands_out():
    band = np.exp(-0.5 * ((WAVELENGTHS_NM - 550) / 40) ** 2)
    assert line_excess(band).max() < 0.05
    narrow = np.exp(-0.5 * ((WAVELENGTHS_NM - 550) / 2) ** 2)
    assert line_excess(narrow).max() > 0.9


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, N, elements=st.floats(0, 10, allow_nan=False)),
       st.sampled_from([3, 5, LINE_WINDOW, 11]))
def test_excess_is_finite_non_negative_and_zero_on_a_monotone_spectrum(spd, window):
    ex = line_excess(spd, window)
    assert ex.shape == spd.shape and np.all(np.isfinite(ex)) and np.all(ex >= 0)
    assert np.all(ex <= spd - spd.min() + 1e-12)
    assert np.all(line_excess(np.sort(spd), window) == 0)


PRIOR = model_prior(load_model())


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(3, 240), st.floats(1e-6, 1e6), st.sampled_from([0.0, 1e-3, 0.5]))
def test_the_solve_with_the_line_pass_is_finite_and_non_negative_on_any_rows(seed, rows, scale, spike):
    """Random features at any scale (each a camera channel's view of a few bins around its
    wavelength, as the readout's are), with one bin made a spike or not: the estimate stays
    finite and non-negative, and without features it is the zero spectrum."""
    rng = np.random.default_rng(seed)
    centre = rng.uniform(0, N, (rows, 1))
    a = np.exp(-0.5 * ((np.arange(N + 6) - centre) / rng.uniform(0.5, 4.0, (rows, 1))) ** 2) * scale
    a[:, N:] = rng.choice([0.0, scale], size=(rows, 6))
    truth = np.abs(rng.normal(size=N))
    truth[rng.integers(N)] += spike * 50
    y = a[:, :N] @ truth + rng.normal(size=rows) * scale
    x = solve_prior(Rows(a, y, float(np.max(np.abs(y))), N), PRIOR[0], precision=PRIOR[1], lines=LINE_ALLOWANCE)
    assert x.shape == (N + 6,) and np.all(np.isfinite(x)) and np.all(x >= 0)
    empty = solve_prior(Rows(a[:0], y[:0], 0.0, N), PRIOR[0], precision=PRIOR[1], lines=LINE_ALLOWANCE)
    assert not np.any(empty[:N])
