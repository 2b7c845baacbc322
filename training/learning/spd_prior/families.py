"""The prior's lamp families: how each kind of source makes light, one generator per family.

Line lists (NIST wavelengths, typical strengths), the random building blocks (line groups,
random line forests) and the generators, registered by name for :mod:`.sampling`.

Families (label: what and why)

- ``smooth``, ``smooth_noise``, ``spiky``: the paper's generic categories (broad Gaussian sums or
  a log-normal random curve; + white noise; + random narrow lines). They keep the model from
  over-trusting the physical families.
- ``blackbody`` (1000–12000 K) and ``incandescent`` (1800–3500 K tungsten with its falling
  emissivity, optional tinted / neodymium / dichroic IR-cut glass): thermal sources.
- ``daylight``: a 5000–6500 K sun with Fraunhofer blanketing × Rayleigh, aerosol (Ångström),
  ozone Chappuis, O₂ A/B and water bands at a random air mass; mixed with Rayleigh-blue sky
  (direct sun, sun + sky, shade, overcast). No CIE daylight basis.
- ``led_white`` (InGaN 440–465 nm pump + garnet / LuAG green-yellow + optional nitride red) and
  ``led_violet`` (405–420 nm pump + blue/green/red phosphors): the mix is *solved* to land on a
  target CCT (nominal ANSI bins 2200–6500 K) and Duv near the Planckian locus, as manufacturers
  bin their products.
- ``led_rgb``: direct-emitting colour LEDs (450…660 nm, 15–35 nm FWHM, wider green/amber,
  phosphor lime/amber), RGB/RGBA/RGBW sets and single colours at random dimming levels.
- ``fluorescent_tri`` (Hg lines + Eu²⁺ BAM + Tb³⁺ + Eu³⁺ line phosphors, solved to a CCT) and
  ``fluorescent_halo`` (Sb³⁺/Mn²⁺ halophosphate bands + Hg lines).
- ``metal_halide`` (Hg, Na, Tl, In, Sc, Li, Ca, Sr, rare-earth line forests + continuum),
  ``hps`` (self-reversed pressure-broadened Na D), ``lps`` (Na D doublet), ``mercury`` (clear or
  red-phosphor mercury vapour), ``xenon`` (short arc: ≈6000 K continuum + Xe I lines),
  ``xenon_flash`` (flash tube: a hotter, partly transparent plasma, Xe I or Xe II lines, a
  UV/warming window).
- ``led_grow``: plant-grow LEDs — royal-blue + deep-red 'blurple' (± 630 nm red, 730 nm far red,
  UV-A), 'full-spectrum' grow whites (phosphor white + deep red ± far red), red/far-red bars.
- ``filtered``: any physical family (tungsten, daylight, flash, LEDs, discharge lamps) behind a gel / filter (long-, short-, band-pass, notch,
  mired-shift CTO/CTB, random dye curve) at a random density.

Default family weights (:data:`DEFAULT_WEIGHTS`, normalised at use): about a fifth generic
(the paper's categories), a quarter LEDs, the rest thermal, daylight, discharge and filtered, so
every real lamp type is well represented without one dominating.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

# Planck's law and c2 only: the prior takes no CIE illuminant from that module (tested).
from cd_spectra_addon.core.spectra.illuminants import C2_NM_K, planck
from cd_spectra_addon.core.spectra.grid import N_BANDS, peak_normalise

from training.learning.spd_prior.grid import (
    D_FINE,
    FINE_NM,
    FWHM_TO_SIGMA,
    GRID,
    HAT3_NM,
    band_grid,
    energy_band,
    fine_to_grid,
    gauss,
    hat3,
    lines_on_grid,
    render_lines,
    sigmoid,
)
from training.learning.spd_prior.white_point import cct_duv, white_mix

Array = NDArray[np.float64]
Generator = np.random.Generator

_CHUNK = 4096  # rows per generator call: bounds the (rows, components, fine) temporaries

# ---------------------------------------------------------------------------------------------
# Line lists (air wavelengths, nm; NIST ASD strong lines) and relative strengths (typical lamp
# ratios, rounded; every row jitters them).
# ---------------------------------------------------------------------------------------------
HG_LINES_NM: tuple[tuple[float, float], ...] = (
    (404.656, 0.35), (407.783, 0.05), (435.833, 0.8), (491.604, 0.03), (546.074, 1.0),
    (576.960, 0.45), (579.066, 0.5), (623.437, 0.02), (690.746, 0.02),
)
_NA_MINOR = ((568.27, 0.05), (568.82, 0.1), (498.28, 0.04), (515.34, 0.04), (615.42, 0.06),
             (616.07, 0.08), (449.42, 0.01), (466.86, 0.015))
_NA_D = ((588.995, 1.0), (589.592, 0.5))
_TL = ((535.046, 1.0),)
_IN = ((410.176, 0.6), (451.131, 1.0))
_SC = ((390.75, 0.3), (391.18, 0.3), (402.04, 0.5), (402.37, 0.5), (474.38, 0.2), (503.10, 0.15),
       (567.18, 0.4), (568.69, 0.3), (570.02, 0.3), (621.07, 0.2), (630.57, 0.2))
_LI = ((670.78, 1.0), (610.36, 0.2))
_CA = ((422.67, 1.0), (393.37, 0.3), (396.85, 0.3))
_SR = ((460.73, 1.0), (407.77, 0.4), (421.55, 0.3))
_DY_HO_TM = ((404.60, 0.5), (418.68, 0.6), (419.48, 0.4), (421.17, 0.6), (405.39, 0.5),
             (410.38, 0.5), (416.30, 0.4), (409.42, 0.4), (410.58, 0.4), (418.76, 0.4),
             (420.37, 0.3), (530.72, 0.2), (598.86, 0.2), (642.19, 0.15))
_K = ((766.49, 1.0), (769.90, 0.6))
# Xe II (ionic; flash tubes at high current density).
_XE_II = ((460.30, 0.4), (484.43, 1.0), (529.22, 0.7), (533.93, 0.6), (541.92, 0.8), (597.65, 0.4),
          (605.12, 0.3))
_XE = ((450.10, 0.3), (452.47, 0.3), (462.43, 0.5), (467.12, 1.0), (473.42, 0.5), (480.70, 0.4),
       (482.97, 0.6), (492.32, 0.4), (764.20, 0.6))
_NE = ((585.25, 0.6), (588.19, 0.3), (594.48, 0.3), (597.55, 0.2), (603.00, 0.2), (607.43, 0.3),
       (609.62, 0.4), (614.31, 0.5), (616.36, 0.2), (621.73, 0.2), (626.65, 0.3), (633.44, 0.4),
       (638.30, 0.4), (640.23, 1.0), (650.65, 0.4), (659.90, 0.3), (692.95, 0.2), (703.24, 0.4),
       (724.52, 0.1))
_AR = ((696.54, 0.5), (706.72, 0.5), (714.70, 0.1), (727.29, 0.2), (738.40, 0.3), (750.39, 0.8),
       (751.47, 0.5), (763.51, 1.0), (772.38, 0.6))
# Eu³⁺ in Y₂O₃ (YOX red): ⁵D₀→⁷F_J; Tb³⁺ (CAT/LAP green): ⁵D₄→⁷F_J.
_EU3 = ((580.8, 0.02), (587.5, 0.06), (593.0, 0.06), (599.2, 0.05), (611.3, 1.0), (624.8, 0.06),
        (631.2, 0.12), (650.0, 0.03), (653.8, 0.02), (687.6, 0.02), (707.5, 0.04), (709.9, 0.04))
_TB3 = ((487.4, 0.25), (490.0, 0.1), (542.4, 0.7), (544.6, 1.0), (548.9, 0.2), (583.7, 0.08),
        (586.1, 0.05), (620.9, 0.06), (646.8, 0.01), (668.6, 0.005), (679.2, 0.005))
# Eu³⁺ in YVO₄ (colour-corrected mercury lamps), Mn⁴⁺ fluorogermanate deep red.
_EU_YVO4 = ((593.5, 0.1), (615.0, 0.4), (619.0, 1.0), (697.0, 0.04), (702.0, 0.03))
_MN4_GERMANATE = ((650.0, 0.3), (655.0, 0.5), (658.0, 1.0), (662.0, 0.4))
# K₂SiF₆:Mn⁴⁺ (KSF) narrow red phosphor.
_KSF = ((609.5, 0.2), (613.0, 0.3), (631.0, 1.0), (635.5, 0.4), (647.5, 0.25))


# ---------------------------------------------------------------------------------------------
# Random helpers
# ---------------------------------------------------------------------------------------------
def _u(rng: Generator, lo: float, hi: float, size: int | tuple[int, ...]) -> Array:
    return rng.uniform(lo, hi, size)


def _logu(rng: Generator, lo: float, hi: float, size: int | tuple[int, ...]) -> Array:
    return np.exp(rng.uniform(math.log(lo), math.log(hi), size))


def _power(spd: Array) -> Array:
    """Radiant power on the grid (Σ·Δ), per row (the hats tile the range)."""
    return spd.sum(-1) * D_FINE


def _unit_power(spd: Array) -> Array:
    p = _power(spd)
    return spd / np.where(p > 0, p, 1.0)[..., None]


@dataclass(frozen=True)
class _LineGroup:
    """One emitter's lines: included per row with probability ``p``; total group power drawn
    log-uniformly; width and Lorentz share per row and group."""

    lines: tuple[tuple[float, float], ...]
    p: float = 1.0
    power: tuple[float, float] = (1.0, 1.0)
    fwhm: tuple[float, float] = (0.5, 3.0)
    eta: tuple[float, float] = (0.0, 0.5)
    jitter_nm: float = 0.0  # per-line centre jitter: unresolved multiplets, host lattice shifts


def _group_lines(rng: Generator, n: int, groups: Sequence[_LineGroup], scatter: float = 0.25) -> Array:
    """Grid spectra (n, 81) of line groups; each group's total line power is its drawn power."""
    rows, cs, ws, areas, etas = [], [], [], [], []
    for g in groups:
        centres = np.array([c for c, _ in g.lines])
        rel = np.array([r for _, r in g.lines])
        on = rng.random(n) < g.p
        pw = _logu(rng, *g.power, n) * on
        w = _logu(rng, *g.fwhm, n)
        e = _u(rng, *g.eta, n)
        rel_row = rel[None, :] * np.exp(scatter * rng.standard_normal((n, rel.size)))
        rel_row /= rel_row.sum(1, keepdims=True)
        c = centres[None, :] + g.jitter_nm * rng.standard_normal((n, rel.size))
        r = np.repeat(np.arange(n)[:, None], rel.size, 1)
        rows.append(r.ravel())
        cs.append(c.ravel())
        ws.append(np.repeat(w[:, None], rel.size, 1).ravel())
        areas.append((pw[:, None] * rel_row).ravel())
        etas.append(np.repeat(e[:, None], rel.size, 1).ravel())
    row, c, w, a, e = (np.concatenate(v) for v in (rows, cs, ws, areas, etas))
    keep = a > 0
    return render_lines(row[keep], c[keep], w[keep], a[keep], e[keep], n)


