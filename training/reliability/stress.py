"""Extreme captures for the forward model, and the OSL shader and its numpy twin evaluated at
pixel centres, shared by ``tests/test_forward_stress.py`` and ``training.reliability.report``.

Pixel-centre values (Cycles: one sample, filter width 0.01 px) compare the two BRDF
implementations exactly, where anti-aliased renders of sub-pixel features (a 0.5 mrad lamp, an
85° tilt, 20 µm rings seen from 1.5 m) would only compare their sampling noise.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from cd_spectra_addon.core.scene import grating
from cd_spectra_addon.core.scene.capture import REFERENCE_PRESET, Pose, Scene, load_preset

__all__ = ["EDGE_BANDS", "EXTREMES", "scene", "psnr", "twin_at_pixel_centres", "cycles_at_pixel_centres",
           "compare_extreme"]

EDGE_BANDS = np.array([380.0, 385.0, 555.0, 600.0, 775.0, 780.0])


def scene(size: int = 48, pitch: float = 1.6, dist: float = 210.0, focal: float = 58.0,
          light: tuple[float, float, float] | None = None, pose: Pose = Pose(), sigma: float = 0.003,
          intensity: float = 1.0) -> Scene:
    base = load_preset(REFERENCE_PRESET).with_image_size(size)
    preset = replace(base, disc=replace(base.disc, pitch_um=pitch),
                     camera=replace(base.camera, distance_mm=dist, focal_length_mm=focal),
                     light=replace(base.light, position_mm=light or (0.0, 0.0, dist), lobe_sigma=sigma,
                                   intensity=intensity))
    return Scene(preset, pose)


# Extreme captures: (name, scene, wavelengths with diffracted light in them per the twin)
EXTREMES = {
    # Orders only at 380-410 nm, from a lamp at 3° above the disc; a 0.03 rad lamp so the lit
    # strip is wider than a pixel (at 0.003 rad it is 0.04 px and pixel centres miss it).
    "pitch-0.3um-grazing-light": scene(pitch=0.3, light=(0.0, -2000.0, 100.0), sigma=0.03),
    "pitch-20um-from-1.5m": scene(pitch=20.0, dist=1500.0, focal=414.0),
    "dvd-0.74um-at-100mm": scene(pitch=0.74, dist=100.0, focal=28.0),
    "camera-at-60mm": scene(dist=60.0),
    "disc-tilted-85deg": scene(pose=Pose(light_offset_mm=(0.0, -2000.0), tilt_deg=(85.0, 0.0))),
    "lamp-0.0005rad": scene(sigma=5e-4),
    "lamp-0.1rad": scene(sigma=0.1),
    "lamp-off": scene(intensity=0.0),
}


def psnr(test: np.ndarray, reference: np.ndarray) -> float:
    mse = float(np.mean((test.astype(np.float64) - reference) ** 2))
    return math.inf if mse == 0 else 10 * math.log10(float(reference.max()) ** 2 / mse)


def twin_at_pixel_centres(capture: Scene, wavelengths: np.ndarray) -> np.ndarray:
    """(bands, H, W) band radiance of the numpy twin at each pixel's centre ray."""
    width, height = capture.preset.camera.image_size_px
    rows, cols = np.meshgrid(np.arange(height, dtype=float), np.arange(width, dtype=float), indexing="ij")
    dirs = capture.pixel_rays(rows.ravel(), cols.ravel())
    points, hit = capture.intersect_disc(dirs)
    frame = grating.surface_frame(points[hit], capture.camera_position, capture.light_position,
                                  capture.disc_center, capture.disc_normal, capture.preset.disc.medium_index,
                                  capture.preset.light.intensity, view_directions=-dirs[hit])
    optics = grating.GratingOptics(capture.preset.disc, capture.preset.light.lobe_sigma)
    out = np.zeros((wavelengths.size, height * width))
    out[:, hit] = grating.band_radiance(frame, optics, wavelengths).T
    return out.reshape(wavelengths.size, height, width)


