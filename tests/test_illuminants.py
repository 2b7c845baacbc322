"""The illuminants module: Planck's law, CIE daylight and the calibration lamps, from first
principles and colour-science (which the product itself never imports)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import constants

from cd_spectra_addon.core.spectra import illuminants as il
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise


def _textbook_planck(lam_nm: np.ndarray, t: float) -> np.ndarray:
    lam = lam_nm * 1e-9
    return 2 * constants.h * constants.c**2 / lam**5 / np.expm1(constants.h * constants.c / (lam * constants.k * t))


def test_c2_is_hc_over_k():
    assert il.C2_NM_K == pytest.approx(constants.h * constants.c / constants.k * 1e9, rel=1e-9)  # 10 digits


@settings(max_examples=50, deadline=None)
@given(st.floats(500.0, 50_000.0))
def test_planck_is_the_textbook_law_scaled_to_one_at_560_nm(t):
    lam = np.append(WAVELENGTHS_NM, 560.0)
    ours = il.planck(lam, t)
    ref = _textbook_planck(lam, t)
    assert ours[-1] == pytest.approx(1.0, rel=1e-12)
    # c2 has 10 digits: the exponent's relative error 3.5e-10 times c2/λT (< 76) here.
    assert np.allclose(ours, ref / ref[-1], rtol=3e-8)
    # The unscaled form is the same law: equal up to one factor.
    raw = il.planck_radiance(lam, t, il.C2_NM_K)
    assert np.allclose(raw / raw[-1], ours, rtol=1e-12)


def test_planck_rows_broadcast():
    temps = np.array([[1500.0], [3000.0], [9000.0]])
    rows = il.planck(WAVELENGTHS_NM, temps)
    assert rows.shape == (3, WAVELENGTHS_NM.size)
    for row, t in zip(rows, temps[:, 0]):
        assert np.array_equal(row, il.planck(WAVELENGTHS_NM, t))


def test_a_hotter_radiator_is_bluer():
    cool, hot = il.planck_spd(2700.0), il.planck_spd(6500.0)
    assert cool.max() == hot.max() == 1.0
    assert cool[0] / cool[-1] < hot[0] / hot[-1]


@pytest.mark.parametrize(("name", "cct"), [("D50", 5003.0), ("D55", 5503.0), ("D65", 6504.0), ("D75", 7504.0)])
def test_daylight_matches_colour_science_d_series(name, cct):
    import colour
    ref = colour.SDS_ILLUMINANTS[name].copy().align(colour.SpectralShape(380, 780, 5)).values
    # colour's tables carry the CIE's published 5 nm values; ours interpolates the 10 nm basis.
    assert np.max(np.abs(il.daylight_spd(cct) - peak_normalise(ref))) < 2e-3


@pytest.mark.parametrize("cct", [3999.0, 25001.0, float("nan")])
def test_daylight_outside_its_range_is_refused(cct):
    with pytest.raises(CDSpectraError, match="between 4000 and 25000 K"):
        il.daylight_spd(cct)


def test_household_bulb_is_close_to_cie_a():
    """The bulb is Planck at 2856 K; CIE A is defined with an older c2 (1.435e-2 at 2848 K), the
    same curve to a few parts in 1e3."""
    import colour
    ref = colour.SDS_ILLUMINANTS["A"].copy().align(colour.SpectralShape(380, 780, 5)).values
    assert np.max(np.abs(il.known_lamp_spd("incandescent") - peak_normalise(ref))) < 5e-3


def test_known_lamps_are_peak_one_and_named():
    assert list(il.KNOWN_LAMPS) == ["incandescent", "daylight", "daylight-d65", "daylight-d50", "daylight-d75"]
    for name, lamp in il.KNOWN_LAMPS.items():
        spd = il.known_lamp_spd(name)
        assert spd.shape == WAVELENGTHS_NM.shape and spd.max() == 1.0 and spd.min() > 0
        assert lamp.label and lamp.description and f"{lamp.temperature_k:.0f} K" in lamp.description


@pytest.mark.parametrize(("alias", "key"), [("A", "incandescent"), ("d50", "daylight-d50"), ("D55", "daylight"),
                                            (" D65 ", "daylight-d65"), ("D75", "daylight-d75")])
def test_cie_names_reach_the_known_lamps(alias, key):
    assert np.array_equal(il.known_lamp_spd(alias), il.known_lamp_spd(key))


@given(st.text(max_size=20).filter(lambda s: s not in il.KNOWN_LAMPS and s.strip().lower() not in il.LAMP_ALIASES))
def test_unknown_lamp_names_the_choices(name):
    with pytest.raises(CDSpectraError, match="choose one of incandescent, daylight, daylight-d65"):
        il.known_lamp_spd(name)
