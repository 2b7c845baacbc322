"""The general-pose inverse recovers a capture from the photo alone, for any set-up (issue 10)."""

from dataclasses import replace

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.pose import self_consistency
from cd_spectra_addon.core.pose.fit import fit_pose

from cd_spectra_addon.core.scene import kernel, relative_pose

from cd_spectra_addon.core.planning import setups
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.spectra.colour import compare_spds
from cd_spectra_addon.core.scene.diffraction import pixel_diffraction
from cd_spectra_addon.core.errors import NoDiscError
from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.photo.images import load_photo
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)
SIZE = 1024  # the loader's working size; below ~800 px across the disc an oblique streak is a pixel wide
# A pose with every kind of error at once: camera aimed 2° off and moved, disc tilted, lamp
# moved and swung out of the camera's plane.
ERRORS = Pose(camera_offset_mm=(3.0, -2.0), light_offset_mm=(4.0, 3.0), tilt_deg=(2.0, -1.0),
              camera_rotation_deg=(1.5, -1.0), light_rotation_deg=(1.0, 0.0))


def _lamp() -> np.ndarray:
    lam = np.arange(380, 781, 5)
    return np.exp(-0.5 * ((lam - 560) / 90.0) ** 2) + 0.6 * np.exp(-0.5 * ((lam - 611) / 6.0) ** 2)


# Version 2's tripod set-up (camera 27.5° from the axis, lamp 7.5° on its side): a strongly
# foreshortened disc and a streak on one side, what the general-pose fit was built on. The shipped
# tripod-oblique now looks down at 12.5° with the lamp opposite (tolerant of a tilted disc); on the
# ERRORS photo below its fit reads λ₁ 2 nm off (0.5 nm here) and physics-only MAE 0.081 against 0.024
# at its true pose (bench/pose_errors.md measures the shipped set-ups).
V2_TRIPOD = Path(__file__).resolve().parent / "tripod_oblique_v2.json"


def _oblique(pose: Pose = Pose(), zoom: float = 3.2, name: str | Path = V2_TRIPOD):
    """An oblique set-up (default: version 2's tripod) as a centred crop at realistic resolution:
    the 24 mm lens's field zoomed so the disc spans ~800 of 1024 pixels (the loader's crop of a
    real photo)."""
    preset = load_preset(name).with_image_size(SIZE)
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * zoom))
    return Scene(preset, pose)


@pytest.fixture(scope="module")
def oblique_photo(tmp_path_factory):
    """An 8-bit JPEG (1 % noise, EXIF focal length) of version 2's tripod set-up with every pose error."""
    scene = _oblique(ERRORS)
    cube = render_cube(scene, supersample=2)
    image, _ = photo.expose(photo.linear_photo(cube, _lamp(), CAMERA), 1.0, photo.track_mask(scene))
    image = np.minimum(photo.add_noise(photo.upsample(image, 2), 0.01, np.random.default_rng(3)), 1.0)
    c = scene.preset.camera
    path = tmp_path_factory.mktemp("oblique") / "oblique.jpg"
    photo.write_photo(path, image, "jpg", photo.exif_for(c.focal_length_mm, c.sensor_width_mm, 2 * SIZE, CAMERA.name))
    loaded = load_photo(path, max_side=SIZE)
    fit = fit_pose(np.asarray(loaded.rgb, np.float64), load_preset(V2_TRIPOD),
                                        c.focal_px, sensitivities=CAMERA.sensitivities,
                                        saturated=np.asarray(loaded.saturated))
    return scene, loaded, fit


@pytest.mark.parametrize("name", ["cd-default", "phone-near-axis", "tripod-oblique", "phone-distant-lamp"])
def test_the_camera_frame_holds_the_whole_capture(name):
    """Disc, lamp and camera re-expressed in the camera's frame and rebuilt as a world scene
    give every pixel the same λ₁, visibility and gain: nothing is lost or gauge-dependent."""
    scene = Scene(load_preset(name).with_image_size(96), ERRORS)
    rel = relative_pose.relative_pose(scene)
    rebuilt = relative_pose.scene_from_relative(rel, scene.preset, (96, 96), scene.preset.camera.focal_px)
    a, b = pixel_diffraction(scene), pixel_diffraction(rebuilt)
    assert np.array_equal(a.index, b.index)
    assert np.max(np.abs(a.lambda1_nm - b.lambda1_nm)) < 1e-6
    assert np.allclose(a.visibility, b.visibility, atol=1e-9) and np.allclose(a.gain, b.gain, rtol=1e-9)


