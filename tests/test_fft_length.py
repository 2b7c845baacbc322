"""fast_length: the smallest 5-smooth length at least n, and a correlation padded to it finds
the same shift as one padded to exactly twice the image."""

from __future__ import annotations

import numpy as np
from hypothesis import given, strategies as st

from cd_spectra_addon.core.numerics.fft import fast_length
from cd_spectra_addon.core.pose.starts import _correlation_peak, symmetry_centre


def _smooth(m: int) -> bool:
    for p in (2, 3, 5):
        while m % p == 0:
            m //= p
    return m == 1


def test_fast_length_is_the_smallest_5_smooth_length_up_to_4000():
    smooth = [m for m in range(1, 5000) if _smooth(m)]
    for n in range(1, 4001):
        assert fast_length(n) == next(m for m in smooth if m >= n)


@given(st.integers(20, 90), st.integers(20, 90), st.integers(-15, 15), st.integers(-15, 15))
def test_the_correlation_shift_and_symmetry_centre_survive_the_padding(h, w, dr, dc):
    rng = np.random.default_rng(h * 1000 + w)
    pattern = np.zeros((h, w))
    r0, c0 = h // 2, w // 2
    pattern[r0 - 3:r0 + 4, c0 - 2:c0 + 3] = rng.random((7, 5)) + 0.5
    photo = np.roll(pattern, (dr, dc), axis=(0, 1))
    if np.roll(photo, (-dr, -dc), axis=(0, 1)).sum() != pattern.sum() or abs(dr) > h // 2 - 5 or abs(dc) > w // 2 - 4:
        return  # the block must stay inside the image
    assert _correlation_peak(photo, pattern)[1:] == (float(dr), float(dc))
    sym = np.zeros((h, w))
    sym[r0 - 3:r0 + 4, c0 - 2:c0 + 3] = 1.0
    sym = np.roll(sym, (dr, dc), axis=(0, 1))
    r, c = symmetry_centre(sym)
    assert abs(r - (r0 + dr)) < 1e-6 and abs(c - (c0 + dc)) < 1e-6
