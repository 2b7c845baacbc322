"""Colour rendition: parity with colour-science on the same SPD, the baked tables, the ranges
drawn from an estimate's uncertainty, and properties that must hold for any SPD a user gives.

"The same SPD" is the product's: the piecewise-linear curve through the 81 samples, zero
outside 380–780 nm, which colour-science is given at 1 nm (360–780 nm for CIE 13.3, whose
observer starts at 360 nm; 380–780 nm for CIE 2017 / TM-30).
"""

from __future__ import annotations

import json
import warnings

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.rendition import cam02, result, uncertainty
from cd_spectra_addon.core.rendition.figures import dominant_wavelength, figures
from cd_spectra_addon.core.rendition.tables import interpolation_matrix, rendition_tables
from cd_spectra_addon.core.rendition.vector_graphic import vector_graphic_image, vector_graphic_points
from cd_spectra_addon.core.spectra.colour import spd_to_xy
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM, resample_to_grid

FAST = ("FL2", "FL11", "LED-B1", "LED-RGB1", "A", "D65", "HP1")
ALL = tuple(f"FL{i}" for i in range(1, 13)) + tuple(n for n in colour.SDS_ILLUMINANTS if n.startswith("LED-")) + (
    "A", "D50", "D65", "HP1", "FL3.8")


def illuminant(name: str) -> np.ndarray:
    sd = colour.SDS_ILLUMINANTS[name]
    spd = resample_to_grid(sd.wavelengths, sd.values)
    return spd / spd.max()


def synthetic() -> dict[str, np.ndarray]:
    """Lights no dataset holds: a blackbody, a phosphor-converted and an RGB LED, a warm LED."""
    lam = WAVELENGTHS_NM
    gauss = lambda c, w: np.exp(-0.5 * ((lam - c) / w) ** 2)  # noqa: E731
    planck = 1.0 / (lam**5 * np.expm1(1.4388e7 / (lam * 3200.0)))
    return {
        "blackbody 3200 K": planck / planck.max(),
        "phosphor LED 5000 K": gauss(450, 10) + 0.9 * gauss(560, 55),
        "RGB LED": gauss(460, 10) + 1.1 * gauss(530, 15) + 0.9 * gauss(625, 10),
        "warm LED + red": 0.4 * gauss(450, 9) + gauss(600, 60) + 0.3 * gauss(660, 12),
    }


def colour_science(spd: np.ndarray) -> dict[str, object]:
    """colour-science's figures of the product's SPD (the 1 nm curve through its samples)."""
    t = rendition_tables()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cri = colour.colour_rendering_index(
            colour.SpectralDistribution(interpolation_matrix(t.cri_wavelength_nm) @ spd, t.cri_wavelength_nm),
            additional_data=True)
        sd = colour.SpectralDistribution(interpolation_matrix(t.cfi_wavelength_nm) @ spd, t.cfi_wavelength_nm)
        tm30 = colour.colour_fidelity_index(sd, additional_data=True, method="ANSI/IES TM-30-18")
        cie2017 = colour.colour_fidelity_index(sd, method="CIE 2017")
    return {"ri": np.array([cri.Q_as[i].Q_a for i in range(1, 15)]), "ra": cri.Q_a, "tm30": tm30, "cie2017": cie2017}


def assert_parity(spd: np.ndarray) -> None:
    ref = colour_science(spd)
    f = figures(spd[None])
    tm30 = ref["tm30"]
    assert f.cri_ri[0] == pytest.approx(ref["ri"], abs=1e-6)
    assert f.cri_ra[0] == pytest.approx(ref["ra"], abs=1e-6)
    assert f.fidelity.rf[0] == pytest.approx(ref["cie2017"], abs=1e-3)
    assert f.fidelity.rf[0] == pytest.approx(tm30.R_f, abs=1e-3)
    assert f.fidelity.rg[0] == pytest.approx(tm30.R_g, abs=1e-3)
    assert f.fidelity.rf_hj[0] == pytest.approx(tm30.R_fs, abs=1e-3)
    assert f.fidelity.rcs_hj[0] == pytest.approx(tm30.R_cs, abs=1e-3)
    assert f.fidelity.rhs_hj[0] == pytest.approx(tm30.R_hs, abs=1e-5)
    assert f.fidelity.cct[0] == pytest.approx(tm30.CCT, abs=1e-3)
    ref_xy = colour.dominant_wavelength(spd_to_xy(spd), [1 / 3, 1 / 3])[0]
    assert f.dominant_wavelength_nm[0] == ref_xy


