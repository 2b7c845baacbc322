"""Spectral OpenEXR files in the Fichet et al. (2021) layout, plus a JSON geometry sidecar.

Emissive channels are named ``S0.<λ with a decimal comma>nm`` (``S0.380,0nm``); the header
carries ``spectralLayoutVersion`` and ``emissiveUnits`` as the layout asks, so colour-science's
``read_spectral_image_Fichet2021`` and other readers of the layout understand the file.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import OpenEXR
from numpy.typing import NDArray

__all__ = ["channel_name", "write_spectral_exr", "read_spectral_exr", "sidecar_path"]

_CHANNEL = re.compile(r"^S0\.(\d+(?:,\d*)?)nm$")


def channel_name(wavelength_nm: float) -> str:
    return "S0." + str(float(wavelength_nm)).replace(".", ",") + "nm"


def sidecar_path(path: str | Path) -> Path:
    return Path(path).with_suffix(".json")


def write_spectral_exr(
    path: str | Path,
    cube: NDArray[np.floating],
    wavelengths_nm: NDArray[np.floating],
    metadata: dict[str, Any] | None = None,
) -> None:
    """Write a (bands, height, width) radiance cube; ``metadata`` goes to the JSON sidecar.

    Written to a temporary file and renamed, so a crash never leaves half a file behind.
    """
    cube = np.asarray(cube, dtype=np.float32)
    if cube.ndim != 3 or cube.shape[0] != len(wavelengths_nm):
        raise ValueError(f"cube shape {cube.shape} does not match {len(wavelengths_nm)} bands")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    channels = {
        channel_name(wl): np.ascontiguousarray(cube[i]) for i, wl in enumerate(wavelengths_nm)
    }
    header = {
        "compression": OpenEXR.ZIP_COMPRESSION,
        "type": OpenEXR.scanlineimage,
        "spectralLayoutVersion": "1.0",
        "emissiveUnits": "W.m^-2.sr^-1",
        "polarisationHandedness": "right",
    }
    fd, tmp = tempfile.mkstemp(suffix=".exr", dir=path.parent)
    os.close(fd)
    try:
        with OpenEXR.File(header, channels) as exr:
            exr.write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    if metadata is not None:
        side = sidecar_path(path)
        side.write_text(json.dumps(metadata, indent=2, sort_keys=True) + "\n", encoding="utf-8")


def read_spectral_exr(path: str | Path) -> tuple[NDArray[np.float32], NDArray[np.float64], dict[str, Any]]:
    """(cube, wavelengths_nm, sidecar metadata or {})."""
    path = Path(path)
    with OpenEXR.File(str(path), separate_channels=True) as exr:
        found: list[tuple[float, NDArray[np.float32]]] = []
        for name, channel in exr.channels().items():
            match = _CHANNEL.match(name)
            if match:
                found.append((float(match.group(1).replace(",", ".")), np.asarray(channel.pixels)))
    if not found:
        raise ValueError(f"{path} has no spectral S0.<λ>nm channels")
    found.sort(key=lambda item: item[0])
    wavelengths = np.array([wl for wl, _ in found])
    cube = np.stack([px for _, px in found]).astype(np.float32)
    side = sidecar_path(path)
    meta = json.loads(side.read_text(encoding="utf-8")) if side.is_file() else {}
    return cube, wavelengths, meta
