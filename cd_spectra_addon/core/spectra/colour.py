"""Colorimetry of an SPD on the product grid: XYZ, chromaticity, CCT / Duv, Blender RGB, metrics.

Runs inside Blender's bundled Python, so numpy only: every number that would need
colour-science is baked offline by ``tools/bake_colour.py`` into ``colour_tables.json``
next to this file, and ``tests/test_colour.py`` checks them against colour-science again.

Conventions
-----------
- An SPD is 81 non-negative samples on 380–780 nm / 5 nm (last axis); the curve it stands for
  is the piecewise-linear one through the samples, zero outside 380–780 nm (the "hat"
  representation of :mod:`~cd_spectra_addon.core.spectral_grid`).
- :func:`spd_to_xyz` returns the absolute tristimulus integrals ``X = ∫ S(λ) x̄(λ) dλ`` (CIE 1931
  2°, λ in nm, no ``K_m`` and no Y = 100 normalisation): an SPD in W·sr⁻¹·m⁻²·nm⁻¹ gives
  XYZ in W·sr⁻¹·m⁻², and :func:`luminance` multiplies Y by K_m = 683 lm/W. Chromaticity does
  not depend on the scale.
- The integral is taken at 1 nm over 380–780 nm, the way colour-science integrates: XYZ equals
  ``colour.sd_to_XYZ(sd, cmfs=<CIE 1931 2° trimmed to 380–780>, method="Integration")`` for the
  81 samples linearly interpolated to 1 nm (the same SPD), to rounding. colour's *default*
  (ASTM E308 weights for 5 nm data) assumes a smoother curve through the samples (Lagrange)
  and extends the SPD below 380 nm; for narrow lamp lines that moves xy by up to ~2.5e-4
  (CIE FL and LED illuminants), which describes a different SPD, not a more exact one. The
  forward model integrates the hat curve, so the colorimetry does too.
- CCT and Duv follow Ohno (2014) exactly as colour-science implements it (same Planckian
  locus: CIE 1931 2° at 1 nm over 360–780 nm, c2 = 1.4388e-2 m·K; same triangular /
  parabolic switch at |Duv| = 0.002), with Ohno's cascade instead of one 7000-row table: a
  baked 1 % table finds the bracket, two finer levels are computed from the baked CMFs.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import CDSpectraError
from .illuminants import C2_ITS90_NM_K, planck_radiance
from .grid import N_BANDS, VISIBLE_NM, WAVELENGTH_MAX_NM, WAVELENGTH_MIN_NM, WAVELENGTHS_NM

__all__ = [
    "TABLES_FILE",
    "CCT_MIN_K",
    "CCT_MAX_K",
    "DUV_MAX",
    "LINEAR_REC709",
    "LINEAR_REC2020",
    "ACESCG",
    "WORKING_SPACES",
    "DEFAULT_WORKING_SPACE",
    "known_working_space",
    "LightColour",
    "spd_to_xyz",
    "spd_to_xy",
    "xyz_to_xy",
    "xy_to_uv1960",
    "xy_to_uv_prime",
    "uv1960_to_xy",
    "hat_cmfs",
    "cmfs_1nm",
    "planck_uv1960",
    "cct_duv_to_uv1960",
    "uv_to_cct_ohno2013",
    "uv_to_cct_in_table",
    "ohno_solution",
    "cct_duv",
    "xyz_to_working_rgb",
    "light_colour",
    "SpectralColour",
    "spectral_colour",
    "luminance",
    "compare_spds",
]

TABLES_FILE = Path(__file__).with_name("colour_tables.json")

CCT_MIN_K = 1000.0
CCT_MAX_K = 100000.0
DUV_MAX = 0.05
"""Beyond these, CCT is not a meaningful description of a light's colour (Ohno 2014, ANSI C78.377)."""

# Blender's working colour spaces, by the names its OCIO config gives them.
LINEAR_REC709 = "Linear Rec.709"
LINEAR_REC2020 = "Linear Rec.2020"
ACESCG = "ACEScg"
WORKING_SPACES: tuple[str, ...] = (LINEAR_REC709, LINEAR_REC2020, ACESCG)
DEFAULT_WORKING_SPACE = LINEAR_REC709
"""Blender 4.x's only working space, and what light colours are given in when a Blender 5 file's
space is not one of :data:`WORKING_SPACES` (a custom OCIO config)."""
_SPACE_ALIASES = {
    # Blender's working_space_interop_id values, and the pre-4.0 name of the default space.
    "lin_rec709_scene": LINEAR_REC709,
    "Linear": LINEAR_REC709,
    "lin_rec2020_scene": LINEAR_REC2020,
    "lin_ap1_scene": ACESCG,
}

