"""The inverse with a capture someone can build: lamp beside the lens, a tilted disc, room light."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.readout import ambient

from cd_spectra_addon.core.pose import result as pose_result
from cd_spectra_addon.core.pose.fit import fit_pose
from cd_spectra_addon.core.scene import relative_pose
from cd_spectra_addon.core.spectra.cameras import load_camera
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera("Canon_EOS_5D_Mark_III")
WARM = np.array([1.0, 0.9, 0.75])


def _capture(pose: Pose, size: int = 192):
    scene = Scene(load_preset("cd-default").with_image_size(size), pose)
    cube = render_cube(scene, supersample=3)
    spd = np.exp(-0.5 * ((np.arange(380, 781, 5) - 560) / 90.0) ** 2)
    image, _ = photo.expose(photo.linear_photo(cube, spd, CAMERA), 1.0, photo.track_mask(scene))
    return scene, image


def _ring_centre_truth(scene: Scene) -> tuple[float, float]:
    """Where the disc mirrors the lamp into the lens (u = v = 0), for an untilted disc with the
    camera on the axis: the point between the lamp's foot and the camera's, weighted by heights."""
    cam = scene.camera_position * 1e3
    lamp = scene.light_position * 1e3
    m = (lamp[2] * cam[:2] + cam[2] * lamp[:2]) / (cam[2] + lamp[2])
    return tuple(scene.project(np.array([[m[0] * 1e-3, m[1] * 1e-3, 0.0]]))[0])


@pytest.mark.parametrize("offset_mm", [15.0, 30.0])
def test_lamp_beside_the_lens_is_found_despite_its_glint(offset_mm):
    """The clipped zero-order glint (most of the photo's energy) must not pull the fit: the ring
    centre lands on the mirror point and the disc centre on the disc (before: 100+ px off at 30 mm)."""
    scene, image = _capture(Pose(light_offset_mm=(offset_mm, 0.0)))
    clipped = np.minimum(image, 1.0)
    assert np.max(image) > 3.0  # the glint really is far brighter than the rainbow
    fit = fit_pose(clipped, scene.preset, scene.preset.camera.focal_px, sensitivities=CAMERA.sensitivities,
                   saturated=image.max(axis=2) >= 1.0)
    truth_ring = _ring_centre_truth(scene)
    centre = scene.project(scene.disc_center[None, :])[0]
    assert np.hypot(*np.subtract(fit.ring_center_px, truth_ring)) < 1.0
    assert np.hypot(*np.subtract(fit.center_px, centre)) < 1.5
    assert fit.rainbow_contrast > 0.9


def test_colour_constraint_prefers_the_true_wavelength_axis():
    """Shifting the ring centre along a single streak relabels λ₁ without breaking the
    self-consistency much; the camera's colour at λ₁ makes the shift cost clearly more."""
    scene, image = _capture(Pose(light_offset_mm=(30.0, 0.0)))
    f = scene.preset.camera.focal_px
    size = scene.preset.camera.image_size_px
    ring = _ring_centre_truth(scene)
    centre = tuple(scene.project(scene.disc_center[None, :])[0])
    colour = pose_result.expected_colours(CAMERA.sensitivities, pose_result.FIT_STEP_NM,
                                          pose_result.colour_blur_nm(scene.preset, 0.003, f))
    rel = relative_pose.relative_pose(scene)

    def cost(shift: float, use_colour: bool) -> float:
        moved = relative_pose.with_disc_centre_at(rel, (centre[0], centre[1] + shift), size, f)
        moved = relative_pose.with_lamp_mirrored_at(moved, (ring[0], ring[1] + shift), size, f)
        s = relative_pose.scene_from_relative(moved, scene.preset, size, f)
        return pose_result.consistency(image, s, step_nm=pose_result.FIT_STEP_NM, colour=colour if use_colour else None)

    plain_gain = cost(3.0, False) - cost(0.0, False)
    colour_gain = cost(3.0, True) - cost(0.0, True)
    assert cost(0.0, True) < cost(3.0, True) and cost(0.0, True) < cost(-3.0, True)
    assert colour_gain > plain_gain


def test_room_light_is_measured_on_the_dark_disc():
    """A uniform warm offset is recovered per channel within 10 % from the pixels the geometry
    says are dark; a photo without one gets exactly zero (nominal photos stay as they were)."""
    scene, image = _capture(Pose(light_offset_mm=(30.0, 0.0)))
    offset = 0.02 * WARM
    found = ambient.dark_levels(np.minimum(image, 1.0) + offset, scene)[0]
    assert np.allclose(found, offset, rtol=0.1)
    assert np.all(ambient.dark_levels(np.minimum(image, 1.0), scene)[0] == 0.0)
    nominal_scene, nominal = _capture(Pose())
    assert np.all(ambient.dark_levels(nominal, nominal_scene)[0] == 0.0)
    assert np.allclose(ambient.dark_levels(nominal + offset, nominal_scene)[0], offset, rtol=0.1)  # the hub


def test_room_light_from_one_side_is_measured_as_uneven():
    """A uniform offset reads as even (its halves differ by noise only); the same offset with a
    gradient across the frame reads as about the gradient over half the dark pixels' span, in
    either direction; no offset, nothing to compare (0)."""
    scene, image = _capture(Pose(light_offset_mm=(30.0, 0.0)))
    base = np.minimum(image, 1.0)
    rng = np.random.default_rng(0)
    noisy = base + rng.normal(0.0, 0.005, base.shape)
    offset, even = ambient.dark_levels(noisy + 0.03 * WARM, scene)
    assert np.allclose(offset, 0.03 * WARM, atol=0.004) and even < 0.002
    none, nothing = ambient.dark_levels(base, scene)
    assert not np.any(none) and nothing == 0.0
    across = np.linspace(-0.5, 0.5, base.shape[1])[None, :, None]
    for gradient in (across, np.swapaxes(across, 0, 1)):
        _, uneven = ambient.dark_levels(noisy + (0.03 + 0.08 * gradient) * WARM, scene)
        assert 0.01 < uneven < 0.05


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, (12, 12, 3), elements=st.floats(0.0, 1.0)), st.floats(0.0, 0.2))
def test_rough_offset_never_exceeds_the_dark_level(image, level):
    """Before the pose is known the offset may be too small, never larger than the photo's
    own dark pixels allow, and is finite and non-negative for any image."""
    found = ambient.rough_offset(image + level)
    assert found.shape == (3,) and np.all(np.isfinite(found)) and np.all(found >= 0)
    assert np.all(found <= np.percentile((image + level).reshape(-1, 3), 10, axis=0) + 1e-12)


