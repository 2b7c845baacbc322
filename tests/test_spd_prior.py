"""The SPD prior: contract of ``sample_spds`` and the physics of the families (its speed, 100 000
SPDs in ≤ 20 s, is a figure of ``make bench``: no test asserts wall-clock time).

Colour-science is used here only as an independent CCT meter (its CMFs and Ohno 2013), never as
a source of spectra.
"""

from __future__ import annotations

import ast
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import constants
from scipy.optimize import minimize_scalar

from cd_spectra_addon.core.spectra.grid import (
    N_BANDS,
    WAVELENGTHS_NM,
    hat_integrals,
    resample_to_grid,
)
from training.learning import spd_prior as prior
from training.learning.spd_prior import FAMILIES, sample_spds
from training.learning.spd_prior.families import _filter_transmission
from training.learning.spd_prior.grid import band_grid, energy_band

MODULES = sorted(Path(prior.__file__).parent.glob("*.py"))


def cct_duv(spds: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """CCT (K) and Duv of grid SPDs with colour-science's CIE 1931 CMFs and Ohno (2013)."""
    import colour

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy()
        cmfs = cmfs.align(colour.SpectralShape(380, 780, 5)).values
        xyz = spds @ cmfs
        uv = colour.xy_to_UCS_uv(xyz[:, :2] / xyz.sum(1, keepdims=True))
        res = colour.temperature.uv_to_CCT_Ohno2013(uv)
    return res[:, 0], res[:, 1]


def _idx(nm: float) -> int:
    return int(np.flatnonzero(WAVELENGTHS_NM == nm)[0])


# --- contract of sample_spds ------------------------------------------------------------------


def test_shape_dtype_labels_and_peak_exactly_one():
    spds, labels = sample_spds(600, np.random.default_rng(0))
    assert spds.shape == (600, N_BANDS) and spds.dtype == np.float64
    assert len(labels) == 600 and set(labels) <= set(FAMILIES)
    assert np.all(spds.max(axis=1) == 1.0)  # exactly, not approximately
    assert np.all(np.isfinite(spds)) and np.all(spds >= 0)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_every_seed_gives_finite_nonnegative_peak_one(seed):
    spds, _ = sample_spds(120, np.random.default_rng(seed))
    assert np.all(np.isfinite(spds)) and np.all(spds >= 0)
    assert np.all(spds.max(axis=1) == 1.0)


def test_same_seed_same_output_and_other_seed_differs():
    a, la = sample_spds(300, np.random.default_rng(42))
    b, lb = sample_spds(300, np.random.default_rng(42))
    c, _ = sample_spds(300, np.random.default_rng(43))
    assert np.array_equal(a, b) and la == lb
    assert not np.allclose(a, c)


def test_every_family_appears_with_roughly_its_default_weight():
    _, labels = sample_spds(4000, np.random.default_rng(1))
    counts = {f: labels.count(f) for f in FAMILIES}
    assert all(counts[f] > 0 for f in FAMILIES), counts
    total = sum(prior.DEFAULT_WEIGHTS.values())
    for fam, w in prior.DEFAULT_WEIGHTS.items():
        expected = 4000 * w / total
        assert abs(counts[fam] - expected) < 5 * np.sqrt(expected) + 2, (fam, counts[fam], expected)


def test_families_and_weights_restrict_the_draw():
    _, labels = sample_spds(400, np.random.default_rng(2), families=["lps", "daylight"])
    assert set(labels) == {"lps", "daylight"}
    _, labels = sample_spds(200, np.random.default_rng(2), weights={"blackbody": 1.0})
    assert set(labels) == {"blackbody"}
    _, labels = sample_spds(300, np.random.default_rng(2), families=["hps", "xenon"],
                            weights={"hps": 1.0, "xenon": 0.0})
    assert set(labels) == {"hps"}


def test_bad_requests_are_rejected():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError):
        sample_spds(10, rng, families=["candle"])
    with pytest.raises(ValueError):
        sample_spds(10, rng, families=[])
    with pytest.raises(ValueError):
        sample_spds(10, rng, weights={"lps": 0.0})
    spds, labels = sample_spds(0, rng)
    assert spds.shape == (0, N_BANDS) and labels == []