def _random_lines(rng: Generator, n: int, count: tuple[int, int], lo_nm: float, hi_nm: float,
                  fwhm: tuple[float, float], power: Array, eta: tuple[float, float] = (0.0, 0.5)) -> Array:
    """``count`` random lines per row between ``lo_nm`` and ``hi_nm`` with log-normal strengths,
    total power ``power`` (n,): unresolved line forests (rare earths) and generic spikes."""
    kmax = count[1]
    k = rng.integers(count[0], count[1] + 1, n)
    mask = np.arange(kmax)[None, :] < k[:, None]
    c = _u(rng, lo_nm, hi_nm, (n, kmax))
    w = _logu(rng, *fwhm, (n, kmax))
    e = _u(rng, *eta, (n, kmax))
    a = np.exp(1.0 * rng.standard_normal((n, kmax))) * mask
    a *= (power / np.maximum(a.sum(1), 1e-12))[:, None]
    row = np.repeat(np.arange(n)[:, None], kmax, 1)
    keep = a > 0
    return render_lines(row[keep], c[keep], w[keep], a[keep], e[keep], n)


# ---------------------------------------------------------------------------------------------
# Families. Internal generators return (n, 81) non-negative, unnormalised rows.
# ---------------------------------------------------------------------------------------------
_GENERATORS: dict[str, Callable[[Generator, int], Array]] = {}


def _family(name: str) -> Callable[[Callable[[Generator, int], Array]], Callable[..., Array]]:
    """Register ``fn(rng, n) -> (n, 81)`` and return the public ``(rng, n=None)`` form."""

    def wrap(fn: Callable[[Generator, int], Array]) -> Callable[..., Array]:
        _GENERATORS[name] = fn

        def public(rng: Generator, n: int | None = None) -> Array:
            rows = generate(name, rng, 1 if n is None else int(n))
            return rows[0] if n is None else rows

        public.__name__ = public.__qualname__ = fn.__name__
        public.__doc__ = (fn.__doc__ or "") + "\n\nReturns (81,) if ``n`` is None, else (n, 81), peak 1."
        return public

    return wrap


