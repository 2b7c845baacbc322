"""The one-shot calibration of an in-camera file (issue 20): how well its processing fit explains
its own photo, the shot posed again on undone values where its first pose was wrong, and the
camera_files bench's calibration-draw summary.

Posed on the file's tone-curved values, a CIE A JPEG sometimes took a wrong capture (the photo's
lines seemed to pin one, or the lamp came out too large); the processing fitted on it was then
wrong and so was every estimate calibrated by it. These tests construct that case with a pose
given by hand.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cd_spectra_addon.core.calibration.calibration import Calibration, calibration_check, calibration_warning
from cd_spectra_addon.core.calibration.camera_pipeline import fit_pipeline_checked
from cd_spectra_addon.core.inverse import calibration_shot
from cd_spectra_addon.core.inverse.calibration_shot import Shot, fit_calibration
from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.inverse.stages import read_photo
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode
from cd_spectra_addon.core.pose.result import PoseFit
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.spectra.grid import N_FEATURES, WAVELENGTHS_NM
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from training.evaluation import camera_files
from training.simulation import photo
from training.simulation.camera_pipelines import (TYPICAL, in_camera_exif, pipeline_for, render_in_camera,
                                                  sample_pipeline)
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)


def _spectral_pixels(rng: np.random.Generator, n: int = 5000) -> np.ndarray:
    """Camera-native RGB of rainbow-like pixels: a band colour of many intensities plus some white."""
    band = CAMERA.sensitivities[(WAVELENGTHS_NM >= 400) & (WAVELENGTHS_NM <= 700)]
    white = CAMERA.sensitivities.sum(axis=0) / CAMERA.sensitivities.sum()
    a = rng.uniform(0.02, 0.25, n)[:, None]
    return band[rng.integers(0, band.shape[0], n)] * a + white * a * rng.uniform(0, 1, n)[:, None]


def _codes(linear: np.ndarray) -> np.ndarray:
    return srgb_decode(np.round(srgb_encode(np.clip(linear, 0, 1)) * 255) / 255)


def test_the_fit_reports_how_well_it_explains_its_pixels():
    """A processing of the fitted family, 8-bit codes: it leaves about the rounding (under 1.5
    codes RMS, half a code's RMS is 0.29). The same pixels with each channel's brightness varying
    from pixel to pixel (local tone mapping no 3×3 matrix and curve can represent): many codes."""
    rng = np.random.default_rng(11)
    pipe = sample_pipeline(CAMERA, rng)
    native = _spectral_pixels(rng)
    good = fit_pipeline_checked(_codes(pipe.to_file(native)), native * 3.0)
    assert good.pixels == native.shape[0] and 0.0 < good.rms_codes < 1.5
    local = pipe.to_file(native) * rng.uniform(0.6, 1.4, native.shape)
    bad = fit_pipeline_checked(_codes(local), native * 3.0)
    assert bad.rms_codes > 5 * good.rms_codes
    assert np.isfinite(bad.rms_codes) and np.all(np.isfinite(bad.pipeline.matrix))


def test_calibration_check_reports_the_numbers_and_judges_only_the_share():
    gains = np.ones((N_FEATURES, 3))
    fine = Calibration("fine", gains, "cd-default", DEFAULT_CAMERA, {"unexplained": 0.004, "processing_rms_codes": 9.0})
    check = calibration_check(fine)
    assert check == {"name": "fine", "unexplained": 0.004, "processing_rms_codes": 9.0, "explains_its_photo": True}
    assert calibration_warning(fine) is None  # the RMS grows with noise: it is reported, not judged
    poor = replace(fine, metadata={"unexplained": 0.2, "processing_rms_codes": 9.0})
    assert calibration_check(poor)["explains_its_photo"] is False
    message = calibration_warning(poor)
    assert message is not None and "9.0 of 255 codes RMS" in message and "shoot RAW" in message
    # old profiles (no numbers, or broken ones) give no verdict and no NaN
    assert calibration_check(replace(fine, metadata={"unexplained": float("nan")})) == {"name": "fine"}


@pytest.fixture(scope="module")
def jpeg_shot(tmp_path_factory):
    """A CIE A in-camera JPEG (Canon, typical rendering) of a 160-px capture, loaded; its scene."""
    scene = Scene(load_preset("cd-default").with_image_size(160))
    cube, meter = render_cube(scene, supersample=3), photo.track_mask(scene)
    image, _ = photo.expose(photo.linear_photo(cube, known_lamp_spd("incandescent"), CAMERA), 1.0, meter)
    image = np.minimum(photo.add_noise(image, 0.01, np.random.default_rng(4)), 1.0)
    c = scene.preset.camera
    tags = in_camera_exif(photo.exif_for(c.focal_length_mm, c.sensor_width_mm, c.image_size_px[0], DEFAULT_CAMERA))
    path = Path(tmp_path_factory.mktemp("shot")) / "cal.jpg"
    photo.write_photo(path, render_in_camera(image, pipeline_for(CAMERA, TYPICAL), meter), "jpg", tags)
    return load_photo(path), scene


@pytest.mark.slow  # three pose fits and four processing fits of a 160-px photo (~10 s)
def test_a_wrong_first_pose_is_replaced_by_the_pose_on_undone_values(jpeg_shot):
    """The constructed bad draw: the shot's first pose puts the lamp 5 mm nearer the disc than it
    was (what draw 99 of bench/camera_files.md's calibration shot did: 205 for 210 mm). Fitted on
    that pose alone (one start) the processing explains the shot worse than the true capture's;
    posed again on undone values (the other starts), the kept pose's processing explains it about
    as well as the true capture's, and a lower cost than the one start's is what was kept."""
    image, scene = jpeg_shot
    ref = known_lamp_spd("incandescent")
    preset = scene.preset
    x, y, z = preset.light.position_mm
    wrong_preset = replace(preset, light=replace(preset.light, position_mm=(x, y, z - 5.0)))
    wrong = PoseFit.of_scene(Scene(wrong_preset, scene.pose))
    truth = calibration_shot._fit_processing([Shot(image, ref)], [read_photo(image, preset, CAMERA,
                                                                                fit=PoseFit.of_scene(scene))],
                                             CAMERA, [ref], None)
    first = read_photo(image, preset, CAMERA, fit=wrong)
    single = calibration_shot._fit_processing([Shot(image, ref)], [first], CAMERA, [ref], None)
    assert single.rms_codes > 1.15 * truth.rms_codes  # the wrong pose does show in the fit's own residual
    chosen, posed = calibration_shot._posed_on_processing([Shot(image, ref)], [first], preset, CAMERA, False, [ref])
    assert chosen.rms_codes < single.rms_codes
    assert chosen.rms_codes < 1.1 * truth.rms_codes
    assert posed[0].fit is not wrong


@pytest.mark.slow  # a calibration fit and an estimate (~8 s)
def test_calibration_stores_its_self_check_and_the_estimate_reports_it(jpeg_shot):
    image, scene = jpeg_shot
    cal, _ = fit_calibration(image, known_lamp_spd("incandescent"), scene.preset, CAMERA, pipeline=True)
    assert cal.pipeline is not None
    assert 0.5 < cal.metadata["processing_rms_codes"] < 6.0 and 0.0 <= cal.metadata["unexplained"] < 0.05
    est = estimate_image(image, preset=scene.preset, camera=DEFAULT_CAMERA, calibration=cal, model=None,
                         method="physics")
    check = est.to_json()["calibration_check"]
    assert check["explains_its_photo"] is True and check["processing_rms_codes"] == cal.metadata["processing_rms_codes"]
    assert np.all(np.isfinite(est.spd)) and np.isfinite(est.confidence)
    assert not any("cannot explain" in w for w in est.warnings)


def test_the_bench_reports_the_median_and_the_worst_calibration_draw():
    """camera_files: a drawn row's cell names its worst draw; a row measured once says '–'; only
    the one-shot in-camera rows are drawn."""
    drawn = [row for _, row in camera_files.ROWS if camera_files.drawn(row)]
    assert drawn and all(r.calibration == "pipeline" and r.rendering == "typical" for r in drawn)
    assert not any(camera_files.drawn(row) for _, row in camera_files.ROWS if row.calibration != "pipeline")
    base = {"mae_400_700": 0.02, "mae_400_700_median": 0.015, "delta_uv_prime": 0.001, "confidence": 0.9,
            "processed_share": 1.0, "refused": 0}
    draws = [dict(base, mae_400_700=m) for m in (0.01, 0.02, 0.12)]
    summary = dict(base, worst=dict(draws[2]), draws=draws)
    row = next(r for _, r in camera_files.ROWS if camera_files.drawn(r))
    text = camera_files.report([("files", row, summary)], 30, 192, 1.0, {}, False, 3)
    line = next(ln for ln in text.splitlines() if ln.startswith(f"| {row.label} |"))
    assert line.endswith("| 0.1200 / 0.0010 / 0.90 (of 3) |") and "3 draws" in text
    once = camera_files.report([("files", row, base)], 30, 192, 1.0, {}, False, 1)
    assert next(ln for ln in once.splitlines() if ln.startswith(f"| {row.label} |")).endswith("| – |")


@pytest.mark.parametrize("rms,kept", [((5.0, 4.8), 0), ((5.0, 3.0, 2.9), 1), ((6.0, 3.0, 2.0), 2)])
def test_a_re_posed_round_is_kept_only_where_it_fits_clearly_better(monkeypatch, rms, kept):
    """One shot: round k's pose replaces the one before only where its processing leaves at most
    POSE_GAIN of that one's RMS (4.8 of 5.0 is noise, not a wrong pose); the rounds stop at the
    first that is not clearly better. The pose fit and the processing fit are scripted here."""
    from types import SimpleNamespace

    from cd_spectra_addon.core.calibration.camera_pipeline import PipelineFit

    assert 4.8 / 5.0 > calibration_shot.POSE_GAIN >= 3.0 / 5.0
    fits = iter(rms)
    pipe = pipeline_for(CAMERA, TYPICAL)
    monkeypatch.setattr(calibration_shot, "_fit_processing",
                        lambda shots, readings, *a, **k: PipelineFit(pipe, next(fits), 1000))
    poses = iter(range(1, 10))
    monkeypatch.setattr(calibration_shot, "_read", lambda *a, **k: SimpleNamespace(round=next(poses)))
    first = SimpleNamespace(round=0, response=np.zeros((N_FEATURES, 3, 1)))
    chosen, posed = calibration_shot._posed_on_processing([Shot(None, None)], [first], load_preset("cd-default"),
                                                          CAMERA, False, [None])
    assert posed[0].round == kept and chosen.rms_codes == rms[kept]