def test_the_glint_is_where_the_disc_mirrors_the_lamp():
    """mirror_point agrees with the forward model: at the glint's pixel u = v = 0; and
    with_glint_at turns the disc so the glint lands on a chosen pixel."""
    scene = Scene(load_preset("cd-default").with_image_size(128), Pose(tilt_deg=(3.0, 0.0)))
    f = scene.preset.camera.focal_px
    rel = relative_pose.relative_pose(scene)
    rc = kernel.project(relative_pose.mirror_point(rel), (128, 128), f)
    px = pixel_diffraction(scene, None, np.array([rc[0]]), np.array([rc[1]]))
    assert abs(px.u[0]) < 1e-9 and abs(px.v[0]) < 1e-9
    moved = relative_pose.with_glint_at(rel, (rc[0] + 6.0, rc[1] - 4.0), (128, 128), f)
    got = kernel.project(relative_pose.mirror_point(moved), (128, 128), f)
    assert np.hypot(got[0] - rc[0] - 6.0, got[1] - rc[1] + 4.0) < 0.01


@pytest.mark.slow
def test_an_oblique_pose_is_recovered_from_the_photo(oblique_photo):
    """From tripod-oblique's nominal pose the fit finds the real one: disc normal within 1°, the
    disc centre within 2 px across the streak. Along the streak the rainbow hardly depends on
    where the centre is (every pixel's λ₁ is set by its ray and the lamp's direction, and the
    lamp's direction trades off against it: 3 mm and 2° leave λ₁ within 0.1 nm), so there the
    centre is held to 4 mm and the lamp's direction to 3°."""
    scene, _, fit = oblique_photo
    truth = relative_pose.relative_pose(scene)
    got = relative_pose.relative_pose(fit.known_scene)
    size, f = (SIZE, SIZE), scene.preset.camera.focal_px

    def angle(a, b):
        return np.degrees(np.arccos(np.clip(a @ b / np.linalg.norm(a) / np.linalg.norm(b), -1, 1)))

    assert angle(truth.disc_normal, got.disc_normal) < 1.0
    assert angle(truth.lamp_mm - truth.disc_centre_mm, got.lamp_mm - got.disc_centre_mm) < 3.0
    px = pixel_diffraction(scene)
    streak = px.index[px.on_tracks & (px.visibility > 0.5)]
    rows, cols = streak // SIZE, streak % SIZE
    along = np.polyfit(cols, rows, 1)[0]  # the streak runs mostly along the image rows
    direction = np.array([along, 1.0]) / np.hypot(along, 1.0)
    error = np.subtract(fit.center_px, kernel.project(truth.disc_centre_mm, size, f))
    across = abs(error[0] * direction[1] - error[1] * direction[0])
    mm_per_px = truth.distance_mm / f
    assert across < 2.0 and np.hypot(*error) * mm_per_px < 4.0
    assert fit.rainbow_contrast > 0.8


@pytest.mark.slow
def test_the_fitted_streak_shows_the_grating_equation_wavelengths(oblique_photo):
    """Where the grating equation d(sin θm − sin θi) = mλ puts 450, 530 and 610 nm on the real
    disc, the fitted capture's λ₁ at that pixel is the same wavelength within 1 nm (the preset's
    nominal pose puts no streak there)."""
    scene, _, fit = oblique_photo
    # The real set-up's lamp is out of the camera's plane: find each wavelength on the real
    # streak (v = 0) by the forward model instead of setups.first_order_positions.
    px = pixel_diffraction(scene)
    streak = px.on_tracks & (px.visibility > 0.3)
    nominal = relative_pose.nominal_scene(load_preset(V2_TRIPOD), (SIZE, SIZE), scene.preset.camera.focal_px)
    for target in (450.0, 530.0, 610.0):
        k = np.flatnonzero(streak)[np.argmin(np.abs(px.lambda1_nm[streak] - target))]
        assert abs(px.lambda1_nm[k] - target) < 2.0
        fitted = pixel_diffraction(fit.known_scene, px.index[k:k + 1])
        assert abs(fitted.lambda1_nm[0] - px.lambda1_nm[k]) < 1.0
        before = pixel_diffraction(nominal, px.index[k:k + 1])
        assert before.index.size == 0 or before.visibility[0] < 0.01 or abs(before.lambda1_nm[0] - target) > 5.0


