"""The pose fit's start strategies, one by one: each proposes finite captures under its own name,
and the ones that read the photo put their capture where the photo says."""

from __future__ import annotations

import numpy as np
import pytest

from cd_spectra_addon.core.pose import starts
from cd_spectra_addon.core.pose.fit import fit_pose
from cd_spectra_addon.core.pose.rim_ellipse import disc_ellipse, project_circle
from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.scene.kernel import project
from cd_spectra_addon.core.scene.relative_pose import mirror_point, relative_pose
from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from training.simulation import photo
from training.simulation.render_numpy import render_cube

CAMERA = load_camera(DEFAULT_CAMERA)
SIZE = 192


def _context(name: str, pose: Pose) -> tuple[Scene, starts.StartContext, np.ndarray]:
    scene = Scene(load_preset(name).with_image_size(SIZE), pose)
    image, _ = photo.expose(photo.linear_photo(render_cube(scene, supersample=2), np.linspace(0.4, 1.0, 81), CAMERA),
                            1.0, photo.track_mask(scene))
    clipped = image.max(axis=2) >= 1.0
    image = np.minimum(image, 1.0)
    ctx = starts.StartContext(image, clipped, load_preset(name), scene.preset.camera.focal_px, CAMERA.sensitivities,
                              disc_ellipse(image, clipped))
    return scene, ctx, image


@pytest.mark.parametrize("name", ["cd-default", "tripod-oblique"])
def test_every_strategy_names_its_starts_and_gives_finite_captures(name):
    scene, ctx, _ = _context(name, Pose(light_offset_mm=(4.0, 0.0), tilt_deg=(1.0, 0.0)))
    ctx.found.extend(starts.STRATEGIES["preset"](ctx))
    ctx.cost = lambda rel: float(np.sum(rel.disc_centre_mm ** 2) * 0.0 + 1.0)  # a flat cost: any start is a start
    ctx.fresh_cost = ctx.cost
    truth = relative_pose(scene)  # the outline a lit table would show, for the strategies that read it
    ctx.outline = project_circle(truth.disc_centre_mm, truth.disc_normal, 60.0, ctx.focal_px, ctx.size)
    proposed = set()
    for outline in (ctx.outline, None):  # (lamp-grid and tilted read an oblique disc with no outline)
        ctx.outline = outline
        for key, strategy in starts.STRATEGIES.items():
            for s in strategy(ctx):
                assert s.strategy.split(" ")[0] == key, (key, s.strategy)
                rel = s.capture
                assert np.all(np.isfinite(rel.disc_centre_mm)) and np.all(np.isfinite(rel.lamp_mm))
                assert np.isclose(np.linalg.norm(rel.disc_normal), 1.0) and rel.lobe_sigma > 0
                proposed.add(key)
    if name == "tripod-oblique":
        assert {"lamp-grid", "tilted", "outline-lamp"} <= proposed
    assert set(starts.CHEAP) | set(starts.ESCALATIONS) == set(starts.STRATEGIES)


def test_the_rings_start_puts_the_mirror_point_on_the_rings_centre():
    """A coaxial lamp moved 6 mm: the rings' symmetry centre is the mirror point, and the rings
    start that moves the lamp puts its mirror point there (within a pixel)."""
    scene, ctx, _ = _context("cd-default", Pose(light_offset_mm=(6.0, 0.0)))
    truth = project(mirror_point(relative_pose(scene)), (SIZE, SIZE), ctx.focal_px)
    found = starts.STRATEGIES["rings"](ctx)
    assert found
    first = project(mirror_point(found[0].capture), (SIZE, SIZE), ctx.focal_px)
    assert np.hypot(*(first - truth)) < 1.0


def test_the_glint_start_tilts_the_disc_to_its_clipped_glint():
    """A disc tilted 4° under a near-axis camera: the clipped glint is the mirror point, and the
    glint start's disc mirrors the lamp there; the fit restricted to the preset reads the disc
    as flat (4° off), with the glint start too within a degree (192 px: a pixel is ~0.2°)."""
    scene, ctx, image = _context("phone-near-axis", Pose(tilt_deg=(4.0, 0.0)))
    found = starts.STRATEGIES["glint"](ctx)
    assert len(found) == 1
    glint = starts.glint_px(image, ctx.saturated)
    got = project(mirror_point(found[0].capture), (SIZE, SIZE), ctx.focal_px)
    assert np.hypot(*(got - np.asarray(glint))) < 0.5
    truth = relative_pose(scene).disc_normal

    def tilt_error(strategies: tuple[str, ...]) -> float:
        fit = fit_pose(image, load_preset("phone-near-axis"), ctx.focal_px, CAMERA.sensitivities, ctx.saturated,
                       strategies=strategies, escalations=())
        return float(np.degrees(np.arccos(np.clip(relative_pose(fit.known_scene).disc_normal @ truth, -1, 1))))

    assert tilt_error(("preset", "glint")) < 1.0 < 3.0 < tilt_error(("preset",))


@pytest.mark.slow
def test_a_tripod_capture_far_from_its_preset_is_found_by_the_lamp_grid_and_its_tilts(tmp_path):
    """pose_errors' tripod combined capture 3 on a black cloth (camera aimed 2.7° off, disc tilted
    2.3°, lamp swung and moved: the streak turned ~40° in the image), a synthetic tri-phosphor
    lamp of the training prior, through the product's loader: without ``lamp-grid`` and
    ``tilted`` the fit settles in a neighbouring capture (λ₁ ~18 nm off); with them within a
    nanometre and a half."""
    from cd_spectra_addon.core.inverse.load import load_for_estimate
    from cd_spectra_addon.core.inverse.stages import pose_photo
    from training.evaluation.pose_errors import crop_preset, pose_report, write_capture
    from training.learning.spd_prior import sample_spds

    pose = Pose(camera_offset_mm=(1.0, 1.2), light_offset_mm=(-1.8, -2.5), tilt_deg=(-0.2, 2.3),
                camera_rotation_deg=(0.4, -2.7), light_rotation_deg=(1.0, 1.4))
    preset, _ = crop_preset("tripod-oblique")
    scene = Scene(preset, pose)
    spds, families = sample_spds(4, np.random.default_rng(4242))
    assert families[1] == "fluorescent_tri"
    path = tmp_path / "capture.jpg"
    write_capture(path, scene, render_cube(scene, supersample=2), spds[1], 0.0075, None, seed=1001)
    loaded = load_for_estimate(path, preset)
    height, width = loaded.rgb.shape[:2]
    truth = Scene(preset.with_image_size(width, height), pose)

    def error_nm(escalations: tuple[str, ...]) -> float:
        return pose_report(pose_photo(loaded, preset, CAMERA, escalations=escalations).fit, truth)["dlambda_nm"]

    assert error_nm(starts.ESCALATIONS) < 1.5
    assert error_nm(tuple(n for n in starts.ESCALATIONS if n not in ("lamp-grid", "tilted"))) > 5.0


def test_the_fits_tiers_run_every_strategy_once_cheap_ones_first():
    """fit.TIERS orders the strategies the fit runs; starts names them (CHEAP, ESCALATIONS): a
    strategy added to one and not the other would never run, or run unnamed."""
    from cd_spectra_addon.core.pose.fit import TIERS

    order = [name for tier in TIERS for name in tier]
    assert sorted(order) == sorted(starts.STRATEGIES) and len(order) == len(set(order))
    assert set(order[:len(starts.CHEAP)]) == set(starts.CHEAP)
    assert set(order[len(starts.CHEAP):]) == set(starts.ESCALATIONS)
