"""The spectral readout of a photo: camera RGB binned by the first-order diffraction coordinate.

Each disc pixel sees, to first order, the lamp at wavelength λ₁ = d·|u| scaled by how visible
the lobe is there (exp(−v²/2σ²)) and by the slowly varying geometry (irradiance × G/w²): its
amplitude a. Binning pixels by λ₁ turns any capture geometry into the same three-channel
"spectrometer read-out": per bin and channel the least-squares A of I = A·a over the bin's
pixels, after rejecting outliers (dust, scratches, glare) against the bin's median. Saturated pixels are left out and counted, never averaged in.
The operator is linear in the image for fixed weights, so the forward matrix of the features
(:mod:`.forward`) applies the same weights to the model's basis images.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..numerics.special import norm_ppf
from ..scene.capture import Scene
from ..scene.diffraction import PixelDiffraction, pixel_diffraction
# The λ₁ bins live with the wavelength grids (planning bins the same way); re-exported here as
# the readout's own: FEATURE_STEP_NM is re-exported for the pose fit, which imports it from here.
from ..spectra.grid import FEATURE_LAMBDA_NM, FEATURE_STEP_NM, MIN_VISIBILITY, N_FEATURES, feature_bins

OUTLIER_MADS = 5.0
# A bin's channel whose used pixels are clipped for more than this share of their weight is a
# bound (at most / at least its value), not a value: see :mod:`..photo.clipping`.
CENSOR_SHARE = 0.1
MIN_BIN_WEIGHT = 2.0  # Σ visibility² of the pixels used — about two fully visible pixels (not Σ amplitude²:
# the geometric gain is relative to the disc centre's irradiance, ~0.1 under a grazing lamp)
# Pixels this close to the tracks' inner or outer edge (mm on the disc) are read only in bins that
# have too few others (EDGE_FALLBACK × MIN_BIN_WEIGHT): whether such a pixel lies on the tracks or
# just off them turns on a fraction of a millimetre of the fitted pose, and one read off them is
# dark where the fit expects the lamp. With lamp and camera facing each other across the disc
# (tripod-oblique) one arm of the streak runs along the outer edge: a synthetic lamp read with
# its fitted λ₁ 0.8 nm off had 60 % of its 625–635 nm pixels at r 57.6–58.5 mm dark, the bins'
# medians 0, and the solve put 0 at 625 nm and its peak at 640 nm (MAE 400–700 0.37).
EDGE_MARGIN_MM = 1.0
EDGE_FALLBACK = 4.0

__all__ = ["FEATURE_LAMBDA_NM", "FEATURE_STEP_NM", "MIN_VISIBILITY", "N_FEATURES", "Readout", "extract_readout"]


@dataclass(frozen=True)
class Readout:
    lambda_nm: NDArray[np.float64]  # (NB,) bin centres of λ₁
    values: NDArray[np.float64]  # (NB, 3) amplitude per bin and channel (0 where invalid)
    weight: NDArray[np.float64]  # (NB,) Σ w·amplitude² of the pixels used
    saturated_fraction: NDArray[np.float64]  # (NB,) share of the bin's weight that was clipped
    valid: NDArray[np.bool_]  # (NB,)
    noise: NDArray[np.float64]  # (NB, 3) standard error of each value (robust, from residuals)
    pixels: PixelDiffraction  # the pixels used (after masks)
    pixel_bin: NDArray[np.int64]  # bin of each used pixel
    pixel_weight: NDArray[np.float64]  # final weight w of each used pixel (0 = rejected)
    # (NB, 3) −1: the channel was clipped at the floor there (the true value is at most the
    # value), +1: at full scale (at least); 0 or None: a value. Only for clipped in-camera files.
    censored: NDArray[np.int8] | None = None
    # (NB,) bins read from pixels within EDGE_MARGIN_MM of the tracks' edges (no others had enough
    # weight there): whether those pixels lie on the tracks turns on the pose (:mod:`..spectrum.track_edges`).
    edge_only: NDArray[np.bool_] | None = None


@dataclass(frozen=True)
class _Groups:
    """Pixels grouped by bin: ``order`` lists bin 0's pixels, then bin 1's, ... (stable)."""

    order: NDArray[np.intp]
    counts: NDArray[np.int64]
    starts: NDArray[np.int64]


def _groups(bins: NDArray[np.int64], n_bins: int) -> _Groups:
    """One stable argsort of the bins (radix sort on a 16-bit copy: ~5× a comparison sort)."""
    small = bins.astype(np.int16) if n_bins < 2 ** 15 else bins
    counts = np.bincount(bins, minlength=n_bins)
    return _Groups(order=np.argsort(small, kind="stable"), counts=counts,
                   starts=np.concatenate([[0], np.cumsum(counts)[:-1]]))


def _bin_median(bins: NDArray[np.int64], values: NDArray[np.float64], n_bins: int,
                groups: _Groups | None = None) -> NDArray[np.float64]:
    """Median of ``values`` per bin (NaN for empty bins).

    The values are encoded in one key per pixel (bin, then value) and read back from the keys
    at the bin's middle ranks; the read-back costs ~1e-13 of the value range, far below any
    photo's precision. The middle ranks come from a partition of each bin's keys (``groups``,
    shared by every median over the same pixels), not a sort of all of them: 25 → 10 ms for
    the two medians of a 24 MP photo's 250k pixels."""
    lo, hi = float(np.min(values)) if values.size else 0.0, float(np.max(values)) if values.size else 1.0
    span = hi - lo if hi > lo else 1.0
    key = bins.astype(np.float64) * 4.0 + (values - lo) / span  # values map into [0, 1] ⊂ [0, 4)
    g = _groups(bins, n_bins) if groups is None else groups
    grouped = key[g.order]
    out = np.full(n_bins, np.nan)
    for i in np.flatnonzero(g.counts):
        seg = grouped[g.starts[i]: g.starts[i] + g.counts[i]]
        first, last = (g.counts[i] - 1) // 2, g.counts[i] // 2
        seg.partition([first, last] if last != first else first)
        out[i] = lo + span * (0.5 * ((seg[first] - 4.0 * i) + (seg[last] - 4.0 * i)))
    return out