def test_grating_equation_on_the_nominal_oblique_line():
    """setups.first_order_positions (the grating equation on the incidence line) and the
    per-pixel λ₁ of the inverse agree at the preset's own pose."""
    scene = _oblique()
    (s550,) = setups.first_order_positions(scene, [550.0])
    point = scene.disc_center * 1e3 + s550[0] * setups.incidence_line(scene)
    rc = scene.project(point[None, :] * 1e-3)[0]
    px = pixel_diffraction(scene, None, np.array([rc[0]]), np.array([rc[1]]))
    assert abs(px.lambda1_nm[0] - 550.0) < 0.05


@pytest.mark.slow
def test_an_oblique_photo_is_read_not_refused(oblique_photo):
    """A photo holding 400–650 nm of first order (its pose errors push the red end into the clear
    hub) from an oblique set-up is estimated, not refused, reading all of that (the readout's
    coverage of 400–700 nm at least the true pose's) and the spectrum (physics only) within
    2× the MAE the true pose gives. (Not closer: along the streak the disc centre is found only to
    ~1.5 mm, which moves the tracks' outer edge, where the blue end lies, and the lamp's direction
    ~1°; the bins there change by up to 7 %, and a physics-only solve amplifies that.)"""
    from cd_spectra_addon.core.pose.result import PoseFit

    scene, loaded, _ = oblique_photo
    kwargs = dict(preset=load_preset(V2_TRIPOD), camera=DEFAULT_CAMERA, model=None, method="physics")
    est = estimate_image(loaded, **kwargs)
    true = estimate_image(loaded, fit=PoseFit.of_scene(scene), **{**kwargs, "preset": scene.preset})
    mae, true_mae = (compare_spds(e.spd, _lamp())["mae_400_700"] for e in (est, true))
    assert mae < 2.0 * true_mae + 0.01
    assert est.extra["checks"]["coverage_400_700"] >= true.extra["checks"]["coverage_400_700"] > 0.8


def test_a_photo_without_first_order_light_is_refused_with_what_to_move(tmp_path):
    """An oblique set-up's photo with no rainbow (lamp off: noise and room light) is refused, and
    the message says where the set-up puts camera and lamp."""
    image = np.clip(0.02 + 0.01 * np.random.default_rng(1).standard_normal((256, 256, 3)), 0.0, 1.0)
    path = tmp_path / "nothing.jpg"
    photo.write_photo(path, image, "jpg", photo.exif_for(76.8, 36.0, 256, CAMERA.name))
    with pytest.raises(NoDiscError) as info:
        estimate_image(load_photo(path), preset="tripod-oblique", camera=DEFAULT_CAMERA, model=None, method="physics")
    text = str(info.value)
    assert "no CD rainbow" in text and "camera 12.5° and lamp 15°" in text and "tripod-oblique" in text


@settings(max_examples=30, deadline=None)
@given(arrays(np.float64, (40, 3), elements=st.floats(-1.0, 1.0)),
       arrays(np.float64, 40, elements=st.floats(0.0, 3000.0)),
       arrays(np.float64, 40, elements=st.floats(0.0, 2.0)), st.sampled_from([2.0, 5.0]))
