"""Forward matrix of the readout: what each 5 nm band of the lamp adds to each λ₁ bin.

The readout operator is linear for fixed pixel weights, so applying it to the model's basis
images (the BRDF at the photo's fitted geometry) gives, per bin, R[bin, λ]: the response to a
unit lamp band. Multiplying by the camera's sensitivities gives the feature forward matrix.
Evaluating the BRDF at every pixel would cost seconds at photo resolution; one footprint per
0.5 nm of λ₁ reproduces it to a fraction of a percent (see bin_response).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..scene import grating
from ..spectra.cameras import CameraProfile
from ..scene.capture import Scene
from ..scene.diffraction import pixel_diffraction
from .readout import Readout
from ..spectra.grid import FEATURE_STEP_NM, N_FEATURES, WAVELENGTHS_NM, feature_bins

SUB_BINS = 10  # λ₁ sub-bins per feature bin: the response shifts with λ₁ inside a bin
# Sub-samples per pixel axis: a pixel integrates several nm of λ₁. 2 × 2 cost no accuracy on
# synthetic spectra (MAE 400–700 within ±0.3 % on three set-ups, −1…−3 % on cd-default) at half
# the BRDF work, but moved a calibration shot's camera fit by 1.1e-3 of the peak between a lamp
# spectrum and 7× it (tests/test_camera_fit.py allows 1e-3; 3 × 3 gives 1.6e-4): kept at 3.
FOOTPRINT = 3
# Pixels of one λ₁ sub-bin can lie in two places: where lamp and camera face each other across the
# disc (the redesigned tripod-oblique) both arms of the streak show 400–660 nm, one at r ≈ 45 mm,
# the other out at the tracks' edge. One representative for both gave the whole sub-bin the
# response of the heavier, an edge pixel whose footprint lies partly off the tracks: the 620 nm
# bin's response 15 % low at a pose 0.4° off, a one-bin spike in the solve, peak-normalised MAE
# 0.115 against 0.007 at the true pose (an LSPDD LED, bench/pose_errors.md's "lamp +5 mm" row).
# So a sub-bin whose pixels spread over more than SPREAD_MM of radius (std) keeps a representative
# per RADIUS_STEP_MM ring of the disc; one on a single ring or arm (a coaxial lamp's rings: a
# sub-bin is a 0.03 mm annulus) keeps its one, as before — splitting those at the ring boundaries
# moved a two-lamp calibration's colour error on cd-default (tests/test_calibration_shots.py).
RADIUS_STEP_MM = 2.5
SPREAD_MM = 1.0

__all__ = ["bin_response", "feature_matrix"]


def bin_response(scene: Scene, readout: Readout) -> NDArray[np.float64]:
    """R[bin, λ] (NB × 81): readout value per unit lamp power in band λ (camera excluded).

    Inside a bin every pixel's response is the same lobe shifted by its λ₁, scaled by geometric
    factors that are smooth along the disc. So the bin is split into λ₁ sub-bins, and a sub-bin
    whose pixels lie far apart (both arms of a streak can show one λ₁: SPREAD_MM) into rings of
    the disc (RADIUS_STEP_MM); each group's weight (Σ w·amplitude²) comes from all its pixels,
    its response from its heaviest pixel, averaged over that pixel's footprint like the photo's
    pixel is.
    """
    px = readout.pixels
    w = readout.pixel_weight * px.amplitude ** 2
    n_bands = WAVELENGTHS_NM.size
    response = np.zeros((N_FEATURES, n_bands))
    live = np.flatnonzero(w > 0)
    if live.size == 0:
        return response
    sub = feature_bins(px.lambda1_nm[live], FEATURE_STEP_NM / SUB_BINS)
    n_sub = N_FEATURES * SUB_BINS
    sub = np.clip(sub, 0, n_sub - 1)
    rings = int(np.ceil(scene.preset.disc.rim_radius_mm / RADIUS_STEP_MM)) + 1
    radius = px.radius_mm[live]
    count = np.maximum(np.bincount(sub, minlength=n_sub), 1)
    mean = np.bincount(sub, weights=radius, minlength=n_sub) / count
    spread = np.sqrt(np.maximum(np.bincount(sub, weights=radius * radius, minlength=n_sub) / count - mean * mean, 0.0))
    ring = np.where(spread[sub] > SPREAD_MM, np.clip((radius / RADIUS_STEP_MM).astype(np.int64), 0, rings - 1), 0)
    group = sub * rings + ring  # (sub-bin, ring): pixels that share one response
    n_groups = n_sub * rings
    group_weight = np.bincount(group, weights=w[live], minlength=n_groups)
    rep_at, rep_group = _heaviest(group, w[live], n_groups)
    rep = live[rep_at]

    width = scene.preset.camera.image_size_px[0]
    offsets = (np.arange(FOOTPRINT) + 0.5) / FOOTPRINT - 0.5
    dr, dc = (a.ravel() for a in np.meshgrid(offsets, offsets, indexing="ij"))
    rep_index = np.repeat(px.index[rep], dr.size)
    rows = (rep_index // width) + np.tile(dr, rep.size)
    cols = (rep_index % width) + np.tile(dc, rep.size)
    owner = np.repeat(np.arange(rep.size), dr.size)
    samples = pixel_diffraction(scene, rep_index, rows, cols)
    # pixel_diffraction drops samples that miss the disc; recover their owners by position.
    hit = _hit_mask(scene, rows, cols)
    owner = owner[hit]
    frame = grating.surface_frame(
        samples.points, scene.camera_position, scene.light_position, scene.disc_center,
        scene.disc_normal, scene.preset.disc.medium_index, scene.preset.light.intensity,
        view_directions=samples.view)
    optics = grating.GratingOptics(scene.preset.disc, scene.preset.light.lobe_sigma)
    footprint = grating.band_radiance_sparse(frame, optics, WAVELENGTHS_NM, tabulated=True).summed(owner, rep.size)
    footprint /= dr.size  # missing samples count as black, as in the photo
    per_unit = footprint / px.amplitude[rep, None]
    rep_bin = rep_group // (rings * SUB_BINS)
    weights = group_weight[rep_group]
    np.add.at(response, rep_bin, per_unit * weights[:, None])
    totals = np.bincount(rep_bin, weights=weights, minlength=N_FEATURES)
    response /= np.where(totals > 0, totals, 1.0)[:, None]
    response[~readout.valid] = 0.0
    return response


def _heaviest(group: NDArray[np.int64], weight: NDArray[np.float64], n_groups: int
              ) -> tuple[NDArray[np.intp], NDArray[np.int64]]:
    """(position, group) of the heaviest element of each non-empty group, the first of equals:
    what ``np.lexsort((-weight, group))`` puts first in each group, by a radix sort of the groups
    and a maximum per group (~20× faster for a 24 MP photo's 250k pixels)."""
    small = group.astype(np.int16) if n_groups < 2 ** 15 else group
    order = np.argsort(small, kind="stable")  # within a group, positions ascending
    g, w = group[order], weight[order]
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    top = np.maximum.reduceat(w, starts)
    run = np.cumsum(np.r_[False, g[1:] != g[:-1]])  # which run each element is in
    heaviest = np.flatnonzero(w == top[run])
    firsts = heaviest[np.r_[True, run[heaviest[1:]] != run[heaviest[:-1]]]]
    return order[firsts], g[firsts]


def _hit_mask(scene: Scene, rows: NDArray[np.float64], cols: NDArray[np.float64]) -> NDArray[np.bool_]:
    _, hit = scene.intersect_disc(scene.pixel_rays(rows, cols))
    return hit


def feature_matrix(response: NDArray[np.float64], camera: CameraProfile) -> NDArray[np.float64]:
    """(NB, 3, 81): feature of channel c in bin b per unit lamp power in band λ."""
    return response[:, None, :] * camera.sensitivities.T[None, :, :]
