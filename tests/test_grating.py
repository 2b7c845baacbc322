"""Physics of the numpy BRDF twin: Bessel weights, energy, band integration, stability."""

import math

import numpy as np
import pytest
from scipy import integrate, special

from cd_spectra_addon.core.scene import grating
from cd_spectra_addon.core.scene.capture import Disc, load_preset, preset_names

CD = Disc()


def _max_phase() -> float:
    """Largest groove phase any preset reaches (w_in ≤ 2, λ ≥ 380 nm)."""
    phases = []
    for name in preset_names():
        d = load_preset(name).disc
        phases.append(2 * math.pi * d.medium_index * d.groove_height_um * 1e3 * 2.0 / 380.0)
    return max(phases)


@pytest.mark.parametrize("m", [0, 1, 2, 3])
def test_bessel_matches_scipy_over_the_range_used(m):
    x = np.linspace(0.0, max(12.0, _max_phase()), 4001)
    assert np.max(np.abs(grating.bessel_j(m, x) - special.jv(m, x))) < 1e-5


def test_sinusoidal_orders_carry_all_the_light():
    x = np.linspace(0, 3, 61)
    total = sum(grating.order_efficiency(m, x) for m in range(-10, 11))
    assert np.allclose(total, 1.0, atol=1e-9)  # Σ J_m² = 1
    shipped = sum(grating.order_efficiency(m, x[x <= 2.4]) for m in range(-3, 4))
    assert np.all(shipped > 0.985)  # orders ±4 and beyond are negligible for a CD


def test_rectangular_orders_obey_parseval():
    x = np.linspace(0, 3, 13)
    total = sum(grating.order_efficiency(m, x, "rectangular", 0.31) for m in range(-3000, 3001))
    assert np.allclose(total, 1.0, atol=2e-4)


def test_hat_gauss_integral_matches_quadrature(rng):
    for _ in range(60):
        mu, s = rng.uniform(-20, 20), rng.uniform(0.05, 12)
        lo, hi = sorted(rng.uniform(-8, 8, 2)) if rng.random() < 0.3 else (-np.inf, np.inf)
        a, b = max(-5.0, lo), min(5.0, hi)
        if b <= a:
            continue
        ref = integrate.quad(lambda t: (1 - abs(t) / 5) * math.exp(-((t - mu) ** 2) / (2 * s * s)), a, b,
                             points=[0.0, mu] if a < mu < b else [0.0], limit=200)[0]
        got = float(grating.hat_gauss_integral(mu, s, 5.0, lo, hi))
        assert got == pytest.approx(ref, rel=1e-5, abs=1e-9)


@pytest.mark.parametrize("s", [0.05, 0.8, 4.8, 8.0, 16.0, 60.0])
def test_tabulated_hat_gauss_integral_equals_the_erf_one(rng, s):
    """The forward matrix reads band integrals from a table: within 1e-6 of the peak everywhere
    it is asked, clipped bands (the grid's ends) exact."""
    h = 5.0
    reach = 5 * s + h
    table = grating.HatGaussTable.for_reach(s, h, reach)
    assert table is not None
    mu = np.concatenate([rng.uniform(-reach, reach, 20000), [0.0, -h, h, reach, -reach]])
    lo = np.where(rng.random(mu.size) < 0.2, rng.uniform(-8, 8, mu.size), -np.inf)
    hi = np.where(rng.random(mu.size) < 0.2, rng.uniform(-8, 8, mu.size), np.inf)
    exact = grating.hat_gauss_integral(mu, s, h, lo, hi)
    peak = float(grating.hat_gauss_integral(0.0, s, h, -np.inf, np.inf))
    got = table(mu, lo, hi)
    assert np.max(np.abs(got - exact)) < 1e-6 * peak
    clipped = (lo > -h) | (hi < h)
    assert np.array_equal(got[clipped], exact[clipped])


def test_tabulated_sparse_bands_match_exact_ones():
    """band_radiance_sparse(tabulated=True) is the exact sparse cube to 1e-6 of its largest value,
    on the same entries; a lobe too wide to tabulate falls back to erf."""
    pts = np.stack([np.linspace(0.023, 0.058, 400), np.zeros(400), np.zeros(400)], axis=1)
    frame = grating.surface_frame(pts, np.array([0.0, 0.0, 0.3]), np.array([-0.04, 0.0, 0.3]), np.zeros(3),
                                  np.array([0.0, 0.0, 1.0]), CD.medium_index)
    for sigma in (0.003, 0.01, 0.3):
        optics = grating.GratingOptics(CD, sigma)
        exact = grating.band_radiance_sparse(frame, optics, grating.AL_F0_WAVELENGTHS_NM[:1] + np.arange(81) * 5.0)
        fast = grating.band_radiance_sparse(frame, optics, grating.AL_F0_WAVELENGTHS_NM[:1] + np.arange(81) * 5.0,
                                            tabulated=True)
        assert np.array_equal(exact.point, fast.point) and np.array_equal(exact.band, fast.band)
        assert exact.value.max() > 0
        assert np.max(np.abs(fast.value - exact.value)) <= 1e-6 * exact.value.max()
    assert grating.HatGaussTable.for_reach(480.0, 5.0, 2500.0) is None


def _frame_at(points_mm, light_mm, camera_mm=None, view=None, normal=(0, 0, 1), index=1.585):
    pts = np.asarray(points_mm, float) * 1e-3
    return grating.surface_frame(pts, None if camera_mm is None else np.asarray(camera_mm) * 1e-3,
                                 np.asarray(light_mm) * 1e-3, np.zeros(3), normal, index,
                                 view_directions=view)