def generate(name: str, rng: Generator, n: int) -> Array:
    fn = _GENERATORS[name]
    parts = [fn(rng, min(_CHUNK, n - s)) for s in range(0, n, _CHUNK)]
    out = np.concatenate(parts) if parts else np.empty((0, N_BANDS))
    out = np.where(np.isfinite(out), np.maximum(out, 0.0), 0.0)
    if np.any(out.max(axis=1, initial=0.0) <= 0):
        raise RuntimeError(f"{name}: generated an all-zero spectrum")  # a bug, never data
    return peak_normalise(out)


def _smooth_curves(rng: Generator, n: int) -> Array:
    lam = GRID[None, :]
    # (a) 1–6 broad Gaussians (centres may lie outside the range: slopes) on a floor.
    kmax = 6
    k = rng.integers(1, kmax + 1, n)
    mask = np.arange(kmax)[None, :] < k[:, None]
    c = _u(rng, 330.0, 830.0, (n, kmax))
    s = _logu(rng, 40.0, 400.0, (n, kmax)) * FWHM_TO_SIGMA
    a = _u(rng, 0.05, 1.0, (n, kmax)) * mask
    gs = np.einsum("nk,nkb->nb", a, gauss(lam[:, None, :], c[..., None], s[..., None]))
    gs = gs / gs.max(1, keepdims=True) + _u(rng, 0.0, 0.3, n)[:, None] * (rng.random(n) < 0.5)[:, None]
    # (b) log-normal random curve: exp of a low-order Fourier series with a decaying spectrum.
    kk = np.arange(1, 9)
    u = (lam - GRID[0]) / (GRID[-1] - GRID[0])
    amp = _u(rng, 0.3, 1.5, n)[:, None] / kk[None, :] ** _u(rng, 1.0, 2.5, n)[:, None]
    coef = amp * rng.standard_normal((n, kk.size))
    phase = _u(rng, 0.0, 2 * math.pi, (n, kk.size))
    waves = np.cos(math.pi * kk[None, :, None] * u[:, None, :] + phase[..., None])
    logc = np.einsum("nk,nkb->nb", coef, waves)
    ln = np.exp(logc - logc.max(1, keepdims=True))
    pick = rng.random(n) < 0.5
    return np.where(pick[:, None], gs, ln)


@_family("smooth")
def smooth(rng: Generator, n: int) -> Array:
    """Random smooth curve (broad Gaussians or a log-normal field): the paper's generic class."""
    return _smooth_curves(rng, n)


@_family("smooth_noise")
def smooth_noise(rng: Generator, n: int) -> Array:
    """Smooth curve + white noise of 0.3–5 % of the peak (clipped at 0): noisy measurements."""
    base = peak_normalise(_smooth_curves(rng, n))
    noise = _logu(rng, 0.003, 0.05, n)[:, None] * rng.standard_normal((n, N_BANDS))
    return np.maximum(base + noise, 0.0) + 1e-6


@_family("spiky")
def spiky(rng: Generator, n: int) -> Array:
    """Smooth curve + 1–15 random narrow lines (0.5–8 nm): generic line sources."""
    base = peak_normalise(_smooth_curves(rng, n)) * _u(rng, 0.1, 1.0, n)[:, None]
    power = _logu(rng, 0.05, 3.0, n) * _power(base)
    return base + _random_lines(rng, n, (1, 15), 380.0, 780.0, (0.5, 8.0), power, eta=(0.0, 0.6))


@_family("blackbody")
def blackbody(rng: Generator, n: int) -> Array:
    """Planck radiator, T log-uniform in 1000–12000 K: embers and candles to blue-sky CCTs."""
    return planck(GRID, _logu(rng, 1000.0, 12000.0, n)[:, None])


def _glass(rng: Generator, n: int, lam: Array = GRID) -> Array:
    """Envelope / reflector effects of real bulbs (identity for most rows): tinted glass tilt,
    neodymium 'daylight' glass (absorption 583 nm + 528/745 nm), dichroic IR-cut roll-off."""
    t = np.ones((n, lam.size))
    tilt = rng.random(n) < 0.25
    s = _u(rng, -0.25, 0.25, n)[:, None]
    t = np.where(tilt[:, None], t * np.exp(s * (lam - 580.0) / 200.0), t)
    nd = rng.random(n) < 0.1
    absorb = (1.0 * gauss(lam, 584.0, 7.0) + 0.3 * gauss(lam, 528.0, 5.0) + 0.4 * gauss(lam, 745.0, 6.0)
              + 0.15 * gauss(lam, 685.0, 5.0))
    dens = _u(rng, 0.2, 1.2, n)[:, None]
    t = np.where(nd[:, None], t * 10.0 ** (-dens * absorb[None, :]), t)
    ir = rng.random(n) < 0.15
    cut = 1.0 - _u(rng, 0.3, 0.9, n)[:, None] * sigmoid((lam - _u(rng, 680.0, 760.0, n)[:, None])
                                                      / _u(rng, 8.0, 25.0, n)[:, None])
    return np.where(ir[:, None], t * cut, t)


@_family("incandescent")
def incandescent(rng: Generator, n: int) -> Array:
    """Tungsten filament 1800–3500 K (dimmed, household, halogen, photoflood); emissivity falls
    ~5–15 % across the visible (slightly bluer than Planck); optional bulb glass effects."""
    t = _u(rng, 1800.0, 3500.0, n)[:, None]
    emiss = 1.0 - _u(rng, 0.03, 0.15, n)[:, None] * (GRID - 380.0) / 400.0
    return planck(GRID, t) * emiss * _glass(rng, n)


# Solar Fraunhofer features as Gaussian dips of σ = 1 nm with their equivalent widths (nm):
# only the energy they remove matters on a 5 nm grid.
_FRAUNHOFER = ((393.37, 2.0), (396.85, 1.5), (382.0, 0.6), (383.8, 0.4), (410.17, 0.31), (430.8, 0.5),
               (434.05, 0.28), (438.4, 0.1), (486.13, 0.37), (516.9, 0.15), (517.3, 0.15), (518.4, 0.2),
               (527.0, 0.1), (589.3, 0.14), (656.28, 0.4))


def _extraterrestrial_sun(rng: Generator, n: int, lam: Array) -> Array:
    t = _u(rng, 5000.0, 6500.0, n)[:, None]
    sun = planck(lam, t)
    depth = np.zeros_like(lam)
    for c, ew in _FRAUNHOFER:
        depth = depth + ew / (1.0 * math.sqrt(2 * math.pi)) * gauss(lam, c, 1.0)
    sun = sun * np.clip(1.0 - _u(rng, 0.7, 1.2, n)[:, None] * depth[None, :], 0.05, 1.0)
    blanket = 1.0 - _u(rng, 0.05, 0.2, n)[:, None] * sigmoid((430.0 - lam) / 15.0)
    return sun * blanket


