"""Cycles + OSL against the numpy twin and the grating equation (headless bpy, CPU)."""

import math
import re

import bpy
import numpy as np
import pytest
from scipy import special

from cd_spectra_addon.core.scene.capture import Pose, Scene, load_preset
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM
from tests.ring_geometry import coaxial_first_order_radius_px, radial_peak_px
from training.simulation import cycles_scene
from training.simulation.render_numpy import render_cube as numpy_cube

pytestmark = [pytest.mark.blender, pytest.mark.slow]

SIZE = 128
SPP = 32


@pytest.fixture(scope="module")
def cubes():
    scene = Scene(load_preset("cd-default").with_image_size(SIZE))
    cycles, seconds = cycles_scene.render_cube(scene, WAVELENGTHS_NM, SPP)
    reference = numpy_cube(scene, supersample=8)
    return scene, cycles, reference


def psnr(test: np.ndarray, reference: np.ndarray) -> float:
    mse = float(np.mean((test.astype(np.float64) - reference) ** 2))
    return 10 * math.log10(float(reference.max()) ** 2 / mse)


def test_cycles_matches_the_numpy_twin_per_wavelength(cubes):
    _, cycles, reference = cubes
    scores = [psnr(cycles[k], reference[k]) for k in range(WAVELENGTHS_NM.size)]
    assert min(scores) >= 40.0, dict(zip(WAVELENGTHS_NM[np.argsort(scores)[:5]], sorted(scores)[:5]))
    # Energy per band agrees too (no stray factor π or unit slip between the two).
    ratio = cycles.reshape(81, -1).sum(1) / reference.reshape(81, -1).sum(1)
    assert np.all(np.abs(ratio - 1) < 0.01)


def test_cycles_rings_follow_the_grating_equation(cubes):
    scene, cycles, _ = cubes
    centre = scene.project(np.zeros((1, 3)))[0]
    for lam in (400.0, 450.0, 550.0, 650.0, 750.0):
        expected = coaxial_first_order_radius_px(lam, 1.6, scene.preset.camera.focal_px)
        found = radial_peak_px(cycles[int((lam - 380) / 5)], centre, expected - 5, expected + 5)
        assert abs(found - expected) < 1.0, (lam, found, expected)


def test_cycles_output_is_finite_and_non_negative(cubes):
    _, cycles, _ = cubes
    assert np.all(np.isfinite(cycles)) and cycles.min() >= 0


def test_grazing_pose_agrees_with_numpy_and_stays_finite():
    scene = Scene(load_preset("cd-default").with_image_size(48), Pose(light_offset_mm=(0, -400), tilt_deg=(80, 0)))
    lam = np.array([380.0, 385.0, 775.0, 780.0, 550.0, 555.0])
    cycles, _ = cycles_scene.render_cube(scene, lam, 64)
    assert np.all(np.isfinite(cycles)) and cycles.min() >= 0
    full = numpy_cube(scene, supersample=8)
    ref = full[[int((x - 380) / 5) for x in lam]]
    assert ref.max() > 0
    for k in range(lam.size):
        if ref[k].max() > 1e-3 * ref.max():
            assert psnr(cycles[k], ref[k]) > 35.0


def _osl_function(name: str) -> str:
    source = cycles_scene.SHADER_PATH.read_text()
    match = re.search(rf"^float {name}\(.*?^}}", source, re.S | re.M)
    assert match, f"{name} not found in the shader"
    return match.group(0)


def test_osl_bessel_matches_scipy_to_1e5():
    """Render the shader's own bessel_j over x ∈ [0, 12) — one value per pixel — and compare."""
    width = 480
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.shading_system = True
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.render.resolution_x, scene.render.resolution_y = width, 4
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"
    mesh = bpy.data.meshes.new("strip")
    mesh.from_pydata([(0, -1, 0), (12, -1, 0), (12, 1, 0), (0, 1, 0)], [], [(0, 1, 2, 3)])
    strip = bpy.data.objects.new("strip", mesh)
    scene.collection.objects.link(strip)
    cam = bpy.data.cameras.new("ortho")
    cam.type = "ORTHO"
    cam.ortho_scale = 12.0
    cam_obj = bpy.data.objects.new("ortho", cam)
    cam_obj.location = (6.0, 0.0, 5.0)
    scene.collection.objects.link(cam_obj)
    scene.camera = cam_obj
    dx = 12.0 / width
    values = {}
    for orders in ((0, 1, 2), (3, 3, 3)):
        src = (f"#define BESSEL_NODES 32\n{_osl_function('bessel_j')}\n"
               "shader probe(output closure color Emission = 0) {\n"
               f"  float x = (floor(P[0] / {dx!r}) + 0.5) * {dx!r};\n"
               f"  Emission = color(bessel_j({orders[0]}, x) + 1.0, bessel_j({orders[1]}, x) + 1.0,"
               f" bessel_j({orders[2]}, x) + 1.0) * emission();\n}}\n")
        path = cycles_scene.Path(bpy.app.tempdir or "/tmp") / "probe.osl"
        path.write_text(src)
        material = bpy.data.materials.new("probe")
        material.use_nodes = True
        tree = material.node_tree
        tree.nodes.clear()
        node = tree.nodes.new("ShaderNodeScript")
        bytecode, params = cycles_scene.compile_shader(path)
        node.mode = "INTERNAL"
        node.bytecode = bytecode
        node.bytecode_hash = str(hash(bytecode))
        node.outputs.new(type="NodeSocketShader", name="Emission", identifier="Emission")
        out = tree.nodes.new("ShaderNodeOutputMaterial")
        tree.links.new(node.outputs["Emission"], out.inputs["Surface"])
        mesh.materials.clear()
        mesh.materials.append(material)
        rgb = cycles_scene.render_rgb()[1]  # one row of pixels
        for channel, m in enumerate(orders):
            values[m] = rgb[:, channel].astype(np.float64) - 1.0
    x = (np.arange(width) + 0.5) * dx
    for m in range(4):
        assert np.max(np.abs(values[m] - special.jv(m, x))) < 1e-5, m


