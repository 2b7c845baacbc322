"""CIE 13.3-1995 colour rendering: the special indices R1–R14 and the general index Ra.

The computation of ``colour.colour_rendering_index`` (colour-science 0.4.6), vectorised over a
batch of test lights: everything at 1 nm over 360–780 nm with the CIE 1931 2° observer; the
reference illuminant's CCT by Robertson (1968) — not Ohno, which the rest of the product uses —
a Planckian radiator below 5000 K and CIE daylight (M1, M2 rounded to 3 decimals) from 5000 K;
the von Kries-type adaptation of CIE 13.3 on the test colour samples and CIE 1964 U*V*W*.
R15 (a JIS sample) is not computed: colour-science has no data for it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..spectra.illuminants import C2_ITS90_NM_K, planck_radiance
from .tables import rendition_tables, sample_weights

__all__ = ["N_TCS", "DAYLIGHT_FROM_K", "robertson_cct", "daylight_xy", "daylight_m", "cri_reference",
           "special_indices"]

N_TCS = 14
DAYLIGHT_FROM_K = 5000.0  # CIE 13.3: a Planckian reference below, CIE daylight from here on


def robertson_cct(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    """CCT (K) of CIE 1960 uv (..., 2) by Robertson's (1968) isotemperature lines, as colour's
    ``uv_to_CCT_Robertson1968`` (its loop over lines, for every point at once)."""
    lines = rendition_tables().robertson_lines
    r, lu, lv, slope = lines.T
    uv = np.asarray(uv, dtype=np.float64)
    u, v = uv[..., 0:1], uv[..., 1:2]
    du = 1.0 / np.hypot(1.0, slope)
    dv = slope * du
    dt = -(u - lu) * dv + (v - lv) * du  # (..., 31): the signed distance from each line
    crossed = (dt[..., 1:] <= 0.0)
    crossed[..., -1] = True  # the last line takes everything beyond it
    i = 1 + np.argmax(crossed, axis=-1)  # first line (from 1) the point is not above
    take = lambda a: np.take_along_axis(a, i[..., None], axis=-1)[..., 0]  # noqa: E731
    dt_i = -np.minimum(take(dt), 0.0)
    dt_prev = np.take_along_axis(dt, (i - 1)[..., None], axis=-1)[..., 0]
    f = np.where(i == 1, 0.0, dt_i / np.where(i == 1, 1.0, dt_prev + dt_i))
    mired = r[i - 1] * f + r[i] * (1.0 - f)
    return 1.0e6 / mired


def daylight_xy(cct: NDArray[np.float64]) -> NDArray[np.float64]:
    """CIE daylight chromaticity at ``cct`` K (CIE 015, as ``colour.temperature.CCT_to_xy_CIE_D``)."""
    t = np.asarray(cct, dtype=np.float64)
    x = np.where(t <= 7000.0,
                 -4.607e9 / t**3 + 2.9678e6 / t**2 + 0.09911e3 / t + 0.244063,
                 -2.0064e9 / t**3 + 1.9018e6 / t**2 + 0.24748e3 / t + 0.23704)
    return np.stack([x, -3.0 * x**2 + 2.870 * x - 0.275], axis=-1)


def daylight_m(cct: NDArray[np.float64]) -> NDArray[np.float64]:
    """(1, M1, M2) (..., 3) of CIE daylight at ``cct``, M1 and M2 rounded to 3 decimals as CIE 015
    says and colour-science does."""
    xy = daylight_xy(cct)
    x, y = xy[..., 0], xy[..., 1]
    m = 0.0241 + 0.2562 * x - 0.7341 * y
    m1 = np.around((-1.3515 - 1.7703 * x + 5.9114 * y) / m, 3)
    m2 = np.around((0.0300 - 31.4424 * x + 30.0717 * y) / m, 3)
    return np.stack([np.ones_like(m1), m1, m2], axis=-1)


def cri_reference(cct: NDArray[np.float64]) -> NDArray[np.float64]:
    """The CIE 13.3 reference illuminant at ``cct`` (n,) on 360–780 nm / 1 nm: (n, 421), each row
    at its own scale (the figures do not depend on it)."""
    t = rendition_tables()
    temps = np.asarray(cct, dtype=np.float64)
    planck = planck_radiance(t.cri_wavelength_nm, np.maximum(temps, 100.0)[:, None], C2_ITS90_NM_K)
    daylight = daylight_m(np.maximum(temps, DAYLIGHT_FROM_K)) @ t.cri_daylight_basis.T
    return np.where((temps < DAYLIGHT_FROM_K)[:, None], planck / planck.max(axis=1, keepdims=True), daylight)


def _reference_xyz(cct: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(the samples' XYZ sums (n, 42), the white's (n, 3)) under the reference at ``cct``: a
    Planckian row is summed at 1 nm, a daylight row is linear in (1, M1, M2)."""
    t, w = rendition_tables(), sample_weights()
    samples = np.empty((cct.size, w.cri_1nm.shape[1]))
    white = np.empty((cct.size, 3))
    planck = cct < DAYLIGHT_FROM_K
    if np.any(planck):
        light = planck_radiance(t.cri_wavelength_nm, np.maximum(cct[planck], 100.0)[:, None], C2_ITS90_NM_K)
        light /= light.max(axis=1, keepdims=True)
        samples[planck], white[planck] = light @ w.cri_1nm, light @ t.cri_cmf
    if not np.all(planck):
        m = daylight_m(cct[~planck])
        samples[~planck] = m @ (t.cri_daylight_basis.T @ w.cri_1nm)
        white[~planck] = m @ (t.cri_daylight_basis.T @ t.cri_cmf)
    return samples, white