def _atmosphere_tau(rng: Generator, n: int, lam: Array) -> tuple[Array, Array, Array, Array, Array]:
    """Optical depths per unit air mass: (continuum = Rayleigh + aerosol + ozone, O₂ bands,
    water bands, Rayleigh, aerosol); the band ones grow ∝ √(path) because they saturate."""
    mu = lam / 1000.0
    press = _u(rng, 0.75, 1.02, n)[:, None]
    rayleigh = press * 0.008569 * mu**-4 * (1.0 + 0.0113 * mu**-2 + 0.00013 * mu**-4)
    beta = _logu(rng, 0.01, 0.3, n)[:, None]
    alpha = _u(rng, 0.5, 2.0, n)[:, None]
    aerosol = beta * mu ** (-alpha)
    du = _u(rng, 220.0, 450.0, n)[:, None]
    chappuis = 4.8e-21 * (0.8 * gauss(lam, 602.0, 40.0) + 0.3 * gauss(lam, 573.0, 18.0)
                          + 0.15 * gauss(lam, 535.0, 25.0))
    ozone = du * 2.687e16 * chappuis
    o2 = press * (1.5 * gauss(lam, 760.8, 0.8) + 0.6 * gauss(lam, 764.8, 1.8)
                  + 0.4 * gauss(lam, 687.3, 0.8) + 0.15 * gauss(lam, 690.5, 1.5)
                  + 0.03 * gauss(lam, 628.5, 1.5)  # O₂ γ band
                  + 0.015 * gauss(lam, 577.0, 4.0) + 0.015 * gauss(lam, 630.0, 4.0))  # O₂–O₂ bands
    water_cm = _logu(rng, 0.3, 4.0, n)[:, None]
    h2o = np.sqrt(water_cm / 2.0) * (0.25 * gauss(lam, 724.0, 7.0) + 0.06 * gauss(lam, 697.0, 3.0)
                                     + 0.04 * gauss(lam, 651.0, 4.0) + 0.03 * gauss(lam, 592.0, 4.0))
    return rayleigh + aerosol + ozone, o2, h2o, rayleigh, aerosol


@_family("daylight")
def daylight(rng: Generator, n: int) -> Array:
    """Sun through the atmosphere and/or sky light, built on the fine grid.

    Direct beam: S·exp(−m·τ_cont − √m·(τ_O₂ + τ_H₂O)), air mass m from the sun's elevation
    (Kasten–Young). Sky: singly scattered sunlight ∝ S·(τ_R + 0.5·τ_aer) over a shorter path.
    Scenes: direct sun, sun + sky, shade (sky only) and overcast (neutral cloud, longer water path).
    """
    lam = FINE_NM
    sun = _extraterrestrial_sun(rng, n, lam)
    cont, o2, h2o, ray, aer = _atmosphere_tau(rng, n, lam)
    elev = np.degrees(np.arcsin(_u(rng, math.sin(math.radians(15.0)), 1.0, n)))
    zen = 90.0 - elev
    m = (1.0 / (np.cos(np.radians(zen)) + 0.50572 * (96.07995 - zen) ** -1.6364))[:, None]
    direct = sun * np.exp(-m * cont - np.sqrt(m) * (o2 + h2o))
    ms = _u(rng, 1.0, 2.5, n)[:, None]
    sky = sun * (ray + 0.5 * aer) * np.exp(-ms * cont - np.sqrt(ms) * (o2 + h2o))
    d_n, s_n = _unit_power(fine_to_grid(direct)), _unit_power(fine_to_grid(sky))
    scene = rng.choice(4, n, p=[0.2, 0.4, 0.25, 0.15])
    f_sky = np.select([scene == 0, scene == 1, scene == 2],
                      [_u(rng, 0.0, 0.05, n), _u(rng, 0.1, 0.35, n), _u(rng, 0.75, 1.0, n)],
                      _u(rng, 0.3, 0.6, n))[:, None]
    out = (1.0 - f_sky) * d_n + f_sky * s_n
    overcast = scene == 3
    extra_water = fine_to_grid(np.exp(-_u(rng, 0.5, 2.0, n)[:, None] * h2o))
    return np.where(overcast[:, None], out * extra_water, out)


# ---- LEDs -----------------------------------------------------------------------------------
_ANSI_CCT = np.array([2200.0, 2700.0, 3000.0, 3500.0, 4000.0, 4500.0, 5000.0, 5700.0, 6500.0])


def _led_targets(lo: float, hi: float) -> Callable[[Generator, int], tuple[Array, Array]]:
    """CCT: 70 % a nominal ANSI bin (±3 %), 30 % log-uniform; Duv ~ N(+0.001, 0.004), |Duv| ≤ 0.012."""
    bins = _ANSI_CCT[(_ANSI_CCT >= lo) & (_ANSI_CCT <= hi)]

    def draw(rng: Generator, m: int) -> tuple[Array, Array]:
        nominal = rng.choice(bins, m) * (1.0 + 0.03 * rng.uniform(-1, 1, m))
        free = _logu(rng, lo, hi, m)
        cct = np.clip(np.where(rng.random(m) < 0.7, nominal, free), lo, hi)
        duv = np.clip(0.001 + 0.004 * rng.standard_normal(m), -0.012, 0.012)
        return cct, duv

    return draw


def _blue_pump(rng: Generator, m: int, lo: float, hi: float, fwhm: tuple[float, float]) -> Array:
    """InGaN emission: Gaussian in energy with a red shoulder (band tail / indium fluctuation),
    sampled at :data:`HAT3_NM`."""
    peak = _u(rng, lo, hi, m)
    w = _u(rng, *fwhm, m)
    shoulder = _u(rng, 0.03, 0.15, m)[:, None]
    side = energy_band(peak + _u(rng, 4.0, 12.0, m), w * _u(rng, 1.2, 1.6, m), HAT3_NM)
    return energy_band(peak, w, HAT3_NM) + shoulder * side


def _led_white_parts(rng: Generator, m: int) -> tuple[Array, Array, Array]:
    pump = _blue_pump(rng, m, 440.0, 465.0, (15.0, 25.0))
    # Green-yellow: YAG:Ce 545–580 nm (105–130 nm FWHM) or LuAG 520–545 nm (90–115 nm).
    luag = rng.random(m) < 0.35
    gpeak = np.where(luag, _u(rng, 520.0, 545.0, m), _u(rng, 545.0, 580.0, m))
    gw = np.where(luag, _u(rng, 90.0, 115.0, m), _u(rng, 105.0, 130.0, m))
    # Ce³⁺ re-absorbs the blue edge of its own emission (its 4f→5d₁ excitation band peaks at
    # 445–460 nm, σ ≈ 25 nm): the steep edge that leaves the 'cyan gap' after the pump.
    reabs = _u(rng, 0.5, 2.0, m)[:, None] * gauss(HAT3_NM, _u(rng, 445.0, 460.0, m)[:, None], 25.0)
    green = energy_band(gpeak, gw, HAT3_NM) * np.exp(-reabs)
    # Red: CaAlSiN₃/(Sr,Ca)AlSiN₃:Eu 610–660 nm, 70–100 nm; a low-energy second green band where
    # no red phosphor is used (keeps three parts; the solver then finds little of it).
    red = energy_band(_u(rng, 610.0, 660.0, m), _u(rng, 70.0, 100.0, m), HAT3_NM)
    parts = hat3(np.stack([pump, green, red], axis=1))
    parts = _unit_power(parts)
    fixed = np.zeros((m, N_BANDS))
    share = np.zeros(m)
    ksf = rng.random(m) < 0.08  # narrow K₂SiF₆:Mn⁴⁺ red (display-style, some high-efficacy lamps)
    if np.any(ksf):
        k = int(ksf.sum())
        fixed[ksf] = _group_lines(rng, k, [_LineGroup(_KSF, fwhm=(2.0, 4.0), eta=(0.0, 0.3))])
        share[ksf] = _u(rng, 0.05, 0.2, k)
    return parts, fixed, share


