"""A small lamp's thin lines: found in the photo whatever surrounds the disc, and the capture moved
until the grating equation's curve (v = 0) passes through them, within a pixel; the orders the
lines show named; a photo whose first order misses 400–700 nm refused with what it holds."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from cd_spectra_addon.core.errors import NoDiscError
from cd_spectra_addon.core.inverse.stages import pose_photo, read_posed
from cd_spectra_addon.core.photo.images import ExifInfo, LinearImage
from cd_spectra_addon.core.pose.lines import line_agreement, line_fit, ridge_pixels, top_hat
from cd_spectra_addon.core.pose.result import PoseFit
from cd_spectra_addon.core.scene.capture import Preset, Scene, load_preset, preset_from_dict
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.scene.relative_pose import N_PARAMS, apply_params, relative_pose
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)
WIDTH, HEIGHT = 300, 250
FOCAL_PX = 353.0  # a 750 × 625 frame's 882 px, scaled


def _position(distance: float, polar_deg: float, azimuth_deg: float) -> list[float]:
    p, a = math.radians(polar_deg), math.radians(azimuth_deg)
    return [distance * math.sin(p) * math.cos(a), distance * math.sin(p) * math.sin(a), distance * math.cos(p)]


def grazing_preset(between_deg: float):
    """A capture like Kim 2023's: camera 230 mm away 38° from the disc's axis, aimed at its
    centre; a small lamp 700 mm away 83.5° from the axis, ``between_deg`` around the axis from the
    camera (180: opposite sides)."""
    data = load_preset("tripod-oblique").to_dict()
    data.pop("setup", None)
    data["name"] = "grazing"
    data["camera"] = {"focal_length_mm": FOCAL_PX / WIDTH * 36.0, "sensor_width_mm": 36.0,
                      "image_size_px": [WIDTH, HEIGHT], "position_mm": _position(230.0, 38.0, 0.0),
                      "look_at_mm": [0.0, 0.0, 0.0], "up": [0.0, 0.0, 1.0], "distance_mm": 230.0}
    data["light"]["position_mm"] = _position(700.0, 83.5, -between_deg)
    data["light"]["lobe_sigma"] = 0.004
    return preset_from_dict(data)


def _photo(scene: Scene, table: float = 0.0) -> np.ndarray:
    """The capture under a tungsten-like lamp, exposed, with a lit 'table' (a smooth bright
    gradient) around the disc when ``table`` > 0."""
    lam = np.linspace(380.0, 780.0, 81)
    image, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=2), (lam / 780.0) ** 3, CAMERA),
                            1.0, photo.track_mask(scene))
    if table > 0:  # the table around the disc, not on it
        rows, cols = np.mgrid[0:HEIGHT, 0:WIDTH]
        lit = (rows < HEIGHT * 0.3).ravel()
        lit[pixel_diffraction(scene).index] = False
        image = image + table * (0.5 + 0.5 * cols / WIDTH)[..., None] * lit.reshape(HEIGHT, WIDTH)[..., None]
    return np.minimum(image, 1.0)


@pytest.fixture(scope="module")
def thin_lines():
    preset = grazing_preset(155.0)
    scene = Scene(preset)
    return preset, scene, _photo(scene, table=0.3)


def test_top_hat_keeps_a_thin_line_and_drops_a_wide_plateau():
    img = np.zeros((60, 60))
    img[:, 30] = 1.0  # a line one pixel wide
    img[10:50, 5:25] += 0.8  # a plateau 20 px wide
    hat = top_hat(img, 7)
    assert hat[20, 30] == pytest.approx(1.0)
    assert np.max(np.abs(hat[15:45, 10:20])) < 1e-12  # the plateau's inside is gone


def test_the_ridges_lie_on_the_true_curve_despite_a_lit_table(thin_lines):
    preset, scene, image = thin_lines
    ridges = ridge_pixels(image, FOCAL_PX)
    assert ridges is not None
    truth = line_agreement(ridges, relative_pose(scene), (WIDTH, HEIGHT), FOCAL_PX, preset.disc)
    assert truth.pixels >= 20
    # the lines are ~3 px wide here: their pixels sit ~1 px either side of the curve
    assert truth.share > 0.85 and truth.median_px < 1.5


@pytest.mark.parametrize("moved", [(1.5, -1.0, 0.0, 0.0, 3.0, 2.0), (-1.0, 1.0, 1.0, -1.0, -2.0, 3.0)])
def test_a_capture_moved_off_the_lines_is_moved_back_onto_them(thin_lines, moved):
    """Aim, tilt and lamp direction all moved by degrees (the lines 10–30 px away): the line fit
    puts the curve back through the lines within a pixel."""
    preset, scene, image = thin_lines
    truth = relative_pose(scene)
    x = np.zeros(N_PARAMS)
    x[:6] = moved
    start = apply_params(truth, x)
    ridges = ridge_pixels(image, FOCAL_PX)
    before = line_agreement(ridges, start, (WIDTH, HEIGHT), FOCAL_PX, preset.disc)
    truth_agreement = line_agreement(ridges, truth, (WIDTH, HEIGHT), FOCAL_PX, preset.disc)
    fit = line_fit(ridges, start, np.zeros(N_PARAMS), (WIDTH, HEIGHT), FOCAL_PX, preset.disc)
    assert fit is not None
    assert before.share < 0.5  # the start really was off the lines
    assert fit.on_line > truth_agreement.share - 0.15 and fit.median_px < truth_agreement.median_px + 0.5
    assert fit.pins_geometry


def test_a_lamp_on_the_cameras_side_shows_only_higher_orders():
    """Lamp 30° around the axis from the camera, nearly grazing: ωi + ωo is long along the line,
    so d·|u| > 1.3 µm and 400–700 nm shows only in orders ≥ 2 — the lines are named so."""
    preset = grazing_preset(30.0)
    scene = Scene(preset)
    image = _photo(scene)
    ridges = ridge_pixels(image, FOCAL_PX)
    agreement = line_agreement(ridges, relative_pose(scene), (WIDTH, HEIGHT), FOCAL_PX, preset.disc)
    assert agreement.orders and 1 not in agreement.orders


def _higher_orders(**image: Any) -> tuple[Preset, PoseFit, LinearImage]:
    """A grazing capture whose lines are the 3rd and 4th orders, its fit, and the photo as a file
    with ``image``'s fields (encoding, path, processed ...)."""
    preset = grazing_preset(30.0)
    scene = Scene(preset)
    rgb = _photo(scene)
    fit = replace(PoseFit.of_scene(scene), residual=0.5, null_residual=1.0, lines_pinned=True, line_orders=(3, 4))
    linear = LinearImage(rgb=rgb.astype(np.float32), saturated=rgb.max(axis=2) >= 1.0,
                         invalid=np.zeros(rgb.shape[:2], bool), scale=1.0, original_size=(WIDTH, HEIGHT),
                         exif=ExifInfo(), **image)
    return preset, fit, linear