def cycles_at_pixel_centres(capture: Scene, wavelengths: np.ndarray) -> np.ndarray:
    """The shader evaluated once per pixel at (nearly) its centre: filter width 0.01 px, 1 sample.

    Comparing point values, not pixel integrals, makes the check exact where the lobe is far
    sharper than a pixel (a 0.5 mrad lamp, an 85° tilt), where anti-aliased renders of both
    would only compare their sampling noise."""
    import bpy

    from training.simulation import cycles_scene

    node = cycles_scene.build_capture_scene(capture, 1)
    bpy.context.scene.cycles.filter_width = 0.01
    width, height = capture.preset.camera.image_size_px
    cube = np.zeros((wavelengths.size, height, width), np.float32)
    for first in range(0, wavelengths.size, 3):
        idx = list(range(first, min(first + 3, wavelengths.size)))
        cycles_scene.set_bands(node, tuple([wavelengths[i] for i in idx] + [wavelengths[idx[-1]]] * (3 - len(idx))))
        rgb = cycles_scene.render_rgb()
        for k, i in enumerate(idx):
            cube[i] = rgb[..., k]
    return cube


def compare_extreme(name: str) -> dict[str, object]:
    """Render one extreme capture both ways at pixel centres (needs bpy) and summarise."""
    capture = EXTREMES[name]
    cycles = cycles_at_pixel_centres(capture, EDGE_BANDS)
    twin = twin_at_pixel_centres(capture, EDGE_BANDS)
    lit = [k for k in range(EDGE_BANDS.size) if twin.max() > 0 and twin[k].max() > 1e-3 * twin.max()]
    return {
        "finite": bool(np.all(np.isfinite(cycles)) and np.all(np.isfinite(twin))),
        "non_negative": bool(cycles.min() >= 0.0 and twin.min() >= 0.0),
        "psnr_db": {float(EDGE_BANDS[k]): round(psnr(cycles[k], twin[k]), 1) for k in lit},
        "sum_ratio": {float(EDGE_BANDS[k]): round(float(cycles[k].sum() / twin[k].sum()), 4) for k in lit},
        "all_zero": bool(cycles.max() == 0.0 and twin.max() == 0.0),
    }


def antialiasing_comparison(spp: int = 1024, supersample: int = 16) -> dict[str, list[float]]:
    """Band sums, Cycles over the twin, for a 28 mm lens at 100 mm (rings far thinner than a
    48 px image's pixel): anti-aliased (Cycles box filter 1 px, ``spp``; twin stratified
    ``supersample``²) and point-sampled (Cycles at 4× resolution, 1 sample at pixel centres, then
    4×4 means; twin stratified 4×4 — the same sample positions). Needs bpy."""
    import bpy

    from training.simulation import cycles_scene
    from training.simulation.render_numpy import render_cube as numpy_cube

    lam = np.array([450.0, 555.0, 600.0])
    idx = [int(round((x - 380.0) / 5.0)) for x in lam]

    def cycles(capture: Scene, samples: int, filter_width: float) -> np.ndarray:
        node = cycles_scene.build_capture_scene(capture, samples)
        bpy.context.scene.cycles.filter_width = filter_width
        cycles_scene.set_bands(node, (lam[0], lam[1], lam[2]))
        return cycles_scene.render_rgb().transpose(2, 0, 1).astype(np.float64)

    capture = scene(size=48, dist=100.0, focal=28.0)
    fine = scene(size=192, dist=100.0, focal=28.0)
    smooth = cycles(capture, spp, 1.0)
    twin = numpy_cube(capture, supersample=supersample)[idx].astype(np.float64)
    points = cycles(fine, 1, 0.01).reshape(3, 48, 4, 48, 4).mean(axis=(2, 4))
    twin4 = numpy_cube(capture, supersample=4)[idx].astype(np.float64)
    return {"wavelength_nm": lam.tolist(),
            "anti_aliased": (smooth.reshape(3, -1).sum(1) / twin.reshape(3, -1).sum(1)).round(4).tolist(),
            "point_sampled": (points.reshape(3, -1).sum(1) / twin4.reshape(3, -1).sum(1)).round(4).tolist()}
