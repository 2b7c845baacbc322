"""The blind tails from physics (core.spectrum.tails), the band rule without islands and the
solve's line pass (issue 21).

Photos are rendered by the numpy twin at the reference geometry; the thresholds come from the
shipped model's metadata (chosen on synthetic spectra, bench/tails_tuning.md).
"""

import numpy as np
import pytest

from cd_spectra_addon.core.inverse.stages import model_prior, tail_settings, tailed
from cd_spectra_addon.core.readout import forward_matrix, readout
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM, peak_normalise
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd, planck_spd
from cd_spectra_addon.core.spectrum import solve
from cd_spectra_addon.core.spectrum.model import load_model
from cd_spectra_addon.core.spectrum.tails import (DEFAULT_SETTINGS, BLIND_STD, blind_weight, joined_tails,
                                                  planck_fit, thermal_weight, widen_std, with_tails)
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)
LAM = WAVELENGTHS_NM


@pytest.fixture(scope="module")
def capture():
    scene = Scene(load_preset("cd-default").with_image_size(192))
    return scene, render_cube(scene, supersample=3), photo.track_mask(scene)


@pytest.fixture(scope="module")
def model():
    return load_model()


def _solve(capture, model, spd, noise=0.01, seed=0, lines=0.0):
    """Physics + prior (the rows' units) and the rows of a photo of ``spd``, read with the true capture."""
    scene, cube, meter = capture
    img, _ = photo.synthesize(cube, spd, CAMERA, 1.0, noise, np.random.default_rng(seed), meter)
    prof = readout.extract_readout(img, None, scene)
    rows = solve.rows_for(prof, forward_matrix.feature_matrix(forward_matrix.bin_response(scene, prof), CAMERA))
    prior = model_prior(model)
    return solve.solve_prior(rows, prior[0], precision=prior[1], lines=lines)[:rows.n], rows


def _warm_led():
    return peak_normalise(0.35 * np.exp(-0.5 * ((LAM - 452) / 9) ** 2) + np.exp(-0.5 * ((LAM - 590) / 55) ** 2))


def _tri_phosphor():
    return peak_normalise(0.05 + sum(h * np.exp(-0.5 * ((LAM - c) / 4) ** 2)
                                     for c, h in ((436, 0.5), (546, 1.0), (611, 0.9), (487, 0.2))))


def test_the_shipped_model_carries_its_tail_settings(model):
    settings = tail_settings(model)
    assert settings is not None and 0 <= settings.thermal_chi2 <= settings.other_chi2
    assert tail_settings(None) is None


@pytest.mark.parametrize("kelvin", [2000.0, 2856.0, 3400.0])
def test_a_planck_lamps_tail_keeps_rising_to_780_nm(capture, model, kelvin):
    """A tungsten-like source rises to 780 nm; the prior alone turns over near 700 nm (issue 21).
    With the Planck continuation the red tail rises monotonically from 690 to 780 nm, within 0.03
    of the truth (peak 1 over 380–780), and MAE 400–700 improves."""
    truth = planck_spd(kelvin)
    est, rows = _solve(capture, model, truth)
    out, _, fit, q = with_tails(est, rows, tail_settings(model))
    assert q == 1.0 and abs(fit.temperature_k - kelvin) < 0.05 * kelvin
    red = LAM >= 690  # the ramp (660–700 nm) may keep a wiggle of the estimate; beyond, Planck
    assert np.all(np.diff(out[red]) > 0) and out[-1] == 1.0
    assert np.max(np.abs(out[LAM >= 680] - truth[LAM >= 680])) < 0.03
    before = compare_spds(est, truth)
    after = compare_spds(out, truth)
    assert after["mae_400_700"] < before["mae_400_700"] and after["mae_380_780"] < 0.02
    assert after["delta_uv_prime"] < 0.002


def _family(name, seed=5):
    from training.learning.spd_prior.families import generate

    return peak_normalise(generate(name, np.random.default_rng(seed), 1)[0])


@pytest.mark.parametrize("spd", [_warm_led(), _tri_phosphor(), _family("led_white"), _family("fluorescent_tri")],
                         ids=["led", "tri-phosphor", "prior-led-white", "prior-fluorescent-tri"])
def test_a_non_thermal_source_keeps_its_tails(capture, model, spd):
    """No Planck curve explains lines or phosphor bumps: the estimate is returned as it was."""
    est, rows = _solve(capture, model, spd)
    fit = planck_fit(rows)
    assert fit.chi2_per_row > tail_settings(model).other_chi2
    out, _, _, q = with_tails(est, rows, tail_settings(model))
    assert q == 0.0 and np.allclose(out, est / est.max(), rtol=0, atol=1e-12)


