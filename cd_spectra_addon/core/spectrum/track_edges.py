"""Bins read only at the tracks' edges, and dark there: off the tracks, not a lamp that is dark.

Where a band of λ₁ falls only on pixels near the tracks' inner or outer edge
(:data:`..readout.readout.EDGE_MARGIN_MM`), whether they lie on the tracks turns on a fraction of a
millimetre of the fitted pose — and an oblique capture with no outline leaves the disc centre
free along its streak (bench/pose_errors_oblique205.md). A pixel the fit puts on the tracks but
that lies off them reads dark whatever the lamp emits there; read as the lamp's value, such a bin
is a step sharper than the lamp's blur allows, which the solve can only meet with a spike beside
a zero. So an edge-only bin that reads less than :data:`EDGE_DARK` of what the rest of the
readout predicts there, short by more than :data:`EDGE_DEFICIT` of the brightest bin, is taken
as not seen; one that reads about what is predicted, or where little is predicted, is kept.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from .solve import physics_solve
from ..readout.readout import Readout

__all__ = ["EDGE_DARK", "EDGE_DEFICIT", "dark_edges_dropped"]

# An edge-only bin reading (R+G+B) below this share of the prediction is left out. Synthetic lamps
# (the training prior) on phone-distant-lamp's combined capture 11 (no outline, the disc centre
# 0.55 mm off along the streak): a daylight lamp's 455–460 nm bins read 0 against ~0.5 predicted,
# and its MAE 400–700 went 0.60 → 0.02; an incandescent lamp's edge bins, on the tracks, read
# 0.70–0.80 of a prediction that the smoothness-only solve overshoots there, and are kept.
EDGE_DARK = 0.5
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
    dark = edge & readout.valid & (read < EDGE_DARK * predicted) & (predicted - read > EDGE_DEFICIT * peak)
    if not np.any(dark):
        return readout
    return replace(readout, valid=readout.valid & ~dark, values=np.where(dark[:, None], 0.0, readout.values))
