"""An in-camera file's readout with its clipped channels read as bounds, brought back to camera-native RGB.

A camera clips in its display space: a spectral colour's weakest sRGB channel at 0, a bright
warm one's red at full scale. Undoing the matrix mixes such a clipped channel into all three
native channels, so the bins a camera clips — the rainbow's purest colours — would come back
biased in every channel. So the readout of a calibrated in-camera file is taken in display space
(:meth:`.camera_pipeline.CameraPipeline.to_display`), where each clipped bin channel is a bound
(:attr:`..readout.readout.Readout.censored`), and the bounds are resolved against the spectrum:

1. the spectrum is solved in display space (the native forward matrix, the gains and the
   camera's matrix composed), from the unclipped values alone — or, for a calibration shot,
   the known lamp is scaled to them;
2. a clipped value whose bound the prediction crosses (above a floor clip, below a full-scale
   clip) joins the solve at its bound; one the prediction respects stays out;
3. repeated until that set settles (an active-set solve of the censored, one-sided least
   squares: a clipped value only pulls a prediction that crosses it). Each clipped value is
   then the prediction where the bound was respected, the bound where it was not.

The result is an ordinary native readout: the gains, the network and the confidence see what a
raw file would give.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from ..readout.readout import Readout
from ..spectrum.solve import physics_solve

__all__ = ["ROUNDS", "uncensor"]

ROUNDS = 6  # active-set rounds at most; the set settles within 2–3 on simulated photos
DROPPED_NOISE = 1e4  # the noise, × the largest value, that takes a value out of a solve


def uncensor(display: Readout, pipeline_matrix: NDArray[np.float64], forward: NDArray[np.float64],
             gains: NDArray[np.float64] | None = None, known_spd: NDArray[np.float64] | None = None,
             rounds: int = ROUNDS) -> Readout:
    """The native readout of a ``display``-space readout (see the module doc). ``forward``:
    the (NB, 3, 81) native forward matrix; ``gains``: a calibration's per-bin gains (the
    photo's readout is divided by them before it is solved); ``known_spd``: the lamp, when it
    is known (a calibration shot), instead of a solve."""
    m = np.asarray(pipeline_matrix, np.float64)
    inverse = np.linalg.inv(m)
    g = np.ones_like(display.values) if gains is None else np.asarray(gains, np.float64)
    native_noise = np.sqrt((display.noise ** 2) @ (inverse ** 2).T)
    bound = display.values
    cens = display.censored
    live = None if cens is None else (cens != 0) & display.valid[:, None]
    if live is None or not np.any(live):
        return replace(display, values=bound @ inverse.T, noise=native_noise, censored=None)
    fd = np.einsum("ij,bj,bjl->bil", m, g, forward)  # display-space forward matrix, gains included
    big = DROPPED_NOISE * max(float(np.max(np.abs(bound))), 1e-12)
    out = live.copy()  # clipped values left out of the solve (their bound respected)
    predicted = bound
    for _ in range(max(1, rounds)):
        trial = replace(display, noise=np.where(out, big, display.noise), censored=None)
        predicted = np.einsum("bil,l->bi", fd, _spd(trial, fd, known_spd, live))
        crossed = live & (((cens < 0) & (predicted > bound)) | ((cens > 0) & (predicted < bound)))
        settled = np.array_equal(live & ~crossed, out)
        out = live & ~crossed
        if settled or known_spd is not None:
            break
    values = np.where(out, predicted, bound)
    return replace(display, values=values @ inverse.T, noise=native_noise, censored=None)


def _spd(readout: Readout, forward: NDArray[np.float64], known: NDArray[np.float64] | None,
         live: NDArray[np.bool_]) -> NDArray[np.float64]:
    """The spectrum the prediction comes from: the solve, or the known lamp scaled to the
    values with no clipped channel."""
    if known is None:
        return physics_solve(readout, forward)
    spd = np.clip(np.asarray(known, np.float64), 0.0, None)
    clean = readout.valid[:, None] & ~live
    pred = np.einsum("bcl,l->bc", forward, spd)[clean]
    obs = readout.values[clean]
    scale = float(pred @ obs) / max(float(pred @ pred), 1e-300)
    return spd * max(scale, 0.0)
