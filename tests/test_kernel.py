"""The geometric kernel: rays and projection invert each other, the diffraction coordinate follows
the grating equation, and its derivatives (the pose fit's Jacobian) are the true ones."""

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.pose.self_consistency import ProfileGrid, RayGeometry, SelfConsistency, footprint_v_span
from cd_spectra_addon.core.scene import kernel
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.scene.relative_pose import apply_params, relative_pose
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)


@settings(max_examples=40, deadline=None)
@given(st.floats(0.0, 499.0), st.floats(0.0, 299.0), st.floats(100.0, 3000.0), st.floats(50.0, 2000.0))
def test_projection_inverts_the_rays(row, col, focal, distance):
    """A point on the ray through (row, col) projects back onto (row, col), at any distance."""
    ray = kernel.camera_rays(np.array([row]), np.array([col]), (300, 500), focal)
    back = kernel.project(ray * distance, (300, 500), focal)
    assert np.allclose(back[0], [row, col], atol=1e-9)
    assert np.isclose(np.linalg.norm(ray), 1.0)


def test_rotations_are_rotations():
    rng = np.random.default_rng(0)
    for _ in range(10):
        a, b = rng.normal(size=3), rng.normal(size=3)
        a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
        turn = kernel.turn_between(a, b)
        assert np.allclose(turn @ a, b) and np.allclose(turn @ turn.T, np.eye(3))
        r = kernel.rotation_about(a, 37.0)
        assert np.allclose(r @ a, a) and np.isclose(np.degrees(np.arccos((np.trace(r) - 1) / 2)), 37.0)
    assert np.allclose(kernel.turn_between(a, -a) @ a, -a)  # half a turn has no unique axis, but exists


@pytest.mark.parametrize("angle_deg", [0.0, 10.0, 30.0])
def test_the_first_order_wavelength_is_the_grating_equations(angle_deg):
    """For lamp and camera far away in one plane with the disc normal, the kernel's λ₁ at any
    point of the line through the centre is d·|sin θi + sin θo| (the grating equation, m = 1)."""
    theta_i, theta_o = np.radians(angle_deg + 20.0), np.radians(-angle_deg)
    far = 1e10
    lamp = far * np.array([np.sin(theta_i), 0.0, np.cos(theta_i)])
    eye = far * np.array([np.sin(theta_o), 0.0, np.cos(theta_o)])
    points = np.array([[30.0, 0.0, 0.0], [-45.0, 0.0, 0.0]])
    view = (eye - points) / np.linalg.norm(eye - points, axis=1, keepdims=True)
    geo = kernel.diffraction_at(points, view, np.zeros(3), np.array([0.0, 0.0, 1.0]), lamp)
    expected = 1600.0 * abs(np.sin(theta_i) + np.sin(theta_o))
    assert np.allclose(geo.lambda1_nm(1.6), expected, rtol=1e-7)
    assert np.allclose(geo.v, 0.0, atol=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.floats(-20.0, 20.0), st.floats(-20.0, 20.0), st.floats(-0.15, 0.15), st.floats(-0.15, 0.15),
       st.floats(-80.0, 80.0), st.floats(-80.0, 80.0), st.floats(-300.0, 100.0))