@pytest.mark.parametrize("family", FAMILIES)
def test_public_family_generators(family):
    fn = getattr(prior, family)
    one = fn(np.random.default_rng(5))
    many = fn(np.random.default_rng(5), 7)
    assert one.shape == (N_BANDS,) and many.shape == (7, N_BANDS)
    assert np.all(many.max(axis=1) == 1.0) and np.all(many >= 0) and np.all(np.isfinite(many))
    assert np.array_equal(many, fn(np.random.default_rng(5), 7))
    assert not np.allclose(many[0], many[1])  # parameters really are random per row


# --- the grid: lines and fine spectra ----------------------------------------------------------


@pytest.mark.parametrize(("centre", "fwhm", "eta"), [(552.3, 0.5, 0.0), (404.656, 1.5, 0.0),
                                                      (600.0, 4.0, 0.6), (437.9, 0.8, 1.0)])
def test_line_matches_resample_to_grid_and_keeps_its_energy(centre, fwhm, eta):
    wl = np.arange(250.0, 910.0, 0.01)
    s, g = fwhm / 2.3548200450309493, fwhm / 2.0
    profile = ((1 - eta) * np.exp(-0.5 * ((wl - centre) / s) ** 2) / (s * np.sqrt(2 * np.pi))
               + eta * (g / np.pi) / ((wl - centre) ** 2 + g * g))
    grid = prior.lines_on_grid(centre, fwhm, 2.0, eta)
    ref = resample_to_grid(wl, 2.0 * profile)
    assert np.abs(grid - ref).max() < 2e-4 * ref.max()
    # Energy: Σ grid × hat area equals the line's area inside 380–780 nm (Lorentz wings leave).
    inside = 1.0 - eta + eta * (np.arctan((780 - centre) / g) - np.arctan((380 - centre) / g)) / np.pi
    assert np.sum(grid * hat_integrals()) == pytest.approx(2.0 * inside, rel=1e-3)


def test_line_energy_lands_on_the_two_nearest_samples():
    grid = prior.lines_on_grid(546.074, 0.6, 1.0)
    assert set(np.flatnonzero(grid > 1e-3 * grid.max())) == {_idx(545), _idx(550)}
    # Hat weights: 546.074 is 1.074 nm from 545 → 0.785 / 0.215 of the energy.
    assert grid[_idx(545)] / grid[_idx(550)] == pytest.approx(0.785 / 0.215, rel=0.01)


@pytest.mark.parametrize(("peak", "fwhm"), [(405.0, 12.0), (450.0, 15.0), (630.0, 20.0), (560.0, 120.0)])
def test_phosphor_and_led_bands_are_hat_averaged_like_resample_to_grid(peak, fwhm):
    wl = np.arange(300.0, 900.0, 0.02)
    ref = resample_to_grid(wl, energy_band(np.array(peak), np.array(fwhm), wl))
    assert np.abs(band_grid(np.array(peak), np.array(fwhm)) - ref).max() < 5e-4 * ref.max()


def test_fine_to_grid_is_resample_to_grid():
    rng = np.random.default_rng(3)
    fine = rng.random((3, prior.FINE_NM.size))
    assert np.allclose(prior.fine_to_grid(fine), resample_to_grid(prior.FINE_NM, fine), atol=1e-12)


# --- physics of the families --------------------------------------------------------------------


def test_planck_matches_the_textbook_formula():
    h, c, k = constants.h, constants.c, constants.k
    lam = WAVELENGTHS_NM * 1e-9
    for t in (1000.0, 2856.0, 6504.0, 12000.0):
        b = 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k * t))
        ours = prior.planck(WAVELENGTHS_NM, t)
        assert np.allclose(ours / ours.max(), b / b.max(), rtol=1e-9)


def test_blackbody_rows_are_planck_curves_between_1000_and_12000_k():
    rows = prior.blackbody(np.random.default_rng(7), 40)
    temps = []
    for row in rows:
        def misfit(log_t: float, row: np.ndarray = row) -> float:
            ref = prior.planck(WAVELENGTHS_NM, np.exp(log_t))
            return float(np.sum((np.log(row) - np.log(ref / ref.max())) ** 2))

        res = minimize_scalar(misfit, bounds=(np.log(800.0), np.log(15000.0)), method="bounded",
                              options={"xatol": 1e-10})
        assert res.fun < 1e-9  # any other shape (or a tilt) costs > 1e-4
        temps.append(np.exp(res.x))
    temps = np.array(temps)
    assert temps.min() >= 999.0 and temps.max() <= 12001.0
    assert temps.max() / temps.min() > 3.0  # the range is used, not one curve