def test_without_settings_the_tails_are_the_solves_own(capture, model):
    est, rows = _solve(capture, model, planck_spd(2856.0))
    out, _, fit, q = with_tails(est, rows, None)
    assert fit is None and q == 0.0 and np.array_equal(out, est / est.max())


def test_thermal_weight_is_linear_between_the_thresholds():
    from cd_spectra_addon.core.spectrum.tails import PlanckFit, TailSettings

    s = TailSettings(2.0, 4.0)
    fit = lambda chi: PlanckFit(3000.0, 1.0, chi, np.ones(81))  # noqa: E731
    assert [thermal_weight(fit(c), s) for c in (0.0, 2.0, 3.0, 4.0, 9.0)] == [1.0, 1.0, 0.5, 0.0, 0.0]
    assert thermal_weight(None, s) == 0.0
    capped = TailSettings(2.0, 4.0, 4000.0)
    assert thermal_weight(PlanckFit(3900.0, 1.0, 0.0, np.ones(81)), capped) == 1.0
    assert thermal_weight(PlanckFit(6500.0, 1.0, 0.0, np.ones(81)), capped) == 0.0


def test_the_tails_join_the_estimate_without_a_step(capture, model):
    """The blend ramps: no jump between neighbouring samples larger than the truth's own slope allows."""
    truth = planck_spd(2856.0)
    est, rows = _solve(capture, model, truth)
    out = with_tails(est, rows, tail_settings(model))[0]
    assert np.max(np.abs(np.diff(out))) < 2 * np.max(np.abs(np.diff(truth))) + 0.01


def test_the_join_hands_each_blind_band_to_the_planck_curve_at_the_estimates_level():
    """Where the camera sees the SPD is kept; into each blind band it becomes the Planck curve's
    shape, scaled to the SPD's level in that side's anchor band (a Planck SPD joins itself)."""
    p = planck_spd(2856.0)
    assert np.allclose(joined_tails(p, 3.0 * p)[0], p)
    flat = np.full(81, 0.5)
    out, tails = joined_tails(flat, p)
    b = blind_weight()
    assert np.array_equal(out[b == 0], flat[b == 0])
    red = LAM >= 700
    assert np.allclose(out[red] / out[red][0], p[red] / p[red][0])  # Planck's rise beyond 700 nm
    assert np.all(tails[b == 0][(LAM[b == 0] > 450) & (LAM[b == 0] < 620)] == 0)
    assert np.array_equal(joined_tails(flat, p, 0.0)[0], flat)


def test_the_planck_ceiling_of_a_planck_lamp_is_exact():
    """The bench's ceiling of Planck tails (training.evaluation.tails): a Planck lamp's own
    curve joins it without error and its ratio to the fit is 1 at every wavelength; a lamp
    whose red falls below its Planck curve reads that shortfall as a ratio under 1."""
    from training.evaluation.lamps import Lamp
    from training.evaluation.tails import CEILING_RATIO_NM, planck_ceiling
    a = planck_spd(2856.0)
    drooping = a * np.where(LAM > 660, 1.0 - 0.002 * (LAM - 660), 1.0)
    out = planck_ceiling([Lamp("A", "incandescent", "test", a), Lamp("droop", "halogen", "test", drooping)])
    assert out["incandescent"]["mae_380_780"] < 2e-3
    assert all(abs(v - 1) < 0.01 for v in out["incandescent"]["ratio_median"].values())
    assert out["halogen"]["ratio_median"][str(CEILING_RATIO_NM[-1])] == pytest.approx(1 - 0.002 * 120, abs=0.02)
    assert out["halogen"]["mae_380_780"] > 0.05


def test_spd_std_is_wider_beyond_the_camera(capture, model):
    """Beyond the camera (≤ 400, ≥ 700 nm) the uncertainty is at least the blind floor; where it
    sees, it is what the solve said; NaN (no uncertainty given) stays NaN."""
    for spd in (planck_spd(2856.0), _warm_led()):
        est, rows = _solve(capture, model, spd)
        std = np.full(81, 0.02)
        out, wide = tailed(est / est.max(), std, rows, tail_settings(model))
        b = blind_weight()
        assert np.all(wide[b >= 0.999] >= BLIND_STD - 1e-12)
        assert np.all(wide[b == 0] == 0.02)
        assert wide[(LAM >= 700)].mean() > 3 * wide[(LAM >= 450) & (LAM <= 650)].mean()
    assert np.all(np.isnan(widen_std(np.full(81, np.nan), np.ones(81), None, 0.0)))


