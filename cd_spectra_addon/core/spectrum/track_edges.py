"""Bins read only at the tracks' edges, and dark there: off the tracks, not a lamp that is dark.

Where a band of λ₁ falls only on pixels near the tracks' inner or outer edge
(:data:`..readout.readout.EDGE_MARGIN_MM`), whether they lie on the tracks turns on a fraction of a
millimetre of the fitted pose — and an oblique capture with no outline leaves the disc centre
free along its streak (bench/pose_errors_oblique205.md). A pixel the fit puts on the tracks but
that lies off them reads dark whatever the lamp emits there; read as the lamp's value, such a bin
is a step sharper than the lamp's blur allows, which the solve can only meet with a spike beside
a zero. So an edge-only bin that reads next to nothing (:data:`EDGE_DARK`) of what the rest of the
readout predicts there, short by more than :data:`EDGE_DEFICIT` of the brightest bin, is taken
as not seen, and so is the bin beside it that holds the true edge (:data:`EDGE_BESIDE`); one that
reads part of its prediction on its own is kept (the prediction, a smoothness-only solve,
overshoots sharp spectral edges), as is one where little is predicted.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from .solve import physics_solve
from ..readout.readout import Readout

__all__ = ["EDGE_BESIDE", "EDGE_DARK", "EDGE_DEFICIT", "dark_edges_dropped"]

# An edge-only bin reading (R+G+B) below this share of the prediction is left out: a bin of pixels
# off the tracks reads nothing but noise. Synthetic lamps (the training prior): on
# phone-distant-lamp's combined capture 11 (no outline, the disc centre 0.55 mm off along the
# streak) the dark bins read 0.00-0.01 of their prediction (a daylight lamp's 455-460 nm: MAE
# 400-700 0.60 -> 0.02 without them); on tripod-oblique with the disc tilted 5° edge-only bins on
# the tracks read down to 0.20 of it (an RGB LED's 570 nm: the smoothness-only prediction
# overshoots a spectrum's sharp edges), and leaving out those at 0.2-0.45 turned two lamps'
# colour worse (Δu'v' 0.004 -> 0.007, 0.033 -> 0.042). (0.5 was the first choice: an evaluation
# lamp's 475 nm at 0.44 on that capture, left out, showed it too high; the value was then chosen
# on the synthetic lamps above.)
EDGE_DARK = 0.1
# The edge-only bin beside a dark one holds the tracks' true edge: part of its pixels lie off them,
# and it reads part of its prediction. It is left out below this share (a daylight lamp read 0.6 mm
# inside the photo's tracks: 460 nm dark, 465 nm at 0.2; with 465 nm kept the solve read MAE 0.19,
# without it 0.007 — tests/test_track_edges.py), as is the next beside it, and so on.
EDGE_BESIDE = 0.5
# ...and short of the prediction by more than this share of the brightest bin (R+G+B): where the
# prediction is itself about nothing (cd-default's edge-only bins at 350-360 and 850-860 nm, past
# the camera's reach) a reading of about nothing is no evidence, and those bins still hold the
# spectrum's ends down. Without it, 30 LSPDD lamps read at 192 px (bench/camera_files.md's DNG
# row) lost them and the incandescent and halogen lamps read 0.002-0.003 worse.
EDGE_DEFICIT = 0.05


def dark_edges_dropped(readout: Readout, matrix: NDArray[np.float64],
                       known_spd: NDArray[np.float64] | None = None) -> Readout:
    """``readout`` without its dark edge-only bins (see the module doc). ``matrix``: the (NB, 3,
    81) forward matrix that predicts ``readout``'s values; ``known_spd``: the lamp when it is
    known (a calibration shot), scaled to the other bins instead of solved from them."""
    edge = readout.edge_only
    if edge is None or not np.any(edge & readout.valid):
        return readout
    inner = replace(readout, valid=readout.valid & ~edge, censored=None)
    if not np.any(inner.valid):
        return readout
    if known_spd is None:
        spd = physics_solve(inner, matrix)
        predicted = np.einsum("bcl,l->b", matrix, spd)
    else:
        lamp = np.einsum("bcl,l->bc", matrix, np.clip(np.asarray(known_spd, np.float64), 0.0, None))
        scale = float(np.sum(lamp[inner.valid] * inner.values[inner.valid])) / \
            max(float(np.sum(lamp[inner.valid] ** 2)), 1e-300)
        predicted = max(scale, 0.0) * lamp.sum(axis=1)
    read = readout.values.sum(axis=1)
    peak = float(np.max(read[readout.valid]))
    short = edge & readout.valid & (predicted - read > EDGE_DEFICIT * peak)
    dark = short & (read < EDGE_DARK * predicted)
    beside = short & (read < EDGE_BESIDE * predicted)
    while True:  # grow from the dark bins through their short neighbours
        near = np.zeros_like(dark)
        near[1:] |= dark[:-1]
        near[:-1] |= dark[1:]
        grown = dark | (near & beside)
        if np.array_equal(grown, dark):
            break
        dark = grown
    if not np.any(dark):
        return readout
    return replace(readout, valid=readout.valid & ~dark, values=np.where(dark[:, None], 0.0, readout.values))