def test_incandescent_is_warm():
    cct, duv = cct_duv(prior.incandescent(np.random.default_rng(8), 300))
    assert np.all((cct > 1600) & (cct < 4300))
    assert np.median(np.abs(duv)) < 0.003  # thermal sources sit on the Planckian locus


@pytest.mark.parametrize(("family", "lo", "hi"), [("led_white", 2200.0, 6500.0),
                                                  ("led_violet", 2700.0, 6500.0),
                                                  ("fluorescent_tri", 2700.0, 6500.0)])
def test_white_sources_hit_their_cct_range_near_the_locus(family, lo, hi):
    spds = getattr(prior, family)(np.random.default_rng(9), 400)
    cct, duv = cct_duv(spds)
    assert np.all((cct > 0.95 * lo) & (cct < 1.05 * hi)), (cct.min(), cct.max())
    assert np.mean((cct >= lo - 50) & (cct <= hi + 50)) > 0.95
    assert np.percentile(cct, 10) < lo + 600 and np.percentile(cct, 90) > hi - 1200  # spans it
    assert np.all(np.abs(duv) < 0.02) and np.mean(np.abs(duv) < 0.01) > 0.9


def test_white_led_has_its_blue_pump_at_440_to_465_nm():
    spds = prior.led_white(np.random.default_rng(10), 400)
    i = np.arange(_idx(400), _idx(490) + 1)
    is_peak = (spds[:, i] >= spds[:, i - 1]) & (spds[:, i] >= spds[:, i + 1]) & (spds[:, i] > 0.02)
    peak_nm = np.where(is_peak, WAVELENGTHS_NM[i], np.nan)
    assert np.all(np.isnan(peak_nm) | ((peak_nm >= 435) & (peak_nm <= 470)))  # no pump elsewhere
    assert np.mean(np.any(is_peak, axis=1)) > 0.97  # a distinct blue peak, the cyan gap after it


def _spikiness(spds: np.ndarray, i: int) -> np.ndarray:
    """How far sample i sticks out above its neighbours (0 on any straight line)."""
    return spds[:, i] - 0.5 * (spds[:, i - 1] + spds[:, i + 1])


@pytest.mark.parametrize("family", ["fluorescent_tri", "fluorescent_halo"])
def test_mercury_lines_land_on_the_right_grid_samples(family):
    spds = getattr(prior, family)(np.random.default_rng(11), 300)
    for line_nm, sample in ((404.656, 405.0), (435.833, 435.0)):
        at = _spikiness(spds, _idx(sample))
        assert np.mean(at > 0) > 0.95, line_nm
        # …and not one sample off.
        for other in (sample - 5.0, sample + 5.0):
            assert np.mean(at > _spikiness(spds, _idx(other))) > 0.95, (line_nm, other)


def test_daylight_is_a_daylight():
    spds = prior.daylight(np.random.default_rng(12), 400)
    cct, duv = cct_duv(spds)
    assert np.mean((cct > 4000) & (cct < 20000)) > 0.9
    assert np.median(cct) > 5000 and np.percentile(cct, 95) > 8000  # sky light is in there
    assert np.all(np.abs(duv) < 0.02)
    # O₂ A band (759–770 nm) dips below its neighbours; no CIE basis would put it exactly there.
    assert np.mean(_spikiness(spds, _idx(760)) < 0) > 0.95


def test_low_pressure_sodium_is_the_d_doublet():
    spds = prior.lps(np.random.default_rng(13), 50)
    assert np.all(np.argmax(spds, axis=1) == _idx(590))
    share = (spds[:, _idx(585)] + spds[:, _idx(590)] + spds[:, _idx(595)]) / spds.sum(axis=1)
    assert np.all(share > 0.8)


def test_high_pressure_sodium_is_self_reversed_at_589_nm():
    spds = prior.hps(np.random.default_rng(14), 200)
    peak_nm = WAVELENGTHS_NM[np.argmax(spds, axis=1)]
    assert np.all((peak_nm >= 560) & (peak_nm <= 640))
    reversed_ = spds[:, _idx(590)] < np.maximum(spds[:, _idx(580)], spds[:, _idx(600)])
    assert np.mean(reversed_) > 0.8


