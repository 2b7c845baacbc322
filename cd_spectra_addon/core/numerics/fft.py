"""FFT sizes numpy transforms quickly (numpy has no ``next_fast_len``).

pocketfft's time per length depends on its factors: an image padded to twice its size can land on
a length with a large prime factor (482 = 2 · 241: 26 ms for a 233 × 241 correlation against
11 ms at 516 × 516 on the build machine). Padding further, to a 5-smooth length, costs only
zeros: a correlation or convolution padded to at least the sum of its inputs' sizes is the same
whatever the padding beyond.
"""

from __future__ import annotations

__all__ = ["fast_length"]


def fast_length(n: int) -> int:
    """The smallest 2^a · 3^b · 5^c ≥ ``n`` (≥ 1)."""
    n = max(1, int(n))
    best = 1 << (n - 1).bit_length()  # a power of two always qualifies
    p5 = 1
    while p5 < best:
        p35 = p5
        while p35 < best:
            m = p35
            while m < n:
                m *= 2
            best = min(best, m)
            p35 *= 3
        p5 *= 5
    return best
