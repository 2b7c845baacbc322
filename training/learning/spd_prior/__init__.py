"""The SPD prior: synthetic lamp spectra for training, built from physics, not from measurements.

The model learns only from spectra drawn here and is judged on measured lamps it never saw, so
each family describes *how a kind of source makes light* (thermal emission, atomic lines,
phosphor bands, atmospheric absorption, filters) with parameter ranges taken from physics and
published product numbers (line wavelengths, phosphor peaks and widths). Nothing is read, fitted,
tuned or selected on measured SPDs or on CIE/colour-science illuminant tables; those are kept for
evaluation only.

Modules, each building on the ones before it:

- ``grid``: the 5 nm hat grid, and how narrow lines, bands and smooth curves are put on it as
  ``resample_to_grid`` would, only fast;
- ``white_point``: aiming white sources at a target CCT / Duv (the core's colorimetry);
- ``families``: line lists, random building blocks, one generator per lamp family, and the
  default family weights;
- ``sampling``: :func:`sample_spds` (a labelled mix) and :func:`gaussian_prior` (its mean and
  covariance, the physics solve's prior).

May import numpy and ``cd_spectra_addon.core`` (Planck's law from ``illuminants``, nothing
else from it); imported by ``training.learning`` and the tests.
"""

from __future__ import annotations

from cd_spectra_addon.core.spectra.illuminants import planck

from training.learning.spd_prior.families import (
    DEFAULT_WEIGHTS,
    FAMILIES,
    HG_LINES_NM,
    blackbody,
    daylight,
    filtered,
    fluorescent_halo,
    fluorescent_tri,
    hps,
    incandescent,
    led_grow,
    led_rgb,
    led_violet,
    led_white,
    lps,
    mercury,
    metal_halide,
    smooth,
    smooth_noise,
    spiky,
    xenon,
    xenon_flash,
)
from training.learning.spd_prior.grid import FINE_NM, fine_to_grid, lines_on_grid
from training.learning.spd_prior.sampling import gaussian_prior, sample_spds

__all__ = [
    "FAMILIES",
    "DEFAULT_WEIGHTS",
    "FINE_NM",
    "HG_LINES_NM",
    "sample_spds",
    "gaussian_prior",
    "planck",
    "lines_on_grid",
    "fine_to_grid",
    "smooth",
    "smooth_noise",
    "spiky",
    "blackbody",
    "incandescent",
    "daylight",
    "led_white",
    "led_violet",
    "led_rgb",
    "led_grow",
    "fluorescent_tri",
    "fluorescent_halo",
    "metal_halide",
    "hps",
    "lps",
    "mercury",
    "xenon",
    "xenon_flash",
    "filtered",
]