def test_an_uncertain_kind_widens_the_tails_by_their_disagreement():
    planck_tail = np.linspace(0.0, 1.0, 81)
    spd = np.full(81, 0.5)
    half = widen_std(np.zeros(81), spd, planck_tail, 0.5)
    none = widen_std(np.zeros(81), spd, planck_tail, 0.0)
    assert half[-1] == pytest.approx(0.5) and none[-1] == pytest.approx(BLIND_STD)


def test_default_settings_match_the_shipped_model(model):
    s = tail_settings(model)
    assert s == DEFAULT_SETTINGS


# --- no network islands ---------------------------------------------------------------------------


def test_network_islands_inside_the_visible_are_removed():
    from training.learning.tune_fusion import without_islands

    # bands: 380–400, 400–450, 450–500, 500–550, 550–600, 600–650, 650–700, 700–780
    assert without_islands([True, False, False, False, True, False, False, False]) == [True] + [False] * 7
    assert without_islands([False, False, True, False, False, False, False, True]) == [False] * 7 + [True]
    wide = [False, False, False, True, True, False, False, False]  # 500–600 nm: 100 nm, kept
    assert without_islands(wide) == wide
    edge = [True, True, False, False, False, False, True, True]  # touching a blind end: kept
    assert without_islands(edge) == edge


def test_the_shipped_band_weights_have_no_island(model):
    for key in ("band_weight", "calibrated_band_weight"):
        w = np.asarray(model.metadata["fusion"][key])
        inside = (LAM >= 410) & (LAM <= 690)
        assert np.all(w[inside] == 0.0), key  # today's rule leaves the network at the violet end only
        assert w[0] == 1.0


def test_colour_guard_compares_with_physics_and_prior():
    from training.learning.tune_fusion import colour_guarded

    assert colour_guarded(0.0010, 0.0010) and colour_guarded(0.0009, 0.0010)
    assert not colour_guarded(0.0011, 0.0010)


@pytest.mark.slow  # 12 photos through the pose fit and the network (~10 s)
def test_the_blend_never_makes_the_colour_worse_than_either_part(tmp_path, model):
    """Issue 21's rule on synthetic photos of the prior's physical families (a seed no choice
    used), read through the product's stages: mean Δu'v' of the shipped blend ≤ that of physics
    + prior alone and of the network everywhere."""
    from dataclasses import replace

    from cd_spectra_addon.core.inverse.load import load_for_estimate
    from cd_spectra_addon.core.inverse.stages import read_photo, spectrum
    from training.evaluation.evaluate import Condition, Photos
    from training.learning.dataset import CubeSpec
    from training.learning.spd_prior import sample_spds
    from training.learning.tune_fusion import TUNING_FAMILIES

    network = replace(model, metadata={**model.metadata, "fusion": {
        k: v for k, v in model.metadata["fusion"].items() if "band_weight" not in k}})
    spec = CubeSpec("eval-nominal", size=128)
    preset = load_preset(spec.preset)
    spds, _ = sample_spds(12, np.random.default_rng(2024), families=TUNING_FAMILIES)
    photos = Photos(str(tmp_path), "numpy")
    duv = {"blend": [], "prior": [], "network": []}
    for i, spd in enumerate(spds):
        reading = read_photo(load_for_estimate(photos.write(Condition("nominal", spec), spd, seed=i), preset),
                             preset, CAMERA)
        for key, mdl, method in (("blend", model, "model"), ("prior", model, "prior"), ("network", network, "model")):
            duv[key].append(compare_spds(spectrum(reading, method, mdl).spd, spd)["delta_uv_prime"])
    mean = {k: float(np.mean(v)) for k, v in duv.items()}
    assert mean["blend"] <= min(mean["prior"], mean["network"]) + 1e-5, mean


@pytest.mark.parametrize("bad", [{"thermal_chi2": 3.0}, {"thermal_chi2": 5.0, "other_chi2": 2.0},
                                 {"thermal_chi2": -1.0, "other_chi2": 2.0}, {"thermal_chi2": "x", "other_chi2": 2.0},
                                 [3.0, 6.0], {"thermal_chi2": 1.0, "other_chi2": 2.0, "max_temperature_k": -5.0}])
