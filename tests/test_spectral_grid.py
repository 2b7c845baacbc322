import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.spectra.grid import (
    N_BANDS,
    WAVELENGTHS_NM,
    hat_integrals,
    peak_normalise,
    resample_to_grid,
)

# numpy 2 renamed trapz (deprecated, then removed); numpy 1.26 has only trapz.
_trapezoid = getattr(np, "trapezoid", None) or np.trapz


def test_grid_is_380_to_780_in_5nm():
    assert N_BANDS == 81
    assert WAVELENGTHS_NM[0] == 380 and WAVELENGTHS_NM[-1] == 780
    assert np.allclose(np.diff(WAVELENGTHS_NM), 5.0)


def test_hat_areas_sum_to_the_domain_width():
    areas = hat_integrals()
    assert areas[0] == pytest.approx(2.5) and areas[-1] == pytest.approx(2.5)
    assert np.allclose(areas[1:-1], 5.0)
    assert areas.sum() == pytest.approx(400.0)


def test_resample_keeps_the_energy_of_a_line_between_samples():
    # A 1 nm-wide line at 552.3 nm sampled at 0.5 nm: linear interpolation at 5 nm would miss it.
    wl = np.arange(300.0, 900.0, 0.5)
    spd = np.exp(-0.5 * ((wl - 552.3) / 0.4) ** 2)
    grid = resample_to_grid(wl, spd)
    energy_in = _trapezoid(spd, wl)
    energy_out = np.sum(grid * hat_integrals())
    assert energy_out == pytest.approx(energy_in, rel=0.02)
    assert set(np.flatnonzero(grid > 0.05 * grid.max())) == {34, 35}  # 550 and 555 nm


def test_resample_is_exact_on_the_grid_and_linear_for_coarser_input():
    values = np.sin(WAVELENGTHS_NM / 40.0) + 2
    assert np.allclose(resample_to_grid(WAVELENGTHS_NM, values), values)
    coarse = np.arange(380.0, 781.0, 10.0)
    out = resample_to_grid(coarse, coarse * 2.0)
    assert np.allclose(out, WAVELENGTHS_NM * 2.0)


def test_resample_rejects_nan_and_duplicates():
    with pytest.raises(ValueError):
        resample_to_grid([400, 500, 600], [1, np.nan, 1])
    with pytest.raises(ValueError):
        resample_to_grid([400, 400, 600], [1, 1, 1])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0, 1e6, allow_nan=False), min_size=81, max_size=81))
def test_peak_normalise_gives_peak_one_or_all_zero(values):
    out = peak_normalise(np.array(values))
    assert np.all(np.isfinite(out)) and np.all(out >= 0)
    assert out.max() == pytest.approx(1.0) or np.all(out == 0)
