"""Reduced-size decoding of JPEGs whose chroma layout libjpeg cannot scale faithfully.

The loader reads JPEGs at reduced size through libjpeg's DCT-domain scaling (Pillow ``draft``),
which averages the file's Y, Cb, Cr codes over each block — exact enough for 4:2:0 and 4:4:4
chroma. With 4:2:2 chroma (what DSLRs write in camera: chroma halved horizontally only) the
scaled decode misplaces colour on fine detail: a ring pattern of 38-px period read at 1/4 scale
had its Cb/Cr off by 6 codes on average against the block average of the full decode (0.9 for
4:2:0), 0.038 of full scale in RGB (tests/test_images.py). A CD rainbow is exactly such detail.

So those files are decoded at full size *in YCbCr* and box-averaged there, then converted to
RGB: the same code-space average that the draft decode gives for 4:2:0. Not in RGB: converting
each full-size pixel first clips the compression's ringing around gamut-clipped (0 or 255)
colours, which biases an in-camera JPEG's saturated rainbow; averaging YCbCr first does not.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

BAND_ROWS = 256  # full-size rows averaged at a time

__all__ = ["scaled_decode_is_faithful", "box_decode"]


def scaled_decode_is_faithful(im: Any) -> bool:
    """Whether libjpeg's DCT-domain scaling keeps this (Pillow) JPEG's colours: grey, CMYK and
    4:4:4 or 4:2:0 colour JPEGs yes; 4:2:2 and rarer chroma layouts no."""
    if getattr(im, "mode", "") != "RGB":
        return True
    from PIL import JpegImagePlugin

    try:
        return JpegImagePlugin.get_sampling(im) in (0, 2)
    except Exception:  # noqa: BLE001 - Pillow's own errors on an odd header: decode at full size
        return False


def box_decode(im: Any, factor: int) -> NDArray[np.uint8]:
    """(H // factor, W // factor, 3) RGB codes: each the factor × factor block mean of the
    file's full-size Y, Cb, Cr (JFIF conversion), rounded like libjpeg's scaled output."""
    im.draft("YCbCr", im.size)  # full size, but no conversion to RGB
    im.load()
    if im.mode != "YCbCr":
        raise ValueError(f"expected YCbCr samples, got {im.mode}")
    k = int(factor)
    h, w = im.height // k, im.width // k
    out = np.empty((h, w, 3), np.uint8)
    step = max(k, BAND_ROWS // k * k)
    scale = np.float32(1.0 / (k * k))
    for y0 in range(0, h * k, step):
        y1 = min(y0 + step, h * k)
        band = np.asarray(im.crop((0, y0, w * k, y1)))
        # k² strided adds in uint16 (8 × 8 × 255 fits): ~10× faster than reshape + sum in float.
        rows = band[0::k].astype(np.uint16)
        for i in range(1, k):
            rows += band[i::k]
        sums = rows[:, 0::k].copy()
        for j in range(1, k):
            sums += rows[:, j::k]
        mean = sums.astype(np.float32) * scale
        y, cb, cr = mean[..., 0], mean[..., 1] - 128.0, mean[..., 2] - 128.0
        rgb = np.stack([y + 1.402 * cr, y - 0.344136 * cb - 0.714136 * cr, y + 1.772 * cb], axis=-1)
        out[y0 // k:y1 // k] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return out
