"""The rainbow's own colours as a ruler: each bright pixel's hue names its first-order wavelength.

A pixel on a streak sees a band a few nm wide of the lamp's spectrum, so its colour is the
camera's colour at λ₁ whatever the lamp — a green pixel cannot be 620 nm. Matching every bright
pixel's colour to a wavelength gives (pixel, λ) pairs, and the pose must put λ₁ = d·|u| there and
the lobe (v ≈ 0) over them: a smooth least-squares problem that finds an oblique or rotated
streak from far away, where the binned self-consistency is flat. It is a start, not the answer:
within the lobe the lamp's own spectrum tilts the colour by a few nm.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..numerics.least_squares import cauchy, levenberg_marquardt
from ..scene.capture import Preset
from ..scene.kernel import index_rays
from ..scene.relative_pose import RelativePose, apply_params, ray_diffraction
from ..spectra.cameras import camera_colours, unit_colours
from .result import colour_blur_nm

__all__ = ["colour_wavelengths", "streak_fit"]

COLOUR_BAND = (400.0, 700.0)  # where a camera's colour changes with λ
MIN_MATCH = 0.97  # a pixel's colour must be this close (cosine) to some single wavelength's
COLOUR_PIXELS = 4000  # the brightest pixels looked at
BRIGHT_SHARE = 0.1  # ...down to this share of the brightest
MIN_PIXELS = 20
LAMBDA_SCALE_NM = 8.0  # how far a pixel's colour wavelength may sit from its λ₁ before it counts as wrong
MISS_PENALTY = 5.0  # a bright pixel the pose puts off the tracks, in residual units
PRIOR_DEG = 3.0  # what the rainbow does not pin stays within a few degrees of the start


def colour_wavelengths(values: NDArray[np.float64], sensitivities: NDArray[np.float64], blur_nm: float
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The single wavelength whose camera colour best matches each pixel (nm), and how sharply
    the colour pins it (|d colour / dλ|², per nm², 0 where the colour fits no wavelength).

    Within the lobe a pixel sees a band a few nm wide, so its hue names λ₁ whatever the lamp's
    spectrum — to within that band. Where the camera's colour barely changes with λ (deep red,
    violet) the weight is small."""
    lam = np.arange(COLOUR_BAND[0], COLOUR_BAND[1] + 0.5, 1.0)
    table = unit_colours(camera_colours(lam, sensitivities, max(float(blur_nm), 1.0)))
    slope = np.gradient(table, axis=0)
    sharp = np.sum(slope ** 2, axis=1)
    norm = np.linalg.norm(values, axis=1)
    unit = values / np.maximum(norm, 1e-12)[:, None]
    match = unit @ table.T
    best = np.argmax(match, axis=1)
    ok = match[np.arange(best.size), best] >= MIN_MATCH
    return lam[best], np.where(ok, sharp[best], 0.0)


def streak_fit(rgb: NDArray[np.float64], preset: Preset, focal_px: float, rel0: RelativePose,
               x0: NDArray[np.float64], sensitivities: NDArray[np.float64],
               saturated: NDArray[np.bool_] | None = None) -> tuple[NDArray[np.float64], int]:
    """The pose parameters (around ``rel0``, from ``x0``) that put each bright pixel's colour
    wavelength at its λ₁ and the lobe over it; (x, evaluations). The aim, tilt and lamp
    direction move; the lamp distance and σ stay. A pixel whose colour fits the second order
    (λ₁ = 2λ) counts as well explained; outliers barely pull (Cauchy loss)."""
    height, width, _ = rgb.shape
    flat = rgb.reshape(-1, 3)
    lum = flat.sum(axis=1)
    if saturated is not None:
        lum = np.where(np.asarray(saturated).reshape(-1), 0.0, lum)
    order = np.argsort(lum)[::-1][:COLOUR_PIXELS]
    if order.size == 0 or not lum[order[0]] > 0:
        return x0, 0
    order = order[lum[order] > BRIGHT_SHARE * lum[order[0]]]
    blur = colour_blur_nm(preset, rel0.lobe_sigma, focal_px)
    lam_c, sharp = colour_wavelengths(flat[order], sensitivities, blur)
    use = sharp > 0
    if int(np.sum(use)) < MIN_PIXELS:
        return x0, 0
    idx = np.sort(order[use])
    lam_c, sharp = colour_wavelengths(flat[idx], sensitivities, blur)
    weight = np.minimum(np.sqrt(sharp / np.median(sharp)), 3.0)  # how well each pixel's colour pins its λ
    sigma = rel0.lobe_sigma
    free = np.arange(6)
    rays = index_rays(idx, (width, height), focal_px)
    disc = preset.disc

    def residuals(y: NDArray[np.float64]) -> NDArray[np.float64]:
        x = x0.copy()
        x[free] = y
        rd = ray_diffraction(rays, apply_params(rel0, x), disc.pitch_um)
        on = rd.hit & (rd.radius_mm >= disc.grating_r_min_mm) & (rd.radius_mm <= disc.grating_r_max_mm)
        l1 = rd.lambda1_nm
        err = np.minimum(np.abs(l1 - lam_c), np.abs(l1 - 2.0 * lam_c))
        out = np.full((2, idx.size), MISS_PENALTY)
        out[0, on] = cauchy(err[on] / LAMBDA_SCALE_NM * weight[on])
        out[1, on] = cauchy(rd.v[on] / (2.0 * sigma))
        return np.concatenate([out.ravel(), (y - x0[free]) / PRIOR_DEG])

    y, _, evals = levenberg_marquardt(residuals, x0[free], np.full(free.size, 0.01))
    x = x0.copy()
    x[free] = y
    return x, evals