@_family("led_white")
def led_white(rng: Generator, n: int) -> Array:
    """Phosphor-converted white LED (blue pump + garnet/LuAG + nitride red), aimed at an ANSI
    CCT bin in 2200–6500 K near the Planckian locus."""
    return white_mix(rng, n, _led_white_parts, _led_targets(2200.0, 6500.0))


def _led_violet_parts(rng: Generator, m: int) -> tuple[Array, Array, Array]:
    violet = _unit_power(band_grid(_u(rng, 405.0, 420.0, m), _u(rng, 12.0, 20.0, m)))
    blue = _unit_power(band_grid(_u(rng, 445.0, 475.0, m), _u(rng, 40.0, 70.0, m)))
    v_share = _u(rng, 0.1, 0.5, m)[:, None]
    vb = (1.0 - v_share) * blue + v_share * violet
    green = band_grid(_u(rng, 505.0, 545.0, m), _u(rng, 70.0, 110.0, m))
    red = band_grid(_u(rng, 615.0, 655.0, m), _u(rng, 80.0, 100.0, m))
    parts = _unit_power(np.stack([vb, green, red], axis=1))
    return parts, np.zeros((m, N_BANDS)), np.zeros(m)


@_family("led_violet")
def led_violet(rng: Generator, n: int) -> Array:
    """Violet-pumped (405–420 nm) 'full-spectrum' LED with blue, green and red phosphors,
    aimed at 2700–6500 K."""
    return white_mix(rng, n, _led_violet_parts, _led_targets(2700.0, 6500.0))


# (peak nm, FWHM range nm, energy-Gaussian band) of colour LEDs; phosphor lime/amber are broad.
_COLOUR_LEDS = (
    (450.0, (15.0, 22.0)), (470.0, (18.0, 28.0)), (505.0, (25.0, 35.0)), (525.0, (27.0, 38.0)),
    (590.0, (14.0, 20.0)), (595.0, (14.0, 20.0)), (615.0, (15.0, 20.0)), (630.0, (16.0, 22.0)),
    (660.0, (18.0, 25.0)), (560.0, (95.0, 110.0)), (605.0, (75.0, 90.0)),
)
# Fixture channel sets (indices into _COLOUR_LEDS); -1 = phosphor white.
_LED_SETS = ((0, 3, 7), (1, 3, 7), (0, 3, 7, 4), (0, 3, 7, -1), (0, 3, 7, 4, -1), (0, 2, 3, 7, 8),
             (0, 3, 6, 9), (1, 3, 7, 10), (0, 1, 3, 5, 7, 8))


@_family("led_rgb")
def led_rgb(rng: Generator, n: int) -> Array:
    """Colour-mixing LED fixtures (RGB, RGBA, RGBW, RGBL, …) at random dimming, plus single- or
    two-colour LEDs: narrow direct emitters are the extreme case for the model."""
    nc = len(_COLOUR_LEDS)
    weights = np.zeros((n, nc + 1))
    kind = rng.random(n)
    set_idx = rng.integers(0, len(_LED_SETS), n)
    for i in range(n):  # building masks only (cheap); spectra are vectorised below
        if kind[i] < 0.15:
            chans = rng.choice(nc, 1)
        elif kind[i] < 0.3:
            chans = rng.choice(nc, 2, replace=False)
        else:
            chans = np.array(_LED_SETS[set_idx[i]])
        weights[i, chans] = 1.0  # -1 → last column (white)
    weights *= _logu(rng, 0.03, 1.0, (n, nc + 1))
    out = np.zeros((n, N_BANDS))
    for j, (peak, fw) in enumerate(_COLOUR_LEDS):
        on = weights[:, j] > 0
        if not np.any(on):
            continue
        m = int(on.sum())
        band = band_grid(peak + _u(rng, -5.0, 5.0, m), _u(rng, *fw, m))
        out[on] += weights[on, j, None] * _unit_power(band)
    white = weights[:, -1] > 0
    if np.any(white):
        out[white] += weights[white, -1, None] * _unit_power(led_white(rng, int(white.sum())))
    return out


# ---- fluorescent ----------------------------------------------------------------------------
def _hg_lines(rng: Generator, m: int, fwhm: tuple[float, float] = (0.5, 2.0)) -> Array:
    return _group_lines(rng, m, [_LineGroup(HG_LINES_NM, fwhm=fwhm, eta=(0.0, 0.3))], scatter=0.2)


def _tri_parts(rng: Generator, m: int) -> tuple[Array, Array, Array]:
    blue = band_grid(_u(rng, 445.0, 455.0, m), _u(rng, 45.0, 58.0, m))  # BAM:Eu²⁺
    tb = _group_lines(rng, m, [_LineGroup(_TB3, fwhm=(2.0, 6.0), eta=(0.0, 0.4), jitter_nm=0.5)])
    eu = _group_lines(rng, m, [_LineGroup(_EU3, fwhm=(1.5, 4.0), eta=(0.0, 0.4), jitter_nm=0.3)])
    parts = _unit_power(np.stack([blue, tb, eu], axis=1))
    fixed = _hg_lines(rng, m)
    # Five-band / deluxe lamps add broad bands (e.g. halophosphate, Sn²⁺ red) to the line phosphors.
    extra = rng.random(m) < 0.25
    band = band_grid(_u(rng, 480.0, 640.0, m), _u(rng, 60.0, 120.0, m))
    fixed = _unit_power(fixed) + extra[:, None] * _u(rng, 0.5, 3.0, m)[:, None] * _unit_power(band)
    share = _u(rng, 0.04, 0.15, m) + extra * 0.1
    return parts, fixed, share


