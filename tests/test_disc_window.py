"""The estimate reads a small disc in a big frame through a window around it, at higher resolution.

Photos here are a phone's whole frame made from a render of its centre: rendering the centre
window with a proportionally longer lens from the same place is the same perspective, so
embedding it in a dark frame is the photo a phone writes (simulator)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import Scene, load_preset
from cd_spectra_addon.core.inverse.load import (DISC_MIN_PX, DISC_READ_PX, DISC_TARGET_PX, PREVIEW_SIDE,
                                               disc_half_extent, load_for_estimate, reduction)
from cd_spectra_addon.core.inverse.estimate import estimate_photo
from cd_spectra_addon.core.photo.images import load_photo
from training.simulation import photo
from training.simulation.render_numpy import render_cube

FRAME = (3200, 2400)  # a 7.7 MP phone photo
WINDOW = 320  # rendered centre, upsampled ×UP into the frame
UP = 4


def _phone_photo(tmp_path, preset_name="phone-near-axis", shift_px=(0, 0)):
    base = load_preset(preset_name)
    width, height = FRAME
    f_full = base.camera.focal_length_mm / base.camera.sensor_width_mm * width  # focal length in frame pixels
    f_window = f_full / UP  # the window's pixels are UP frame pixels wide
    camera = replace(base.camera, focal_length_mm=f_window * base.camera.sensor_width_mm / WINDOW)
    scene = Scene(replace(base, camera=camera).with_image_size(WINDOW))
    cube = render_cube(scene, supersample=2)
    sens = load_camera(DEFAULT_CAMERA)
    spd = np.ones(81)
    img, _ = photo.expose(photo.linear_photo(cube, spd, sens), 1.0, photo.track_mask(scene))
    img = photo.upsample(img, UP)
    frame = np.zeros((height, width, 3))
    side = WINDOW * UP
    y0, x0 = (height - side) // 2 + shift_px[1], (width - side) // 2 + shift_px[0]
    frame[y0: y0 + side, x0: x0 + side] = img
    frame = np.minimum(photo.add_noise(frame, 0.005, np.random.default_rng(0)), 1.0)
    exif = photo.exif_for(base.camera.focal_length_mm, base.camera.sensor_width_mm, width, sens.name)
    path = tmp_path / "phone.jpg"
    photo.write_photo(path, frame, "jpg", exif)
    centre = (x0 + side / 2.0 - 0.5, y0 + side / 2.0 - 0.5)  # the disc centre in frame pixels
    return path, base, centre


@pytest.mark.slow
def test_a_phone_photo_is_read_through_a_window_with_the_whole_rainbow_in_it(tmp_path):
    path, preset, centre = _phone_photo(tmp_path)
    preview = load_photo(path, max_side=PREVIEW_SIDE)
    image = load_for_estimate(path, preset)
    _, _, diameter = disc_half_extent(preview, preset)
    assert diameter < DISC_MIN_PX and image.scale < preview.scale  # a small disc is read closer...
    assert 0.6 * DISC_TARGET_PX < diameter * preview.scale / image.scale < 1.5 * DISC_TARGET_PX  # ...about this close
    # Every bright pixel of the preview lies inside the window.
    lum = preview.rgb.sum(axis=2)
    rows, cols = np.nonzero(lum > 0.05 * lum.max())
    x, y = (cols + 0.5) * preview.scale, (rows + 0.5) * preview.scale
    x0, y0 = image.origin_px
    assert x.min() >= x0 and y.min() >= y0
    assert x.max() <= x0 + image.rgb.shape[1] * image.scale and y.max() <= y0 + image.rgb.shape[0] * image.scale
    # The same light: the window's total radiance equals the preview's over the same area.
    rr, cc = np.indices(lum.shape)
    xc, yc = (cc + 0.5) * preview.scale, (rr + 0.5) * preview.scale
    inside = (xc > x0) & (yc > y0) & (xc < x0 + image.rgb.shape[1] * image.scale) & \
        (yc < y0 + image.rgb.shape[0] * image.scale)
    assert image.rgb.sum() * image.scale ** 2 == pytest.approx(preview.rgb[inside].sum() * preview.scale ** 2,
                                                               rel=0.02)
    # And the estimate reports the disc where it is in the frame.
    result = estimate_photo(path, preset=preset)
    assert result.extra["image_size_px"] == [image.rgb.shape[1], image.rgb.shape[0]]
    assert np.hypot(result.disc.center_px[0] - centre[0], result.disc.center_px[1] - centre[1]) < 3.0


def test_a_disc_that_fills_the_frame_is_read_whole(tmp_path):
    preset = load_preset("cd-default").with_image_size(600, 400)
    scene = Scene(preset)
    img, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=1), np.ones(81),
                                             load_camera(DEFAULT_CAMERA)), 1.0)
    path = tmp_path / "full.png"
    photo.write_photo(path, photo.upsample(img, 2), "png")
    image = load_for_estimate(path, preset)
    assert image.scale == load_photo(path, max_side=PREVIEW_SIDE).scale and image.origin_px == (0.0, 0.0)


@pytest.mark.slow
def test_the_window_reaches_a_disc_placed_off_the_frame_centre(tmp_path):
    path, preset, centre = _phone_photo(tmp_path, shift_px=(700, -300))
    preview = load_photo(path, max_side=PREVIEW_SIDE)
    hx, hy, _ = disc_half_extent(preview, preset)
    # The rainbow's far end is ~1.3 disc radii + 700 px from the centre: the bright pixels, not
    # the preset's rim, set the window.
    radius_px = preset.disc.rim_radius_mm / preset.camera.distance_mm * \
        preset.camera.focal_length_mm / preset.camera.sensor_width_mm * FRAME[0] / preview.scale
    assert hx * preview.scale > 700 + 0.5 * radius_px * preview.scale
    image = load_for_estimate(path, preset)
    lum = image.rgb.sum(axis=2)
    assert lum.max() > 0.5 * preview.rgb.sum(axis=2).max()


@pytest.mark.parametrize("fmt", ["png", "jpg"])
def test_a_large_disc_is_read_reduced_to_whole_preview_pixels(tmp_path, fmt):
    """A disc at least 2 × DISC_READ_PX wide in the preview is read at the integer reduction that
    leaves it at least DISC_READ_PX wide: here a 384 × 256 render upsampled 4× to 1536 × 1024 is
    read back at its rendered size, box-averaged in linear light from the preview's decode."""
    preset = load_preset("cd-default").with_image_size(384, 256)
    scene = Scene(preset)
    img, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=1), np.ones(81),
                                             load_camera(DEFAULT_CAMERA)), 1.0)
    path = tmp_path / f"big.{fmt}"
    cam = preset.camera
    photo.write_photo(path, photo.upsample(img, 4), fmt, photo.exif_for(cam.focal_length_mm, cam.sensor_width_mm,
                                                                         1536, DEFAULT_CAMERA))
    preview = load_photo(path, max_side=PREVIEW_SIDE)
    _, _, diameter = disc_half_extent(preview, preset)
    assert diameter >= 2 * DISC_READ_PX and reduction(diameter) == 2
    image = load_for_estimate(path, preset)
    assert image.scale == 2 * preview.scale == 4.0 and image.rgb.shape[:2] == (256, 384)
    assert diameter / 2 >= DISC_READ_PX
    # whole preview pixels, averaged in linear light: the same light per area as the preview
    assert image.rgb.sum() * 4 == pytest.approx(preview.rgb.sum(), rel=1e-3 if fmt == "png" else 2e-2)


def test_reduction_keeps_the_disc_at_least_the_read_size():
    assert reduction(DISC_READ_PX * 2 - 1) == 1 and reduction(DISC_READ_PX * 2) == 2
    for diameter in (700.0, 1000.0, 1300.0, 2500.0):
        k = reduction(diameter)
        assert k & (k - 1) == 0  # a power of two, as the JPEG drafts are
        assert diameter / k >= DISC_READ_PX > diameter / (2 * k)
