"""Bins read only at the tracks' edges: dark ones are off the tracks, not a dark lamp."""

from dataclasses import replace

import numpy as np
import pytest

from cd_spectra_addon.core.readout import forward_matrix, readout
from cd_spectra_addon.core.spectrum.track_edges import dark_edges_dropped
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.spectra.illuminants import daylight_spd
from cd_spectra_addon.core.spectrum import solve
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera("Canon_EOS_5D_Mark_III")
SPD = daylight_spd(6504.0)
# phone-distant-lamp with its disc tilted 3°: the rainbow's blue end (460–475 nm) lies only on
# pixels within a millimetre of the tracks' inner edge.
POSE = Pose(tilt_deg=(3.0, 0.0))


@pytest.fixture(scope="module")
def capture():
    preset = load_preset("phone-distant-lamp").with_image_size(512)
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * 1.09))
    # The photo's tracks begin 0.6 mm further out than the geometry the readout is given, as a
    # pose whose disc centre slid along the streak puts them (no outline pins it).
    later = replace(preset, disc=replace(preset.disc, grating_r_min_mm=preset.disc.grating_r_min_mm + 0.6))
    img = photo.linear_photo(render_cube(Scene(later, POSE), supersample=3), SPD, CAMERA)
    return Scene(preset, POSE), Scene(later, POSE), img / img.max()


def _read(scene, img):
    prof = readout.extract_readout(img, None, scene)
    return prof, forward_matrix.feature_matrix(forward_matrix.bin_response(scene, prof), CAMERA)


@pytest.mark.parametrize("known", [False, True])
def test_a_dark_edge_only_bin_is_left_out(capture, known):
    """Read through the wrong edge, the 460–465 nm bins come only from pixels off the photo's
    tracks and read (nearly) 0 beside a lit 470 nm: the solve put 0 there and its peak beside
    (MAE 400–700 ≈ 0.5). Left out, it reads the lamp; the other bins are untouched. A known lamp
    (a calibration shot) is judged the same way."""
    wrong, _, img = capture
    prof, matrix = _read(wrong, img)
    edge = prof.valid & prof.edge_only
    assert np.any(edge & (prof.lambda_nm < 470))
    kept = dark_edges_dropped(prof, matrix, SPD if known else None)
    dropped = prof.valid & ~kept.valid
    assert np.all(edge[dropped]) and np.any(dropped)
    assert np.all(prof.lambda_nm[dropped] < 470)  # only the dark ones
    assert np.array_equal(kept.values[kept.valid], prof.values[kept.valid])
    assert compare_spds(solve.physics_solve(prof, matrix), SPD)["mae_400_700"] > 0.2
    assert compare_spds(solve.physics_solve(kept, matrix), SPD)["mae_400_700"] < 0.02


def test_edge_only_bins_that_read_the_lamp_are_kept(capture):
    """Through the photo's own edge its edge-only bins read what the rest predicts: kept."""
    _, right, img = capture
    prof, matrix = _read(right, img)
    assert np.any(prof.valid & prof.edge_only)
    assert np.array_equal(dark_edges_dropped(prof, matrix).valid, prof.valid)
