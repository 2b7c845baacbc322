"""``solve.line_excess``: what the solve's line pass reads as a narrow line (issue 21)."""

import numpy as np
from hypothesis import given, settings, strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from cd_spectra_addon.core.spectrum.solve import LINE_WINDOW, line_excess

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