def test_tail_settings_that_make_no_sense_are_refused(tmp_path, bad):
    import json
    import shutil

    from cd_spectra_addon.core.errors import ModelError
    from cd_spectra_addon.core.spectrum.model import MODEL_DIR

    onnx = tmp_path / "cd_spectra.onnx"
    shutil.copy(MODEL_DIR / "cd_spectra.onnx", onnx)
    meta = json.loads((MODEL_DIR / "cd_spectra.json").read_text())
    onnx.with_suffix(".json").write_text(json.dumps({**meta, "tails": bad}))
    with pytest.raises(ModelError, match="tails"):
        load_model(onnx)


@pytest.mark.parametrize("kind", ["planck", "led", "phosphor"])
def test_the_batched_temperature_search_is_the_nnls_one(capture, model, kind):
    """Every grid temperature's χ² from the batched solves equals its own NNLS (the search the
    batches replaced), temperatures whose backgrounds sit at their bound of 0 included."""
    from cd_spectra_addon.core.numerics.nnls import nnls_normal
    from cd_spectra_addon.core.spectrum import tails
    from cd_spectra_addon.core.spectra.illuminants import planck

    spd = {"planck": planck_spd(2700.0), "led": _warm_led(), "phosphor": _tri_phosphor()}[kind]
    _, rows = _solve(capture, model, spd)
    n, a, y = rows.n, rows.a, rows.y
    free, spectral = a[:, n:], a[:, :n]
    yy = float(y @ y)

    def chi2(t):
        col = spectral @ planck(LAM, t)
        g = np.block([[np.array([[col @ col]]), (free.T @ col)[None, :]], [(free.T @ col)[:, None], free.T @ free]])
        rhs = np.concatenate([[col @ y], free.T @ y])
        g += 1e-12 * np.trace(g) / g.shape[0] * np.eye(g.shape[0])
        x = nnls_normal(g, rhs)
        return max(yy - 2 * float(x @ rhs) + float(x @ g @ x), 0.0), x, None

    reference = np.array([chi2(float(t))[0] for t in tails.TEMPERATURES_K])
    bound = sum(bool(np.any(chi2(float(t))[1][1:] == 0.0)) for t in tails.TEMPERATURES_K)
    batched = tails._grid_chi2(spectral, free, free.T @ free, free.T @ y, y, yy, chi2)
    np.testing.assert_allclose(batched, reference, rtol=1e-9, atol=1e-12 * yy)
    assert bound > 0 or kind != "planck"  # the clamped patterns were exercised


def _halophosphate():
    """A halophosphate tube as the CIE tabulates one: broad bands, each Hg line in one 5 nm bin."""
    spd = 0.25 + 0.35 * np.exp(-0.5 * ((LAM - 480) / 45) ** 2) + 0.5 * np.exp(-0.5 * ((LAM - 580) / 35) ** 2)
    for centre, height in ((405, 0.5), (435, 1.6), (545, 1.3), (580, 0.3)):
        spd[np.argmin(np.abs(LAM - centre))] += height
    return peak_normalise(spd)


def test_the_line_pass_gives_a_resolved_line_its_peak_back(capture, model):
    """Without the pass the 436 nm line's energy spreads into its neighbours and the peak-normalised
    continuum reads ~25 % high (the CIE fluorescent tables' error in bench/eval.md)."""
    spd = _halophosphate()
    plain, _ = _solve(capture, model, spd)
    sharp, _ = _solve(capture, model, spd, lines=solve.LINE_ALLOWANCE)
    e_plain, e_sharp = (compare_spds(x / x.max(), spd) for x in (plain, sharp))
    assert e_sharp["mae_400_700"] < 0.7 * e_plain["mae_400_700"]
    assert e_sharp["delta_uv_prime"] <= e_plain["delta_uv_prime"] + 2e-4
    k = np.argmin(np.abs(LAM - 435))
    assert abs(sharp[k] - plain[k]) > 0  # the line bin itself moved
    assert sharp[k - 1] < plain[k - 1] and sharp[k + 1] < plain[k + 1]  # its neighbours gave energy back


@pytest.mark.parametrize("spd", [planck_spd(2856.0), known_lamp_spd("D65"), _warm_led()], ids=["A", "D65", "led"])
def test_the_line_pass_leaves_a_smooth_spectrum_as_it_was(capture, model, spd):
    spd = peak_normalise(spd)
    plain, _ = _solve(capture, model, spd)
    sharp, _ = _solve(capture, model, spd, lines=solve.LINE_ALLOWANCE)
    e_plain, e_sharp = (compare_spds(x / x.max(), spd)["mae_400_700"] for x in (plain, sharp))
    assert e_sharp <= e_plain + 0.002
    assert np.all(np.isfinite(sharp)) and np.all(sharp >= 0)