def _unclip(values: NDArray[np.float64], flat: NDArray[np.float64], b: NDArray[np.int64],
            weight: NDArray[np.float64], vis: NDArray[np.float64]) -> NDArray[np.float64]:
    """Undo the bias of noise clipped at zero (integer encodings) in dark bins.

    Where a bin's pixels are often exactly 0, the mean of max(0, x) overstates the true mean μ
    (by up to 0.4σ): a dark floor that a solver reads as a fake infrared tail. For a clipped
    normal, the zero fraction p0 gives μ/σ = −Φ⁻¹(p0) and the mean then gives σ, hence μ.
    """
    used = weight > 0
    n = np.bincount(b, weights=weight, minlength=N_FEATURES)
    out = values.copy()
    for c in range(3):  # channel by channel: (n, 3) arrays broadcast against (n,) ones run ~4× slower
        zero = (flat[:, c] <= 1e-7) & used
        p0 = np.bincount(b, weights=zero.astype(float), minlength=N_FEATURES) / np.maximum(n, 1)
        mean = np.bincount(b, weights=weight * flat[:, c], minlength=N_FEATURES) / np.maximum(n, 1)
        fix = (p0 > 0.005) & (p0 < 0.995) & (n >= 8) & (mean > 0)
        if not np.any(fix):
            continue
        z = -norm_ppf(p0[fix])
        phi = np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi)
        big_phi = 1.0 - p0[fix]
        sigma = mean[fix] / (z * big_phi + phi)
        mu = z * sigma
        ratio = np.where(mean[fix] > 0, np.maximum(mu, 0.0) / mean[fix], 1.0)
        out[fix, c] = values[fix, c] * ratio
    return out


