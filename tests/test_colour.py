"""Colorimetry: reference values, parity with colour-science (the guard for the baked tables),
and properties that must hold for any non-negative SPD."""

from __future__ import annotations


import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.spectra import colour as cc
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM

OBSERVER = "CIE 1931 2 Degree Standard Observer"
SPACES = ("Linear Rec.709", "Linear Rec.2020", "ACEScg")


def blackbody(temperature: float) -> np.ndarray:
    lam = WAVELENGTHS_NM * 1e-9
    return lam**-5 / np.expm1(1.4388e-2 / (lam * temperature))


def line(wavelength_nm: float) -> np.ndarray:
    spd = np.zeros(N_BANDS)
    spd[round((wavelength_nm - 380) / 5)] = 1.0
    return spd


# --- colour-science references ------------------------------------------------------------


@pytest.fixture(scope="module")
def ref():
    """colour-science's XYZ and CCT for the same SPD (the piecewise-linear curve, 380–780 nm)."""
    cmfs = colour.MSDS_CMFS[OBSERVER].copy().trim(colour.SpectralShape(380, 780, 1))
    fine = colour.SpectralShape(380, 780, 1)

    class Ref:
        @staticmethod
        def xyz(spd: np.ndarray) -> np.ndarray:
            sd = colour.SpectralDistribution(spd, WAVELENGTHS_NM)
            sd = sd.copy().interpolate(fine, interpolator=colour.LinearInterpolator)
            return colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration", k=1)

        @staticmethod
        def cct(spd: np.ndarray) -> np.ndarray:
            uv = colour.xy_to_UCS_uv(colour.XYZ_to_xy(Ref.xyz(spd)))
            return colour.uv_to_CCT(uv, method="Ohno 2013")

    return Ref


def real_spectra() -> dict[str, np.ndarray]:
    """CIE illuminants (A, D, FL, HP) and LEDs from colour's datasets, on the product grid."""
    out = {}
    for name, sd in colour.SDS_ILLUMINANTS.items():
        if name.startswith(("A", "D", "FL", "HP", "LED")) and name != "ISO 7589 Photographic Daylight":
            out[name] = np.interp(WAVELENGTHS_NM, sd.wavelengths, sd.values, left=0.0, right=0.0)
    return out


REAL = real_spectra()
BLACKBODY_K = np.geomspace(1500, 25000, 17).round(1).tolist()


# --- reference values (colour-science style; the numbers come from colour-science 0.4.6) ---


class TestReferenceValues:
    def test_uv_to_cct_ohno2013(self):
        got = cc.uv_to_cct_ohno2013([[0.1978, 0.3122], [0.2400, 0.3500], [0.1900, 0.2900]])
        want = np.array([[6507.474788, 0.003223346], [3245.345880, 0.006304782],
                         [10935.622200, -0.001083129]])
        np.testing.assert_allclose(got[:, 0], want[:, 0], atol=0.2)
        np.testing.assert_allclose(got[:, 1], want[:, 1], atol=1e-6)

    def test_cct_duv_of_d65_chromaticity(self):
        cct, duv = cc.cct_duv([0.3127, 0.3290])
        assert cct == pytest.approx(6504.3117, abs=0.2)
        assert duv == pytest.approx(0.0032069, abs=1e-6)

    def test_ucs(self):
        np.testing.assert_allclose(cc.xy_to_uv1960([0.3127, 0.3290]), [0.19783001, 0.31221333], atol=1e-8)
        np.testing.assert_allclose(cc.xy_to_uv_prime([0.3127, 0.3290]), [0.19783001, 0.46831999], atol=1e-8)

    def test_equal_energy_and_luminance(self):
        # Hats add up to 1 at every nm, so Σ W = Σ ȳ(380…780) · 1 nm.
        np.testing.assert_allclose(cc.spd_to_xy(np.ones(N_BANDS)), [0.3333413, 0.3333455], atol=1e-7)
        assert cc.luminance(np.ones(N_BANDS)) == pytest.approx(72982.939, rel=1e-6)
        assert cc.luminance(2 * np.ones(N_BANDS)) == pytest.approx(2 * 72982.939, rel=1e-6)

    def test_blackbody_cct(self):
        # Sampled on 380–780 nm only, a blackbody reads a little low against the CIE locus.
        cct, duv = cc.cct_duv(blackbody(2856))
        assert cct == pytest.approx(2856.12, abs=0.05)
        assert abs(duv) < 1e-5