def test_kernel_derivatives_match_finite_differences(px, py, nx, ny, lx, ly, lz):
    """∂u, ∂v, ∂gain and ∂radius along random changes of disc centre, normal and lamp equal
    central differences of the kernel itself."""
    rng = np.random.default_rng(1)
    rays = kernel.camera_rays(rng.uniform(0, 300, 60), rng.uniform(0, 300, 60), (300, 300), 400.0)
    centre = np.array([px, py, -210.0])
    normal = np.array([nx, ny, 1.0]) / np.linalg.norm([nx, ny, 1.0])
    lamp = np.array([lx, ly, lz])
    dirs = rng.normal(size=(9, 3))
    dirs[3:6] -= normal[:, None] * (normal @ dirs[3:6])  # a unit normal changes perpendicularly
    hit, geo = kernel.diffraction_along(rays, np.zeros(3), centre, normal, lamp, directions=dirs)
    h = 1e-6
    for j in range(dirs.shape[1]):
        moved = []
        for sign in (1.0, -1.0):
            n = normal + sign * h * dirs[3:6, j]
            _, g = kernel.diffraction_along(rays, np.zeros(3), centre + sign * h * dirs[0:3, j], n / np.linalg.norm(n),
                                            lamp + sign * h * dirs[6:9, j])
            moved.append(g)
        for name in ("u", "v", "gain", "radius"):
            numeric = (getattr(moved[0], name) - getattr(moved[1], name)) / (2 * h)
            analytic = getattr(geo.derivatives, name)[:, j]
            live = geo.gain > 0 if name == "gain" else slice(None)
            assert np.allclose(analytic[live], numeric[live], rtol=1e-4, atol=1e-6 * (1 + np.abs(numeric).max()))


@pytest.mark.parametrize("name", ["tripod-oblique", "phone-near-axis"])
def test_the_self_consistency_gradient_is_exact(name):
    """The pose fit's Jacobian (kernel derivatives through the variable projection) gives the
    same cost gradient as central differences of the residuals, for a pose a little off."""
    preset = load_preset(name).with_image_size(192)
    zoom = {"tripod-oblique": 3.2, "phone-near-axis": 1.9}[name]  # the disc across most of the frame
    preset = replace(preset, camera=replace(preset.camera, focal_length_mm=preset.camera.focal_length_mm * zoom))
    scene = Scene(preset, Pose(tilt_deg=(1.0, 0.5)))
    image = photo.linear_photo(render_cube(scene, supersample=2), np.linspace(0.3, 1.0, 81), CAMERA)
    flat = (image / image.max()).reshape(-1, 3)
    index = np.unique(np.concatenate([np.argsort(flat.sum(axis=1))[-1500:], np.arange(0, flat.shape[0], 23)]))
    rel0 = relative_pose(scene)
    f = preset.camera.focal_px
    hit, geo = kernel.diffraction_along(kernel.index_rays(index, (192, 192), f), np.zeros(3), rel0.disc_centre_mm,
                                        rel0.disc_normal, rel0.lamp_mm)
    glint = np.zeros(index.size, bool)
    glint[hit] = np.hypot(geo.u, geo.v) < 6 * rel0.lobe_sigma + 4 / f  # the zero order: not this model's
    index = index[~glint]
    flat = flat / flat[index].max()
    grid = ProfileGrid.with_camera(300.0, 2500.0, 5.0, CAMERA.sensitivities, 3.0, 1.0)
    rows, cols = np.divmod(index, 192)
    objective = SelfConsistency(flat[index], kernel.index_rays(index, (192, 192), f), preset.disc, grid,
                                lambda x: apply_params(rel0, x), rel0.distance_mm / f,
                                blur_v=footprint_v_span(rows, cols, 1.0, (192, 192), f, rel0))
    x = np.array([0.02, -0.015, 0.03, 0.02, -0.02, 0.01, 0.0, 0.03])
    free = np.array([0, 1, 2, 3, 4, 5, 7])
    jac = objective.jacobian(x, free)
    r = objective(x)
    numeric = np.zeros_like(jac)
    for j, p in enumerate(free):
        dx = np.zeros(8)
        dx[p] = 1e-5
        numeric[:, j] = (objective(x + dx) - objective(x - dx)) / 2e-5
    assert jac.shape == (r.size, free.size)
    assert float(r @ r) < 0.3  # near the truth: the rainbow is mostly explained
    g, gn = jac.T @ r, numeric.T @ r
    # The profile's smoothing scales with the mean node weight, which the Jacobian holds fixed:
    # a few per cent on single components, nothing on the gradient's direction.
    assert g @ gn / (np.linalg.norm(g) * np.linalg.norm(gn)) > 0.999
    assert np.allclose(g, gn, rtol=0.1, atol=0.02 * np.abs(gn).max())