# --- parity with colour-science -------------------------------------------------------------------


@pytest.mark.parametrize("name", FAST)
def test_parity_on_cie_illuminants(name: str) -> None:
    assert_parity(illuminant(name))


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in ALL if n not in FAST])
def test_parity_on_every_f_series_and_led_illuminant(name: str) -> None:
    assert_parity(illuminant(name))


@pytest.mark.parametrize("name", sorted(synthetic()))
def test_parity_on_synthetic_lights(name: str) -> None:
    assert_parity(synthetic()[name])


def test_a_batch_gives_each_lights_own_figures() -> None:
    """The batch path (what the ranges use) computes each row as if it were alone."""
    spds = np.stack([illuminant(n) for n in ("FL2", "A", "D65", "LED-B1")])
    together = figures(spds)
    for i, spd in enumerate(spds):
        alone = figures(spd[None])
        assert together.cri_ri[i] == pytest.approx(alone.cri_ri[0], abs=1e-9)
        assert together.fidelity.rf_hj[i] == pytest.approx(alone.fidelity.rf_hj[0], abs=1e-9)
        assert together.fidelity.rg[i] == pytest.approx(alone.fidelity.rg[0], abs=1e-9)


def test_native_data_differ_only_by_the_representation() -> None:
    """colour-science on an illuminant's own 5 nm data interpolates it smoothly (Sprague) and
    extends it below 380 nm; the product's SPD is linear between samples. That moves the figures
    by at most a few tenths — the size of the difference README states."""
    for name in ("FL2", "FL11", "HP1", "LED-RGB1", "LED-B1"):
        sd = colour.SDS_ILLUMINANTS[name]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            native = colour.colour_fidelity_index(sd, additional_data=True, method="ANSI/IES TM-30-18")
            ra = colour.colour_rendering_index(sd)
        f = figures(illuminant(name)[None])
        assert abs(f.fidelity.rf[0] - native.R_f) < 0.35 and abs(f.fidelity.rg[0] - native.R_g) < 0.35
        assert abs(f.cri_ra[0] - ra) < 0.05


def test_cam02_ucs_matches_colour_science(rng: np.random.Generator) -> None:
    xyz = rng.uniform(1.0, 90.0, (4, 30, 3))
    white = np.stack([rng.uniform(90, 110, 4), np.full(4, 100.0), rng.uniform(60, 110, 4)], axis=-1)[:, None, :]
    jab, hue = cam02.xyz_to_jab(xyz, white)
    spec = colour.XYZ_to_CIECAM02(xyz, white, 100.0, 20.0, colour.VIEWING_CONDITIONS_CIECAM02["Average"],
                                  discount_illuminant=True, compute_H=False)
    want = colour.JMh_CIECAM02_to_CAM02UCS(np.stack([spec.J, spec.M, spec.h], axis=-1))
    assert jab == pytest.approx(want, abs=1e-9)
    assert hue == pytest.approx(spec.h, abs=1e-9)


def test_dominant_wavelength_matches_colour_science(rng: np.random.Generator) -> None:
    xy = rng.uniform(0.05, 0.7, (300, 2))
    xy = xy[xy.sum(axis=1) < 0.95]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        want = np.array([colour.dominant_wavelength(p, [1 / 3, 1 / 3])[0] for p in xy])
    assert np.array_equal(dominant_wavelength(xy), want)
    assert np.isnan(dominant_wavelength([1 / 3, 1 / 3]))  # the white itself has none