# --- parity with colour-science --------------------------------------------------------------


class TestBakedTables:
    def test_cmf_hat(self):
        cmfs = colour.MSDS_CMFS[OBSERVER]
        lam = np.arange(380, 781)
        hats = np.clip(1 - np.abs(lam[None] - WAVELENGTHS_NM[:, None]) / 5, 0, None)
        np.testing.assert_allclose(cc._tables().cmf_hat, hats @ cmfs[lam], rtol=1e-12, atol=1e-15)

    def test_planckian_table_and_locus(self):
        t = cc._tables()
        np.testing.assert_allclose(t.table_uv, colour.temperature.CCT_to_uv_Planck1900(t.table_t),
                                   atol=1e-13)
        temps = np.array([1000.0, 1234.5, 2856.0, 6504.0, 25000.0, 100000.0])
        np.testing.assert_allclose(cc.planck_uv1960(temps),
                                   colour.temperature.CCT_to_uv_Planck1900(temps), atol=1e-13)
        assert t.table_t[0] == 1000 and t.table_t[-1] == pytest.approx(100000)

    def test_working_space_matrices(self, rng):
        xyz = rng.uniform(0, 1, (50, 3))
        d65 = colour.CCS_ILLUMINANTS[OBSERVER]["D65"]
        # D65 spaces: colour's own whitepoint (no adaptation needed).
        for name, cs in (("Linear Rec.709", "ITU-R BT.709"), ("Linear Rec.2020", "ITU-R BT.2020")):
            np.testing.assert_allclose(cc.xyz_to_working_rgb(xyz, name), colour.XYZ_to_RGB(xyz, cs),
                                       atol=1e-12)
        # ACEScg: Blender's D65-referred XYZ, Bradford to the ACES white.
        np.testing.assert_allclose(
            cc.xyz_to_working_rgb(xyz, "ACEScg"),
            colour.XYZ_to_RGB(xyz, "ACEScg", illuminant=d65, chromatic_adaptation_transform="Bradford"),
            atol=1e-12)

    def test_acescg_matches_blender_ocio(self):
        """Blender's config: ACEScg ↔ ACES2065-1 ↔ XYZ D65 via ``ACES-AP0_to_CIE-XYZ-D65_BFD``."""
        ap0_to_xyz_d65 = np.array([[0.938280, -0.004451, 0.016628],  # as Cycles spells it out
                                   [0.337369, 0.729522, -0.066890],
                                   [0.001174, -0.003711, 1.091595]])
        ap0_to_ap1 = (colour.RGB_COLOURSPACES["ACEScg"].matrix_XYZ_to_RGB
                      @ colour.RGB_COLOURSPACES["ACES2065-1"].matrix_RGB_to_XYZ)
        blender = ap0_to_ap1 @ np.linalg.inv(ap0_to_xyz_d65)
        np.testing.assert_allclose(cc._tables().xyz_to_rgb["ACEScg"], blender, atol=2e-5)


def test_working_space_matrices_match_blender_config():
    """``Linear Rec.709`` / ``Linear Rec.2020`` matrices as printed in Blender's config.ocio."""
    rec709 = [[3.2409699, -1.5373832, -0.4986108], [-0.9692436, 1.8759675, 0.0415551],
              [0.0556301, -0.2039770, 1.0569715]]
    rec2020 = [[1.7166512, -0.3556708, -0.2533663], [-0.6666844, 1.6164812, 0.0157685],
               [0.0176399, -0.0427706, 0.9421031]]
    np.testing.assert_allclose(cc._tables().xyz_to_rgb["Linear Rec.709"], rec709, atol=1e-7)
    np.testing.assert_allclose(cc._tables().xyz_to_rgb["Linear Rec.2020"], rec2020, atol=1e-7)


