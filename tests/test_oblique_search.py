"""The oblique fit's search where the photo shows only the rainbow: a distant lamp over a disc on
a black cloth (no outline), with the errors a person makes placing camera, lamp and disc."""

import numpy as np
import pytest

from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.inverse.load import load_for_estimate
from cd_spectra_addon.core.inverse.stages import pose_photo
from cd_spectra_addon.core.scene.capture import Pose, Scene
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.spectra.illuminants import known_lamp_spd
from training.evaluation import pose_errors
from training.simulation import photo
from training.simulation.render_numpy import render_cube

# One of bench/pose_errors_oblique205.md's combined captures of phone-distant-lamp (capture 1 of
# 16): camera 3.5 mm off and turned ~1°, lamp 1.9 mm off and swung ~1.4°, disc tilted 1.7°, room
# light 2.8 %.
CAPTURE = Pose(camera_offset_mm=(1.6168803102681533, -3.072218725547189),
               light_offset_mm=(-0.052865414187470434, -1.903174353912029),
               tilt_deg=(-1.5507260174314792, -0.7994914828222298),
               camera_rotation_deg=(0.9322461245102042, -0.6205479096299547),
               light_rotation_deg=(0.8618194015098636, -1.136792515040422))
AMBIENT = 0.02800315412554744


@pytest.mark.slow  # a 1024 px render and a full oblique search (~8 s): make test only
def test_a_lobe_shrunk_to_a_sliver_of_the_streak_does_not_win(tmp_path):
    """With the lamp's size free in the coarse stage, LM shrank the lobe to a quarter of the lamp's
    (σ 0.0015 for 0.0061) on a capture 4–9° off that explains a sliver of the streak and leaves a
    quarter of the photo unexplained (MAE 0.4 on synthetic lamps). The refit at the start's size
    (fit._at_start_size) must win: the lamp's size within 1.5× of the truth, most of the photo
    explained, and the spectrum read."""
    preset, _ = pose_errors.crop_preset("phone-distant-lamp")
    scene = Scene(preset, CAPTURE)
    cube = render_cube(scene, supersample=pose_errors.SUPERSAMPLE)
    path = tmp_path / "capture.jpg"
    lamp = known_lamp_spd("A")
    pose_errors.write_capture(path, scene, cube, lamp, AMBIENT, None, seed=7, masks=(photo.track_mask(scene), None))
    loaded = load_for_estimate(path, preset)
    fit = pose_photo(loaded, preset, load_camera(DEFAULT_CAMERA)).fit
    truth = scene.preset.light.lobe_sigma
    assert truth / 1.5 < fit.lobe_sigma < truth * 1.5
    assert fit.residual < 0.15
    estimate = estimate_image(loaded, preset=preset, fit=fit)
    assert compare_spds(estimate.spd, lamp)["mae_400_700"] < 0.05
    assert np.all(np.isfinite(estimate.spd))
