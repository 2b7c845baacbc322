"""Camera spectral sensitivities: the shipped profiles of 52 measured cameras, or a user's file.

Profiles are relative R, G, B sensitivities on the product's 380–780 nm / 5 nm grid, scaled so
the largest value of the three channels is 1 (only ratios between channels and wavelengths
matter; exposure absorbs the rest).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import CDSpectraError

from .grid import WAVELENGTHS_NM, resample_to_grid

CAMERA_FILE = Path(__file__).resolve().parents[2] / "cameras" / "cameras.json"
DEFAULT_CAMERA = "Canon_EOS_5D_Mark_III"
GENERIC_CAMERA = "generic"  # "my camera is not listed": the model's typical sensitivities

__all__ = ["CAMERA_FILE", "DEFAULT_CAMERA", "GENERIC_CAMERA", "CameraProfile", "camera_names", "load_camera", "camera_from_exif",
           "camera_colours", "unit_colours"]

# EXIF Make → the brand word our profile names start with.
_BRANDS = {"nikon corporation": "nikon", "nikon": "nikon", "canon": "canon", "sony": "sony", "fujifilm": "fujifilm",
           "fuji photo film co., ltd.": "fujifilm", "panasonic": "panasonic", "hasselblad": "hasselblad",
           "arashi vision": "arashivision", "arri": "arri"}
# Other names the same bodies are sold or written under (normalised keys).
_ALIASES = {"canoneosrebelsl2": "Canon_EOS_200D", "canoneoskissx9": "Canon_EOS_200D",
            "canoneosrebelt3i": "Canon_EOS_600D", "canoneoskissx5": "Canon_EOS_600D",
            "canoneosrebelsl1": "Canon_EOS_100D", "canoneoskissx7": "Canon_EOS_100D",
            "canoneosrebelsl3": "Canon_EOS_200D_II", "canoneos250d": "Canon_EOS_200D_II",
            "canoneoskissx10": "Canon_EOS_200D_II", "canoneos400ddigital": "Canon_Digital_Rebel_XTi",
            "canoneoskissdigitalx": "Canon_Digital_Rebel_XTi", "canoneosdigitalrebelxti": "Canon_Digital_Rebel_XTi",
            "canoneosr5markii": "Canon_EOS_R5m2", "canoneosr6markii": "Canon_EOS_R6m2"}


@dataclass(frozen=True)
class CameraProfile:
    name: str
    sensitivities: NDArray[np.float64]  # (81, 3): R, G, B on WAVELENGTHS_NM, max 1

    def __post_init__(self) -> None:
        s = self.sensitivities
        if s.shape != (WAVELENGTHS_NM.size, 3) or not np.all(np.isfinite(s)) or s.max() <= 0:
            raise CDSpectraError(f"camera {self.name!r}: need finite, non-zero (81, 3) sensitivities")


@lru_cache(maxsize=1)
def _shipped() -> dict[str, NDArray[np.float64]]:
    data = json.loads(CAMERA_FILE.read_text(encoding="utf-8"))
    return {name: np.asarray(entry["rgb"], dtype=np.float64) for name, entry in data["cameras"].items()}


def camera_names() -> list[str]:
    return sorted(_shipped())


def _normalised(name: str, rgb: NDArray[np.float64]) -> CameraProfile:
    rgb = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, None)
    return CameraProfile(name, rgb / rgb.max() if rgb.max() > 0 else rgb)


def load_camera(name_or_path: str | Path) -> CameraProfile:
    """A shipped camera by name (``Nikon_D5100``) or a JSON file in the rawtoaces-data format
    (``header`` + ``spectral_data.data.main`` mapping wavelength → [R, G, B], any sampling)."""
    key = str(name_or_path)
    shipped = _shipped()
    if key in shipped:
        return _normalised(key, shipped[key])
    path = Path(key)
    if path.suffix.lower() != ".json" or not path.is_file():
        raise CDSpectraError(f"unknown camera {key!r}: give one of {len(shipped)} shipped names "
                         f"(e.g. {DEFAULT_CAMERA}) or a rawtoaces-format JSON file")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        rows = data["spectral_data"]["data"]["main"]
        wl = np.array([float(k) for k in rows])
        rgb = np.array([rows[k] for k in rows], dtype=np.float64)
        if rgb.ndim != 2 or rgb.shape[1] != 3:
            raise ValueError("each wavelength needs three values (R, G, B)")
    except (OSError, UnicodeDecodeError, json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise CDSpectraError(f"camera file {path} is not a rawtoaces-format sensitivity file: {exc}") from exc
    return _normalised(path.stem, resample_to_grid(wl, rgb.T).T)


def _key(text: str) -> str:
    return "".join(ch for ch in text.lower() if ch.isalnum())


def camera_from_exif(make: str | None, model: str | None) -> str | None:
    """The shipped profile for an EXIF Make/Model, or None when it is not one of ours.

    Names are normalised the way cameras write them: ``NIKON CORPORATION`` + ``NIKON D850`` →
    Nikon_D850, ``Canon`` + ``Canon EOS 5D Mark III`` → Canon_EOS_5D_Mark_III, ``SONY`` +
    ``ILCE-7M3`` → Sony_ILCE-7M3; a few bodies sold under other names are aliased."""
    if not model:
        return None
    make_text = (make or "").strip().lower()
    brand = _BRANDS.get(make_text, _key(make_text.split(" ")[0]) if make_text else "")
    model_key = _key(model)
    for prefix in {brand, _key(make_text)}:
        if prefix and model_key.startswith(prefix):
            model_key = model_key[len(prefix):]
    wanted = brand + model_key
    profiles = {_key(name): name for name in _shipped()}
    if wanted in profiles:
        return profiles[wanted]
    return _ALIASES.get(wanted)


# Where a lamp's spectrum is dark, its light still has the camera's colours: the expected colours
# of a lamp (camera_colours(spd=…)) take its SPD peak 1 above a floor of this share.
LAMP_SPD_FLOOR = 0.01


def lamp_light(spd: NDArray[np.floating] | None) -> NDArray[np.float64] | None:
    """``spd`` as the expected colours take a lamp's light: peak 1 above LAMP_SPD_FLOOR (NaN,
    infinite and negative values as no light); None (a flat spectrum's colours) where it has none."""
    if spd is None:
        return None
    spd = np.maximum(np.nan_to_num(np.asarray(spd, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0), 0.0)
    peak = float(spd.max(initial=0.0))
    return spd / peak + LAMP_SPD_FLOOR if peak > 0 else None


def camera_colours(lambda_nm: NDArray[np.float64], sensitivities: NDArray[np.float64],
                   blur_nm: float | NDArray[np.float64], spd: NDArray[np.float64] | None = None
                   ) -> NDArray[np.float64]:
    """The camera's RGB (not normalised) of the light a pixel showing wavelength ``lambda_nm``
    gets from a CD: the lamp's ``spd`` (on the product grid; flat without one) times the
    sensitivities, blurred by the lobe and the pixel footprint (Gaussian std ``blur_nm``, one or
    one per wavelength). Where the lamp's spectrum is steep within the blur (a narrow LED band, a
    line) the colour is that of the bright side, not of ``lambda_nm`` itself. The one
    implementation behind the pose fit's expected colours, the streak colours and the readout's
    colour check."""
    lam = np.asarray(lambda_nm, dtype=np.float64)[:, None]
    s = np.asarray(blur_nm, dtype=np.float64).reshape(-1, 1) if np.ndim(blur_nm) else float(blur_nm)
    kernel = np.exp(-0.5 * ((lam - WAVELENGTHS_NM[None, :]) / s) ** 2)
    sens = np.asarray(sensitivities, dtype=np.float64)
    if spd is not None:
        sens = sens * np.asarray(spd, dtype=np.float64)[:, None]
    return kernel @ sens


def unit_colours(rgb: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rows of ``rgb`` scaled to length 1; NaN rows where there is no colour to speak of."""
    norm = np.linalg.norm(rgb, axis=1, keepdims=True)
    return np.divide(rgb, norm, out=np.full_like(rgb, np.nan), where=norm > 1e-12)