def extract_readout(
    rgb: NDArray[np.floating],
    saturated: NDArray[np.bool_] | None,
    scene: Scene,
    pixels: PixelDiffraction | None = None,
    min_visibility: float = MIN_VISIBILITY,
    clipped: tuple[NDArray[np.bool_], NDArray[np.bool_]] | None = None,
) -> Readout:
    """Readout of a linear photo whose geometry is ``scene`` (same image size). ``clipped``:
    (H, W, 3) masks of channels clipped low and high (an in-camera file's, with ``saturated``
    None so that such pixels are read), which make the bins they dominate bounds."""
    height, width, _ = rgb.shape
    if tuple(scene.preset.camera.image_size_px) != (width, height):
        raise ValueError("scene image size does not match the photo")
    if pixels is None:
        pixels = pixel_diffraction(scene)
    b = feature_bins(pixels.lambda1_nm)
    keep = pixels.on_tracks & (pixels.visibility >= min_visibility) & (b >= 0) & (b < N_FEATURES)
    sel = np.flatnonzero(keep)
    px = pixels.select(sel)
    b = b[sel]
    vis = px.amplitude
    flat = np.take(np.asarray(rgb, dtype=np.float64).reshape(-1, 3), px.index, axis=0)
    sat = np.zeros(px.index.size, bool) if saturated is None else np.asarray(saturated).reshape(-1)[px.index]
    vis2 = vis * vis
    total_w = np.bincount(b, weights=vis2, minlength=N_FEATURES)
    sat_w = np.bincount(b, weights=vis2 * sat, minlength=N_FEATURES)

    # Robust rejection on the luminance-like sum of the amplitude-corrected values. (Channel by
    # channel: numpy's reductions over a 3-long axis are ~10× slower, and give the same sums.)
    ratio = (flat[:, 0] + flat[:, 1] + flat[:, 2]) / vis
    usable = ~sat & np.isfinite(flat[:, 0]) & np.isfinite(flat[:, 1]) & np.isfinite(flat[:, 2])
    visible2 = px.visibility * px.visibility  # what MIN_BIN_WEIGHT counts
    disc = scene.preset.disc
    edge = ((px.radius_mm > disc.grating_r_max_mm - EDGE_MARGIN_MM)
            | (px.radius_mm < disc.grating_r_min_mm + EDGE_MARGIN_MM))
    if np.any(edge):
        inner = np.bincount(b, weights=(usable & ~edge) * visible2, minlength=N_FEATURES)
        usable &= ~(edge & (inner[b] >= EDGE_FALLBACK * MIN_BIN_WEIGHT))
    b_usable = b[usable]
    groups = _groups(b_usable, N_FEATURES)
    med = _bin_median(b_usable, ratio[usable], N_FEATURES, groups)
    dev = np.abs(ratio - med[b])
    mad = _bin_median(b_usable, dev[usable], N_FEATURES, groups)
    scale = np.maximum(1.4826 * mad, 1e-3 * np.abs(med) + 1e-12)
    weight = np.where(usable & (dev <= OUTLIER_MADS * scale[b]), 1.0, 0.0)
    weight = np.where(np.isnan(med[b]), 0.0, weight)

    wv2 = np.bincount(b, weights=weight * vis2, minlength=N_FEATURES)
    values = np.zeros((N_FEATURES, 3))
    weight_vis = weight * vis
    for c in range(3):
        values[:, c] = np.bincount(b, weights=weight_vis * flat[:, c], minlength=N_FEATURES)
    safe = np.where(wv2 > 0, wv2, 1.0)
    values /= safe[:, None]
    values = _unclip(values, flat, b, weight, vis)
    # Standard error from the weighted residual scatter of I − A·a (channel by channel, as above).
    var = np.zeros((N_FEATURES, 3))
    for c in range(3):
        resid = flat[:, c] - values[:, c].take(b) * vis
        var[:, c] = np.bincount(b, weights=weight * resid ** 2, minlength=N_FEATURES)
    n_used = np.bincount(b, weights=weight, minlength=N_FEATURES)
    noise = np.sqrt(var / np.maximum(n_used - 1, 1)[:, None]) / np.sqrt(safe)[:, None]
    sat_frac = np.divide(sat_w, total_w, out=np.zeros(N_FEATURES), where=total_w > 0)
    seen = np.bincount(b, weights=weight * visible2, minlength=N_FEATURES)
    valid = (seen >= MIN_BIN_WEIGHT) & (sat_frac < 0.5)
    values[~valid] = 0.0
    censored = None if clipped is None else _censored(clipped, px.index, b, weight * vis2, wv2)
    edge_only = None
    if np.any(edge):
        on_edge = np.bincount(b, weights=weight * vis2 * edge, minlength=N_FEATURES)
        edge_only = valid & (on_edge > 0.5 * wv2)
    return Readout(
        lambda_nm=FEATURE_LAMBDA_NM.copy(),
        values=values,
        weight=wv2,
        saturated_fraction=sat_frac,
        valid=valid,
        noise=noise,
        pixels=px,
        pixel_bin=b,
        pixel_weight=weight,
        censored=censored,
        edge_only=edge_only,
    )


def _censored(clipped: tuple[NDArray[np.bool_], NDArray[np.bool_]], index: NDArray[np.intp], b: NDArray[np.int64],
              w: NDArray[np.float64], total: NDArray[np.float64]) -> NDArray[np.int8]:
    """(NB, 3): −1 / +1 where clipped-low / clipped-high pixels carry more than
    :data:`CENSOR_SHARE` of a bin channel's weight ``w`` (the larger share wins)."""
    out = np.zeros((N_FEATURES, 3), np.int8)
    safe = np.where(total > 0, total, 1.0)
    for c in range(3):
        shares = [np.bincount(b, weights=w * np.asarray(m)[..., c].reshape(-1)[index], minlength=N_FEATURES) / safe
                  for m in clipped]
        low, high = shares
        out[:, c] = np.where((low > CENSOR_SHARE) & (low >= high), -1, np.where(high > CENSOR_SHARE, 1, 0))
    return out