def test_the_baked_tables_are_colour_sciences() -> None:
    """The guard for ``make bake-colour``: every rendition table is colour-science's own array."""
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES, SPECTRAL_SHAPE_DEFAULT, reshape_sd
    from colour.quality.cfi2017 import load_TCS_CIE2017
    from colour.quality.datasets.tcs import SDS_TCS
    from colour.temperature.ohno2013 import planckian_table

    t = rendition_tables()
    shape = colour.SpectralShape(380, 780, 1)
    # colour-science interpolates these on load; the last bits of its rounding differ by machine
    # (seen: 1e-15 relative, 7e-14 absolute next to zero), so "its own array" is to 1e-12
    same = {"rel": 1e-12, "abs": 1e-12}
    assert t.cri_tcs[:, 8] == pytest.approx(reshape_sd(SDS_TCS["TCS09"], SPECTRAL_SHAPE_DEFAULT).values, **same)
    assert t.cfi_ces == pytest.approx(load_TCS_CIE2017(shape).values, **same)
    assert t.cfi_cmf_10 == pytest.approx(colour.colorimetry.reshape_msds(
        colour.MSDS_CMFS["CIE 1964 10 Degree Standard Observer"], shape).values, **same)
    s1 = SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES["S1"]
    assert t.cfi_daylight_basis[:, 1] == pytest.approx(reshape_sd(s1, shape).values, **same)
    assert t.cri_daylight_basis[:, 1] == pytest.approx(np.interp(t.cri_wavelength_nm, s1.wavelengths, s1.values))
    table = planckian_table(colour.colorimetry.handle_spectral_arguments(None)[0], 1000, 25000, 1.001)
    assert t.cfi_planckian_table == pytest.approx(table, rel=1e-12)  # uv are sums: rounding differs by machine


# --- behaviour ------------------------------------------------------------------------------------


def test_a_reference_illuminant_renders_colours_as_itself() -> None:
    """A Planckian radiator below 4000 K is its own reference for both CIE 13.3 and CIE 2017: every
    index is 100 and the vector graphic is the unit circle."""
    f = figures(synthetic()["blackbody 3200 K"][None])
    assert f.cri_ri[0] == pytest.approx(np.full(14, 100.0), abs=0.1)  # Robertson's CCT is a few K off
    assert f.fidelity.rf[0] == pytest.approx(100.0, abs=0.05) and f.fidelity.rg[0] == pytest.approx(100.0, abs=0.05)
    assert np.hypot(*f.fidelity.cvg_test[0].T) == pytest.approx(np.ones(16), abs=0.01)


def test_figures_do_not_depend_on_the_scale() -> None:
    spd = illuminant("FL11")
    a, b = result.rendition(spd), result.rendition(spd * 1e-6)
    assert {k: a[k] for k in ("cri_ra", "cri_r9", "tm30_rf", "tm30_rg")} == pytest.approx(
        {k: b[k] for k in ("cri_ra", "cri_r9", "tm30_rf", "tm30_rg")}, abs=1e-9)


def test_ranges_hold_the_value_and_shrink_with_the_uncertainty() -> None:
    spd = illuminant("FL11")
    wide = result.rendition(spd, np.full(N_BANDS, 0.05))
    narrow = result.rendition(spd, np.full(N_BANDS, 0.002))
    for key in result.HEADLINE:
        lo, hi = wide["ranges"][key]
        assert lo <= wide[key] <= hi
        n_lo, n_hi = narrow["ranges"][key]
        assert n_hi - n_lo < (hi - lo) / 5
    assert narrow["too_wide"] == [] and narrow["ranges"]["cri_ra"][1] - narrow["ranges"]["cri_ra"][0] < 2.0


def test_ranges_are_reproducible_and_seeded() -> None:
    spd, std = illuminant("LED-B1"), np.full(N_BANDS, 0.03)
    assert result.rendition(spd, std) == result.rendition(spd, std)
    assert result.rendition(spd, std, seed=1)["ranges"] != result.rendition(spd, std, seed=2)["ranges"]


def test_an_uncertain_estimate_is_flagged_not_trusted() -> None:
    data = result.rendition(illuminant("FL2"), np.full(N_BANDS, 0.4))
    assert {"cri_ra", "cri_r9"} <= set(data["too_wide"])
    text = "\n".join(result.summary_text(data))
    assert "Ra" in text and "range too wide to mean anything" in text


