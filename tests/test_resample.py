"""The pose fit's pixel reductions: the brightest pixels are exactly the top of the usable ones."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cd_spectra_addon.core.photo.resample import BRIGHT_STRIDE, brightest


def _check(lum: np.ndarray, usable: np.ndarray, count: int) -> None:
    picked = brightest(lum, usable, count)
    assert picked.size == count and np.unique(picked).size == count
    assert usable[picked].all()
    rest = np.ones(lum.size, bool)
    rest[picked] = False
    rest &= usable
    if rest.any():  # nothing left out is brighter than anything taken
        assert lum[picked].min() >= lum[rest].max()


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 40 * BRIGHT_STRIDE), seed=st.integers(0, 2**32 - 1), levels=st.sampled_from([0, 4, 256]),
       share=st.floats(0.05, 1.0), frac=st.floats(0.0, 1.0))
def test_brightest_takes_the_top_of_the_usable_pixels(n, seed, levels, share, frac):
    """Ties (8-bit levels), few usable pixels, NaN where unusable, any count: the set taken is
    a top-count set of the usable pixels, as a full partial sort's would be."""
    rng = np.random.default_rng(seed)
    lum = rng.random(n) if levels == 0 else rng.integers(0, levels, n).astype(np.float64)
    usable = rng.random(n) < share
    lum[~usable & (rng.random(n) < 0.5)] = np.nan
    available = int(usable.sum())
    if available == 0:
        return
    _check(lum, usable, max(1, int(frac * available)))


def test_brightest_of_a_photo_sized_array_with_a_bright_streak():
    """The fast path (bound from every BRIGHT_STRIDE-th pixel) on a 0.8 MP dark photo whose few
    bright pixels lie in one streak, which the stride may miss entirely."""
    rng = np.random.default_rng(3)
    lum = rng.random(900 * 900) * 0.01
    lum[5000:5003] = 5.0  # fewer than the stride: the bound cannot see them
    usable = np.ones(lum.size, bool)
    for count in (1, 3, 4000):
        _check(lum, usable, count)
