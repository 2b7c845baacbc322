"""``colour.spectral_colour``: the one colour of an SPD (estimate, CLI and Blender lights), checked
against colour-science for the same piecewise-linear SPD and for any SPD a user may load."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.spectra import colour as cc
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.illuminants import daylight_spd, planck_spd
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM

import colour

OBSERVER = "CIE 1931 2 Degree Standard Observer"
SPACES = {"Linear Rec.709": ("ITU-R BT.709", None), "Linear Rec.2020": ("ITU-R BT.2020", None),
          "ACEScg": ("ACEScg", "Bradford")}


def _reference(spd: np.ndarray, space: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """xy, (CCT, Duv) and max-1 RGB by colour-science: 1 nm integral of the linear curve."""
    cmfs = colour.MSDS_CMFS[OBSERVER].copy().trim(colour.SpectralShape(380, 780, 1))
    sd = colour.SpectralDistribution(spd, WAVELENGTHS_NM).interpolate(
        colour.SpectralShape(380, 780, 1), interpolator=colour.LinearInterpolator)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        xyz = colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration", k=1)
        xy = colour.XYZ_to_xy(xyz)
        cct_duv = colour.uv_to_CCT(colour.xy_to_UCS_uv(xy), method="Ohno 2013")
        name, cat = SPACES[space]
        d65 = colour.CCS_ILLUMINANTS[OBSERVER]["D65"]
        rgb = (colour.XYZ_to_RGB(xyz, name, illuminant=d65, chromatic_adaptation_transform=cat) if cat
               else colour.XYZ_to_RGB(xyz, name))
    rgb = np.clip(rgb / rgb.max(), 0.0, None)
    return xy, cct_duv, rgb / rgb.max()


def _lamps() -> dict[str, np.ndarray]:
    led = np.exp(-0.5 * ((WAVELENGTHS_NM - 450) / 10) ** 2) + 0.8 * np.exp(-0.5 * ((WAVELENGTHS_NM - 570) / 50) ** 2)
    fl = colour.SDS_ILLUMINANTS["FL11"]
    return {"bulb 2856 K": planck_spd(2856.0), "D65": daylight_spd(6504.0), "warm LED": led,
            "FL11": np.interp(WAVELENGTHS_NM, fl.wavelengths, fl.values)}


@pytest.mark.parametrize("space", list(SPACES))
@pytest.mark.parametrize("name", list(_lamps()))
def test_matches_colour_science(name, space):
    spd = _lamps()[name]
    got = cc.spectral_colour(spd, space)
    xy, (cct, duv), rgb = _reference(spd, space)
    assert got.working_space == space
    np.testing.assert_allclose(got.xy, xy, atol=1e-9)
    assert got.cct_k == pytest.approx(cct, abs=0.2)  # colour's 1-step table vs our cascade
    assert got.duv == pytest.approx(duv, abs=1e-6)
    np.testing.assert_allclose(got.rgb, rgb, atol=1e-9)
    assert max(got.rgb) == 1.0


def test_a_line_outside_rec709_is_flagged_and_clipped():
    spd = np.zeros(N_BANDS)
    spd[46] = 1.0  # 610 nm
    got = cc.spectral_colour(spd, "Linear Rec.709")
    assert got.out_of_gamut and min(got.rgb) == 0.0 and got.cct_k is None and got.duv is None
    assert cc.spectral_colour(spd, "ACEScg").out_of_gamut is False


def test_the_estimate_reports_the_same_colour():
    """One computation: what the estimate prints is spectral_colour of its SPD."""
    from cd_spectra_addon.core.inverse.estimate import estimate_photo

    est = estimate_photo(Path(__file__).parents[1] / "samples" / "cd_photo.jpg")
    info = cc.spectral_colour(est.spd)
    assert (est.xy, est.cct_k, est.duv, est.rgb_scene_linear) == (info.xy, info.cct_k, info.duv, info.rgb)


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, N_BANDS, elements=st.floats(0.0, 1e6)).filter(lambda a: a.max() > 1e-290),  # ×1e-3 stays > 0
       st.sampled_from(list(SPACES)))
def test_any_light_has_a_finite_colour_independent_of_its_scale(spd, space):
    got = cc.spectral_colour(spd, space)
    assert all(np.isfinite(got.xy)) and 0 < got.xy[0] < 1 and 0 < got.xy[1] < 1
    assert max(got.rgb) == 1.0 and min(got.rgb) >= 0.0
    assert (got.cct_k is None) == (got.duv is None)
    if got.cct_k is not None:
        assert cc.CCT_MIN_K <= got.cct_k <= cc.CCT_MAX_K and abs(got.duv) <= cc.DUV_MAX
    scaled = cc.spectral_colour(spd * 1e-3, space)
    np.testing.assert_allclose(scaled.xy, got.xy, rtol=1e-12)
    np.testing.assert_allclose(scaled.rgb, got.rgb, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize(("spd", "match"), [
    (np.zeros(N_BANDS), "zero everywhere"),
    (np.full(N_BANDS, np.nan), "NaN"),
    (-np.ones(N_BANDS), "negative"),
    (np.ones(80), "81 samples"),
    (np.ones((2, N_BANDS)), "one SPD"),
])
def test_bad_spds_are_refused_with_a_reason(spd, match):
    with pytest.raises(CDSpectraError, match=match):
        cc.spectral_colour(spd)


def test_unknown_working_space_is_refused():
    with pytest.raises(CDSpectraError, match="unknown working colour space"):
        cc.spectral_colour(np.ones(N_BANDS), "sRGB gamma")
