"""The colours a pose fit expects are the lamp's light under the lobe's blur (issue 21).

A pixel at λ₁ gathers the lamp's light over the lobe's blur (≈ 5 nm at the presets' lamp size).
Under a flat spectrum its colour is the camera's at λ₁; under a narrow band (a blue LED 25 nm
wide, a white LED's pump) a pixel on the band's flank gets most of its light from the bright
side, so its colour is that of a wavelength nearer the peak. A fit that expects flat-spectrum
colours slides the capture to match: the fine stage expects the lamp's own colours, its spectrum
as the coarse fit's profile shows it (core.pose.fit._lamp_coloured). The readout's colour check
judges the fitted axis the same way, with the estimated lamp's colours.
"""

from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.pose import fit as pose_fit
from cd_spectra_addon.core.pose.self_consistency import ProfileGrid, profile_spd
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.spectra.cameras import (DEFAULT_CAMERA, LAMP_SPD_FLOOR, camera_colours, load_camera,
                                                  unit_colours)
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from cd_spectra_addon.core.spectra.illuminants import planck_spd
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)
LAM = WAVELENGTHS_NM
BLUE_LED = np.exp(-0.5 * ((LAM - 460.0) / 10.0) ** 2)  # a blue LED's band (25 nm wide)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1.0, 1.0))))


def test_a_flat_lamp_keeps_the_cameras_own_colours():
    nodes = np.arange(400.0, 700.0, 3.0)
    assert np.allclose(camera_colours(nodes, CAMERA.sensitivities, 5.0, np.ones(LAM.size)),
                       camera_colours(nodes, CAMERA.sensitivities, 5.0))


@pytest.mark.parametrize("flank", [440.0, 480.0])
def test_a_narrow_band_lights_its_flanks_in_its_peaks_colour(flank):
    """On either flank of a 460 nm band a pixel's colour lies nearer the peak's than the camera's
    own colour at the flank does (by little below the peak, where the camera's colour barely
    turns; by degrees above it, where green comes in)."""
    sens = CAMERA.sensitivities
    peak = camera_colours(np.array([460.0]), sens, 5.0)[0]
    flat = camera_colours(np.array([flank]), sens, 5.0)[0]
    lit = camera_colours(np.array([flank]), sens, 5.0, BLUE_LED)[0]
    assert _angle(lit, peak) < _angle(flat, peak) - (1.0 if flank > 460 else 0.1)


def test_the_profile_shows_the_lamps_spectrum():
    """A profile whose nodes carry the band's light (what a fit at the true capture finds) gives
    the band back: its peak within a node, dark (the floor) 60 nm away."""
    grid = ProfileGrid(300.0, 2500.0, 3.0)
    profile = np.zeros((grid.size, 3))
    first = (grid.nodes_nm >= 400) & (grid.nodes_nm <= 750)
    profile[first] = 2.5 * camera_colours(grid.nodes_nm[first], CAMERA.sensitivities, 5.0, BLUE_LED)
    spd = profile_spd(profile, grid, CAMERA.sensitivities, 5.0)
    assert abs(LAM[np.argmax(spd)] - 460.0) <= 3.0
    assert spd.max() == pytest.approx(1.0 + LAMP_SPD_FLOOR, abs=0.01)
    assert np.all(spd[LAM >= 520] < 2 * LAMP_SPD_FLOOR)
    assert profile_spd(np.zeros_like(profile), grid, CAMERA.sensitivities, 5.0) is None


def test_a_speck_where_the_camera_barely_sees_is_not_the_lamps_peak():
    """A bulb's profile (2700 K, rising to 780 nm) with a speck of noise at 740 nm, where the
    camera's response is 0.02 % of its peak: a node's level is its colour over the response
    squared, so the speck was the lamp's "peak" and the bulb's own light fell to 0.41 of it at
    680 nm, its blue to 0.03. The lamp is read where the camera sees it: its slope as the bulb's,
    brightest at the red end of that range."""
    grid = ProfileGrid(300.0, 2500.0, 3.0)
    nodes = grid.nodes_nm
    first = (nodes >= 400) & (nodes <= 750)
    bulb = planck_spd(2700.0)
    profile = np.zeros((grid.size, 3))
    profile[first] = camera_colours(nodes[first], CAMERA.sensitivities, 5.0, bulb)
    profile[np.argmin(np.abs(nodes - 740.0))] += 1e-3 * np.abs(profile).max()
    spd = profile_spd(profile, grid, CAMERA.sensitivities, 5.0)
    at = lambda nm: float(np.interp(nm, LAM, spd))  # noqa: E731
    truth = lambda nm: float(np.interp(nm, LAM, bulb))  # noqa: E731
    assert LAM[np.argmax(spd)] >= 660.0 and at(680.0) > 0.9  # the red end the camera sees is the peak
    assert at(600.0) / at(480.0) == pytest.approx(truth(600.0) / truth(480.0), rel=0.15)
    assert spd.min() > 5 * LAMP_SPD_FLOOR  # nowhere floored: a bulb lights every colour


