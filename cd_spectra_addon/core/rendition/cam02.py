"""CIECAM02 → CAM02-UCS under the viewing conditions of CIE 224:2017 and ANSI/IES TM-30.

The same computation as ``colour.XYZ_to_CIECAM02`` (L_A = 100 cd/m², Y_b = 20, average surround,
illuminant discounted so D = 1) followed by ``colour.models.JMh_CIECAM02_to_CAM02UCS``
(Luo et al. 2006), vectorised over any leading axes; only J, M and h are needed, so brightness,
saturation and hue quadrature are not computed.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["CAT02", "HPE", "L_A", "Y_B", "xyz_to_jab"]

CAT02 = np.array([[0.7328, 0.4296, -0.1624], [-0.7036, 1.6975, 0.0061], [0.0030, 0.0136, 0.9834]])
HPE = np.array([[0.38971, 0.68898, -0.07868], [-0.22981, 1.18340, 0.04641], [0.00000, 0.00000, 1.00000]])
L_A = 100.0  # adapting luminance, cd/m²
Y_B = 20.0  # relative background luminance
_F, _C, _N_C = 1.0, 0.69, 1.0  # average surround
_UCS_C1, _UCS_C2 = 0.007, 0.0228  # CAM02-UCS (K_L = 1)
_CAT02_TO_HPE = HPE @ np.linalg.inv(CAT02)


def _spow(x: NDArray[np.float64], p: float) -> NDArray[np.float64]:
    """Sign-preserving power, as colour-science's ``spow``."""
    return np.copysign(np.power(np.abs(x), p), x)


def _compress(rgb: NDArray[np.float64], f_l: float) -> NDArray[np.float64]:
    """Post-adaptation non-linear response compression."""
    x = np.power(np.abs(rgb) * (f_l / 100.0), 0.42)
    return 400.0 * np.copysign(x, rgb) / (27.13 + x) + 0.1


def xyz_to_jab(xyz: NDArray[np.float64], xyz_w: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(CAM02-UCS J′a′b′ (n, s, 3), CIECAM02 hue h in degrees (n, s)) of samples ``xyz`` (n, s, 3)
    seen under whites ``xyz_w`` (n, 1, 3), both with the white's Y = 100."""
    xyz = np.asarray(xyz, dtype=np.float64)
    xyz_w = np.asarray(xyz_w, dtype=np.float64)
    y_w = xyz_w[..., 1]  # (n, 1)
    n = Y_B / y_w
    k4 = (1.0 / (5.0 * L_A + 1.0)) ** 4
    f_l = 0.2 * k4 * (5.0 * L_A) + 0.1 * (1.0 - k4) ** 2 * (5.0 * L_A) ** (1.0 / 3.0)
    n_bb = 0.725 * (1.0 / n) ** 0.2
    z = 1.48 + np.sqrt(n)
    rgb_w = xyz_w @ CAT02.T
    gain = y_w[..., None] / rgb_w  # full adaptation (D = 1): the white maps to Y_w in each channel
    # XYZ → CAT02 RGB → adapted → Hunt-Pointer-Estevez, one 3 × 3 matrix per white.
    to_hpe = _CAT02_TO_HPE[None] @ (gain.transpose(0, 2, 1) * CAT02[None])  # (n, 3, 3)
    rgb_a = _compress(xyz @ to_hpe.transpose(0, 2, 1), f_l)
    rgb_aw = _compress((rgb_w * gain) @ _CAT02_TO_HPE.T, f_l)
    r, g, b_ = rgb_a[..., 0], rgb_a[..., 1], rgb_a[..., 2]
    a = r - 12.0 * g / 11.0 + b_ / 11.0
    b = (r + g - 2.0 * b_) / 9.0
    h = np.degrees(np.arctan2(b, a)) % 360.0
    radius = np.hypot(a, b)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos_h = np.where(radius > 0, a / radius, 1.0)
        sin_h = np.where(radius > 0, b / radius, 0.0)
    e_t = 0.25 * (np.cos(2.0) * cos_h - np.sin(2.0) * sin_h + 3.8)  # ¼ (cos(h + 2) + 3.8)
    achromatic = (2.0 * r + g + b_ / 20.0 - 0.305) * n_bb
    achromatic_w = (2.0 * rgb_aw[..., 0] + rgb_aw[..., 1] + rgb_aw[..., 2] / 20.0 - 0.305) * n_bb
    j = 100.0 * _spow(achromatic / achromatic_w, _C * z)
    t = (50000.0 / 13.0) * _N_C * n_bb * e_t * radius / (r + g + 21.0 * b_ / 20.0)
    chroma = _spow(t, 0.9) * _spow(j / 100.0, 0.5) * (1.64 - 0.29 ** n) ** 0.73
    m = chroma * f_l ** 0.25
    j_p = (1.0 + 100.0 * _UCS_C1) * j / (1.0 + _UCS_C1 * j)
    with np.errstate(invalid="ignore"):  # NaN, as in colour-science, for a sample no light could show
        m_p = np.log1p(_UCS_C2 * m) / _UCS_C2
    return np.stack([j_p, m_p * cos_h, m_p * sin_h], axis=-1), h
