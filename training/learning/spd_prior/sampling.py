"""Drawing the prior: a labelled mix of families, and its Gaussian moments for the physics solve.

Same generator state, same spectra: the Gaussian prior baked into the model is drawn with a
fixed seed, so every build gets the same numbers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cache

import numpy as np
from numpy.typing import NDArray

from cd_spectra_addon.core.spectrum.solve import GaussianPrior
from cd_spectra_addon.core.spectra.grid import N_BANDS

from training.learning.spd_prior.families import DEFAULT_WEIGHTS, FAMILIES, generate

Array = NDArray[np.float64]

# ---------------------------------------------------------------------------------------------
# Public sampling
# ---------------------------------------------------------------------------------------------
def sample_spds(
    n: int,
    rng: np.random.Generator,
    families: Sequence[str] | None = None,
    weights: Mapping[str, float] | None = None,
) -> tuple[Array, list[str]]:
    """Draw ``n`` peak-normalised SPDs on the 81-sample grid and the family label of each row.

    Families are drawn with ``weights`` (default :data:`DEFAULT_WEIGHTS`), restricted to
    ``families`` when given. Same generator state → same output.
    """
    fams = tuple(families) if families is not None else FAMILIES
    table = DEFAULT_WEIGHTS if weights is None else dict(weights)
    unknown = (set(fams) | set(table)) - set(FAMILIES)
    if unknown:
        raise ValueError(f"unknown families: {sorted(unknown)}")
    if not fams:
        raise ValueError("no families to sample from")
    w = np.array([float(table.get(f, 0.0)) for f in fams])
    if np.any(w < 0) or not np.isfinite(w).all() or w.sum() <= 0:
        raise ValueError("family weights must be finite, non-negative and not all zero")
    n = int(n)
    if n < 0:
        raise ValueError("n must be non-negative")
    label_idx = rng.choice(len(fams), size=n, p=w / w.sum())
    out = np.empty((n, N_BANDS))
    for k, fam in enumerate(fams):
        idx = np.flatnonzero(label_idx == k)
        if idx.size:
            out[idx] = generate(fam, rng, idx.size)
    return out, [fams[i] for i in label_idx]



@cache
def gaussian_prior(n: int = 50_000, seed: int = 20240) -> GaussianPrior:
    """Mean and covariance of the prior's spectra: the physics solve's Gaussian prior (baked into
    the model's metadata; a fixed seed so every build gets the same numbers)."""
    spds, _ = sample_spds(n, np.random.default_rng(seed))
    return GaussianPrior.from_samples(spds)