def test_band_integral_matches_brute_force_spectral_integration():
    """Closed-form hat × Gaussian band integral vs a 0.02 nm Riemann sum of the point BRDF."""
    optics = grating.GratingOptics(CD, 0.003)
    radii = np.linspace(24, 56, 200)
    pts = np.stack([radii, np.zeros_like(radii), np.zeros_like(radii)], 1)
    frame = _frame_at(pts, [0, 0, 210], camera_mm=[0, 0, 210])
    for center in (400.0, 552.5, 700.0):
        closed = grating.band_radiance(frame, optics, [center])[:, 0]
        fine = np.arange(center - 5, center + 5, 0.02) + 0.01
        delta = 1e-3
        point = grating.band_radiance(frame, optics, fine, half_width_nm=delta, lo_nm=0, hi_nm=2000) / delta
        hat = 1 - np.abs(fine - center) / 5
        brute = point @ (hat * 0.02)
        assert np.max(np.abs(closed - brute)) < 0.01 * brute.max()


def test_each_order_carries_F_c2_G_over_w2_of_the_flux():
    """Integrate f·cos θo over outgoing directions around each lobe: the Stam normalisation."""
    sigma = 0.01
    optics = grating.GratingOptics(CD, sigma)
    lam, d_nm = 550.0, CD.pitch_um * 1e3
    point = np.array([[30.0, 0.0, 0.0]])  # r̂ = +x, t̂ = +y
    light_far = point[0] + np.array([0, 0, 1e6])  # normal incidence, far away
    for m in (1, 2, -1):
        uc = m * lam / d_nm - 1.0 * 0  # ωi has no tangential part: lobe at u_o = mλ/d
        step = 0.0004
        uu, vv = np.meshgrid(np.arange(uc - 0.08, uc + 0.08, step), np.arange(-0.08, 0.08, step))
        wz = np.sqrt(1 - uu ** 2 - vv ** 2)
        view = np.stack([uu, vv, wz], -1).reshape(-1, 3)
        pts = np.repeat(point, view.shape[0], 0)
        frame = _frame_at(pts, light_far, view=view)
        radiance = grating.band_radiance(frame, optics, [lam])[:, 0]
        flux = np.sum(radiance / frame.irradiance) * step * step / 5.0  # per nm of band
        wo = np.array([uc, 0.0, math.sqrt(1 - uc * uc)])
        cos_o = wo[2]
        g_over_w2 = (1 + wo[2]) ** 2 / (cos_o * (1 + cos_o) ** 2)
        sin_o_in = math.sqrt(1 - cos_o ** 2) / CD.medium_index
        w_in = 1 + math.sqrt(1 - sin_o_in ** 2)
        x = 2 * math.pi * CD.medium_index * CD.groove_height_um * 1e3 * w_in / lam
        f0 = np.interp(lam, grating.AL_F0_WAVELENGTHS_NM, grating.AL_F0)
        t = (1 - float(grating.fresnel_dielectric(1.0, CD.medium_index))) * (
            1 - float(grating.fresnel_dielectric(cos_o, CD.medium_index)))
        expected = f0 * t * special.jv(m, x) ** 2 * g_over_w2
        assert flux == pytest.approx(expected, rel=0.02)
    assert g_over_w2 > 1.0  # oblique orders gain G/w² > 1; the mirror direction has exactly 1


def test_geometry_factor_is_one_in_the_mirror_direction_and_sec4_when_retroreflecting():
    mirror = _frame_at([[30.0, 0, 0]], [-20, 0, 210], camera_mm=[80, 0, 210])
    assert float(mirror.g_over_w2[0]) == pytest.approx(1.0, abs=1e-12)
    retro = _frame_at([[30.0, 0, 0]], [0, 0, 210], camera_mm=[0, 0, 210])
    cos_t = 210 / math.hypot(30, 210)
    assert float(retro.g_over_w2[0]) == pytest.approx(cos_t ** -4, rel=1e-12)


@pytest.mark.parametrize("center", [380.0, 780.0, 552.5])
def test_finite_and_non_negative_at_grazing_angles_and_band_edges(center):
    optics = grating.GratingOptics(CD, 0.003)
    radii = np.linspace(7.5, 60, 300)
    angles = np.linspace(0, 2 * math.pi, 300)
    pts = np.stack([radii * np.cos(angles), radii * np.sin(angles), np.zeros_like(radii)], 1)
    for light, cam in [([1e4, 0, 1e-3], [0, 0, 210]),  # lamp grazing the disc plane
                       ([0, 0, 210], [-1e4, 0, 1e-2]),  # camera grazing
                       ([1e4, 1, 0.0], [-1e4, 0, 0.0]),  # both exactly in the plane
                       ([0, 0, -210], [0, 0, 210])]:  # lamp behind the disc
        frame = _frame_at(pts, light, camera_mm=cam)
        out = grating.band_radiance(frame, optics, [center])
        assert np.all(np.isfinite(out)) and np.all(out >= 0)
    frame = _frame_at(pts, [0, 0, -210], camera_mm=[0, 0, 210])
    assert np.all(grating.band_radiance(frame, optics, [center]) == 0)


def test_extreme_pitch_and_sigma_stay_finite():
    for pitch, sigma in [(0.3, 1e-5), (20.0, 1e-5), (1.6, 0.5), (0.74, 1e-4)]:
        disc = Disc(pitch_um=pitch)
        optics = grating.GratingOptics(disc, sigma)
        radii = np.linspace(23, 58, 500)
        pts = np.stack([radii, np.zeros_like(radii), np.zeros_like(radii)], 1)
        frame = _frame_at(pts, [0, 0, 210], camera_mm=[0, 0, 210])
        out = grating.band_radiance(frame, optics, np.arange(380.0, 781.0, 40.0))
        assert np.all(np.isfinite(out)) and np.all(out >= 0)
