"""The forward model at its extremes: finite, non-negative, and the OSL shader = its numpy twin.

Grazing light and view, the grid's end bands (380 and 780 nm, half-width hats), lamps with
zero-power bands or no power at all, pitches from 0.3 µm (orders only at grazing angles) to
20 µm (orders only close to the axis, so seen from far away), lamp sizes from 5e-4 to 0.1 rad,
camera distances from 60 mm to 1.5 m. The numpy twin (``core.grating`` / ``training.simulation.render_numpy``)
is checked everywhere by hypothesis; Cycles renders a small image of each extreme scene and must
agree with the twin wherever there is signal.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.scene import grating
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import Disc
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM
from training.simulation import photo
from training.simulation.render_numpy import render_cube as numpy_cube
from training.reliability.stress import EDGE_BANDS, EXTREMES, compare_extreme, scene, twin_at_pixel_centres

# --- numpy twin ----------------------------------------------------------------------------

unit = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: 1e-3 < math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2))


@settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(pitch=st.sampled_from([0.3, 0.74, 1.6, 5.0, 20.0]), sigma=st.floats(1e-5, 0.3),
       height=st.floats(0.0, 0.5), profile=st.sampled_from(["sinusoidal", "rectangular"]),
       max_order=st.integers(0, 6), index=st.floats(1.0, 2.5), light=unit, camera=unit,
       light_dist=st.floats(0.02, 5.0), camera_dist=st.floats(0.02, 5.0),
       radius=st.floats(0.0, 0.07), angle=st.floats(0.0, 2 * math.pi))
def test_band_radiance_is_finite_non_negative_and_sparse_equals_dense(
        pitch, sigma, height, profile, max_order, index, light, camera, light_dist, camera_dist, radius, angle) -> None:
    disc = Disc(pitch_um=pitch, groove_height_um=height, profile=profile, max_order=max_order, medium_index=index)
    point = np.array([[radius * math.cos(angle), radius * math.sin(angle), 0.0]])
    to_light = np.array(light) / np.linalg.norm(light) * light_dist
    to_camera = np.array(camera) / np.linalg.norm(camera) * camera_dist
    frame = grating.surface_frame(point, point[0] + to_camera, point[0] + to_light, np.zeros(3),
                                  np.array([0.0, 0.0, 1.0]), index)
    optics = grating.GratingOptics(disc, sigma)
    dense = grating.band_radiance(frame, optics, WAVELENGTHS_NM)
    sparse = grating.band_radiance_sparse(frame, optics, WAVELENGTHS_NM).dense()
    assert dense.shape == (1, N_BANDS)
    assert np.all(np.isfinite(dense)) and dense.min() >= 0.0
    # The sparse path drops lobe tails beyond its reach (5σ) in u or v: exp(−reach²/2) < 4e-6 of a
    # lobe's peak, which is irradiance·G/w²/(2πσ²) times at most 2 (Fresnel + front surface)
    # times a 5 nm hat.
    peak = float(np.max(frame.irradiance * frame.g_over_w2)) / (2 * math.pi * sigma ** 2)
    tail = math.exp(-grating._LOBE_REACH ** 2 / 2.0) * 2.0 * 5.0 * peak
    np.testing.assert_allclose(sparse, dense, rtol=1e-9, atol=tail + 1e-12 * max(float(dense.max()), 1e-300))


@pytest.mark.parametrize("name", list(EXTREMES))
def test_numpy_twin_renders_extremes_finite(name: str) -> None:
    cube = numpy_cube(replace(EXTREMES[name], preset=EXTREMES[name].preset.with_image_size(24)), supersample=2)
    assert np.all(np.isfinite(cube)) and cube.min() >= 0.0
    if name == "lamp-off":
        assert cube.max() == 0.0


def test_zero_power_bands_give_finite_photos_and_no_nan_estimate(tmp_path) -> None:
    """A lamp with power only where the camera is blind (380 and 780 nm), and one with none."""
    from cd_spectra_addon.core.inverse.estimate import estimate_photo

    capture = scene(size=96)
    cube = numpy_cube(capture, supersample=2)
    cam = load_camera(DEFAULT_CAMERA)
    edges = np.zeros(N_BANDS)
    edges[[0, -1]] = 1.0
    for name, spd in [("edges", edges), ("dark", np.zeros(N_BANDS))]:
        image, gain = photo.synthesize(cube, spd, cam, noise=0.01, meter=photo.track_mask(capture))
        assert np.all(np.isfinite(image)) and math.isfinite(gain)
        path = tmp_path / f"{name}.png"
        photo.write_photo(path, image, "png")
        try:
            result = estimate_photo(path, preset=capture.preset.name, model=None)
        except CDSpectraError:
            continue  # black / no rainbow: both are honest answers
        assert np.all(np.isfinite(result.spd)) and result.spd.max() == 1.0


# --- Cycles + OSL against the twin ---------------------------------------------------------


@pytest.mark.blender
@pytest.mark.slow
@pytest.mark.parametrize("name", list(EXTREMES))
def test_cycles_agrees_with_the_twin_at_extremes(name: str) -> None:
    from training.simulation import cycles_scene

    anti_aliased, _ = cycles_scene.render_cube(EXTREMES[name], EDGE_BANDS, 8)  # jittered rays: no NaN anywhere
    assert np.all(np.isfinite(anti_aliased)) and anti_aliased.min() >= 0.0
    result = compare_extreme(name)
    print(name, result)
    assert result["finite"] and result["non_negative"]
    if name == "lamp-off":
        assert result["all_zero"] and anti_aliased.max() == 0.0
        return
    assert result["psnr_db"], "no band with signal"
    assert min(result["psnr_db"].values()) >= 45.0, result
    assert all(abs(r - 1.0) < 0.005 for r in result["sum_ratio"].values()), result


def test_extremes_have_diffracted_light_where_claimed() -> None:
    """The extreme scenes test what their names say: diffraction is present (max_order 3 vs 0)."""
    for name, bands in [("pitch-0.3um-grazing-light", (380.0, 385.0)), ("pitch-20um-from-1.5m", (555.0, 600.0)),
                        ("dvd-0.74um-at-100mm", (555.0, 600.0))]:
        capture = EXTREMES[name]
        flat = replace(capture, preset=replace(capture.preset, disc=replace(capture.preset.disc, max_order=0)))
        lam = np.array(bands)
        with_orders, without = twin_at_pixel_centres(capture, lam), twin_at_pixel_centres(flat, lam)
        assert np.all((with_orders - without).reshape(lam.size, -1).sum(axis=1) > 0.05 * without.sum() / lam.size), name
