"""Headless Cycles capture scene: the disc with the OSL grating shader, a pinhole camera, nothing else.

The shader carries the lamp as a parameter and emits what the camera sees, so the scene has no
light objects, no world light and no bounces; only camera rays that hit the disc do work.
The bpy wheel lacks ``oslquery``, so the shader is compiled with Cycles' own compiler and the
script node's sockets are created from the parameter list of the compiled ``.oso``.
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import time
from pathlib import Path

import bpy
import mathutils
import numpy as np
import OpenEXR
from numpy.typing import NDArray

from cd_spectra_addon.core.scene.capture import Scene

SHADER_PATH = Path(__file__).resolve().parent / "shaders" / "cd_grating.osl"
_SOCKET_TYPES = {
    "float": "NodeSocketFloat",
    "int": "NodeSocketInt",
    "point": "NodeSocketVector",
    "vector": "NodeSocketVector",
    "normal": "NodeSocketVector",
    "color": "NodeSocketColor",
    "closure color": "NodeSocketShader",
}

__all__ = ["SHADER_PATH", "compile_shader", "build_capture_scene", "set_bands", "render_rgb", "render_cube"]


def compile_shader(source_path: Path | None = None) -> tuple[str, list[tuple[bool, str, str, list[str]]]]:
    """OSO bytecode of the shader and its parameters as (is_output, osl_type, name, defaults)."""
    import _cycles  # Cycles' embedded OSL compiler, present in the bpy wheel

    source_path = SHADER_PATH if source_path is None else source_path
    with tempfile.TemporaryDirectory() as tmp:
        oso_path = os.path.join(tmp, "cd_grating.oso")
        if not _cycles.osl_compile(str(source_path), oso_path):
            raise RuntimeError(f"OSL compilation of {source_path} failed (see stderr)")
        bytecode = Path(oso_path).read_text()
    params: list[tuple[bool, str, str, list[str]]] = []
    for line in bytecode.splitlines():
        fields = line.split("\t")
        if fields[0] in ("param", "oparam"):
            defaults = [f for f in fields[3:] if f and not f.startswith("%")]
            params.append((fields[0] == "oparam", fields[1], fields[2], defaults))
    return bytecode, params


def _script_node(tree: bpy.types.NodeTree) -> bpy.types.Node:
    bytecode, params = compile_shader()
    node = tree.nodes.new("ShaderNodeScript")
    node.name = "cd_grating"
    node.mode = "INTERNAL"
    # No node.script: assigning a text makes Cycles re-compile and query it with oslquery,
    # which the wheel lacks. The bytecode alone is what Cycles renders.
    node.bytecode = bytecode
    node.bytecode_hash = hashlib.md5(bytecode.encode(), usedforsecurity=False).hexdigest()
    for is_output, osl_type, name, defaults in params:
        sockets = node.outputs if is_output else node.inputs
        if name in sockets:
            continue
        socket = sockets.new(type=_SOCKET_TYPES[osl_type], name=name, identifier=name)
        if not is_output and defaults:
            # The shader's own defaults, as a real Blender's oslquery would set them.
            values = [float(v) for v in defaults[0].split()]
            if osl_type == "int":
                socket.default_value = int(values[0])
            elif osl_type == "color":
                socket.default_value = (*values[:3], 1.0)[: len(socket.default_value)]
            elif len(values) == 1:
                socket.default_value = values[0]
            else:
                socket.default_value = values[:3]
    return node


def _disc_mesh(inner_m: float, outer_m: float, segments: int = 512) -> bpy.types.Mesh:
    angles = np.arange(segments) * (2.0 * math.pi / segments)
    ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(segments)], axis=1)
    verts = np.concatenate([ring * inner_m, ring * outer_m]).tolist()
    # Counter-clockwise seen from +z, so the faces' normals point at the camera.
    faces = [(i, segments + i, segments + (i + 1) % segments, (i + 1) % segments) for i in range(segments)]
    mesh = bpy.data.meshes.new("cd_disc")
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    return mesh


def build_capture_scene(capture: Scene, samples: int, seed: int = 0) -> bpy.types.Node:
    """Reset Blender to an empty file and build the capture; returns the grating script node."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    preset = capture.preset
    disc = preset.disc

    scene.render.engine = "CYCLES"
    cyc = scene.cycles
    cyc.device = "CPU"
    cyc.shading_system = True  # OSL
    cyc.samples = int(samples)
    cyc.use_adaptive_sampling = False
    cyc.use_denoising = False
    cyc.seed = int(seed)
    cyc.use_animated_seed = False
    cyc.pixel_filter_type = "BOX"  # the numpy twin's box filter ("filter_type" is not a Cycles property)
    cyc.filter_width = 1.0
    for attr in ("max_bounces", "diffuse_bounces", "glossy_bounces", "transmission_bounces",
                 "volume_bounces", "transparent_max_bounces"):
        setattr(cyc, attr, 0)
    cyc.caustics_reflective = False
    cyc.caustics_refractive = False
    cyc.sample_clamp_direct = 0.0
    cyc.sample_clamp_indirect = 0.0
    cyc.film_exposure = 1.0
    scene.render.film_transparent = False
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.render.use_compositing = False
    scene.render.use_sequencer = False
    width, height = preset.camera.image_size_px
    scene.render.resolution_x = width
    scene.render.resolution_y = height
    scene.render.resolution_percentage = 100
    scene.render.pixel_aspect_x = scene.render.pixel_aspect_y = 1.0
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_depth = "32"
    settings.color_mode = "RGB"
    settings.exr_codec = "NONE"

    world = bpy.data.worlds.new("black")
    world.use_nodes = False
    world.color = (0.0, 0.0, 0.0)
    scene.world = world

    cam_data = bpy.data.cameras.new("capture_camera")
    cam_data.type = "PERSP"
    cam_data.lens = preset.camera.focal_length_mm
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = preset.camera.sensor_width_mm
    cam_data.clip_start = 1e-3
    cam_data.clip_end = 100.0
    cam = bpy.data.objects.new("capture_camera", cam_data)
    if capture.looks_straight_down:
        cam.location = capture.camera_position.tolist()
        cam.rotation_euler = (0.0, 0.0, 0.0)  # looks down −z, image up = +y
    else:  # full pose: Blender's camera also looks down its own −z with +y up in the image
        placement = np.eye(4)
        placement[:3, :3] = capture.camera_rotation
        placement[:3, 3] = capture.camera_position
        cam.matrix_world = mathutils.Matrix(placement.tolist())
    scene.collection.objects.link(cam)
    scene.camera = cam

    disc_obj = bpy.data.objects.new("cd_disc", _disc_mesh(disc.hole_radius_mm * 1e-3, disc.rim_radius_mm * 1e-3))
    rot = capture.disc_rotation
    placement = np.eye(4)
    placement[:3, :3] = rot
    placement[:3, 3] = capture.disc_center
    disc_obj.matrix_world = mathutils.Matrix(placement.tolist())  # rows; a bare list would be read as columns
    scene.collection.objects.link(disc_obj)

    material = bpy.data.materials.new("cd_grating")
    material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    node = _script_node(tree)
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(node.outputs["Emission"], out.inputs["Surface"])
    disc_obj.data.materials.append(material)

    values = {
        "pitch_um": disc.pitch_um,
        "groove_height_um": disc.groove_height_um,
        "profile": 0 if disc.profile == "sinusoidal" else 1,
        "duty": disc.duty,
        "medium_index": disc.medium_index,
        "lobe_sigma": preset.light.lobe_sigma,
        "max_order": disc.max_order,
        "light_position": capture.light_position.tolist(),
        "light_intensity": preset.light.intensity,
        "disc_center": capture.disc_center.tolist(),
        "disc_normal": capture.disc_normal.tolist(),
        "grating_r_min": disc.grating_r_min_mm * 1e-3,
        "grating_r_max": disc.grating_r_max_mm * 1e-3,
        "diffuse_albedo": disc.diffuse_albedo,
    }
    for name, value in values.items():
        node.inputs[name].default_value = value

    # Only the disc's bounding box on the image needs rays.
    rim = disc.rim_radius_mm * 1e-3
    corners = np.array([[x, y, 0.0] for x in (-rim, rim) for y in (-rim, rim)]) @ rot.T + capture.disc_center
    rc = capture.project(corners)
    col0, col1 = np.clip([rc[:, 1].min() - 1, rc[:, 1].max() + 2], 0, width)
    row0, row1 = np.clip([rc[:, 0].min() - 1, rc[:, 0].max() + 2], 0, height)
    scene.render.use_border = True
    scene.render.use_crop_to_border = False
    scene.render.border_min_x = col0 / width
    scene.render.border_max_x = col1 / width
    scene.render.border_min_y = 1.0 - row1 / height  # Blender's border y runs upwards
    scene.render.border_max_y = 1.0 - row0 / height
    return node