@_family("fluorescent_tri")
def fluorescent_tri(rng: Generator, n: int) -> Array:
    """Tri-phosphor tube / CFL: Hg lines + BAM blue band + Tb³⁺ green + Eu³⁺ red line phosphors,
    mixed to a nominal lamp CCT (2700–6500 K)."""
    return white_mix(rng, n, _tri_parts, _led_targets(2700.0, 6500.0))


def _halo_parts(rng: Generator, m: int) -> tuple[Array, Array, Array]:
    sb = band_grid(_u(rng, 470.0, 490.0, m), _u(rng, 110.0, 145.0, m))
    mn = band_grid(_u(rng, 575.0, 590.0, m), _u(rng, 70.0, 90.0, m))
    red = band_grid(_u(rng, 620.0, 645.0, m), _u(rng, 90.0, 130.0, m))
    parts = _unit_power(np.stack([sb, mn, red], axis=1))
    return parts, _hg_lines(rng, m), _u(rng, 0.03, 0.2, m)


def _halo_targets(rng: Generator, m: int) -> tuple[Array, Array]:
    cct = np.where(rng.random(m) < 0.7, rng.choice(np.array([3000.0, 3500.0, 4100.0, 5000.0, 6500.0]), m)
                   * (1.0 + 0.04 * rng.uniform(-1, 1, m)), _logu(rng, 2700.0, 6800.0, m))
    return cct, np.clip(0.005 + 0.004 * rng.standard_normal(m), -0.006, 0.015)


@_family("fluorescent_halo")
def fluorescent_halo(rng: Generator, n: int) -> Array:
    """Halophosphate tube (Ca₅(PO₄)₃(F,Cl):Sb,Mn): broad Sb³⁺ blue + Mn²⁺ orange bands + Hg
    lines (3–20 % of the luminance); 'deluxe' ones add a broad red band (≤ 35 % of the
    luminance). Mixed to warm…daylight with the slightly green tint these lamps are known for."""
    return white_mix(rng, n, _halo_parts, _halo_targets, part_share=[(0.0, 1.0), (0.0, 1.0), (0.0, 0.35)])


# ---- high-intensity discharge ---------------------------------------------------------------
def _continuum(rng: Generator, n: int, t_lo: float, t_hi: float) -> Array:
    """Broad background of an arc (recombination, molecular bands, far wings): a Planck shape
    times a gentle random curve."""
    bb = planck(GRID, _u(rng, t_lo, t_hi, n)[:, None])
    freq = _u(rng, 0.5, 2.0, n)[:, None]
    phase = _u(rng, 0, 2 * math.pi, n)[:, None]
    wig = np.exp(0.3 * rng.standard_normal((n, 1)) * np.cos(math.pi * (GRID - 380.0) / 400.0 * freq + phase))
    return _unit_power(bb * wig)


def _broad_na_d(rng: Generator, n: int, sep: tuple[float, float], fwhm: tuple[float, float]) -> Array:
    """Pressure-broadened, self-reversed Na D as two lines either side of 589.3 nm (the red one
    stronger): enough shape for a 5 nm grid."""
    d = _u(rng, *sep, n)
    c = np.stack([589.3 - d, 589.3 + d * _u(rng, 1.0, 1.5, n)], 1)
    w = np.repeat(_u(rng, *fwhm, n)[:, None], 2, 1)
    a = np.stack([np.ones(n), _u(rng, 1.0, 2.0, n)], 1)
    return lines_on_grid(c, w, a, _u(rng, 0.3, 0.8, n)[:, None])


_MH_GROUPS = (
    _LineGroup(HG_LINES_NM, p=0.95, power=(0.1, 0.6), fwhm=(1.0, 5.0), eta=(0.2, 0.7)),
    _LineGroup(_NA_MINOR, p=0.7, power=(0.05, 0.3), fwhm=(1.0, 5.0), eta=(0.2, 0.7)),
    _LineGroup(_TL, p=0.6, power=(0.05, 0.5), fwhm=(0.5, 4.0), eta=(0.2, 0.7)),
    _LineGroup(_IN, p=0.35, power=(0.1, 0.6), fwhm=(0.5, 4.0), eta=(0.2, 0.7)),
    _LineGroup(_SC, p=0.4, power=(0.1, 0.8), fwhm=(0.5, 3.0), eta=(0.1, 0.6)),
    _LineGroup(_LI, p=0.3, power=(0.05, 0.4), fwhm=(0.5, 3.0), eta=(0.1, 0.6)),
    _LineGroup(_CA, p=0.25, power=(0.05, 0.3), fwhm=(0.5, 3.0), eta=(0.1, 0.6)),
    _LineGroup(_SR, p=0.15, power=(0.05, 0.3), fwhm=(0.5, 3.0), eta=(0.1, 0.6)),
    _LineGroup(_DY_HO_TM, p=0.4, power=(0.1, 0.8), fwhm=(0.5, 3.0), eta=(0.1, 0.6), jitter_nm=0.2),
    _LineGroup(_K, p=0.1, power=(0.02, 0.2), fwhm=(1.0, 5.0), eta=(0.2, 0.7)),
)


def _mh_raw(rng: Generator, n: int) -> Array:
    lines = _group_lines(rng, n, _MH_GROUPS)
    na_power = (rng.random(n) < 0.75) * _logu(rng, 0.1, 1.0, n)
    na = na_power[:, None] * _broad_na_d(rng, n, (1.5, 6.0), (3.0, 8.0))
    forest_power = (rng.random(n) < 0.5) * _logu(rng, 0.2, 2.0, n)
    forest = _random_lines(rng, n, (10, 60), 390.0, 660.0, (0.5, 3.0), forest_power)
    lines = lines + na + forest
    cont = _continuum(rng, n, 3000.0, 7000.0)
    f = _u(rng, 0.05, 0.6, n)[:, None]
    return (1.0 - f) * _unit_power(lines) + f * cont


@_family("metal_halide")
def metal_halide(rng: Generator, n: int) -> Array:
    """Quartz / ceramic metal halide and HMI: Hg + additive lines (Na, Tl, In, Sc, Li, Ca, Sr,
    Dy/Ho/Tm), a broadened Na D, a rare-earth line forest and an arc continuum. Lamp makers
    balance the fill for white light, so 85 % of rows are redrawn until CCT 2500–8000 K and
    |Duv| < 0.02; the rest keep any colour (coloured and aged lamps)."""
    out = _mh_raw(rng, n)
    todo = np.flatnonzero(rng.random(n) < 0.85)
    for _ in range(100):
        cct, duv = cct_duv(out[todo])
        todo = todo[(cct < 2500.0) | (cct > 8000.0) | (np.abs(duv) > 0.02)]
        if todo.size == 0:
            break
        out[todo] = _mh_raw(rng, todo.size)
    return out