def test_a_photo_of_higher_orders_is_refused_with_what_it_holds():
    """The first order misses 400–700 nm: refused, saying how much it holds and which orders
    the lines are, never 'no CD rainbow found'."""
    preset, fit, linear = _higher_orders(encoding="linear-float", path="higher.png")
    posed = pose_photo(linear, preset, CAMERA, focal_px=FOCAL_PX, fit=fit)
    with pytest.raises(NoDiscError) as err:
        read_posed(posed)
    text = str(err.value)
    assert "holds none of 400–700 nm" in text or "holds only" in text
    assert "3rd and 4th orders" in text and "no CD rainbow found" not in text
    assert "camera-processed" not in text  # a linear file: the colours are the camera's own


def test_a_processed_file_refused_for_its_coverage_is_told_its_colours_may_be_the_cause():
    """The same refusal for a camera-processed file read without a calibration of its processing:
    the fit placed the wavelengths by colours the camera's rendering moved, so after the geometry
    advice the message says so (a phone's CIE A JPEG through a real camera's rendering was told to
    move the lamp when it stood where the preset says)."""
    preset, fit, linear = _higher_orders(encoding="srgb-8", path="higher.jpg", processed=True,
                                         processed_reason="EXIF WhiteBalance (auto) says the camera white-balanced it")
    posed = pose_photo(linear, preset, CAMERA, focal_px=FOCAL_PX, fit=fit)
    with pytest.raises(NoDiscError) as err:
        read_posed(posed)
    text = str(err.value)
    assert "holds none of 400–700 nm" in text or "holds only" in text
    hint = text.index("camera-processed file")
    assert "shoot RAW" in text and text.index("unless the colours misled the fit:") < hint
    # with a calibration of its processing that explains its own photo, the colours are trusted;
    # with one that cannot (20 % of its rainbow unexplained), the message names it
    from cd_spectra_addon.core.calibration.calibration import Calibration
    from cd_spectra_addon.core.calibration.camera_pipeline import CameraPipeline
    from cd_spectra_addon.core.spectra.grid import N_FEATURES

    identity = CameraPipeline(np.eye(3), np.array([0.0, 1.0]), np.array([0.0, 1.0]))
    good = Calibration("shot", np.ones((N_FEATURES, 3)), preset.name, CAMERA.name, {"unexplained": 0.004}, identity)
    for cal, named in ((good, False), (replace(good, metadata={"unexplained": 0.2}), True)):
        posed = pose_photo(linear, preset, CAMERA, focal_px=FOCAL_PX, fit=fit, calibration=cal)
        with pytest.raises(NoDiscError) as err:
            read_posed(posed)
        assert ("calibration 'shot', which cannot explain the processing" in str(err.value)) == named
        assert "read without a calibration" not in str(err.value)
