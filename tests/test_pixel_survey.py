"""The kernel evaluated only near the lobe gives the readout every pixel would.

:func:`lobe_pixels` bounds |u|, |v| and the radius per block of pixels from the block corners
and evaluates the kernel per pixel only where the answer is uncertain. Being exact is the whole
point: a pixel it wrongly skipped would change the readout. These tests compare it with
:func:`pixel_diffraction` over every pixel, for the four buildable set-ups at the resolutions
the estimate reads them (~750–930 px) and at a pose off the preset's, pixel for pixel, and the
readout and the ambient offset of rendered photos bit for bit.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.inverse.stages import read_photo
from cd_spectra_addon.core.photo.image_formats import ExifInfo
from cd_spectra_addon.core.photo.images import LinearImage
from cd_spectra_addon.core.pose.result import PoseFit
from cd_spectra_addon.core.readout import ambient
from cd_spectra_addon.core.readout.ambient import GLINT_UV, INVISIBLE, dark_levels, readout_pixels
from cd_spectra_addon.core.readout.readout import MIN_VISIBILITY, N_FEATURES, extract_readout
from cd_spectra_addon.core.spectra.grid import feature_bins
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.scene.diffraction import PixelDiffraction, pixel_diffraction
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.simulation import photo
from training.simulation.render_numpy import render_cube

SETUPS = ("cd-default", "phone-near-axis", "tripod-oblique", "phone-distant-lamp")
OFF = Pose(camera_offset_mm=(3.0, -2.0), light_offset_mm=(-4.0, 5.0), tilt_deg=(1.5, -1.0),
           camera_rotation_deg=(0.7, -0.5), light_rotation_deg=(1.0, 0.5))


def _zoomed(name: str, side: int) -> Scene:
    """The preset with its lens lengthened until the disc spans ~80 % of the frame: what the
    estimate's window around a small disc reads (:mod:`.inverse.load`)."""
    preset = load_preset(name).with_image_size(side)
    angle = np.linspace(0.0, 2.0 * np.pi, 72, endpoint=False)
    rim = preset.disc.rim_radius_mm * 1e-3 * np.stack([np.cos(angle), np.sin(angle), np.zeros_like(angle)], axis=1)
    scene = Scene(preset)
    rows, cols = scene.project(rim @ scene.disc_rotation.T).T
    zoom = 0.8 * side / max(np.ptp(rows), np.ptp(cols))
    return Scene(replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * zoom)),
                 OFF)


def _same(a: PixelDiffraction, b: PixelDiffraction) -> bool:
    return all(np.array_equal(getattr(a, k), getattr(b, k)) for k in a.__dict__)


def _dark(px: PixelDiffraction) -> np.ndarray:
    return px.on_tracks & (px.visibility < INVISIBLE) & ~(np.hypot(px.u, px.v) < GLINT_UV)


@pytest.mark.parametrize("side", [768, 933])
@pytest.mark.parametrize("framing", ["preset", "zoomed"])
@pytest.mark.parametrize("name", SETUPS)
def test_the_survey_finds_exactly_the_visible_and_the_dark_pixels(name, framing, side):
    scene = Scene(load_preset(name).with_image_size(side)) if framing == "preset" else _zoomed(name, side)
    full = pixel_diffraction(scene)
    lobe = readout_pixels(scene)
    got = lobe.pixels
    assert np.all(np.diff(got.index) > 0)  # ascending, as over every pixel: the readout's sums add in that order
    # Every pixel the readout can read, with the kernel's values bit for bit.
    b = feature_bins(full.lambda1_nm)
    read = full.on_tracks & (full.visibility >= MIN_VISIBILITY) & (b >= 0) & (b < N_FEATURES)
    b = feature_bins(got.lambda1_nm)
    assert _same(got.select(got.on_tracks & (got.visibility >= MIN_VISIBILITY) & (b >= 0) & (b < N_FEATURES)),
                 full.select(read))
    # Evaluated pixels are the kernel's own values wherever they are.
    at = np.searchsorted(full.index, got.index)
    assert np.array_equal(full.index[at], got.index) and _same(got, full.select(at))
    # Dark pixels: the evaluated ones that are, and the ones the survey vouched for.
    assert np.intersect1d(lobe.dark, got.index).size == 0
    assert np.array_equal(np.sort(np.concatenate([got.index[_dark(got)], lobe.dark])), full.index[_dark(full)])
    # The hub, clear of the glint (the offset's fallback).
    r = scene.preset.disc.grating_r_min_mm - 1.0
    hub = lobe.hub(r)
    assert np.unique(hub).size == hub.size
    assert np.array_equal(np.sort(hub), full.index[(full.radius_mm < r) & ~(np.hypot(full.u, full.v) < GLINT_UV)])
    if name != "cd-default" and framing == "zoomed":  # a coaxial lamp lights the whole disc: nothing to skip
        assert got.index.size < 0.4 * full.index.size