def test_profile_residuals_are_finite_for_any_pixels(values, lam, amp, step):
    """Whatever pixels a photo gives (zero amplitudes, λ₁ off the grid, duplicates), the smooth
    self-consistency is finite, has a fixed length, and never exceeds the pixels' own energy
    by more than the colour terms."""
    grid = self_consistency.ProfileGrid.with_camera(300.0, 1000.0, step, CAMERA.sensitivities, 3.0)
    r = self_consistency.profile_residuals(values, lam, amp, grid)
    assert np.all(np.isfinite(r)) and r.size == values.size + 3 * int(np.sum(~np.isnan(grid.colour[:, 0])))
    assert float(np.sum(r[: values.size] ** 2)) <= float(np.sum(values ** 2)) * (1 + 1e-9) + 1e-12


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, (12, 3), elements=st.floats(0.0, 1.0)),
       arrays(np.float64, 12, elements=st.floats(480.0, 520.0)),
       arrays(np.float64, 12, elements=st.floats(0.0, 1.0)), st.floats(-170.0, 0.0))
def test_profile_residuals_survive_a_vanishing_lobe(values, lam, amp, exponent):
    """A pose far off puts every pixel in the lobe's far tail (amplitudes ~1e-155, squares in
    the denormals): the residuals are still finite and the same as for the amplitudes scaled
    up (the profile absorbs a common scale). Before, the pivots underflowed to zero."""
    grid = self_consistency.ProfileGrid.with_camera(300.0, 1000.0, 5.0, CAMERA.sensitivities, 3.0)
    small = self_consistency.profile_residuals(values, lam, amp * 10.0 ** exponent, grid)
    assert np.all(np.isfinite(small))
    peak = float(np.max(amp)) * 10.0 ** exponent
    if 0.0 < peak < self_consistency.TINY_AMPLITUDE:  # rescaled: as the same pixels at peak 1
        same = self_consistency.profile_residuals(values, lam, amp * 10.0 ** exponent / peak, grid)
        assert np.allclose(small, same, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("name", ["cd-default", "tripod-oblique"])
def test_a_photo_of_subnormal_values_gives_a_finite_fit(name):
    """The example hypothesis found below (every value 5e-324, one 0): the outline's Otsu
    threshold asked numpy for 256 bins over a range it cannot split and raised."""
    image = np.full((48, 48, 3), 5e-324)
    image[0, 0, 0] = 0.0
    fit = fit_pose(image, load_preset(name), 60.0, sensitivities=CAMERA.sensitivities, saturated=image.max(axis=2) >= 1.0)
    assert np.all(np.isfinite([*fit.center_px, fit.lobe_sigma, fit.residual, fit.null_residual, fit.distance_mm]))


@pytest.mark.slow  # make test only: 3.5 s, the second slowest check of make test-fast
@settings(max_examples=8, deadline=None)
@given(arrays(np.float64, (48, 48, 3), elements=st.floats(0.0, 1.0)),
       st.sampled_from(["cd-default", "tripod-oblique"]))
def test_the_general_fit_never_returns_nan(image, name):
    """Any image (noise, flat, black) gives a pose fit with finite numbers."""
    preset = load_preset(name)
    fit = fit_pose(image, preset, 60.0, sensitivities=CAMERA.sensitivities,
                                        saturated=image.max(axis=2) >= 1.0)
    assert np.all(np.isfinite([*fit.center_px, fit.lobe_sigma, fit.residual, fit.null_residual, fit.distance_mm]))
    assert 0.0 <= fit.rainbow_contrast <= 1.0


def test_the_fit_evaluates_the_same_diffraction_as_the_inverse():
    """ray_diffraction (the fit's fast path, in the camera frame) and pixel_diffraction (what the
    readout and forward matrix use) give every pixel the same λ₁, amplitude and radius."""
    for name in ("cd-default", "tripod-oblique", "phone-distant-lamp"):
        scene = Scene(load_preset(name).with_image_size(96), ERRORS)
        rel = relative_pose.relative_pose(scene)
        px = pixel_diffraction(scene)
        rays = kernel.index_rays(px.index, (96, 96), scene.preset.camera.focal_px)
        fast = relative_pose.ray_diffraction(rays, rel, scene.preset.disc.pitch_um)
        assert np.all(fast.hit)
        assert np.max(np.abs(fast.lambda1_nm - px.lambda1_nm)) < 1e-6
        assert np.allclose(fast.amplitude, px.amplitude, rtol=1e-9, atol=1e-12)
        assert np.allclose(fast.radius_mm, px.radius_mm, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(arrays(np.float64, 60, elements=st.floats(1.0, 10.0)), arrays(np.float64, 59, elements=st.floats(-0.45, 0.45)),
       arrays(np.float64, (60, 3), elements=st.floats(-5.0, 5.0)))
def test_the_tridiagonal_solve_matches_a_dense_one(diag, off, rhs):
    """The cyclic-reduction solve of the profile's normal equations equals numpy's dense solve
    (diagonally dominant systems, as the normal equations of shared pixel weights are), for one
    right-hand side and for many."""
    dense = np.diag(diag) + np.diag(off, 1) + np.diag(off, -1)
    assert np.allclose(self_consistency.solve_tridiagonal(diag, off, rhs), np.linalg.solve(dense, rhs), atol=1e-9)
    assert np.allclose(self_consistency.solve_tridiagonal(diag, off, rhs[:, 0]), np.linalg.solve(dense, rhs[:, 0]),
                       atol=1e-9)


@pytest.mark.slow
def test_a_wrong_wavelength_axis_shows_in_the_camera_colours_and_the_confidence(oblique_photo):
    """At the true pose the readout's colours agree with the camera's at their labels (|shift| <
    2.5 nm); the same photo read with the camera aimed 0.3° off (λ₁ ~15 nm off along the streak)
    disagrees by the shift the pose makes, and the estimate says so and is trusted less."""
    from cd_spectra_addon.core.pose.result import PoseFit

    scene, loaded, _ = oblique_photo
    rel = relative_pose.relative_pose(scene)
    off = relative_pose.scene_from_relative(relative_pose.apply_params(rel, np.array([0, 0.3, 0, 0, 0, 0, 0, 0.0])),
                                            scene.preset, (SIZE, SIZE), scene.preset.camera.focal_px)
    px = pixel_diffraction(scene)
    sel = px.on_tracks & (px.visibility > 0.3) & (px.lambda1_nm > 450) & (px.lambda1_nm < 640)
    moved = float(np.mean(pixel_diffraction(off, px.index[sel]).lambda1_nm - px.lambda1_nm[sel]))
    kwargs = dict(preset=scene.preset, camera=DEFAULT_CAMERA, model=None, method="physics")
    good, bad = (estimate_image(loaded, fit=PoseFit.of_scene(s), **kwargs) for s in (scene, off))
    shifts = [e.extra["checks"]["colour_shift_nm"] for e in (good, bad)]
    assert abs(shifts[0]) < 2.5 and abs(moved) > 8.0 and abs(shifts[1] - moved) < 0.4 * abs(moved)
    assert any("colours put its wavelengths" in w for w in bad.warnings)
    assert not any("colours put its wavelengths" in w for w in good.warnings)
    assert bad.confidence < 0.7 * good.confidence


def _lit_disc(scene: Scene, level: float = 0.05) -> np.ndarray:
    """Room light on the disc only (a dark surround): the disc's outline shows."""
    width, height = scene.preset.camera.image_size_px
    disc = np.zeros(width * height)
    disc[pixel_diffraction(scene).index] = level
    return disc.reshape(height, width)[..., None] * np.array([1.0, 0.9, 0.75])


def test_the_disc_outline_gives_the_camera_pose():
    """A room-lit disc's outline, a circle of 60 mm seen as an ellipse with the EXIF focal length,
    gives the disc's distance within 4 % and (one of its two solutions) its normal within 2.5°;
    a photo of a dark disc (only the rainbow) shows no outline."""
    from cd_spectra_addon.core.pose import rim_ellipse

    scene = _oblique(Pose(tilt_deg=(2.0, 1.0), camera_rotation_deg=(1.0, 0.0)), zoom=1.6)
    scene = Scene(scene.preset.with_image_size(512), scene.pose)
    cube = render_cube(scene, supersample=1)
    image, _ = photo.expose(photo.linear_photo(cube, _lamp(), CAMERA), 1.0, photo.track_mask(scene))
    noisy = [np.minimum(photo.add_noise(image + extra, 0.01, np.random.default_rng(0)), 1.0)
             for extra in (_lit_disc(scene), 0.0)]
    outline = rim_ellipse.disc_ellipse(noisy[0])
    assert outline is not None and rim_ellipse.disc_ellipse(noisy[1]) is None
    truth = relative_pose.relative_pose(scene)
    poses = rim_ellipse.circle_poses(outline, 60.0, scene.preset.camera.focal_px, (512, 512))
    errors = [np.degrees(np.arccos(np.clip(normal @ truth.disc_normal, -1, 1))) for _, normal in poses]
    assert min(errors) < 2.5
    assert abs(np.linalg.norm(poses[0][0]) / truth.distance_mm - 1.0) < 0.04


@pytest.mark.slow
def test_a_visible_outline_rescues_a_wrong_preset():
    """The photo is version 2's tripod set-up's (camera 27.5° from the disc's axis) but the preset handed to
    the fit says 40°. With the room-lit disc's outline, the cheap starts find the wavelengths
    (within 2 nm); the same starts without the outline strategy (and the lines one, which also
    rescues it) read them wrong (λ₁ > 10 nm off).
    (The escalations are left out to see the outline's part alone; with them the product also
    reads the dark disc, which has no outline, within 2 nm.)"""
    from cd_spectra_addon.core.pose.starts import CHEAP

    scene = _oblique(Pose(tilt_deg=(3.0, 2.0), camera_rotation_deg=(2.0, 1.0)))
    preset = load_preset(V2_TRIPOD)
    said = replace(preset, camera=replace(preset.camera, position_mm=(-207.0, 0.0, 246.7)))  # 40°, 322 mm
    cube = render_cube(scene, supersample=2)
    image, _ = photo.expose(photo.linear_photo(cube, _lamp(), CAMERA), 1.0, photo.track_mask(scene))
    px = pixel_diffraction(scene)
    sel = px.on_tracks & (px.visibility > 0.3) & (px.lambda1_nm > 400) & (px.lambda1_nm < 700)

    def error(extra, **strategies) -> float:
        noisy = np.minimum(photo.add_noise(image + extra, 0.01, np.random.default_rng(0)), 1.0)
        fit = fit_pose(noisy, said, scene.preset.camera.focal_px, sensitivities=CAMERA.sensitivities, **strategies)
        got = pixel_diffraction(fit.known_scene, px.index[sel])
        keep = np.isin(px.index[sel], got.index)
        return float(np.mean(np.abs(got.lambda1_nm - px.lambda1_nm[sel][keep]))) if keep.any() else 1e3

    lit = _lit_disc(scene)
    assert error(lit, escalations=()) < 2.0
    # the thin-lines start (a curve moved through the rainbow's ridge) now rescues it too: without
    # it and without the outline, the wavelengths are read wrong
    assert error(lit, strategies=tuple(s for s in CHEAP if s not in ("outline", "lines")), escalations=()) > 10.0
    assert error(0.0) < 2.0


def test_turning_in_the_plane_of_incidence_keeps_the_plane():
    """turned_in_plane turns disc and lamp about the normal of the plane through disc centre, lens
    and lamp: the lamp stays in that plane and at its distance, the disc normal turns by the tilt,
    nothing moves at zero angles, and a lamp seen next to the lens has no plane (None)."""
    scene = Scene(load_preset("tripod-oblique").with_image_size(64))
    rel = relative_pose.relative_pose(scene)
    centre = np.asarray(rel.disc_centre_mm)
    plane = np.cross(-centre, np.asarray(rel.lamp_mm) - centre)
    plane /= np.linalg.norm(plane)
    same = relative_pose.turned_in_plane(rel, 0.0, 0.0)
    assert np.allclose(same.lamp_mm, rel.lamp_mm) and np.allclose(same.disc_normal, rel.disc_normal)
    turned = relative_pose.turned_in_plane(rel, 2.0, -1.5)
    lamp = np.asarray(turned.lamp_mm) - centre
    assert abs(lamp @ plane) < 1e-9
    assert np.isclose(np.linalg.norm(lamp), np.linalg.norm(np.asarray(rel.lamp_mm) - centre))
    cos = np.clip(np.asarray(turned.disc_normal) @ np.asarray(rel.disc_normal), -1.0, 1.0)
    assert np.isclose(np.degrees(np.arccos(cos)), 2.0)
    on_axis = relative_pose.relative_pose(Scene(load_preset("cd-default").with_image_size(64)))
    assert relative_pose.turned_in_plane(on_axis, 1.0, 1.0) is None


def _noisy_photo(scene: Scene) -> np.ndarray:
    """A linear photo of ``scene`` under _lamp() with 1 % noise (seeded), clipped at full scale."""
    cube = render_cube(scene, supersample=2)
    image, _ = photo.expose(photo.linear_photo(cube, _lamp(), CAMERA), 1.0, photo.track_mask(scene))
    return np.minimum(photo.add_noise(image, 0.01, np.random.default_rng(5)), 1.0)


def _first_order_error(truth: Scene, fitted: Scene) -> tuple[float, float]:
    """On the true first-order pixels of 400–700 nm: the fraction the fitted capture also puts on
    the tracks, and the mean |λ₁ error| there (nm)."""
    px = pixel_diffraction(truth)
    sel = px.on_tracks & (px.visibility > 0.3) & (px.lambda1_nm > 400) & (px.lambda1_nm < 700)
    got = pixel_diffraction(fitted, px.index[sel])
    keep = np.isin(px.index[sel], got.index)
    return float(keep.mean()), float(np.mean(np.abs(got.lambda1_nm - px.lambda1_nm[sel][keep])))


@pytest.mark.slow
@pytest.mark.parametrize("pose", [Pose(light_rotation_deg=(0.0, -3.0)), Pose(tilt_deg=(0.0, 3.0))],
                         ids=["lamp swung 3° in its plane", "disc tilted 3° in that plane"])
def test_an_in_plane_turn_is_found_on_an_oblique_streak(pose):
    """A lamp swung or a disc tilted 3° in the plane of incidence slides the wavelength axis along
    an oblique streak by ~100 nm without moving the streak; from the preset's pose the fit finds
    the true wavelengths (within 1.5 nm on the first-order pixels), not a neighbouring valley."""
    scene = _oblique(pose, name="tripod-oblique")
    noisy = _noisy_photo(scene)
    fit = fit_pose(noisy, load_preset("tripod-oblique"), scene.preset.camera.focal_px,
                                        sensitivities=CAMERA.sensitivities)
    kept, error = _first_order_error(scene, fit.known_scene)
    assert kept > 0.9
    assert error < 1.5


@pytest.mark.slow
@pytest.mark.parametrize("name, zoom", [("cd-default", 0.85), ("phone-near-axis", 1.89)])
def test_a_tilted_disc_under_a_near_axis_camera_is_read_as_tilted(name, zoom):
    """A disc tilted 5° under a camera looking straight down, the lamp beside the lens, mirrors
    the lamp ~10° off: the glint lands ~18 mm from the disc centre and the rings become arcs about
    it. Much the same arcs come from a flat disc with the lamp 10° off. The fit reads the tilt:
    camera and lamp angles from the disc's axis within 1° of the truth (the flat reading is 2–5°
    off), and the first-order pixels' λ₁ within 1 nm. (zoom: the disc ~800 px across, as the
    loader's crop of a real photo.)"""
    from cd_spectra_addon.core.planning.capture_advice import capture_angles

    preset = load_preset(name).with_image_size(SIZE)
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * zoom))
    scene = Scene(preset, Pose(tilt_deg=(5.0, 0.0)))
    noisy = _noisy_photo(scene)
    fit = fit_pose(noisy, load_preset(name), scene.preset.camera.focal_px,
                                        sensitivities=CAMERA.sensitivities, saturated=noisy.max(axis=2) >= 1.0)
    fitted, true = capture_angles(fit.known_scene), capture_angles(scene)
    assert abs(fitted[0] - true[0]) < 1.0 and abs(fitted[1] - true[1]) < 1.0
    kept, error = _first_order_error(scene, fit.known_scene)
    assert kept > 0.9
    assert error < 1.0