@_family("hps")
def hps(rng: Generator, n: int) -> Array:
    """High-pressure sodium (standard to 'white SON'): optically thick, pressure-broadened Na D
    (saturated at the arc's temperature, red wing wider) self-reversed by the cooler outer layer,
    + Na minor lines, Hg amalgam lines, a weak continuum. Built on the fine grid."""
    lam = FINE_NM[None, :]
    x = lam - 589.3
    half_b = _logu(rng, 4.0, 30.0, n)[:, None]  # extent of the saturated core, blue side
    half_r = half_b * _u(rng, 1.2, 2.0, n)[:, None]
    half = np.where(x < 0, half_b, half_r)
    tau0 = _logu(rng, 30.0, 3000.0, n)[:, None]
    gamma = half / np.sqrt(tau0)
    core = -np.expm1(-tau0 / (1.0 + (x / gamma) ** 2)) * planck(lam, _u(rng, 3000.0, 4500.0, n)[:, None])
    dip_half = np.minimum(_u(rng, 1.5, 8.0, n)[:, None], 0.7 * half_b)
    tc0 = _logu(rng, 3.0, 300.0, n)[:, None]
    gc = dip_half / np.sqrt(tc0)
    profile = core * np.exp(-tc0 / (1.0 + (x / gc) ** 2))
    d_line = _unit_power(fine_to_grid(profile))
    groups = [_LineGroup(_NA_MINOR, power=(0.05, 0.25), fwhm=(1.0, 6.0), eta=(0.3, 0.8)),
              _LineGroup(HG_LINES_NM, p=0.6, power=(0.005, 0.05), fwhm=(0.5, 2.0), eta=(0.0, 0.3)),
              _LineGroup(_XE, p=0.3, power=(0.002, 0.02), fwhm=(0.5, 2.0))]
    minor = _group_lines(rng, n, groups)
    cont = _continuum(rng, n, 2500.0, 5000.0) * _u(rng, 0.0, 0.1, n)[:, None]
    return d_line + minor + cont


@_family("lps")
def lps(rng: Generator, n: int) -> Array:
    """Low-pressure sodium: the 589.0/589.6 nm doublet almost alone; weak Na minor lines and
    Ne/Ar starting-gas lines (stronger while warming up)."""
    groups = [_LineGroup(_NA_D, power=(1.0, 1.0), fwhm=(0.5, 1.5), eta=(0.0, 0.3)),
              _LineGroup(_NA_MINOR, power=(0.005, 0.03), fwhm=(0.5, 1.5)),
              _LineGroup(_NE, p=0.6, power=(0.002, 0.1), fwhm=(0.5, 1.5)),
              _LineGroup(_AR, p=0.3, power=(0.001, 0.03), fwhm=(0.5, 1.5))]
    glow = _continuum(rng, n, 2000.0, 4000.0) * _logu(rng, 1e-3, 2e-2, n)[:, None]
    return _group_lines(rng, n, groups) + glow


@_family("mercury")
def mercury(rng: Generator, n: int) -> Array:
    """High-pressure mercury vapour, clear or with a red phosphor (YVO₄:Eu³⁺ or Mn⁴⁺ germanate)."""
    groups = [_LineGroup(HG_LINES_NM, power=(1.0, 1.0), fwhm=(1.0, 5.0), eta=(0.2, 0.7)),
              _LineGroup(_EU_YVO4, p=0.4, power=(0.1, 0.6), fwhm=(1.0, 4.0), eta=(0.0, 0.4)),
              _LineGroup(_MN4_GERMANATE, p=0.15, power=(0.1, 0.4), fwhm=(2.0, 6.0), eta=(0.0, 0.4))]
    cont = _continuum(rng, n, 4000.0, 8000.0) * _u(rng, 0.05, 0.4, n)[:, None]
    return _group_lines(rng, n, groups) + cont


@_family("xenon")
def xenon(rng: Generator, n: int) -> Array:
    """Xenon short arc (projectors, solar simulators, searchlights): a ≈5300–6500 K continuum
    with Xe I lines in 450–500 nm; some behind a UV-cut coating. Flash tubes: ``xenon_flash``."""
    cont = planck(GRID, _u(rng, 5300.0, 6500.0, n)[:, None])
    cont = _unit_power(cont * np.exp(0.05 * rng.standard_normal((n, 1)) * (GRID - 580.0) / 200.0))
    lines = _group_lines(rng, n, [_LineGroup(_XE, power=(0.005, 0.04), fwhm=(1.0, 5.0), eta=(0.2, 0.7))])
    coat = np.where((rng.random(n) < 0.3)[:, None],
                    0.05 + 0.95 * sigmoid((GRID - _u(rng, 390.0, 430.0, n)[:, None]) / 6.0), 1.0)
    return (cont + lines) * coat


@_family("xenon_flash")
def xenon_flash(rng: Generator, n: int) -> Array:
    """Xenon flash tube (speedlights, studio strobes, phone xenon flashes). The pulsed plasma is
    hotter than a short arc (≈6500–11000 K) but optically thin at low current density: its
    emissivity 1 − exp(−τ), with τ ∝ λ² (free–free absorption grows towards the red), leaves a
    continuum redder than Planck's at the plasma temperature — at high current density (short,
    full-power pulses) τ is large and the tube approaches a blackbody. Ionic Xe II lines appear
    at high current density, neutral Xe I lines at low; most flashes sit behind a UV-absorbing,
    often slightly yellow, window that takes the colour to ≈5500 K."""
    t = _u(rng, 6500.0, 11000.0, n)[:, None]
    tau = _logu(rng, 0.2, 5.0, n)[:, None] * (GRID / 550.0) ** 2
    cont = _unit_power(planck(GRID, t) * -np.expm1(-tau))
    density = rng.random(n)  # current density, low → high: lines change from Xe I to Xe II
    xe1 = _group_lines(rng, n, [_LineGroup(_XE, power=(0.005, 0.04), fwhm=(1.0, 5.0), eta=(0.2, 0.7))])
    xe2 = _group_lines(rng, n, [_LineGroup(_XE_II, power=(0.01, 0.08), fwhm=(1.0, 6.0), eta=(0.3, 0.8))])
    spd = cont + (1.0 - density)[:, None] * xe1 + density[:, None] * xe2
    window = np.where((rng.random(n) < 0.6)[:, None],
                      0.02 + 0.98 * sigmoid((GRID - _u(rng, 385.0, 440.0, n)[:, None]) / _u(rng, 5.0, 15.0, n)[:, None]),
                      1.0)
    return spd * window


# ---- horticultural LEDs ---------------------------------------------------------------------
# (peak range nm, FWHM range nm) of grow-light emitters: InGaN UV-A, royal blue and blue;
# AlGaInP red and deep red; GaAlAs far red (datasheet values).
_GROW_CHANNELS = {
    "uv": ((385.0, 405.0), (10.0, 15.0)),
    "royal_blue": ((440.0, 455.0), (17.0, 24.0)),
    "blue": ((460.0, 470.0), (20.0, 27.0)),
    "red": ((625.0, 635.0), (15.0, 20.0)),
    "deep_red": ((655.0, 665.0), (17.0, 25.0)),
    "far_red": ((725.0, 740.0), (25.0, 35.0)),
}