class TestParity:
    @pytest.mark.parametrize("temperature", BLACKBODY_K)
    def test_blackbody(self, ref, temperature):
        spd = blackbody(temperature)
        xyz_ref = ref.xyz(spd)
        np.testing.assert_allclose(cc.spd_to_xyz(spd), xyz_ref, rtol=1e-9)
        np.testing.assert_allclose(cc.spd_to_xy(spd), colour.XYZ_to_xy(xyz_ref), atol=1e-4)
        cct, duv = cc.cct_duv(spd)
        cct_ref, duv_ref = ref.cct(spd)
        assert abs(cct - cct_ref) <= 1.0
        assert abs(duv - duv_ref) <= 1e-4

    @pytest.mark.parametrize("name", sorted(REAL))
    def test_real_spectra(self, ref, name):
        spd = REAL[name]
        xyz_ref = ref.xyz(spd)
        np.testing.assert_allclose(cc.spd_to_xyz(spd), xyz_ref, rtol=1e-9)
        np.testing.assert_allclose(cc.spd_to_xy(spd), colour.XYZ_to_xy(xyz_ref), atol=1e-4)
        cct, duv = cc.cct_duv(spd)
        cct_ref, duv_ref = ref.cct(spd)
        assert cct is not None, name
        assert abs(cct - cct_ref) <= 1.0
        assert abs(duv - duv_ref) <= 1e-4

    def test_uv_grid_off_the_locus(self, rng):
        """Ohno parity over 1500–25 000 K and the whole |Duv| ≤ 0.05 band."""
        temps = np.geomspace(1500, 25000, 60)
        duvs = np.concatenate([np.linspace(-0.05, 0.05, 9), rng.uniform(-0.003, 0.003, 3)])
        grid = np.stack(np.meshgrid(temps, duvs, indexing="ij"), axis=-1).reshape(-1, 2)
        uv = colour.temperature.CCT_to_uv_Ohno2013(grid)
        got = cc.uv_to_cct_ohno2013(uv)
        want = colour.uv_to_CCT(uv, method="Ohno 2013")
        assert np.max(np.abs(got[:, 0] - want[:, 0])) <= 1.0
        assert np.max(np.abs(got[:, 1] - want[:, 1])) <= 1e-4
        assert np.max(np.abs(got[:, 0] - grid[:, 0])) <= 0.1  # and closer to the truth

    def test_cct_duv_to_uv_and_uv_to_xy_invert_the_forward_maps(self, rng):
        """The prior aims its whites with these: colour's CCT_to_uv_Ohno2013 and UCS_uv_to_xy."""
        grid = np.stack([np.geomspace(1500, 25000, 40), rng.uniform(-0.02, 0.02, 40)], axis=-1)
        uv = cc.cct_duv_to_uv1960(grid[:, 0], grid[:, 1])
        np.testing.assert_allclose(uv, colour.temperature.CCT_to_uv_Ohno2013(grid), atol=1e-9)
        np.testing.assert_allclose(cc.uv1960_to_xy(uv), colour.UCS_uv_to_xy(uv), atol=1e-15)
        np.testing.assert_allclose(cc.xy_to_uv1960(cc.uv1960_to_xy(uv)), uv, atol=1e-15)
        np.testing.assert_allclose(cc.hat_cmfs(), cc._tables().cmf_hat, rtol=0)

    def test_light_colour_of_d65_is_white(self):
        d65 = REAL["D65"]
        for space in SPACES:
            rgb, out_of_gamut = cc.light_colour(d65, space)
            np.testing.assert_allclose(rgb, [1, 1, 1], atol=2e-3)
            assert not out_of_gamut