_CASCADE_POINTS = 21  # locus points per refinement level
_CASCADE_LEVELS = 2  # 1 % bracket → 0.1 % steps → 0.01 % steps
_OUT_OF_GAMUT_TOLERANCE = 1e-6  # relative to the largest channel: invisible, rounding-level


@dataclass(frozen=True)
class _Tables:
    cmf_hat: NDArray[np.float64]  # (81, 3), nm
    cmf_planck: NDArray[np.float64]  # (421, 3)
    planck_wavelength_m: NDArray[np.float64]  # (421,)
    c2: float
    table_t: NDArray[np.float64]
    table_uv: NDArray[np.float64]  # (n, 2)
    k_m: float
    xyz_to_rgb: dict[str, NDArray[np.float64]]


@lru_cache(maxsize=1)
def _tables() -> _Tables:
    data = json.loads(TABLES_FILE.read_text(encoding="utf-8"))
    if not np.allclose(data["wavelength_nm"], WAVELENGTHS_NM):
        raise RuntimeError(f"{TABLES_FILE.name} was baked for another wavelength grid")
    if data["planck_c2_m_k"] != C2_ITS90_NM_K / 1e9:
        raise RuntimeError(f"{TABLES_FILE.name} was baked for another Planckian locus (c2)")
    planck = data["cmf_planck"]
    wl = np.arange(planck["start_nm"], planck["end_nm"] + planck["step_nm"] / 2, planck["step_nm"])
    table = data["planckian_table"]

    def frozen(values: object) -> NDArray[np.float64]:
        arr = np.array(values, dtype=np.float64)
        arr.flags.writeable = False
        return arr

    return _Tables(
        cmf_hat=frozen(data["cmf_hat"]),
        cmf_planck=frozen(planck["values"]),
        planck_wavelength_m=frozen(wl * 1e-9),
        c2=C2_ITS90_NM_K / 1e9,
        table_t=frozen(table["T"]),
        table_uv=frozen(np.stack([table["u"], table["v"]], axis=-1)),
        k_m=float(data["k_m_lm_per_w"]),
        xyz_to_rgb={name: frozen(m) for name, m in data["xyz_to_rgb"].items()},
    )


# --- validation ---------------------------------------------------------------------------