def _local_peak_in(spds: np.ndarray, lo: float, hi: float, floor: float = 0.05) -> np.ndarray:
    """Rows with a local maximum (≥ ``floor`` of the peak) on a grid sample in [lo, hi] nm."""
    i = np.arange(_idx(lo), _idx(hi) + 1)
    peak = (spds[:, i] >= spds[:, i - 1]) & (spds[:, i] >= spds[:, i + 1]) & (spds[:, i] > floor)
    return peak.any(axis=1)


def test_grow_leds_are_royal_blue_and_deep_red_with_far_red():
    """Horticultural LEDs: AlGaInP deep red 655–665 nm in every fixture, InGaN royal blue
    440–455 nm (or a white's 440–465 nm pump), GaAlAs far red 725–740 nm in many; the strongest
    sample is always one of the blue or red emitters, never the gap between them."""
    spds = prior.led_grow(np.random.default_rng(20), 600)
    assert np.all(_local_peak_in(spds, 650, 670))
    assert np.mean(_local_peak_in(spds, 440, 465)) > 0.7
    assert 0.25 < np.mean(_local_peak_in(spds, 720, 745)) < 0.7
    assert np.mean(_local_peak_in(spds, 680, 715)) < 0.02  # deep red and far red stay apart
    peak_nm = WAVELENGTHS_NM[np.argmax(spds, axis=1)]
    assert np.all(((peak_nm >= 435) & (peak_nm <= 470)) | ((peak_nm >= 620) & (peak_nm <= 670)))


def test_xenon_flash_is_a_near_daylight_continuum_with_xenon_lines():
    """A flash tube: CCT mostly 5000–8500 K near the locus (warming windows pull it to ~5500 K),
    Xe II 484.4 nm and 529.2/533.9 nm lines above the continuum, nothing at 500 nm."""
    spds = prior.xenon_flash(np.random.default_rng(21), 400)
    cct, duv = cct_duv(spds)
    assert 4500 < np.percentile(cct, 5) and np.percentile(cct, 95) < 9500 and 5500 < np.median(cct) < 7000
    assert np.all(np.abs(duv) < 0.025)
    assert np.mean(_spikiness(spds, _idx(485)) > 0) > 0.9
    assert np.mean(_spikiness(spds, _idx(530)) > 0) > 0.9
    assert np.mean(_spikiness(spds, _idx(500)) > 0) < 0.05
    assert np.median(spds[:, _idx(380)]) < 0.3  # most flashes sit behind a UV-absorbing window


def test_filters_only_remove_light():
    rng = np.random.default_rng(15)
    t = _filter_transmission(rng, 500)
    assert np.all((t > 0) & (t <= 1.0))
    assert np.mean(t.min(axis=1) < 0.5) > 0.5  # filters are not mostly clear glass


# --- the hard rule --------------------------------------------------------------------------------


def test_the_module_reads_no_measured_spectra():
    """Hard rule: the prior is physics only; measured lamps and CIE tables are for evaluation."""
    assert {m.name for m in MODULES} == {"__init__.py", "grid.py", "white_point.py", "families.py", "sampling.py"}
    for module in MODULES:
        tree = ast.parse(module.read_text(encoding="utf-8"))
        roots = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                module_name = node.module or ""
                roots.add(module_name.split(".")[0])
                if module_name.split(".")[0] in ("training", "cd_spectra_addon"):  # itself and the core only
                    assert module_name.startswith(("training.learning.spd_prior.", "cd_spectra_addon.core.")), module_name
                if node.module == "cd_spectra_addon.core.spectra.illuminants":  # Planck, not CIE daylight
                    assert {a.name for a in node.names} <= {"planck", "C2_NM_K"}, module.name
        assert roots <= {"__future__", "math", "collections", "dataclasses", "functools", "typing",
                         "numpy", "cd_spectra_addon", "training"}, (module.name, roots)
        text = module.read_text(encoding="utf-8")
        for banned in ("spds-validation", "SDS_ILLUMINANTS", "SDS_LIGHT_SOURCES", "open(", "np.load", "loadtxt",
                       "daylight_spd", "known_lamp"):
            assert banned not in text, (module.name, banned)