# --- behaviour ----------------------------------------------------------------------------------


class TestBehaviour:
    def test_batches_match_singles(self, rng):
        spds = rng.uniform(0, 1, (4, 3, N_BANDS))
        xyz = cc.spd_to_xyz(spds)
        assert xyz.shape == (4, 3, 3)
        np.testing.assert_allclose(xyz[2, 1], cc.spd_to_xyz(spds[2, 1]))
        assert cc.spd_to_xy(spds).shape == (4, 3, 2)
        assert cc.luminance(spds).shape == (4, 3)
        assert isinstance(cc.luminance(spds[0, 0]), float)
        uv = cc.xy_to_uv1960(cc.spd_to_xy(spds))
        np.testing.assert_allclose(cc.uv_to_cct_ohno2013(uv)[1, 2], cc.cct_duv(spds[1, 2]))

    def test_scale_invariance(self, rng):
        spd = rng.uniform(0, 1, N_BANDS)
        for k in (1e-280, 1e-6, 1e6, 1e280):
            np.testing.assert_allclose(cc.spd_to_xy(k * spd), cc.spd_to_xy(spd), rtol=1e-12)
            np.testing.assert_allclose(cc.light_colour(k * spd).rgb, cc.light_colour(spd).rgb, rtol=1e-12)
        np.testing.assert_allclose(cc.spd_to_xyz(1e6 * spd), 1e6 * cc.spd_to_xyz(spd), rtol=1e-12)

    @pytest.mark.parametrize("spd", [line(450), line(520), line(650), blackbody(800), blackbody(3e5)],
                             ids=["450nm", "520nm", "650nm", "800K", "300000K"])
    def test_cct_undefined(self, spd):
        assert cc.cct_duv(spd) == (None, None)

    def test_cct_undefined_far_from_locus(self):
        assert cc.cct_duv([0.30, 0.60]) == (None, None)  # green
        assert cc.cct_duv([0.35, 0.25]) == (None, None)  # purple

    def test_light_colour(self):
        rgb, out = cc.light_colour(blackbody(2856))
        assert max(rgb) == 1.0 and min(rgb) > 0 and not out
        assert rgb[0] == 1.0 and rgb[0] > rgb[1] > rgb[2]  # warm
        assert all(isinstance(c, float) for c in rgb)
        rgb, out = cc.light_colour(line(610))  # a narrow red line is outside Rec.709
        assert out and min(rgb) == 0.0 and max(rgb) == 1.0
        assert cc.light_colour(line(610), "ACEScg").out_of_gamut is False
        assert cc.light_colour(line(610), "lin_ap1_scene") == cc.light_colour(line(610), "ACEScg")

    def test_unknown_space(self):
        with pytest.raises(ValueError, match=r"Linear Rec\.709"):
            cc.xyz_to_working_rgb([0.95, 1.0, 1.09], "sRGB")

    def test_compare_identical_and_scaled(self):
        spd = blackbody(4000)
        for other in (spd, 3.0 * spd):
            m = cc.compare_spds(spd, other)
            for key in ("mae_400_700", "rmse_400_700", "mae_380_780", "rmse_380_780",
                        "delta_uv_prime", "delta_cct_k", "delta_duv"):
                assert m[key] == pytest.approx(0.0, abs=1e-9), key
            assert m["pearson_r"] == pytest.approx(1.0)
            assert m["pearson_r_400_700"] == pytest.approx(1.0)

    def test_compare_values(self):
        ref = np.ones(N_BANDS)
        est = np.ones(N_BANDS)
        band = (WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)
        est[band] = 0.9
        est[~band] = 1.0  # peak 1 over 380–780; 0.9 everywhere inside 400–700
        m = cc.compare_spds(est, ref)
        assert m["mae_400_700"] == pytest.approx(0.0)  # per-band peak: same shape inside
        assert m["mae_380_780"] == pytest.approx(0.1 * band.sum() / N_BANDS)
        assert m["rmse_380_780"] == pytest.approx(np.sqrt(0.01 * band.sum() / N_BANDS))
        assert m["pearson_r"] is None  # a flat reference has no shape to correlate with
        assert m["delta_uv_prime"] > 0

    def test_compare_tail_does_not_set_the_visible_score(self):
        ref = blackbody(2856)
        est = ref.copy()
        est[WAVELENGTHS_NM > 700] *= 0.5  # a wrong tail where the camera is blind
        m = cc.compare_spds(est, ref)
        assert m["mae_400_700"] == pytest.approx(0.0)
        assert m["mae_380_780"] > 0.05

    @pytest.mark.parametrize("fn", [cc.spd_to_xyz, cc.spd_to_xy, cc.cct_duv, cc.light_colour,
                                    cc.luminance, lambda s: cc.compare_spds(s, np.ones(N_BANDS)),
                                    lambda s: cc.compare_spds(np.ones(N_BANDS), s)])
    def test_all_zero_spd_is_a_clear_error(self, fn):
        with pytest.raises(ValueError, match="zero everywhere"):
            fn(np.zeros(N_BANDS))

    @pytest.mark.parametrize("bad, match", [
        (np.full(N_BANDS, np.nan), "NaN"),
        (np.r_[np.ones(N_BANDS - 1), np.inf], "NaN or infinite"),
        (np.r_[np.ones(N_BANDS - 1), -1.0], "negative"),
        (np.ones(80), "81 samples"),
    ])
    def test_bad_spd(self, bad, match):
        with pytest.raises(CDSpectraError, match=match):
            cc.spd_to_xyz(bad)

    def test_planck_domain(self):
        assert np.all(np.isfinite(cc.planck_uv1960([100.0, 1e9])))
        with pytest.raises(ValueError, match="at least 100 K"):
            cc.planck_uv1960(50.0)

    def test_bad_chromaticity(self):
        with pytest.raises(ValueError, match="no light"):
            cc.xyz_to_xy([0.0, 0.0, 0.0])
        with pytest.raises(ValueError, match="not a chromaticity"):
            cc.xy_to_uv1960([3.0, 0.0])
        with pytest.raises(ValueError, match="one xy"):
            cc.cct_duv([0.3, 0.3, 0.3])


