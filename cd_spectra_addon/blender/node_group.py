"""The "spectral light" shader node group: one per SPD, reused, never duplicated.

Inside: the SPD as a Float Curve over 380–780 nm (x normalised to 0–1, linear segments, as the
product's hat-function grid defines an SPD), a "Power" output at an input wavelength for
band-wise spectral rendering, and a "Color" output holding the scene-linear emission colour.
The colour is computed once in Python by the core's colour module (tables baked from
colour-science), not by nodes: shader nodes cannot integrate a spectrum against CIE functions,
and one number per light is all a renderer needs.

The SPD, wavelengths and metadata are stored as custom properties on the group (and on lights
that use it), so a .blend round-trips without the add-on.
"""

from __future__ import annotations

import hashlib
import struct
from typing import TYPE_CHECKING, Any, Sequence

import bpy

from ..core.spectra.grid import N_BANDS, WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, WAVELENGTHS_NM

if TYPE_CHECKING:  # the colour is computed by the callers (core.spectra.colour, loaded on first use)
    from ..core.spectra.colour import SpectralColour

GROUP_PREFIX = "CD Spectra SPD"
KEY = "cd_spectra"  # prefix of every custom property the add-on writes
HASH_KEY = f"{KEY}_hash"
CURVE_NODE = "SPD"
COLOUR_NODE = "Emission colour"
WAVELENGTH_NODE = "Wavelength to curve x"
WAVELENGTH_SOCKET = "Wavelength"
COLOUR_SOCKET = "Color"
POWER_SOCKET = "Power"
# Rendition figures a light carries as custom properties (with ``_range`` = [low, high]).
RENDITION_PROPERTIES = ("cri_ra", "cri_r9", "tm30_rf", "tm30_rg")


def spd_hash(spd: Sequence[float]) -> str:
    """Identity of an SPD: the same values (to 1e-6) give the same group."""
    if len(spd) != N_BANDS:
        raise ValueError(f"an SPD has {N_BANDS} values, got {len(spd)}")
    packed = struct.pack(f"<{N_BANDS}d", *(round(float(v), 6) + 0.0 for v in spd))
    return hashlib.sha1(packed).hexdigest()[:12]


def find_node_group(digest: str) -> bpy.types.NodeTree | None:
    for group in bpy.data.node_groups:
        if group.bl_idname == "ShaderNodeTree" and group.get(HASH_KEY) == digest:
            return group
    return None


def _is_intact(group: bpy.types.NodeTree) -> bool:
    nodes = group.nodes
    names = {item.name for item in group.interface.items_tree if getattr(item, "item_type", "") == "SOCKET"}
    return (
        CURVE_NODE in nodes and COLOUR_NODE in nodes and WAVELENGTH_NODE in nodes
        and {WAVELENGTH_SOCKET, COLOUR_SOCKET, POWER_SOCKET} <= names
    )


def _set_curve(mapping: bpy.types.CurveMapping, spd: Sequence[float]) -> None:
    """Put the 81 samples in the curve as straight segments (x = (λ − 380) / 400)."""
    curve = mapping.curves[0]
    points = curve.points
    while len(points) > 2:
        points.remove(points[len(points) - 1])
    span = WAVELENGTH_MAX_NM - WAVELENGTH_MIN_NM
    xs = [(float(w) - WAVELENGTH_MIN_NM) / span for w in WAVELENGTHS_NM]
    points[0].location = (xs[0], float(spd[0]))
    points[1].location = (xs[-1], float(spd[-1]))
    for x, y in zip(xs[1:-1], spd[1:-1]):
        points.new(x, float(y))
    for point in points:
        point.handle_type = "VECTOR"
    mapping.use_clip = True
    mapping.clip_min_x, mapping.clip_max_x = 0.0, 1.0
    mapping.clip_min_y, mapping.clip_max_y = 0.0, 1.0
    mapping.extend = "HORIZONTAL"
    mapping.update()


def _build(group: bpy.types.NodeTree) -> None:
    """(Re)create the group's sockets and nodes; values are filled by :func:`_fill`."""
    group.nodes.clear()
    group.interface.clear()
    wl = group.interface.new_socket(WAVELENGTH_SOCKET, in_out="INPUT", socket_type="NodeSocketFloat")
    wl.default_value, wl.min_value, wl.max_value = 550.0, WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM
    wl.description = "Wavelength in nm (380–780) at which to read the SPD"
    out_colour = group.interface.new_socket(COLOUR_SOCKET, in_out="OUTPUT", socket_type="NodeSocketColor")
    out_colour.description = "Scene-linear emission colour of the SPD (brightest channel 1)"
    power = group.interface.new_socket(POWER_SOCKET, in_out="OUTPUT", socket_type="NodeSocketFloat")
    power.description = "Relative spectral power at the input wavelength (peak 1)"

    nodes, links = group.nodes, group.links
    n_in = nodes.new("NodeGroupInput")
    n_in.location = (-600, 0)
    n_out = nodes.new("NodeGroupOutput")
    n_out.location = (300, 0)
    to_x = nodes.new("ShaderNodeMapRange")
    to_x.name = to_x.label = WAVELENGTH_NODE
    to_x.location = (-380, -120)
    to_x.clamp = True
    to_x.inputs["From Min"].default_value = WAVELENGTH_MIN_NM
    to_x.inputs["From Max"].default_value = WAVELENGTH_MAX_NM
    to_x.inputs["To Min"].default_value = 0.0
    to_x.inputs["To Max"].default_value = 1.0
    curve = nodes.new("ShaderNodeFloatCurve")
    curve.name = curve.label = CURVE_NODE
    curve.location = (-120, -120)
    colour = nodes.new("ShaderNodeRGB")
    colour.name = colour.label = COLOUR_NODE
    colour.location = (-120, 160)
    links.new(n_in.outputs[WAVELENGTH_SOCKET], to_x.inputs["Value"])
    links.new(to_x.outputs["Result"], curve.inputs["Value"])
    links.new(curve.outputs["Value"], n_out.inputs[POWER_SOCKET])
    links.new(colour.outputs["Color"], n_out.inputs[COLOUR_SOCKET])


