"""Lights that carry an SPD: the node group wired for Cycles, ``light.color`` for EEVEE.

Used by the operators and by the command line's ``--blend``. Every function checks its input
before it touches ``bpy.data``, so a failure leaves the file as it was (no half-made light).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import bpy
from mathutils import Vector

from .node_group import (
    HASH_KEY,
    KEY,
    ensure_node_group,
    find_node_group,
    metadata_properties,
    spd_hash,
)

if TYPE_CHECKING:
    from ..core.spectra.colour import SpectralColour

GROUP_NODE = "CD Spectra"
# Blender's own defaults for Add › Light (W, or W/m² for the sun).
DEFAULT_ENERGY = {"POINT": 10.0, "SPOT": 10.0, "AREA": 10.0, "SUN": 1.0}


def check_colour(info: SpectralColour) -> None:
    """Refuse NaN, infinite or negative colours before anything is created."""
    if len(info.rgb) != 3 or not all(math.isfinite(c) and 0.0 <= c for c in info.rgb) or max(info.rgb) <= 0:
        raise ValueError(f"the SPD gives no usable light colour ({info.rgb})")


def light_name(meta: dict[str, Any], info: SpectralColour) -> str:
    label = meta.get("name") or "CD Spectra"
    return f"{label} {info.cct_k:.0f}K" if info.cct_k else str(label)


def _wire(light: bpy.types.Light, group: bpy.types.NodeTree) -> None:
    """Group "Color" → Emission "Color" in the light's node tree (what Cycles renders)."""
    # Blender 5 lights always use nodes and deprecate use_nodes (removed in 6.0); 4.x needs it on.
    if bpy.app.version < (5, 0, 0) and not light.use_nodes:
        light.use_nodes = True
    tree = light.node_tree
    if tree is None:
        raise RuntimeError("Blender did not create a node tree for the light")
    nodes = tree.nodes
    emission = next((n for n in nodes if n.bl_idname == "ShaderNodeEmission"), None)
    output = next((n for n in nodes if n.bl_idname == "ShaderNodeOutputLight"), None)
    if output is None:
        output = nodes.new("ShaderNodeOutputLight")
        output.location = (300, 0)
    if emission is None:
        emission = nodes.new("ShaderNodeEmission")
        emission.location = (100, 0)
    if not emission.outputs["Emission"].is_linked:
        tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])
    for node in [n for n in nodes if n.bl_idname == "ShaderNodeGroup"
                 and n.node_tree is not None and n.node_tree.get(HASH_KEY)]:
        nodes.remove(node)  # the previous SPD of this light
    node = nodes.new("ShaderNodeGroup")
    node.name = node.label = GROUP_NODE
    node.node_tree = group
    node.location = (emission.location.x - 250, emission.location.y)
    tree.links.new(node.outputs["Color"], emission.inputs["Color"])


def apply_spd(light: bpy.types.Light, spd: Sequence[float], info: SpectralColour,
              meta: dict[str, Any] | None = None) -> bpy.types.NodeTree:
    """Give an existing light this SPD: colour, node group and custom properties.

    Energy, size and type stay as the artist set them.
    """
    check_colour(info)
    meta = dict(meta or {})
    group_existed = find_node_group(spd_hash(spd)) is not None
    group = ensure_node_group(spd, info, meta)
    try:
        _wire(light, group)
    except Exception:
        if not group_existed:  # made for this light only: do not leave it behind
            bpy.data.node_groups.remove(group)
        raise
    light.color = info.rgb
    for key in [k for k in light.keys() if k.startswith(KEY)]:
        del light[key]
    for key, value in metadata_properties(spd, info, meta).items():
        light[key] = value
    return group


def create_light(collection: bpy.types.Collection, spd: Sequence[float],
                 info: SpectralColour, meta: dict[str, Any] | None = None, light_type: str = "SPOT",
                 location: Sequence[float] = (0.0, 0.0, 0.0)) -> bpy.types.Object:
    """A new light object with this SPD at ``location``, linked into ``collection``."""
    if light_type not in DEFAULT_ENERGY:
        raise ValueError(f"unknown light type {light_type!r}; use one of {', '.join(DEFAULT_ENERGY)}")
    check_colour(info)
    meta = dict(meta or {})
    name = light_name(meta, info)
    group_existed = find_node_group(spd_hash(spd)) is not None
    light = bpy.data.lights.new(name, light_type)
    obj = None
    try:
        light.energy = DEFAULT_ENERGY[light_type]
        apply_spd(light, spd, info, meta)
        obj = bpy.data.objects.new(name, light)
        obj.location = Vector(location)
        collection.objects.link(obj)
    except Exception:
        if obj is not None:
            bpy.data.objects.remove(obj)
        bpy.data.lights.remove(light)
        group = None if group_existed else find_node_group(spd_hash(spd))
        if group is not None:
            bpy.data.node_groups.remove(group)
        raise
    return obj