def set_bands(node: bpy.types.Node, centers_nm: tuple[float, float, float]) -> None:
    node.inputs["lambda_r"].default_value = float(centers_nm[0])
    node.inputs["lambda_g"].default_value = float(centers_nm[1])
    node.inputs["lambda_b"].default_value = float(centers_nm[2])


def render_rgb() -> NDArray[np.float32]:
    """Render the current scene; (height, width, 3) linear radiance, row 0 at the top."""
    scene = bpy.context.scene
    with tempfile.TemporaryDirectory() as tmp:
        scene.render.filepath = os.path.join(tmp, "band.exr")
        bpy.ops.render.render(write_still=True)
        with OpenEXR.File(scene.render.filepath) as exr:
            channels = exr.channels()  # grouped by OpenEXR: "RGB" or "RGBA"
            key = "RGB" if "RGB" in channels else "RGBA"
            rgb = np.asarray(channels[key].pixels, dtype=np.float32)
    return rgb[..., :3].copy()


def render_cube(
    capture: Scene, wavelengths_nm: NDArray[np.float64], samples: int, seed: int = 0
) -> tuple[NDArray[np.float32], float]:
    """(bands, height, width) radiance cube, three bands per render, and seconds spent."""
    start = time.perf_counter()
    node = build_capture_scene(capture, samples, seed)
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    width, height = capture.preset.camera.image_size_px
    cube = np.zeros((lam.size, height, width), dtype=np.float32)
    for first in range(0, lam.size, 3):
        idx = list(range(first, min(first + 3, lam.size)))
        triple = [lam[i] for i in idx] + [lam[idx[-1]]] * (3 - len(idx))
        set_bands(node, tuple(triple))
        rgb = render_rgb()
        for k, i in enumerate(idx):
            cube[i] = rgb[..., k]
    return cube, time.perf_counter() - start