def test_the_lamps_colours_are_unit_rows_where_it_shows_light():
    grid = ProfileGrid.with_camera(300.0, 2500.0, 3.0, CAMERA.sensitivities, 5.0, 1.0, spd=BLUE_LED + LAMP_SPD_FLOOR)
    c = grid.colour[~np.isnan(grid.colour[:, 0])]
    assert np.allclose(np.linalg.norm(c, axis=1), 1.0)
    assert np.all(np.isnan(unit_colours(np.zeros((2, 3)))))


@pytest.mark.slow
def test_a_blue_leds_capture_is_fitted_where_its_colours_say(monkeypatch):
    """tripod-oblique's nominal photo of a 460 nm LED (no pose error; the disc 800 px across): the
    flat-spectrum colours slide the fit's wavelengths 3 nm off; the lamp's own colours in the
    fine stage take back at least 40 % of that (3.3 → 1.2 nm when written)."""
    preset = load_preset("tripod-oblique").with_image_size(1024)
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * 3.15))
    scene = Scene(preset)
    cube = render_cube(scene, supersample=2)
    image, _ = photo.expose(photo.linear_photo(cube, BLUE_LED, CAMERA), 1.0, photo.track_mask(scene))
    image = np.clip(photo.add_noise(image, 0.01, np.random.default_rng(5)), 0.0, 1.0)
    truth = pixel_diffraction(scene)
    sel = truth.on_tracks & (truth.visibility > 0.3) & (truth.lambda1_nm > 430) & (truth.lambda1_nm < 500)

    def wavelength_error() -> float:
        fitted = pose_fit.fit_pose(image, preset, preset.camera.focal_px, sensitivities=CAMERA.sensitivities)
        got = pixel_diffraction(fitted.known_scene, truth.index[sel])
        keep = np.isin(truth.index[sel], got.index)
        return float(np.mean(np.abs(got.lambda1_nm - truth.lambda1_nm[sel][keep])))

    lamp_coloured = wavelength_error()
    monkeypatch.setattr(pose_fit, "LAMP_COLOURS", False)
    flat = wavelength_error()
    assert flat > 2.0  # what the lamp's colours are for: without them this photo reads 3.3 nm off
    assert lamp_coloured < 0.6 * flat


@pytest.mark.slow
@pytest.mark.parametrize("centre", [460.0, 530.0])
def test_the_colour_check_expects_the_lamps_own_colours(centre, tmp_path):
    """tripod-oblique's nominal photo of a 25 nm wide LED read at the true capture: the
    readout's colour check (core.readout.colour_check) judged with a flat spectrum's colours puts
    the axis 3–4 nm off (a false alarm: 4.2 and −3.4 nm when written); with the estimated lamp's
    own colours it agrees within 1.5 nm (0.7 and −0.3) and the estimate carries no warning."""
    from cd_spectra_addon.core.inverse.estimate import estimate_image
    from cd_spectra_addon.core.inverse.stages import read_photo
    from cd_spectra_addon.core.photo.images import load_photo
    from cd_spectra_addon.core.pose.result import PoseFit, colour_blur_nm
    from cd_spectra_addon.core.readout.colour_check import wavelength_shift_nm

    preset = load_preset("tripod-oblique").with_image_size(1024)
    scene = Scene(preset)
    led = np.exp(-0.5 * ((LAM - centre) / 10.0) ** 2)
    image, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=2), led, CAMERA), 1.0,
                            photo.track_mask(scene))
    image = np.clip(photo.add_noise(image, 0.01, np.random.default_rng(5)), 0.0, 1.0)
    path = tmp_path / "led.png"
    photo.write_photo(path, image, "png")
    loaded, fit = load_photo(path), PoseFit.of_scene(scene)
    estimate = estimate_image(loaded, preset=preset, camera=DEFAULT_CAMERA, model=None, method="physics", fit=fit)
    readout = read_photo(loaded, preset, CAMERA, fit=fit).readout
    flat = wavelength_shift_nm(readout, CAMERA.sensitivities, colour_blur_nm(preset, preset.light.lobe_sigma,
                                                                             preset.camera.focal_px), None)
    assert abs(flat) > 2.5
    assert abs(estimate.extra["checks"]["colour_shift_nm"]) < 1.5
    assert not any("colours put its wavelengths" in w for w in estimate.warnings)