@pytest.mark.slow
@pytest.mark.parametrize("offset", [0.0, 0.02], ids=["dark-room", "room-light"])
@pytest.mark.parametrize("name", SETUPS)
def test_a_rendered_photo_reads_the_same_from_the_survey_as_from_every_pixel(name, offset):
    scene = _zoomed(name, 480)
    camera = load_camera(DEFAULT_CAMERA)
    lam = np.linspace(380.0, 780.0, 81)
    img, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=1), 1.0 + 0.5 * np.sin(lam / 40.0),
                                             camera), 0.9, photo.track_mask(scene))
    rgb = np.clip(photo.add_noise(img + offset, 0.01, np.random.default_rng(1)), 0.0, 1.0)
    saturated = rgb.max(axis=2) >= 1.0
    full = pixel_diffraction(scene)
    lobe = readout_pixels(scene)
    ambient = dark_levels(rgb, scene, saturated, full)[0]
    assert np.array_equal(dark_levels(rgb, scene, saturated, lobe)[0], ambient)
    assert np.array_equal(dark_levels(rgb, scene, saturated)[0], ambient)
    assert (np.max(ambient) > 0) == (offset > 0)
    want = extract_readout(rgb - ambient, saturated, scene, full)
    got = extract_readout(rgb - ambient, saturated, scene, lobe.pixels)
    for key in want.__dict__:
        a, b = getattr(want, key), getattr(got, key)
        assert _same(a, b) if isinstance(a, PixelDiffraction) else np.array_equal(a, b), key
    # ...and through prepare, which surveys when it has no pixels.
    image = LinearImage(rgb=rgb.astype(np.float32), saturated=saturated, invalid=np.zeros_like(saturated), scale=1.0,
                        original_size=scene.preset.camera.image_size_px, encoding="linear-float", exif=ExifInfo(),
                        path="")
    fit = PoseFit.of_scene(scene)
    a = read_photo(image, scene.preset, camera, fit=fit, pixels=pixel_diffraction(fit.scene(scene.preset, (480, 480))))
    b = read_photo(image, scene.preset, camera, fit=fit)
    assert np.array_equal(a.ambient, b.ambient)
    assert np.array_equal(a.readout.values, b.readout.values) and np.array_equal(a.matrix, b.matrix)


def test_an_offset_is_called_insignificant_only_where_the_percentile_would_be():
    """The ambient shortcut (a count instead of a selection) never zeroes an offset the
    percentile or the median would have kept — at the threshold, with NaNs and masks."""
    rng = np.random.default_rng(0)
    for trial in range(2000):
        n = int(rng.integers(1, 60))
        flat = rng.random((n, 3)) * (1e-4, 1e-3, 3e-3, 1e-2)[trial % 4]
        if trial % 7 == 0:
            flat[:, 1] = ambient.MIN_OFFSET * (1 - 1e-15)
        if trial % 11 == 0:
            flat[rng.integers(0, n)] = np.nan
        keep = rng.random(n) < 0.8 if trial % 2 else None
        rows = flat if keep is None else flat[keep]
        if rows.shape[0] == 0:
            continue
        for percent, full in ((ambient.ROUGH_PERCENTILE, np.percentile(rows, ambient.ROUGH_PERCENTILE, axis=0)),
                              (50.0, np.median(rows, axis=0))):
            if ambient._insignificant(flat, keep, percent):
                assert not np.any(ambient._significant(full)), (trial, percent)


@pytest.mark.parametrize("name", ["cd-default", "tripod-oblique"])
def test_pixel_diffraction_in_chunks_is_the_one_pass_value_for_value(monkeypatch, name):
    """The kernel runs over cache-sized chunks of pixels (PIXEL_CHUNK): the same arrays, element
    by element, as one pass over all of them, also at sub-pixel sample positions."""
    from cd_spectra_addon.core.scene import diffraction

    scene = Scene(load_preset(name).with_image_size(160, 120))
    index = np.arange(160 * 120, dtype=np.int64)[::3]
    rows, cols = np.divmod(index, 160)
    rows, cols = rows + 0.25, cols - 0.125
    whole = pixel_diffraction(scene, index, rows, cols)
    monkeypatch.setattr(diffraction, "PIXEL_CHUNK", 97)
    chunked = pixel_diffraction(scene, index, rows, cols)
    assert whole.index.size > 0
    for key in PixelDiffraction.__dataclass_fields__:
        assert np.array_equal(getattr(whole, key), getattr(chunked, key)), key


def test_a_negative_median_is_never_skipped():
    """The shortcut to a median below zero (a count) never skips one at or below −MIN_OFFSET."""
    rng = np.random.default_rng(1)
    for trial in range(2000):
        n = int(rng.integers(1, 60))
        flat = (rng.random((n, 3)) - rng.random()) * (1e-3, 3e-3, 1e-2)[trial % 3]
        if trial % 5 == 0:
            flat[:, 2] = -ambient.MIN_OFFSET
        if np.any(np.median(flat, axis=0) <= -ambient.MIN_OFFSET):
            assert ambient._below_zero(flat), trial


def test_a_black_level_subtracted_too_far_is_added_back():
    """A float photo whose dark parts read 2 % below zero (its black level subtracted too far):
    the offset is measured on the disc's dark part, and the readout is the one the photo without
    it gives. Non-negative codes keep the shortcut: no offset at all."""
    scene = _zoomed("cd-default", 256)
    camera = load_camera(DEFAULT_CAMERA)
    img, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=1), np.ones(81), camera), 0.9,
                          photo.track_mask(scene))
    rgb = photo.add_noise(img, 0.005, np.random.default_rng(2))
    none = np.zeros(rgb.shape[:2], bool)
    assert not np.any(dark_levels(rgb, scene, none)[0])
    low = dark_levels(rgb - 0.02, scene, none)[0]
    assert np.allclose(low, -0.02, atol=0.002)
    want = extract_readout(rgb, none, scene)
    got = extract_readout(rgb - 0.02 - low, none, scene)
    top = np.max(want.values)
    assert np.max(np.abs(got.values - want.values)) < 0.01 * top
    assert not np.any(dark_levels(np.clip(rgb - 0.02, 0.0, None), scene, none)[0] < 0)  # clipped codes: nothing to add