def test_an_oblique_camera_pose_agrees_with_the_numpy_twin():
    """Full pose: camera 20° off the normal at 150 mm aimed at the centre, lamp 2 m away at 15°.
    Cycles places its camera from Scene.camera_rotation; the twin casts Scene.pixel_rays. A wide
    lobe (σ = 0.03) makes the streak a few pixels wide: a realistic σ = 0.002 streak is ~0.03 px
    wide at this size, and both renderers' per-pixel energies are then sampling luck."""
    from dataclasses import replace

    from cd_spectra_addon.core.scene.capture import preset_from_dict

    data = load_preset("cd-default").with_image_size(64).to_dict()
    eye = [150 * math.sin(math.radians(20)), 0.0, 150 * math.cos(math.radians(20))]
    data["camera"] = {**{k: v for k, v in data["camera"].items() if k != "distance_mm"},
                      "position_mm": eye, "focal_length_mm": 24.0}
    preset = preset_from_dict(data)
    lamp = (2000 * math.sin(math.radians(15)), 0.0, 2000 * math.cos(math.radians(15)))
    scene = Scene(replace(preset, light=replace(preset.light, position_mm=lamp, lobe_sigma=0.03, intensity=90.0)))
    lam = np.array([450.0, 550.0, 650.0])
    cycles, _ = cycles_scene.render_cube(scene, lam, 64)
    full = numpy_cube(scene, supersample=8)
    ref = full[[int((x - 380) / 5) for x in lam]]
    assert np.all(np.isfinite(cycles)) and cycles.min() >= 0
    for k in range(lam.size):
        assert ref[k].max() > 0
        assert psnr(cycles[k], ref[k]) > 35.0, (lam[k], psnr(cycles[k], ref[k]))
    ratio = cycles.reshape(3, -1).sum(1) / ref.reshape(3, -1).sum(1)
    assert np.all(np.abs(ratio - 1) < 0.02), ratio


def test_a_turned_camera_agrees_with_the_numpy_twin():
    """Pose.camera_rotation_deg (a camera aimed a few degrees off) reaches Cycles' camera matrix
    as it reaches the twin's rays: the rings move off the image centre in both alike."""
    from dataclasses import replace

    preset = load_preset("cd-default").with_image_size(64)
    preset = replace(preset, light=replace(preset.light, lobe_sigma=0.03))
    scene = Scene(preset, Pose(camera_rotation_deg=(2.0, -3.0)))
    lam = np.array([450.0, 550.0, 650.0])
    cycles, _ = cycles_scene.render_cube(scene, lam, 64)
    ref = numpy_cube(scene, supersample=8)[[int((x - 380) / 5) for x in lam]]
    straight = numpy_cube(Scene(preset), supersample=8)[[int((x - 380) / 5) for x in lam]]
    for k in range(lam.size):
        assert psnr(cycles[k], ref[k]) > 35.0, (lam[k], psnr(cycles[k], ref[k]))
        assert psnr(straight[k], ref[k]) < 25.0  # the turn really moved the image


def test_cycles_uses_the_box_pixel_filter_and_keeps_sub_pixel_streaks():
    """Cycles' property is pixel_filter_type; setting a misspelt one silently left the Blackman-
    Harris filter on, which weights pixel centres and lost up to 27 % of streaks thinner than a
    pixel (tripod-oblique at 192 px). The twin and Cycles must integrate the same box."""
    scene = Scene(load_preset("tripod-oblique").with_image_size(192))
    cycles_scene.build_capture_scene(scene, 16)
    assert bpy.context.scene.cycles.pixel_filter_type == "BOX" and bpy.context.scene.cycles.filter_width == 1.0
    lam = np.array([450.0, 550.0, 650.0])
    cycles, _ = cycles_scene.render_cube(scene, lam, 2048)
    ref = numpy_cube(scene, supersample=8)[[int((x - 380) / 5) for x in lam]]
    ratio = cycles.reshape(3, -1).mean(1) / ref.reshape(3, -1).mean(1)
    # Before the fix: 0.76 / 0.75 / 0.73. The streak is a few pixels, so sampling noise is ~1 %.
    assert np.all(np.abs(ratio - 1) < 0.04), ratio


def test_every_cycles_setting_the_scene_makes_exists():
    """Blender's Cycles settings accept any attribute name without complaint; a misspelt one is
    simply ignored (that is how the box filter was lost). Check every name set on scene.cycles."""
    names = set(re.findall(r"cyc\.([a-z_]+)\s*=", cycles_scene.SHADER_PATH.parent.parent.joinpath(
        "cycles_scene.py").read_text()))
    assert {"pixel_filter_type", "filter_width", "samples"} <= names
    known = bpy.context.scene.cycles.bl_rna.properties
    assert sorted(n for n in names if n not in known) == []