def _grow_channel(rng: Generator, name: str, power: Array) -> Array:
    (lo, hi), fwhm = _GROW_CHANNELS[name]
    n = power.size
    return power[:, None] * _unit_power(band_grid(_u(rng, lo, hi, n), _u(rng, *fwhm, n)))


@_family("led_grow")
def led_grow(rng: Generator, n: int) -> Array:
    """Plant-grow LEDs. 'Blurple' fixtures: royal blue ≈450 nm + deep red ≈660 nm (red:blue
    power 1.5–10), optionally 630 nm red, 730 nm far red and a 385–405 nm UV-A channel;
    'full-spectrum' grow whites: a phosphor white (warm to cool) with 10–50 % of the power
    added in deep red and often some far red; flowering / end-of-day bars: deep red + far red."""
    kind = rng.choice(3, n, p=[0.4, 0.45, 0.15])
    zero = np.zeros(n)
    blurple, white, bar = kind == 0, kind == 1, kind == 2
    out = _grow_channel(rng, "deep_red", np.ones(n))
    blue_share = np.where(blurple, 1.0 / _u(rng, 1.5, 10.0, n), zero)
    out += _grow_channel(rng, "royal_blue", blue_share)
    out += _grow_channel(rng, "blue", np.where(blurple & (rng.random(n) < 0.2), 0.5 * blue_share, zero))
    out += _grow_channel(rng, "red", np.where(blurple & (rng.random(n) < 0.5), _u(rng, 0.1, 0.6, n), zero))
    out += _grow_channel(rng, "uv", np.where(blurple & (rng.random(n) < 0.15), _u(rng, 0.02, 0.1, n), zero))
    far = np.select([bar, white], [_u(rng, 0.2, 1.0, n), (rng.random(n) < 0.6) * _u(rng, 0.02, 0.15, n)],
                    (rng.random(n) < 0.4) * _u(rng, 0.03, 0.2, n))
    out += _grow_channel(rng, "far_red", far)
    if np.any(white):
        m = int(white.sum())
        red_share = _u(rng, 0.1, 0.5, m)  # deep red's share of deep red + white (unit power above)
        out[white] += ((1.0 - red_share) / red_share)[:, None] * _unit_power(led_white(rng, m))
    return out


# ---- filters --------------------------------------------------------------------------------
def _filter_transmission(rng: Generator, n: int) -> Array:
    """Random gel / filter transmission on the grid: long-, short-, band-pass, notch, mired
    shift (CTO/CTB), or a random dye curve; raised to a density and floored (real gels leak)."""
    lam = GRID[None, :]
    kind = rng.integers(0, 6, n)[:, None]
    c1 = _u(rng, 400.0, 680.0, n)[:, None]
    c2 = c1 + _u(rng, 30.0, 200.0, n)[:, None]
    s1 = _u(rng, 5.0, 40.0, n)[:, None]
    s2 = _u(rng, 5.0, 40.0, n)[:, None]
    lp = sigmoid((lam - c1) / s1)
    sp = sigmoid((c1 - lam) / s1)
    bp = sigmoid((lam - c1) / s1) * sigmoid((c2 - lam) / s2)
    notch = 1.0 - _u(rng, 0.3, 0.95, n)[:, None] * gauss(lam, _u(rng, 480.0, 620.0, n)[:, None],
                                                         _u(rng, 15.0, 60.0, n)[:, None])
    mired = _u(rng, -150.0, 160.0, n)[:, None] * 1e-6  # CTB < 0 < CTO (full CTO ≈ +159 mired)
    shift = np.exp(-C2_NM_K * mired / lam)
    shift /= shift.max(1, keepdims=True)
    dye = np.exp(-np.abs(_smooth_curves(rng, n)) * _u(rng, 0.5, 3.0, n)[:, None])
    t = np.select([kind == 0, kind == 1, kind == 2, kind == 3, kind == 4], [lp, sp, bp, notch, shift], dye)
    red_leak = (rng.random(n) < 0.3)[:, None] * sigmoid((lam - _u(rng, 680.0, 760.0, n)[:, None]) / 10.0)
    t = np.maximum(t, red_leak * _u(rng, 0.2, 0.9, n)[:, None])
    t = t ** _logu(rng, 0.3, 3.0, n)[:, None]
    floor = _logu(rng, 1e-3, 5e-2, n)[:, None]
    return floor + (1.0 - floor) * t


_FILTER_BASES = ("blackbody", "incandescent", "daylight", "led_white", "led_violet", "led_rgb",
                 "fluorescent_tri", "fluorescent_halo", "metal_halide", "hps", "mercury", "xenon", "xenon_flash")


@_family("filtered")
def filtered(rng: Generator, n: int) -> Array:
    """A physical source behind a colour gel or filter (stage, film and photo lighting). The
    source family is drawn with :data:`DEFAULT_WEIGHTS` (``sample_spds(weights=…)`` does not
    reach inside) and the row is labelled ``filtered``."""
    w = np.array([DEFAULT_WEIGHTS[f] for f in _FILTER_BASES])
    base_idx = rng.choice(len(_FILTER_BASES), n, p=w / w.sum())
    out = np.empty((n, N_BANDS))
    for k, fam in enumerate(_FILTER_BASES):
        idx = np.flatnonzero(base_idx == k)
        if idx.size:
            out[idx] = _GENERATORS[fam](rng, idx.size)
    return peak_normalise(out) * _filter_transmission(rng, n)


#: Default relative weights (normalised at use). Generic 19 %, thermal 10 %, daylight 8 %,
#: LEDs 28 % (grow lights 3 %), fluorescent 10 %, HID, arcs & flash 13 %, filtered 11 %.
DEFAULT_WEIGHTS: dict[str, float] = {
    "smooth": 0.08,
    "smooth_noise": 0.05,
    "spiky": 0.07,
    "blackbody": 0.04,
    "incandescent": 0.07,
    "daylight": 0.08,
    "led_white": 0.14,
    "led_violet": 0.04,
    "led_rgb": 0.08,
    "led_grow": 0.03,
    "fluorescent_tri": 0.08,
    "fluorescent_halo": 0.03,
    "metal_halide": 0.05,
    "hps": 0.03,
    "lps": 0.01,
    "mercury": 0.01,
    "xenon": 0.02,
    "xenon_flash": 0.02,
    "filtered": 0.12,
}

FAMILIES: tuple[str, ...] = tuple(DEFAULT_WEIGHTS)
assert set(FAMILIES) == set(_GENERATORS), "every family needs a generator and a weight"