def test_derivatives_in_passes_are_those_of_one_pass(monkeypatch):
    """Many rays are differentiated in passes of DERIVATIVE_CHUNK (for the cache): the same
    values, hits and order as one pass over them all."""
    rng = np.random.default_rng(3)
    n = 2 * kernel.DERIVATIVE_CHUNK + 77
    rays = kernel.camera_rays(rng.uniform(-200, 500, n), rng.uniform(-200, 500, n), (300, 300), 400.0)
    rays[rng.random(n) < 0.1, 2] *= -1.0  # looking away from the disc's plane: no hit
    normal = np.array([0.05, -0.02, 1.0]) / np.linalg.norm([0.05, -0.02, 1.0])
    args = (rays, np.zeros(3), np.array([3.0, -2.0, -210.0]), normal, np.array([40.0, 10.0, -20.0]))
    dirs = rng.normal(size=(9, 4))
    hit, geo = kernel.diffraction_along(*args, directions=dirs)
    monkeypatch.setattr(kernel, "DERIVATIVE_CHUNK", 10 * n)
    hit1, geo1 = kernel.diffraction_along(*args, directions=dirs)
    assert not hit.all() and np.array_equal(hit, hit1)  # some rays miss: the passes keep their places
    for name in ("points_c", "u", "v", "gain", "view_c", "radial_c"):
        assert np.array_equal(getattr(geo, name), getattr(geo1, name))
    for name in ("u", "v", "gain", "radius"):
        assert np.array_equal(getattr(geo.derivatives, name), getattr(geo1.derivatives, name))


def test_a_capture_s_geometry_taken_for_some_rays_is_the_kernel_s_for_those_rays():
    """RayGeometry.take (how one capture's lamp sizes and glint masks share one evaluation of
    the kernel) gives, value for value, what the kernel gives the kept rays alone; and a
    SelfConsistency handed the geometry costs a capture exactly as one that evaluates it."""
    preset = load_preset("cd-default").with_image_size(128)
    scene = Scene(preset, Pose(tilt_deg=(1.0, 0.5)))
    rel = relative_pose(scene)
    f = preset.camera.focal_px
    rng = np.random.default_rng(5)
    index = np.unique(rng.integers(0, 128 * 128, 3000))
    rays = kernel.index_rays(index, (128, 128), f)
    rays[::17, 2] *= -1.0  # some rays miss the disc's plane
    whole = RayGeometry.of(rays, rel)
    keep = rng.random(index.size) < 0.6
    part = whole.take(keep)
    alone = RayGeometry.of(rays[keep], rel)
    assert not whole.hit.all() and np.array_equal(part.hit, alone.hit)
    for name in ("points_c", "radius", "u", "v", "cos_i", "cos_o", "gain", "view_c", "radial_c"):
        assert np.array_equal(getattr(part.geo, name), getattr(alone.geo, name))
    image = photo.linear_photo(render_cube(scene), np.linspace(0.3, 1.0, 81), CAMERA)
    values = (image / image.max()).reshape(-1, 3)[index]
    grid = ProfileGrid.with_camera(300.0, 2500.0, 5.0, CAMERA.sensitivities, 3.0, 1.0)

    def objective(**shared) -> SelfConsistency:
        return SelfConsistency(values[keep], rays[keep], preset.disc, grid, lambda x: apply_params(rel, x),
                               rel.distance_mm / f, **shared)

    plain, given_part = objective(), objective(geometry=whole, subset=keep)
    assert np.array_equal(plain.residuals_at(rel), given_part.residuals_at(rel))
    moved = apply_params(rel, np.array([0.01, 0, 0, 0, 0, 0, 0, 0]))
    assert np.array_equal(plain.residuals_at(moved), given_part.residuals_at(moved))  # another capture: evaluated
