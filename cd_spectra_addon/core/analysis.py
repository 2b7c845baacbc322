"""Photo → geometry → spectral profile → forward matrix: the preprocessing shared by training
and the add-on (one implementation, so the model sees at training time exactly what it gets
from a user's photo)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .capture import Preset, Scene
from .forward_matrix import bin_response
from .pose_fit import PoseFit, fit_pose
from .readout import Readout, extract_readout

__all__ = ["Analysis", "analyse"]


@dataclass
class Analysis:
    fit: PoseFit
    scene: Scene
    readout: Readout
    response: NDArray[np.float64]  # R[bin, λ] without the camera
    timing_ms: dict[str, float] = field(default_factory=dict)


def analyse(
    rgb: NDArray[np.floating],
    saturated: NDArray[np.bool_] | None,
    preset: Preset,
    focal_px: float,
    fit: PoseFit | None = None,
) -> Analysis:
    """Fit the capture geometry (unless given), extract the profile and its forward response."""
    timing: dict[str, float] = {}
    t0 = time.perf_counter()
    height, width, _ = rgb.shape
    if fit is None:
        fit = fit_pose(rgb, preset, focal_px)
    t1 = time.perf_counter()
    scene = fit.scene(preset, (width, height))
    readout = extract_readout(rgb, saturated, scene)
    t2 = time.perf_counter()
    response = bin_response(scene, readout)
    t3 = time.perf_counter()
    timing.update(geometry=(t1 - t0) * 1e3, profile=(t2 - t1) * 1e3, forward=(t3 - t2) * 1e3)
    return Analysis(fit=fit, scene=scene, readout=readout, response=response, timing_ms=timing)