def test_correlated_draws_give_wider_ranges_than_independent_ones() -> None:
    """Independent errors per 5 nm sample average out in the integrals behind every figure; a
    correlated error does not. (Which one covers the truth is measured: make eval-rendition.)"""
    spd, std = illuminant("FL11"), np.full(N_BANDS, 0.05)
    ind = result.rendition(spd, std, correlation_nm=0.0)["ranges"]["cri_ra"]
    cor = result.rendition(spd, std, correlation_nm=20.0)["ranges"]["cri_ra"]
    assert cor[1] - cor[0] > 1.5 * (ind[1] - ind[0])


def test_the_factor_on_spd_std_is_the_same_as_a_larger_std_and_is_recorded() -> None:
    spd, std = illuminant("FL11"), np.full(N_BANDS, 0.02)
    scaled = result.rendition(spd, std, std_scale=1.5)
    assert scaled["ranges"] == result.rendition(spd, 1.5 * std, std_scale=1.0)["ranges"]
    assert scaled["std_scale"] == 1.5 and "1.5 × spd_std" in scaled["interval"]
    assert result.rendition(spd, std)["std_scale"] == uncertainty.STD_SCALE


def test_a_fidelity_figure_near_100_has_a_range_up_to_100() -> None:
    """A near-Planckian estimate is near the fidelity figures' maximum: its drawn SPDs all score
    lower, so the quantiles alone would end at the estimate and miss a truer lamp above it."""
    planck = illuminant("A")
    data = result.rendition(planck * (1 + 0.004 * np.linspace(-1, 1, N_BANDS)), np.full(N_BANDS, 0.03))
    for key in ("cri_ra", "tm30_rf"):
        assert data[key] < 100 and data["ranges"][key][1] == 100.0
    assert data["ranges"]["tm30_rg"][1] != 100.0  # Rg has no ceiling
    fl11 = result.rendition(illuminant("FL11"), np.full(N_BANDS, 0.02))  # Ra 83, far below: untouched
    assert fl11["ranges"]["cri_ra"][1] < 95


def test_correlated_normals_have_unit_variance_and_the_asked_correlation() -> None:
    z = uncertainty.correlated_normals(20000, seed=3, correlation_nm=20.0)
    assert z.std(axis=0) == pytest.approx(np.ones(N_BANDS), abs=0.03)
    lag = 4  # 20 nm
    r = np.mean([np.corrcoef(z[:, i], z[:, i + lag])[0, 1] for i in range(0, N_BANDS - lag, 7)])
    assert r == pytest.approx(np.exp(-0.5), abs=0.03)
    assert uncertainty.draw_spds(np.zeros(N_BANDS), np.ones(N_BANDS), 50).min() >= 0.0  # no negative power


def test_lights_far_from_white_have_no_rendition_and_say_why() -> None:
    red = np.exp(-0.5 * ((WAVELENGTHS_NM - 630) / 8) ** 2)
    data = result.rendition(red, np.full(N_BANDS, 0.01))
    assert data["defined"] is False and "white" in data["reason"]
    assert result.summary_text(data) == [f"no colour rendition: {data['reason']}"]
    hot = 1.0 / (WAVELENGTHS_NM**5 * np.expm1(1.4388e7 / (WAVELENGTHS_NM * 40000.0)))
    assert "25000" in result.rendition(hot)["reason"]


def test_cie_13_3_limit_on_duv_is_noted() -> None:
    green = synthetic()["phosphor LED 5000 K"]
    from cd_spectra_addon.core.spectra.colour import cct_duv

    _, duv = cct_duv(green)
    notes = result.rendition(green)["notes"]
    assert bool(notes) == (abs(duv) > result.CIE_13_3_MAX_DUV)


def test_what_is_not_computed_is_said() -> None:
    data = result.rendition(illuminant("D65"))
    assert "colour-science" in data["not_computed"]["tlci"] and "cri_r15" in data["not_computed"]
    assert len(data["cri_ri"]) == 14