def test_lamp_reach_and_advice_follow_the_geometry():
    """With the camera 210 mm up, a lamp up to ~10–15 mm beside the lens puts 400–700 nm on the
    tracks (issue 10); at 60 mm the glint alone tells the user how far off the lamp is."""
    from cd_spectra_addon.core.planning import capture_advice

    preset = load_preset("cd-default")
    reach = capture_advice.lamp_reach_mm(preset)
    assert 10.0 <= reach <= 20.0
    scene, image = _capture(Pose(light_offset_mm=(60.0, 0.0)), size=256)
    image = image / np.max(image) * 0.8  # exposed for the glint: the rainbow is dim
    glint = capture_advice.glint_px(image, np.zeros(image.shape[:2], bool))
    offset = capture_advice.lamp_offset_from_glint(glint, (256, 256), scene.preset.camera.focal_px, scene.preset)
    assert abs(offset - 60.0) < 3.0
    text = capture_advice.advice_for_photo(scene.preset, scene, False, image, np.zeros(image.shape[:2], bool),
                                           scene.preset.camera.focal_px)
    assert "move the lamp closer" in text and "60 mm" in text
    nominal_scene, nominal = _capture(Pose())
    assert capture_advice.glint_px(nominal, np.zeros(nominal.shape[:2], bool)) is None  # a rainbow is no glint
    clipped = np.zeros(image.shape[:2], bool)
    r, c = np.unravel_index(int(np.argmax(image.sum(axis=-1))), clipped.shape)
    clipped[r - 1:r + 2, c - 1:c + 2] = True  # the same glint, clipped: a solid spot
    assert "60 mm" in capture_advice.advice_for_photo(scene.preset, scene, False, image, clipped,
                                                      scene.preset.camera.focal_px)


def test_pure_noise_gets_the_set_up_not_a_lamp_distance():
    """An 8-bit photo of uniform noise has a channel at 255 in ~3.5 % of its pixels, scattered:
    no clipped spot is a glint, so the advice is the set-up's, not a distance read off noise."""
    from cd_spectra_addon.core.planning import capture_advice

    preset = load_preset("cd-default")
    noise = np.random.default_rng(7).integers(0, 256, (256, 256, 3)) / 255.0
    saturated = np.any(noise >= 1.0, axis=-1)
    assert capture_advice.glint_px(noise, saturated) is not None  # the brightest clipped pixel
    assert capture_advice.glint_px(noise, saturated, solid=True) is None
    text = capture_advice.advice_for_photo(preset, Scene(preset), False, noise, saturated, preset.camera.focal_px)
    assert text == capture_advice.lamp_advice(preset, None)
