"""Light sources known by formula: Planck's law, CIE daylight and the calibration lamps.

One home for these so the calibration shot, the colour module's Planckian locus, the training
prior and the evaluation all mean the same curve by "a 2856 K bulb" or "D65". Pure numpy.

- :func:`planck`: Planck's spectral radiance shape at any wavelengths, 1 at 560 nm (the CIE's
  reference wavelength for illuminant A); :func:`planck_radiance`: the same law unscaled, for
  ratios (chromaticity). The second radiation constant is :data:`C2_NM_K` (CODATA, exact since
  the 2019 SI) everywhere except the CIE Planckian locus, which the CIE and colour-science
  compute with :data:`C2_ITS90_NM_K` = 1.4388e-2 m·K (CCTs are quoted on that scale).
- :func:`daylight_spd`: the CIE daylight illuminant at a CCT, from the S0/S1/S2 basis.
- :data:`KNOWN_LAMPS` / :func:`known_lamp_spd`: the lamps a calibration photo may show; the
  Blender menu is built from this table.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CDSpectraError
from .grid import WAVELENGTHS_NM, peak_normalise

__all__ = [
    "C2_NM_K",
    "C2_ITS90_NM_K",
    "KNOWN_LAMPS",
    "KnownLamp",
    "LAMP_ALIASES",
    "planck",
    "planck_radiance",
    "planck_spd",
    "daylight_spd",
    "known_lamp_spd",
]

C2_NM_K = 1.438776877e7
"""Second radiation constant hc/k in nm·K (CODATA 2018: exact since the 2019 SI, here to 10 digits)."""
C2_ITS90_NM_K = 1.4388e7
"""The c2 of the ITS-90 temperature scale, which the CIE Planckian locus (and colour-science's
``CCT_to_uv_Planck1900``) uses: CCTs are reported on it."""

_REFERENCE_NM = 560.0


def planck_radiance(wavelengths: ArrayLike, temperature_k: ArrayLike, c2: float) -> NDArray[np.float64]:
    """Planck's law without its constant factor, λ⁻⁵/(exp(c₂/λT)−1): wavelengths and ``c2`` in
    the same length unit (the scale then depends on it; ratios such as chromaticity do not).
    ``temperature_k`` broadcasts against the wavelengths as numpy does. ``expm1`` keeps the
    value exact where c₂/λT is small (hot sources, long wavelengths).

    The one implementation of the law in the product: :func:`planck`, the colour module's
    Planckian locus and the training prior all come here."""
    lam = np.asarray(wavelengths, dtype=np.float64)
    return lam**-5 / np.expm1(c2 / (lam * np.asarray(temperature_k, dtype=np.float64)))


def planck(wavelengths_nm: ArrayLike, temperature_k: ArrayLike, c2_nm_k: float = C2_NM_K
           ) -> NDArray[np.float64]:
    """Planck's spectral radiance shape :func:`planck_radiance`, scaled to 1 at 560 nm.

    ``temperature_k`` broadcasts against the wavelengths' last axis (pass shape (n, 1) for rows).
    """
    t = np.asarray(temperature_k, dtype=np.float64)
    return planck_radiance(wavelengths_nm, t, c2_nm_k) / planck_radiance(_REFERENCE_NM, t, c2_nm_k)


def planck_spd(temperature_k: float) -> NDArray[np.float64]:
    """A Planck radiator at ``temperature_k`` on the product grid, peak 1."""
    return peak_normalise(planck(WAVELENGTHS_NM, float(temperature_k)))


# CIE daylight basis S0, S1, S2 at 380–780 nm / 10 nm (CIE 015:2018 Table 6); interpolated to
# the 5 nm grid linearly.
_S_WL = np.arange(380.0, 781.0, 10.0)
_S0 = np.array([63.4, 65.8, 94.8, 104.8, 105.9, 96.8, 113.9, 125.6, 125.5, 121.3, 121.3, 113.5, 113.1,
                110.8, 106.5, 108.8, 105.3, 104.4, 100.0, 96.0, 95.1, 89.1, 90.5, 90.3, 88.4, 84.0, 85.1,
                81.9, 82.6, 84.9, 81.3, 71.9, 74.3, 76.4, 63.3, 71.7, 77.0, 65.2, 47.7, 68.6, 65.0])
_S1 = np.array([38.5, 35.0, 43.4, 46.3, 43.9, 37.1, 36.7, 35.9, 32.6, 27.9, 24.3, 20.1, 16.2, 13.2,
                8.6, 6.1, 4.2, 1.9, 0.0, -1.6, -3.5, -3.5, -5.8, -7.2, -8.6, -9.5, -10.9, -10.7, -12.0,
                -14.0, -13.6, -12.0, -13.3, -12.9, -10.6, -11.6, -12.2, -10.2, -7.8, -11.2, -10.4])
_S2 = np.array([3.0, 1.2, -1.1, -0.5, -0.7, -1.2, -2.6, -2.9, -2.8, -2.6, -2.6, -1.8, -1.5, -1.3,
                -1.2, -1.0, -0.5, -0.3, 0.0, 0.2, 0.5, 2.1, 3.2, 4.1, 4.7, 5.1, 6.7, 7.3, 8.6, 9.8,
                10.2, 8.3, 9.6, 8.5, 7.0, 7.6, 8.0, 6.7, 5.2, 7.4, 6.8])


def daylight_spd(cct_k: float) -> NDArray[np.float64]:
    """CIE daylight illuminant at a correlated colour temperature (4000–25000 K), peak 1."""
    t = float(cct_k)
    if not 4000 <= t <= 25000:
        raise CDSpectraError("daylight calibration needs a CCT between 4000 and 25000 K")
    if t <= 7000:
        xd = -4.6070e9 / t ** 3 + 2.9678e6 / t ** 2 + 0.09911e3 / t + 0.244063
    else:
        xd = -2.0064e9 / t ** 3 + 1.9018e6 / t ** 2 + 0.24748e3 / t + 0.23704
    yd = -3.0 * xd * xd + 2.870 * xd - 0.275
    m = 0.0241 + 0.2562 * xd - 0.7341 * yd
    m1 = (-1.3515 - 1.7703 * xd + 5.9114 * yd) / m
    m2 = (0.0300 - 31.4424 * xd + 30.0717 * yd) / m
    spd = _S0 + m1 * _S1 + m2 * _S2
    return peak_normalise(np.interp(WAVELENGTHS_NM, _S_WL, spd))


@dataclass(frozen=True)
class KnownLamp:
    """A lamp whose SPD a calibration photo can take as given."""

    label: str  # short name for menus
    description: str  # one line for tooltips and help
    kind: str  # "planck" or "daylight"
    temperature_k: float

    def spd(self) -> NDArray[np.float64]:
        """Its SPD on the product grid, peak 1."""
        return planck_spd(self.temperature_k) if self.kind == "planck" else daylight_spd(self.temperature_k)


KNOWN_LAMPS: dict[str, KnownLamp] = {
    "incandescent": KnownLamp("Household bulb (CIE A)",
                              "Incandescent or halogen bulb: close to CIE illuminant A, 2856 K",
                              "planck", 2856.0),
    "daylight": KnownLamp("Direct sunlight (D55)", "Direct sun on a clear day: CIE D55, 5503 K",
                          "daylight", 5503.0),
    "daylight-d65": KnownLamp("Overcast daylight (D65)", "Overcast sky: CIE D65, 6504 K", "daylight", 6504.0),
    "daylight-d50": KnownLamp("Warm daylight (D50)", "Morning or evening sun: CIE D50, 5003 K", "daylight", 5003.0),
    "daylight-d75": KnownLamp("North-sky daylight (D75)", "Shade under a blue sky: CIE D75, 7504 K", "daylight",
                              7504.0),
}

LAMP_ALIASES: dict[str, str] = {"a": "incandescent", "d50": "daylight-d50", "d55": "daylight",
                                "d65": "daylight-d65", "d75": "daylight-d75"}
"""The CIE names people type (``--known-lamp A``), case-insensitive, for the keys above."""


def known_lamp_spd(name: str) -> NDArray[np.float64]:
    """SPD (peak 1) of a lamp in :data:`KNOWN_LAMPS`; CDSpectraError naming the choices otherwise."""
    lamp = KNOWN_LAMPS.get(name) or KNOWN_LAMPS.get(LAMP_ALIASES.get(str(name).strip().lower(), ""))
    if lamp is None:
        raise CDSpectraError(f"unknown reference lamp {name!r}; choose one of {', '.join(KNOWN_LAMPS)} "
                             f"(or {', '.join(k.upper() for k in LAMP_ALIASES)}) or an SPD file")
    return lamp.spd()