def test_compare_against_a_reference() -> None:
    spd, std = illuminant("FL11"), np.full(N_BANDS, 0.02)
    est = result.rendition(spd, std)
    same = result.compare_rendition(est, spd)
    assert same["difference"]["cri_ra"] == pytest.approx(0.0, abs=1e-9)
    assert all(same["within_range"][k] for k in result.HEADLINE)
    other = result.compare_rendition(est, illuminant("FL2"))
    assert other["difference"]["cri_ra"] == pytest.approx(est["cri_ra"] - result.rendition(illuminant("FL2"))["cri_ra"])
    assert other["within_range"]["cri_ra"] is False
    assert result.compare_rendition({"defined": False, "reason": "x"}, spd) == {"defined": False, "reason": "x"}


def test_vector_graphic() -> None:
    data = result.rendition(illuminant("FL2"))
    ref, test = vector_graphic_points(data)
    assert len(ref) == len(test) == 16
    assert np.hypot(*np.array(ref).T) == pytest.approx(np.ones(16))
    image = vector_graphic_image(data, 64)
    assert image.shape == (64, 64, 4) and image.dtype == np.float32
    assert np.all(np.isfinite(image)) and image.min() >= 0.0 and image.max() <= 1.0
    assert vector_graphic_image(result.rendition(np.exp(-0.5 * ((WAVELENGTHS_NM - 630) / 8) ** 2))) is None
    assert vector_graphic_points({"defined": True, "tm30_cvg": {"reference_hue_deg": [None] * 16,
                                                                "test_xy": [[0, 0]] * 16}}) is None


# --- what a user may hand it ------------------------------------------------------------------------


@pytest.mark.parametrize("bad, match", [
    (np.full(N_BANDS, np.nan), "NaN"),
    (np.r_[np.ones(80), np.inf], "NaN or infinite"),
    (np.r_[np.ones(80), -0.1], "negative"),
    (np.zeros(N_BANDS), "zero everywhere"),
    (np.ones(40), "81"),
])
def test_bad_spds_are_refused_with_a_reason(bad: np.ndarray, match: str) -> None:
    with pytest.raises(CDSpectraError, match=match):
        result.rendition(bad)


@pytest.mark.parametrize("std, match", [(np.full(N_BANDS, np.nan), "finite"), (np.full(N_BANDS, -1.0), "non-negative"),
                                        (np.ones(3), "81")])
def test_a_bad_uncertainty_is_refused(std: np.ndarray, match: str) -> None:
    with pytest.raises(CDSpectraError, match=match):
        result.rendition(illuminant("A"), std)


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, N_BANDS, elements=st.floats(0.0, 1e3, allow_nan=False, allow_infinity=False)),
       st.floats(0.0, 0.3))
def test_any_spd_gives_finite_json_or_a_reason(spd: np.ndarray, sigma: float) -> None:
    if spd.max() <= 0:
        with pytest.raises(CDSpectraError):
            result.rendition(spd)
        return
    data = result.rendition(spd, np.full(N_BANDS, sigma) * spd.max(), samples=20)  # 20 draws: the same path, 4× faster
    json.dumps(data, allow_nan=False)  # no NaN or Inf reaches the JSON
    if data["defined"]:
        for key in result.HEADLINE:
            lo, hi = data["ranges"][key]
            if data[key] is None:  # e.g. Rg of a few lines that leave TM-30's hue bins empty
                assert lo is None and hi is None and key in data["too_wide"]
            else:
                assert lo <= data[key] <= hi
        assert -1000 < data["cri_ra"] <= 100.0 + 1e-9 and 0.0 < data["tm30_rf"] <= 100.0 + 1e-9
    else:
        assert data["reason"]


def test_a_figure_without_a_value_has_no_range():
    """Two lines (425 and 610 nm) leave TM-30's hue bins empty: the estimate has no Rg, and its
    range must not be made of the draws that have one (hypothesis found [88, …] around nothing)."""
    spd = np.zeros(N_BANDS)
    spd[16], spd[46] = 1.0, 4.0
    data = result.rendition(spd, np.full(N_BANDS, 0.25) * spd.max(), samples=20)
    json.dumps(data, allow_nan=False)
    if data["defined"]:
        for key in result.HEADLINE:
            lo, hi = data["ranges"][key]
            if data[key] is None:
                assert lo is None and hi is None and key in data["too_wide"]
            else:
                assert lo <= data[key] <= hi
