"""Basis cubes: one radiance image per 5 nm band, rendered once per capture geometry and cached.

Any photo of that capture is then a weighted sum (the pixel value is linear in the SPD), so the
renderer runs 27 times per geometry instead of once per training sample. Cubes are cached as
spectral EXR files under ``data/basis/`` keyed by everything that changes the pixels.
"""

from __future__ import annotations

import hashlib
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon import __version__
from cd_spectra_addon.core.scene import grating
from cd_spectra_addon.core.scene.capture import Scene
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

from training.simulation.spectral_exr import read_spectral_exr, write_spectral_exr

REPO = Path(__file__).resolve().parents[2]
CACHE_DIR = REPO / "data" / "basis"
HERE = Path(__file__).resolve().parent
SHADER = HERE / "shaders" / "cd_grating.osl"
ENGINES = ("cycles", "numpy")
NUMPY_SUPERSAMPLE = 4

__all__ = ["CACHE_DIR", "ENGINES", "cube_key", "render_basis", "basis_cube"]


def _physics_fingerprint(engine: str) -> str:
    """Hash of the code that makes this engine's pixels, so a changed shader invalidates the cache."""
    files = (SHADER, HERE / "cycles_scene.py") if engine == "cycles" else (
        Path(grating.__file__), HERE / "render_numpy.py")
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def cube_key(scene: Scene, engine: str, samples: int) -> str:
    payload = {"geometry": scene.geometry_dict(), "preset": scene.preset.to_dict(),
               "engine": engine, "samples": samples, "physics": _physics_fingerprint(engine)}
    blob = json.dumps(payload, sort_keys=True, default=str).encode()
    return f"{scene.preset.name}-{hashlib.sha256(blob).hexdigest()[:12]}"


def render_basis(
    scene: Scene, engine: str = "cycles", samples: int | None = None, seed: int = 0
) -> tuple[NDArray[np.float32], dict[str, Any]]:
    """Render a cube now (no cache). ``samples``: Cycles spp or numpy supersampling per axis."""
    if engine not in ENGINES:
        raise ValueError(f"engine must be one of {ENGINES}")
    start = time.perf_counter()
    if engine == "cycles":
        from . import cycles_scene  # imports bpy: only when Cycles is asked for

        spp = int(samples or scene.preset.samples)
        cube, _ = cycles_scene.render_cube(scene, WAVELENGTHS_NM, spp, seed)
    else:
        from training.simulation.render_numpy import render_cube

        spp = int(samples or NUMPY_SUPERSAMPLE)
        cube = render_cube(scene, supersample=spp)
    meta = {
        **scene.geometry_dict(),
        "engine": engine,
        "samples": spp,
        "seed": seed,
        "render_seconds": time.perf_counter() - start,
        "wavelength_nm": WAVELENGTHS_NM.tolist(),
        "version": __version__,
        "units": "radiance per unit lamp intensity, integrated over each band's 5 nm hat",
    }
    return cube, meta


def basis_cube(
    scene: Scene,
    engine: str = "cycles",
    samples: int | None = None,
    cache_dir: Path = CACHE_DIR,
    log: Any = None,
) -> tuple[NDArray[np.float32], dict[str, Any]]:
    """The cube for ``scene``, rendered on first use and read from the cache afterwards."""
    spp = int(samples or (scene.preset.samples if engine == "cycles" else NUMPY_SUPERSAMPLE))
    path = Path(cache_dir) / f"{cube_key(scene, engine, spp)}.exr"
    if path.is_file():
        cube, _, meta = read_spectral_exr(path)
        return cube, meta
    if log:
        log(f"rendering basis cube {path.name} with {engine} ({spp} samples)...")
    cube, meta = render_basis(scene, engine, spp)
    write_spectral_exr(path, cube, WAVELENGTHS_NM, meta)
    return cube, meta
