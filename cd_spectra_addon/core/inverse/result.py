"""What an estimate returns: the SPD and everything needed to trust, show and reuse it."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..scene.capture import DEFAULT_PRESET
from ..spectra.colour import DEFAULT_WORKING_SPACE
from ..spectra.grid import WAVELENGTHS_NM

__all__ = ["DiscFit", "Estimate", "METHOD_MODEL", "METHOD_PRIOR", "METHOD_PHYSICS", "ESTIMATE_METHODS"]

# How an estimate may be solved (estimate_photo's ``method``): the product, and the two
# baselines the benchmarks compare it with.
METHOD_MODEL = "model"  # physics + prior + network: the product
METHOD_PRIOR = "prior"  # physics under the Gaussian prior only
METHOD_PHYSICS = "physics"  # smoothness-regularised physics only
ESTIMATE_METHODS = (METHOD_MODEL, METHOD_PRIOR, METHOD_PHYSICS)


@dataclass(frozen=True)
class DiscFit:
    """Where the disc is in the photo (full-resolution pixel coordinates, x = column, y = row;
    the centre of the top-left pixel is (0, 0))."""

    center_px: tuple[float, float]
    radius_px: float  # rim (60 mm) radius along the major axis
    hole_radius_px: float | None = None
    axis_ratio: float = 1.0  # minor / major axis of the rim ellipse (1 = facing the camera)
    angle_deg: float = 0.0  # orientation of the major axis
    px_per_mm: float | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "center_px": [float(self.center_px[0]), float(self.center_px[1])],
            "radius_px": float(self.radius_px),
            "hole_radius_px": None if self.hole_radius_px is None else float(self.hole_radius_px),
            "axis_ratio": float(self.axis_ratio),
            "angle_deg": float(self.angle_deg),
            "px_per_mm": None if self.px_per_mm is None else float(self.px_per_mm),
        }


@dataclass
class Estimate:
    """A recovered SPD on 380–780 nm / 5 nm, peak-normalised, with its colour and reliability."""

    spd: NDArray[np.float64]  # (81,), max exactly 1, finite, ≥ 0
    spd_std: NDArray[np.float64]  # (81,) one-sigma uncertainty per wavelength (same scale)
    xy: tuple[float, float]
    cct_k: float | None  # None where the chromaticity is too far from the Planckian locus
    duv: float | None
    rgb_scene_linear: tuple[float, float, float]  # emission colour in the scene's working space
    confidence: float  # 0–1
    warnings: list[str]
    disc: DiscFit
    timing_ms: dict[str, float]
    source: str = ""
    preset: str = DEFAULT_PRESET
    camera: str = ""
    calibration: str | None = None
    model_version: str = ""
    working_space: str = DEFAULT_WORKING_SPACE
    rendition: dict[str, Any] | None = None  # core.rendition.result.rendition's object; None when skipped
    extra: dict[str, Any] = field(default_factory=dict)
    wavelength_nm: NDArray[np.float64] = field(default_factory=lambda: WAVELENGTHS_NM.copy())

    def to_json(self) -> dict[str, Any]:
        """The CLI's JSON object for one photo."""
        return {
            "source": self.source,
            "wavelength_nm": [float(w) for w in self.wavelength_nm],
            "spd": [float(v) for v in self.spd],
            "spd_std": [float(v) for v in self.spd_std],
            "xy": [float(self.xy[0]), float(self.xy[1])],
            "cct_k": None if self.cct_k is None else float(self.cct_k),
            "duv": None if self.duv is None else float(self.duv),
            "rgb_scene_linear": [float(c) for c in self.rgb_scene_linear],
            "working_space": self.working_space,
            "confidence": float(self.confidence),
            "warnings": list(self.warnings),
            "disc": self.disc.to_json(),
            "timing_ms": {k: float(v) for k, v in self.timing_ms.items()},
            "preset": self.preset,
            "camera": self.camera,
            "calibration": self.calibration,
            "model_version": self.model_version,
            **({} if self.rendition is None else {"rendition": self.rendition}),
            **self.extra,
        }