def _uv(xyz: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    den = xyz[..., 0] + 15.0 * xyz[..., 1] + 3.0 * xyz[..., 2]
    return 4.0 * xyz[..., 0] / den, 6.0 * xyz[..., 1] / den


def _uvw(xyz_samples: NDArray[np.float64], uv_white: tuple, uv_ref: tuple, adapt_from: tuple | None
         ) -> NDArray[np.float64]:
    """CIE 1964 U*V*W* of the samples (n, 14, 3) relative to the reference white, after CIE 13.3's
    adaptation from the test white when ``adapt_from`` (the test white's uv) is given."""
    u, v = _uv(xyz_samples)
    if adapt_from is not None:
        c = lambda uu, vv: (4.0 - uu - 10.0 * vv) / vv  # noqa: E731
        d = lambda uu, vv: (1.708 * vv + 0.404 - 1.481 * uu) / vv  # noqa: E731
        cr_ct = (c(*uv_ref) / c(*adapt_from))[:, None]
        dr_dt = (d(*uv_ref) / d(*adapt_from))[:, None]
        cs, ds = c(u, v), d(u, v)
        den = 16.518 + 1.481 * cr_ct * cs - dr_dt * ds
        u, v = (10.872 + 0.404 * cr_ct * cs - 4.0 * dr_dt * ds) / den, 5.52 / den
    y = xyz_samples[..., 1]
    w = 25.0 * np.sign(y) * np.abs(y) ** (1.0 / 3.0) - 17.0
    return np.stack([13.0 * w * (u - uv_white[0][:, None]), 13.0 * w * (v - uv_white[1][:, None]), w], axis=-1)


def special_indices(spds: NDArray[np.float64], xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """R1–R14 (n, 14) of lights on the product grid (n, 81) whose CIE 1931 XYZ (n, 3) the caller
    has (any scale). Ra is the mean of the first eight."""
    w = sample_weights()
    cct = robertson_cct(np.stack(_uv(np.asarray(xyz, dtype=np.float64)), axis=-1))

    def normalised(samples: NDArray[np.float64], white: NDArray[np.float64]) -> NDArray[np.float64]:
        return samples.reshape(-1, N_TCS, 3) * (100.0 / white[:, 1])[:, None, None]

    xyz_t = normalised(spds @ w.cri_grid, xyz)
    samples_r, white_r = _reference_xyz(cct)
    xyz_r = normalised(samples_r, white_r)
    uv_t, uv_r = _uv(xyz), _uv(white_r)
    uvw_t = _uvw(xyz_t, uv_r, uv_r, adapt_from=uv_t)
    uvw_r = _uvw(xyz_r, uv_r, uv_r, adapt_from=None)
    return 100.0 - 4.6 * np.linalg.norm(uvw_r - uvw_t, axis=-1)