def _as_spd(spd: ArrayLike) -> NDArray[np.float64]:
    """SPD(s) as float64 (..., 81); CDSpectraError for anything colorimetry can't be done on."""
    arr = np.asarray(spd, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != N_BANDS:
        raise CDSpectraError(f"an SPD has {N_BANDS} samples (380–780 nm, 5 nm); got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise CDSpectraError("the SPD contains NaN or infinite values")
    if np.any(arr < 0):
        raise CDSpectraError("the SPD has negative values; a light's power cannot be negative")
    if np.any(np.max(arr, axis=-1) <= 0):
        raise CDSpectraError("the SPD is zero everywhere: there is no light to measure")
    return arr


def _peak_normalised(spd: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(spd / peak, peak): chromaticity is scale-free, and this keeps 1e-300 or 1e300 finite."""
    peak = np.max(spd, axis=-1, keepdims=True)
    return spd / peak, peak


def _as_vectors(values: ArrayLike, n: int, what: str, label: str | None = None,
                finite: bool = True) -> NDArray[np.float64]:
    """``values`` as float64 (..., n); CDSpectraError naming ``what`` for another shape or,
    with ``finite``, for NaN/Inf (``label`` overrides how the shape message names it)."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != n:
        raise CDSpectraError(f"{label or what} needs {n} values on its last axis; got shape {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise CDSpectraError(f"{what} contains NaN or infinite values")
    return arr


def _as_xy(xy: ArrayLike) -> NDArray[np.float64]:
    return _as_vectors(xy, 2, "xy", label="xy chromaticity")


# --- tristimulus and chromaticity ----------------------------------------------------------


def spd_to_xyz(spd: ArrayLike) -> NDArray[np.float64]:
    """CIE 1931 2° XYZ ``∫ S x̄ dλ`` (λ in nm) of SPD(s) on the grid: (..., 81) → (..., 3).

    The hat-integrated CMFs make this the 1 nm integral of the piecewise-linear SPD, so a
    narrow line between two samples counts as much as it does in the forward model.
    """
    rel, peak = _peak_normalised(_as_spd(spd))
    return (rel @ _tables().cmf_hat) * peak


def xyz_to_xy(xyz: ArrayLike) -> NDArray[np.float64]:
    """CIE xy from XYZ (..., 3) → (..., 2); ValueError where X + Y + Z is not positive."""
    arr = _as_vectors(xyz, 3, "XYZ")
    scale = np.max(np.abs(arr), axis=-1, keepdims=True)
    scaled = np.divide(arr, scale, out=np.zeros_like(arr), where=scale > 0)
    total = np.sum(scaled, axis=-1, keepdims=True)
    if np.any(total <= 0):
        raise CDSpectraError("X + Y + Z is zero or negative: no chromaticity (no light)")
    return scaled[..., :2] / total


def spd_to_xy(spd: ArrayLike) -> NDArray[np.float64]:
    """CIE 1931 xy of SPD(s): (..., 81) → (..., 2)."""
    rel, _ = _peak_normalised(_as_spd(spd))
    return xyz_to_xy(rel @ _tables().cmf_hat)


def _uv_denominator(xy: NDArray[np.float64]) -> NDArray[np.float64]:
    den = -2.0 * xy[..., 0] + 12.0 * xy[..., 1] + 3.0
    if np.any(den <= 0):
        raise CDSpectraError("xy is not a chromaticity (−2x + 12y + 3 ≤ 0)")
    return den


def xy_to_uv1960(xy: ArrayLike) -> NDArray[np.float64]:
    """CIE 1960 UCS uv (the CCT / Duv plane): u = 4x / d, v = 6y / d, d = −2x + 12y + 3."""
    arr = _as_xy(xy)
    den = _uv_denominator(arr)
    return np.stack([4.0 * arr[..., 0] / den, 6.0 * arr[..., 1] / den], axis=-1)


def xy_to_uv_prime(xy: ArrayLike) -> NDArray[np.float64]:
    """CIE 1976 UCS u'v' (the plane for colour differences Δu'v'): u' = 4x / d, v' = 9y / d."""
    arr = _as_xy(xy)
    den = _uv_denominator(arr)
    return np.stack([4.0 * arr[..., 0] / den, 9.0 * arr[..., 1] / den], axis=-1)


def uv1960_to_xy(uv: ArrayLike) -> NDArray[np.float64]:
    """CIE xy from CIE 1960 uv, the inverse of :func:`xy_to_uv1960`: x = 3u / d, y = 2v / d,
    d = 2u − 8v + 4."""
    arr = _as_vectors(uv, 2, "uv")
    den = 2.0 * arr[..., 0] - 8.0 * arr[..., 1] + 4.0
    if np.any(den <= 0):
        raise CDSpectraError("uv is not a chromaticity (2u − 8v + 4 ≤ 0)")
    return np.stack([3.0 * arr[..., 0] / den, 2.0 * arr[..., 1] / den], axis=-1)


def hat_cmfs() -> NDArray[np.float64]:
    """The CIE 1931 2° CMFs integrated against each grid sample's hat, (81, 3) in nm, read-only.

    ``spd @ hat_cmfs()`` is :func:`spd_to_xyz` without its checks: the same linear map for rows
    that may be zero (a mix's optional part), as the training prior needs for batches."""
    return _tables().cmf_hat


def cmfs_1nm() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(wavelengths in nm, CMFs (n, 3)) of the CIE 1931 2° observer at 1 nm over 360–780 nm, read-only:
    colour-science's default observer (``SPECTRAL_SHAPE_DEFAULT``), which its Planckian locus,
    CIE 13.3 colour rendering and dominant wavelength use."""
    t = _tables()
    return np.round(t.planck_wavelength_m * 1e9, 9), t.cmf_planck


# --- CCT and Duv (Ohno 2014) ---------------------------------------------------------------


def planck_uv1960(cct: ArrayLike) -> NDArray[np.float64]:
    """CIE 1960 uv of the Planckian radiator at ``cct`` K: (...) → (..., 2).

    Same locus as colour-science's ``CCT_to_uv_Planck1900`` (CIE 1931 2° at 1 nm over
    360–780 nm, c2 = 1.4388e-2 m·K); constant factors of Planck's law cancel in uv.
    """
    t = _tables()
    temps = np.asarray(cct, dtype=np.float64)
    if not np.all(np.isfinite(temps)) or np.any(temps < 100.0):
        raise CDSpectraError("a Planckian temperature must be finite and at least 100 K")  # else 0/0
    radiance = planck_radiance(t.planck_wavelength_m, temps[..., None], t.c2)
    xyz = radiance @ t.cmf_planck
    den = xyz[..., 0] + 15.0 * xyz[..., 1] + 3.0 * xyz[..., 2]
    return np.stack([4.0 * xyz[..., 0] / den, 6.0 * xyz[..., 1] / den], axis=-1)


def cct_duv_to_uv1960(cct: ArrayLike, duv: ArrayLike) -> NDArray[np.float64]:
    """CIE 1960 uv at a CCT (K) and Duv, the inverse of :func:`uv_to_cct_ohno2013`: the
    Planckian point at ``cct`` moved by ``duv`` along the locus normal (Duv > 0 towards +v,
    above the locus). The normal is taken from the locus at CCT and CCT + 0.01 K, as
    colour-science's ``CCT_to_uv_Ohno2013`` does. ``cct`` and ``duv`` broadcast: (...) → (..., 2)."""
    temps, shift = np.broadcast_arrays(np.asarray(cct, dtype=np.float64), np.asarray(duv, dtype=np.float64))
    uv0 = planck_uv1960(temps)
    back = uv0 - planck_uv1960(temps + 0.01)  # along the locus, from CCT + 0.01 K back to CCT
    back = back / np.hypot(back[..., 0], back[..., 1])[..., None]
    return np.stack([uv0[..., 0] - shift * back[..., 1], uv0[..., 1] + shift * back[..., 0]], axis=-1)


def _ohno_chunk(uv: NDArray[np.float64]) -> NDArray[np.float64]:
    t = _tables()
    rows = np.arange(uv.shape[0])
    dist = np.hypot(t.table_uv[None, :, 0] - uv[:, 0:1], t.table_uv[None, :, 1] - uv[:, 1:2])
    i = np.clip(np.argmin(dist, axis=1), 1, t.table_t.size - 2)  # colour clamps the same way
    lo, hi = t.table_t[i - 1], t.table_t[i + 1]
    steps = np.linspace(0.0, 1.0, _CASCADE_POINTS)
    for _ in range(_CASCADE_LEVELS):
        temps = lo[:, None] * (hi / lo)[:, None] ** steps[None, :]  # geometric, like the table
        locus = planck_uv1960(temps)
        dist = np.hypot(locus[..., 0] - uv[:, 0:1], locus[..., 1] - uv[:, 1:2])
        j = np.clip(np.argmin(dist, axis=1), 1, _CASCADE_POINTS - 2)
        lo, hi = temps[rows, j - 1], temps[rows, j + 1]
    three = j[:, None] + np.arange(-1, 2)
    return ohno_solution(uv, np.take_along_axis(temps, three, axis=1), np.take_along_axis(locus, three[..., None], axis=1))


def ohno_solution(uv: NDArray[np.float64], temps: NDArray[np.float64], locus: NDArray[np.float64]
                  ) -> NDArray[np.float64]:
    """CCT and Duv (m, 2) of uv (m, 2) from the three Planckian points around its nearest one:
    temperatures (m, 3) and their uv (m, 3, 2), in increasing temperature — Ohno's triangular
    solution near the locus, his parabolic one where |Duv| ≥ 0.002."""
    dist = np.hypot(locus[..., 0] - uv[:, None, 0], locus[..., 1] - uv[:, None, 1])
    t_p, t_i, t_n = temps.T
    d_p, d_i, d_n = dist.T
    uv_p, uv_n = locus[:, 0], locus[:, 2]

    # Triangular solution (close to the locus).
    length = np.hypot(*(uv_n - uv_p).T)
    x = (d_p**2 - d_n**2 + length**2) / (2.0 * length)
    cct_t = t_p + (t_n - t_p) * (x / length)
    v_tx = uv_p[:, 1] + (uv_n[:, 1] - uv_p[:, 1]) * (x / length)
    sign = np.sign(uv[:, 1] - v_tx)  # above the locus (greener) is positive
    duv_t = np.sqrt(np.maximum(d_p**2 - x**2, 0.0)) * sign

    # Parabolic solution (further away), fitted around t_i to keep the numbers well scaled.
    s_p, s_n = t_p - t_i, t_n - t_i
    det = s_p * s_n * (s_p - s_n)
    a = ((d_p - d_i) * s_n - (d_n - d_i) * s_p) / det
    b = ((d_n - d_i) * s_p**2 - (d_p - d_i) * s_n**2) / det
    convex = a > 0
    a_safe = np.where(convex, a, 1.0)
    cct_p = t_i - b / (2.0 * a_safe)
    duv_p = (d_i - b**2 / (4.0 * a_safe)) * sign

    parabolic = (np.abs(duv_t) >= 0.002) & convex
    return np.stack([np.where(parabolic, cct_p, cct_t), np.where(parabolic, duv_p, duv_t)], axis=-1)


def uv_to_cct_in_table(uv: ArrayLike, table_t: NDArray[np.float64], table_uv: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
    """CCT and Duv of uv (..., 2) by Ohno on a given Planckian table (T (k,), uv (k, 2)), without
    the cascade: colour-science's ``uv_to_CCT_Ohno2013`` on the same table, point for point (the
    CIE 2017 fidelity index uses its 1000–25 000 K table; a fine table makes a batch cheap).

    The nearest table point is found on every 16th point first, then among its neighbours: the
    distance to the locus has one minimum along it for any chromaticity CCT is defined for."""
    arr = _as_vectors(uv, 2, "uv")
    flat = arr.reshape(-1, 2)
    stride = 16
    coarse = np.arange(0, table_t.size, stride)
    d2 = (table_uv[coarse, 0] - flat[:, 0:1]) ** 2 + (table_uv[coarse, 1] - flat[:, 1:2]) ** 2
    window = coarse[np.argmin(d2, axis=1)][:, None] + np.arange(-2 * stride, 2 * stride + 1)
    window = np.clip(window, 0, table_t.size - 1)
    d2 = (table_uv[window, 0] - flat[:, 0:1]) ** 2 + (table_uv[window, 1] - flat[:, 1:2]) ** 2
    nearest = window[np.arange(flat.shape[0]), np.argmin(d2, axis=1)]
    three = np.clip(nearest, 1, table_t.size - 2)[:, None] + np.arange(-1, 2)  # colour clamps the same way
    return ohno_solution(flat, table_t[three], table_uv[three]).reshape(arr.shape)


def uv_to_cct_ohno2013(uv: ArrayLike) -> NDArray[np.float64]:
    """CCT (K) and Duv of CIE 1960 uv by Ohno (2014): (..., 2) → (..., 2), no range check.

    Like ``colour.temperature.uv_to_CCT_Ohno2013`` (which this matches within 0.2 K), values
    outside 1000–100 000 K or |Duv| > 0.05 are returned as computed; :func:`cct_duv` applies
    the range. Duv > 0 is above the locus (greenish), < 0 below (pinkish).

    References
    ----------
    Ohno, Y. (2014). Practical Use and Calculation of CCT and Duv. LEUKOS, 10(1), 47–55.
    doi:10.1080/15502724.2014.839020

    Examples
    --------
    >>> cct, duv = uv_to_cct_ohno2013([0.1978, 0.3122])
    >>> round(float(cct), 2), round(float(duv), 7)
    (6507.47, 0.0032233)
    """
    arr = _as_vectors(uv, 2, "uv")
    flat = arr.reshape(-1, 2)
    out = np.empty_like(flat)
    for start in range(0, flat.shape[0], 512):  # bounded memory for large batches
        out[start:start + 512] = _ohno_chunk(flat[start:start + 512])
    return out.reshape(arr.shape)


def cct_duv(xy_or_spd: ArrayLike) -> tuple[float | None, float | None]:
    """(CCT in K, Duv) of one xy chromaticity (2 values) or one SPD (81 values).

    (None, None) where CCT is undefined: |Duv| > 0.05 or CCT outside 1000–100 000 K (a deep
    red, a saturated LED, ...). For arrays of uv use :func:`uv_to_cct_ohno2013`.

    The locus is the CIE one (360–780 nm) while an SPD here is zero below 380 nm, so a
    blackbody sampled on the grid reads slightly low: −2 K at 6500 K, −110 K at 25 000 K
    (colour-science gives the same numbers for the same SPD).
    """
    arr = np.asarray(xy_or_spd, dtype=np.float64)
    if arr.ndim != 1 or arr.size not in (2, N_BANDS):
        raise CDSpectraError(f"cct_duv takes one xy (2 values) or one SPD ({N_BANDS} values); "
                             f"got shape {arr.shape}")
    xy = spd_to_xy(arr) if arr.size == N_BANDS else _as_xy(arr)
    cct, duv = (float(v) for v in uv_to_cct_ohno2013(xy_to_uv1960(xy)))
    if not (np.isfinite(cct) and np.isfinite(duv)):
        return None, None
    if not (CCT_MIN_K <= cct <= CCT_MAX_K) or abs(duv) > DUV_MAX:
        return None, None
    return cct, duv


# --- Blender working spaces ----------------------------------------------------------------


def known_working_space(space: str) -> str | None:
    """The canonical name of a working space (a name or Blender's interop id), None if unknown."""
    name = _SPACE_ALIASES.get(space, space)
    return name if name in WORKING_SPACES else None


def _space(space: str) -> str:
    name = known_working_space(space)
    if name is None:
        raise CDSpectraError(f"unknown working colour space {space!r}; "
                             f"expected one of {', '.join(WORKING_SPACES)}")
    return name


def xyz_to_working_rgb(xyz: ArrayLike, space: str = DEFAULT_WORKING_SPACE) -> NDArray[np.float64]:
    """CIE XYZ (..., 3) → scene-linear RGB in a Blender working space (..., 3).

    ``space`` is Blender's ``working_space`` name ("Linear Rec.709", the 4.x default;
    "Linear Rec.2020"; "ACEScg") or its interop id. XYZ is taken as Blender takes it
    (``Linear CIE-XYZ D65``: D65 is white), so for ACEScg the matrix includes the Bradford
    D65 → ACES-white adaptation of Blender's OCIO config. No clipping.
    """
    arr = _as_vectors(xyz, 3, "XYZ", finite=False)
    return arr @ _tables().xyz_to_rgb[_space(space)].T


class LightColour(NamedTuple):
    rgb: tuple[float, float, float]
    out_of_gamut: bool


def light_colour(spd: ArrayLike, space: str = DEFAULT_WORKING_SPACE) -> LightColour:
    """What a Blender light's ``color`` gets: working-space RGB with its largest channel 1.

    A light outside the working space's gamut (a narrow-band LED in Rec.709) has a negative
    channel; it is clipped to 0 and ``out_of_gamut`` is True, so the UI can say the light's
    colour is only approximated (hue kept as well as a clip can, saturation lost).
    """
    arr = np.asarray(spd, dtype=np.float64)
    if arr.ndim != 1:
        raise CDSpectraError(f"light_colour takes one SPD of {N_BANDS} values; got shape {arr.shape}")
    rel, _ = _peak_normalised(_as_spd(arr))
    rgb = xyz_to_working_rgb(rel @ _tables().cmf_hat, space)
    rgb = rgb / np.max(rgb)  # > 0: Y > 0 and every working space has positive luminance weights
    out_of_gamut = bool(np.any(rgb < -_OUT_OF_GAMUT_TOLERANCE))
    rgb = np.clip(rgb, 0.0, None)
    rgb = rgb / np.max(rgb)
    return LightColour((float(rgb[0]), float(rgb[1]), float(rgb[2])), out_of_gamut)


@dataclass(frozen=True)
class SpectralColour:
    """Everything the product reports about a light's colour, in one working space."""

    rgb: tuple[float, float, float]  # scene-linear, largest channel 1, clipped to the gamut
    out_of_gamut: bool
    xy: tuple[float, float]
    cct_k: float | None  # None where CCT is undefined (see cct_duv)
    duv: float | None
    working_space: str


def spectral_colour(spd: ArrayLike, space: str = DEFAULT_WORKING_SPACE) -> SpectralColour:
    """The colour of one SPD: xy, CCT, Duv and the light's RGB in ``space``, all from the SPD.

    The one computation behind the estimate, the CLI and the Blender lights, so a light's
    colour and the numbers printed beside it never disagree.
    """
    values = np.asarray(spd, dtype=np.float64)
    if values.ndim != 1:
        raise CDSpectraError(f"spectral_colour takes one SPD of {N_BANDS} values; got shape {values.shape}")
    xy = spd_to_xy(values)
    cct, duv = cct_duv(xy)
    light = light_colour(values, space)
    if not all(np.isfinite(c) and c >= 0.0 for c in light.rgb):  # light_colour clips; a guard for NaN
        raise CDSpectraError(f"the SPD has no valid colour in {space} (got {light.rgb})")
    return SpectralColour(rgb=light.rgb, out_of_gamut=light.out_of_gamut, xy=(float(xy[0]), float(xy[1])),
                          cct_k=cct, duv=duv, working_space=space)


def luminance(spd: ArrayLike) -> float | NDArray[np.float64]:
    """Photometric value K_m ∫ S ȳ dλ (K_m = 683 lm/W): cd/m² for a radiance SPD in
    W·sr⁻¹·m⁻²·nm⁻¹, lm for a spectral flux in W/nm; for a peak-normalised SPD, a relative
    brightness that lets two lights of different shape be set to the same lumens."""
    y = spd_to_xyz(spd)[..., 1] * _tables().k_m
    return float(y) if np.ndim(y) == 0 else y


# --- comparison with a reference ------------------------------------------------------------

_BANDS_NM = {"400_700": VISIBLE_NM, "380_780": (WAVELENGTH_MIN_NM, WAVELENGTH_MAX_NM)}


def compare_spds(estimate: ArrayLike, reference: ArrayLike) -> dict[str, float | None]:
    """How close an estimated SPD is to a reference (a meter's measurement), both on the grid.

    - ``mae_400_700``, ``rmse_400_700``, ``mae_380_780``, ``rmse_380_780``: mean absolute and
      root-mean-square differences over the grid samples inside the band, after scaling each
      SPD so its peak *inside that band* is 1. Per-band peaks keep the 400–700 nm score (what a
      camera sees) from being set by a tail the camera cannot see (an incandescent's peak is
      beyond 780 nm in the data).
    - ``pearson_r`` (380–780) and ``pearson_r_400_700``: shape agreement, independent of scale;
      None where either SPD is flat in the band (r undefined).
    - ``delta_uv_prime``: CIE 1976 u'v' distance (≈ 0.001 is a just-visible difference).
    - ``delta_cct_k``, ``delta_duv``: estimate − reference; None where either CCT is undefined.
    """
    est = _as_spd(estimate)
    ref = _as_spd(reference)
    if est.ndim != 1 or ref.ndim != 1:
        raise CDSpectraError("compare_spds compares one SPD with one SPD")
    out: dict[str, float | None] = {}
    for key, (lo, hi) in _BANDS_NM.items():
        band = (WAVELENGTHS_NM >= lo - 1e-9) & (WAVELENGTHS_NM <= hi + 1e-9)
        e, r = est[band], ref[band]
        e_peak, r_peak = float(np.max(e)), float(np.max(r))
        if e_peak <= 0 or r_peak <= 0:
            out[f"mae_{key}"] = out[f"rmse_{key}"] = None  # dark in this band: nothing to compare
        else:
            diff = e / e_peak - r / r_peak
            out[f"mae_{key}"] = float(np.mean(np.abs(diff)))
            out[f"rmse_{key}"] = float(np.sqrt(np.mean(diff**2)))
        out["pearson_r" if key == "380_780" else f"pearson_r_{key}"] = _pearson(e, r)
    uvp = xy_to_uv_prime(np.stack([spd_to_xy(est), spd_to_xy(ref)]))
    out["delta_uv_prime"] = float(np.hypot(*(uvp[0] - uvp[1])))
    cct_e, duv_e = cct_duv(est)
    cct_r, duv_r = cct_duv(ref)
    both = cct_e is not None and cct_r is not None
    out["delta_cct_k"] = cct_e - cct_r if both else None  # type: ignore[operator]
    out["delta_duv"] = duv_e - duv_r if both else None  # type: ignore[operator]
    return out


def _pearson(a: NDArray[np.float64], b: NDArray[np.float64]) -> float | None:
    a = a / np.max(a) if np.max(a) > 0 else a
    b = b / np.max(b) if np.max(b) > 0 else b
    da, db = a - a.mean(), b - b.mean()
    na, nb = float(np.sqrt(np.sum(da * da))), float(np.sqrt(np.sum(db * db)))
    if na <= 1e-12 * np.sqrt(a.size) or nb <= 1e-12 * np.sqrt(b.size):
        return None
    return float(np.clip(np.sum(da * db) / (na * nb), -1.0, 1.0))