# --- any non-negative SPD -------------------------------------------------------------------

finite_values = st.floats(min_value=0.0, max_value=1e6, allow_nan=False, allow_infinity=False)
spds = arrays(np.float64, N_BANDS, elements=finite_values).filter(lambda a: a.max() > 0)
sparse_spds = st.lists(st.integers(0, N_BANDS - 1), min_size=1, max_size=4).map(
    lambda idx: np.bincount(idx, minlength=N_BANDS).astype(np.float64))


@settings(max_examples=150, deadline=None)
@given(spd=st.one_of(spds, sparse_spds))
def test_any_spd_gives_finite_colorimetry(spd):
    xy = cc.spd_to_xy(spd)
    assert np.all(np.isfinite(xy)) and np.all(xy >= 0) and xy.sum() <= 1 + 1e-12
    assert np.all(np.isfinite(cc.xy_to_uv_prime(xy)))
    cct, duv = cc.cct_duv(spd)
    assert (cct is None) == (duv is None)
    if cct is not None:
        assert cc.CCT_MIN_K <= cct <= cc.CCT_MAX_K and abs(duv) <= cc.DUV_MAX
    for space in SPACES:
        rgb, _ = cc.light_colour(spd, space)
        assert np.all(np.isfinite(rgb)) and max(rgb) == 1.0 and min(rgb) >= 0.0
    assert np.isfinite(cc.luminance(spd))
    metrics = cc.compare_spds(spd, blackbody(3000))
    assert all(v is None or np.isfinite(v) for v in metrics.values())
