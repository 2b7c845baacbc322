"""Bake the colorimetry tables the add-on needs from colour-science into shipped files.

    make bake-colour   (python -m tools.bake_colour)

Blender's bundled Python has numpy only, so :mod:`cd_spectra_addon.core.spectra.colour` and
:mod:`cd_spectra_addon.core.rendition` work from numbers baked here, once, offline:
``cd_spectra_addon/core/spectra/colour_tables.json`` and
``cd_spectra_addon/core/rendition/rendition_tables.npz``. Re-run only when colour-science or a
choice below changes (the outputs are committed; the parity tests in ``tests/test_colour.py``
and ``tests/test_rendition.py`` compare every table, and every figure, with colour-science again).

What is baked and why:

- ``cmf_hat`` (81 × 3): the CIE 1931 2° observer summed against each grid sample's 5 nm
  triangular hat at 1 nm resolution, ``W_i = Σ_k hat_i(λ_k) cmf(λ_k) · 1 nm`` over the 1 nm
  samples 380 … 780 nm. The product's SPD is the piecewise-linear curve through its 81
  samples, zero outside 380–780 nm (the curve the forward model integrates), so
  ``XYZ = Σ_i S_i W_i`` is that curve's tristimulus integral at 1 nm: the same number as
  ``colour.sd_to_XYZ(method="Integration")`` on the SPD linearly interpolated to 1 nm with the
  CMFs trimmed to 380–780 nm. The exact integral (CMFs linear between 1 nm samples) differs
  only by giving the end samples 380 / 780 nm half weight: < 2e-5 in xy, but up to 4e-5 in
  XYZ, i.e. several kelvin at 25 000 K; matching colour-science's quadrature keeps CCT parity.
- ``cmf_planck`` (421 × 3): the same observer on 360–780 nm at 1 nm, which is what
  colour-science's Ohno (2013) uses for its Planckian locus (``SPECTRAL_SHAPE_DEFAULT``).
  The add-on needs it to compute exact locus points while refining CCT (Ohno's cascade).
- ``planckian_table``: T, u, v (CIE 1960) of the Planckian locus from 1000 K to 100 000 K,
  geometric steps of 1 %, from ``colour.temperature.CCT_to_uv_Planck1900`` (c2 = 1.4388e-2
  m·K as in CIE 015 and colour-science). The first level of the cascade.
- ``xyz_to_rgb``: CIE XYZ → Blender's scene-linear working spaces, as Blender's own OCIO
  config converts: Linear Rec.709 and Linear Rec.2020 have a D65 white (no adaptation);
  ACEScg has the ACES white (≈ D60) and Blender reaches it from its D65-referred XYZ with a
  Bradford adaptation (``UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD``; Cycles builds its own
  XYZ→scene-linear matrix the same way). So an SPD with the chromaticity of D65 gives equal
  RGB in every working space and a light looks the same whichever space the user picks.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import colour
import numpy as np

from cd_spectra_addon.core.spectra.colour import ACESCG, LINEAR_REC709, LINEAR_REC2020
from cd_spectra_addon.core.spectra.grid import WAVELENGTHS_NM

CORE = Path(__file__).resolve().parents[1] / "cd_spectra_addon" / "core"
TARGET = CORE / "spectra" / "colour_tables.json"
RENDITION_TARGET = CORE / "rendition" / "rendition_tables.npz"

OBSERVER = "CIE 1931 2 Degree Standard Observer"
CCT_MIN_K = 1000.0
CCT_MAX_K = 100000.0
TABLE_STEP_RATIO = 1.01  # coarse level only: it just has to bracket the nearest locus point

# name → (colour-science colourspace, illuminant of the XYZ fed to it, chromatic adaptation)
WORKING_SPACES: dict[str, tuple[str, str, str | None]] = {
    LINEAR_REC709: ("ITU-R BT.709", "D65", None),  # not "sRGB": its matrix is rounded
    LINEAR_REC2020: ("ITU-R BT.2020", "D65", None),
    ACESCG: ("ACEScg", "D65", "Bradford"),
}


def cmf_hat_weights(cmfs: colour.MultiSpectralDistributions) -> np.ndarray:
    """(81, 3) Σ_k hat_i(λ_k) cmf(λ_k) · 1 nm over the 1 nm samples λ_k = 380 … 780 nm."""
    lam = np.arange(WAVELENGTHS_NM[0], WAVELENGTHS_NM[-1] + 0.5, 1.0)
    values = cmfs.copy().trim(colour.SpectralShape(lam[0], lam[-1], 1.0))
    if not np.array_equal(values.wavelengths, lam):
        raise ValueError(f"{cmfs.name} is not tabulated at 1 nm over 380-780 nm")
    step = float(WAVELENGTHS_NM[1] - WAVELENGTHS_NM[0])
    hats = np.clip(1.0 - np.abs(lam[None, :] - WAVELENGTHS_NM[:, None]) / step, 0.0, None)
    return hats @ values.values * 1.0


def working_space_matrices() -> dict[str, list[list[float]]]:
    matrices = {}
    for name, (cs_name, illuminant, cat) in WORKING_SPACES.items():
        cs = colour.RGB_COLOURSPACES[cs_name]
        xy_w = colour.CCS_ILLUMINANTS[OBSERVER][illuminant]
        # Columns of the matrix = images of the unit vectors, through colour's own function.
        m = colour.XYZ_to_RGB(np.eye(3), cs, illuminant=xy_w, chromatic_adaptation_transform=cat).T
        matrices[name] = m.tolist()
    return matrices


def bake(target: Path = TARGET) -> dict:
    cmfs_full = colour.MSDS_CMFS[OBSERVER]
    cmf_planck, _ = colour.colorimetry.handle_spectral_arguments(None)  # colour's Ohno default
    n = int(np.ceil(np.log(CCT_MAX_K / CCT_MIN_K) / np.log(TABLE_STEP_RATIO)))
    temps = np.geomspace(CCT_MIN_K, CCT_MAX_K, n + 1)
    uv = colour.temperature.CCT_to_uv_Planck1900(temps, cmf_planck)
    payload = {
        "source": f"colour-science {colour.__version__}, baked by tools/bake_colour.py",
        "observer": OBSERVER,
        "wavelength_nm": WAVELENGTHS_NM.tolist(),
        "cmf_hat": cmf_hat_weights(cmfs_full).tolist(),
        "cmf_planck": {
            "start_nm": float(cmf_planck.shape.start),
            "end_nm": float(cmf_planck.shape.end),
            "step_nm": float(cmf_planck.shape.interval),
            "values": cmf_planck.values.tolist(),
        },
        "planck_c2_m_k": float(colour.colorimetry.blackbody.CONSTANT_C2),
        "planckian_table": {"T": temps.tolist(), "u": uv[:, 0].tolist(), "v": uv[:, 1].tolist()},
        "k_m_lm_per_w": float(colour.constants.CONSTANT_K_M),
        "xyz_to_rgb": working_space_matrices(),
        "xyz_to_rgb_white": {
            name: {"xyz_illuminant": ill, "colourspace": cs, "chromatic_adaptation": cat}
            for name, (cs, ill, cat) in WORKING_SPACES.items()
        },
    }
    target.write_text(json.dumps(payload, indent=None, separators=(",", ":")) + "\n", encoding="utf-8")
    return payload


def rendition_tables() -> dict[str, np.ndarray]:
    """The reference data of CIE 13.3, CIE 224:2017 and TM-30, as colour-science uses them."""
    from colour.colorimetry import SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES, SPECTRAL_SHAPE_DEFAULT, reshape_sd
    from colour.quality.cfi2017 import SPECTRAL_SHAPE_CIE2017, load_TCS_CIE2017
    from colour.quality.datasets.tcs import INDEXES_TO_NAMES_TCS, SDS_TCS
    from colour.temperature.ohno2013 import CCT_DEFAULT_SPACING_OHNO2013, planckian_table
    from colour.temperature.robertson1968 import DATA_ISOTEMPERATURE_LINES_ROBERTSON1968

    cri_shape = SPECTRAL_SHAPE_DEFAULT  # what colour_rendering_index reshapes everything to
    cfi_shape = colour.SpectralShape(SPECTRAL_SHAPE_CIE2017.start, SPECTRAL_SHAPE_CIE2017.end, 1)
    basis = [SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES[k] for k in ("S0", "S1", "S2")]
    linear = [colour.SpectralDistribution(b.values, b.wavelengths, interpolator=colour.LinearInterpolator)
              for b in basis]
    tcs = [reshape_sd(SDS_TCS[INDEXES_TO_NAMES_TCS[i]], cri_shape) for i in sorted(INDEXES_TO_NAMES_TCS)]
    return {
        "cri_wavelength_nm": np.asarray(cri_shape.wavelengths, dtype=np.float64),
        "cri_tcs": np.stack([t.values for t in tcs], axis=1),
        "cri_daylight_basis": np.stack([b.copy().align(cri_shape).values for b in linear], axis=1),
        "robertson_lines": np.asarray(DATA_ISOTEMPERATURE_LINES_ROBERTSON1968, dtype=np.float64),
        "cfi_wavelength_nm": np.asarray(cfi_shape.wavelengths, dtype=np.float64),
        "cfi_ces": np.asarray(load_TCS_CIE2017(cfi_shape).values, dtype=np.float64),
        "cfi_cmf_10": np.asarray(colour.colorimetry.reshape_msds(
            colour.MSDS_CMFS["CIE 1964 10 Degree Standard Observer"], cfi_shape).values, dtype=np.float64),
        "cfi_daylight_basis": np.stack([reshape_sd(b, cfi_shape).values for b in basis], axis=1),
        # colour.quality.cfi2017.CCT_reference_illuminant: uv_to_CCT_Ohno2013(uv, start=1000, end=25000)
        "cfi_planckian_table": planckian_table(colour.colorimetry.handle_spectral_arguments(None)[0], 1000, 25000,
                                               CCT_DEFAULT_SPACING_OHNO2013),
    }


def bake_rendition(target: Path = RENDITION_TARGET) -> dict[str, np.ndarray]:
    tables = rendition_tables()
    with open(target, "wb") as handle:  # uncompressed (float64 noise barely compresses; loads in ~1 ms), fixed zip dates
        np.savez(handle, source=np.array(f"colour-science {colour.__version__}, baked by "
                                                    "tools/bake_colour.py"), **tables)
    return tables


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.parse_args()
    payload = bake()
    print(f"baked {len(payload['cmf_hat'])} hat CMFs, {len(payload['planckian_table']['T'])} "
          f"locus points, {len(payload['xyz_to_rgb'])} working spaces into {TARGET}")
    tables = bake_rendition()
    print(f"baked {tables['cri_tcs'].shape[1]} CIE 13.3 test colour samples and {tables['cfi_ces'].shape[1]} "
          f"CIE 2017 colour evaluation samples into {RENDITION_TARGET}")


if __name__ == "__main__":
    main()