def metadata_properties(spd: Sequence[float], info: SpectralColour, meta: dict[str, Any]) -> dict[str, Any]:
    """Custom properties describing an SPD (None values are left out: ID properties have no None)."""
    props: dict[str, Any] = {
        HASH_KEY: spd_hash(spd),
        f"{KEY}_spd": [float(v) for v in spd],
        f"{KEY}_wavelength_nm": [float(w) for w in WAVELENGTHS_NM],
        f"{KEY}_rgb": list(info.rgb),
        f"{KEY}_out_of_gamut": info.out_of_gamut,
        f"{KEY}_xy": list(info.xy),
        f"{KEY}_working_space": info.working_space,
        f"{KEY}_cct_k": info.cct_k,
        f"{KEY}_duv": info.duv,
    }
    for key in ("source", "photo", "model_version", "preset", "camera", "calibration", "confidence",
                "kind", "name"):
        if meta.get(key) not in (None, ""):
            props[f"{KEY}_{key}"] = meta[key]
    props.update(rendition_properties(meta.get("rendition")))
    return {k: v for k, v in props.items() if v is not None}


def rendition_properties(rendition: Any) -> dict[str, Any]:
    """Ra, R9, Rf, Rg and their 90 % ranges as custom properties (none for an estimate without
    rendition figures), and which ranges were too wide to mean anything."""
    if not isinstance(rendition, dict) or not rendition.get("defined"):
        return {}
    props: dict[str, Any] = {}
    ranges = rendition.get("ranges") or {}
    for key in RENDITION_PROPERTIES:
        value = rendition.get(key)
        if isinstance(value, (int, float)):
            props[f"{KEY}_{key}"] = float(value)
        bounds = ranges.get(key)
        if isinstance(bounds, list) and len(bounds) == 2 and all(isinstance(b, (int, float)) for b in bounds):
            props[f"{KEY}_{key}_range"] = [float(bounds[0]), float(bounds[1])]
    wide = [k for k in rendition.get("too_wide") or () if k in RENDITION_PROPERTIES]
    if ranges:
        props[f"{KEY}_rendition_too_wide"] = ", ".join(wide)
    return props


def _fill(group: bpy.types.NodeTree, spd: Sequence[float], info: SpectralColour,
          meta: dict[str, Any]) -> None:
    _set_curve(group.nodes[CURVE_NODE].mapping, spd)
    group.nodes[COLOUR_NODE].outputs["Color"].default_value = (*info.rgb, 1.0)
    for key in [k for k in group.keys() if k.startswith(KEY)]:
        del group[key]
    for key, value in metadata_properties(spd, info, meta).items():
        group[key] = value


def group_name(spd: Sequence[float], meta: dict[str, Any]) -> str:
    label = meta.get("name") or meta.get("kind") or ""
    return f"{GROUP_PREFIX} {spd_hash(spd)}" + (f" ({label})" if label else "")


def ensure_node_group(spd: Sequence[float], info: SpectralColour,
                      meta: dict[str, Any] | None = None) -> bpy.types.NodeTree:
    """The group of this SPD: found by its hash (whatever its name now), else created.

    A found group gets its colour refreshed (the working space may have changed) and is rebuilt
    only if someone broke its nodes.
    """
    meta = dict(meta or {})
    digest = spd_hash(spd)
    group = find_node_group(digest)
    created = group is None
    if group is None:
        group = bpy.data.node_groups.new(group_name(spd, meta), "ShaderNodeTree")
    try:
        if created or not _is_intact(group):
            _build(group)
        _fill(group, spd, info, meta)
    except Exception:
        # A new group that failed half-way has no hash yet, so no caller could find it to
        # clean up: remove it here rather than leave a half-made group in the file.
        if created:
            bpy.data.node_groups.remove(group)
        raise
    return group


def curve_node(group: bpy.types.NodeTree | None) -> bpy.types.Node | None:
    """The Float Curve node the sidebar draws (None if the group is gone or broken)."""
    if group is None:
        return None
    node = group.nodes.get(CURVE_NODE)
    return node if node is not None and node.bl_idname == "ShaderNodeFloatCurve" else None
