"""JPEGs with 4:2:2 chroma (what DSLRs write in camera) load as faithfully as 4:2:0 ones.

libjpeg's DCT-domain scaling misplaces 4:2:2 colour on fine detail, so the loader decodes such
files at full size in YCbCr and averages there (core/photo/jpeg_chroma.py). Every file is generated
here; the truth is the block mean of the linear values that were encoded.
"""

from __future__ import annotations

import io
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image

from cd_spectra_addon.core.errors import PhotoError
from cd_spectra_addon.core.photo.images import load_photo
from cd_spectra_addon.core.photo.srgb import srgb_decode, srgb_encode

SUBSAMPLING = {"4:4:4": 0, "4:2:2": 1, "4:2:0": 2}


def _rings(height: int, width: int, period: float = 6.0) -> np.ndarray:
    """Linear RGB rings of a ~38-px period, a different phase per channel: fine colour detail."""
    y, x = np.mgrid[0:height, 0:width]
    r = np.hypot(y - height / 2, x - width / 2)
    return np.stack([0.02 + 0.9 * (0.5 + 0.5 * np.sin(r / period + 2.1 * c)) for c in range(3)], axis=-1)


def _jpeg(path: Path, linear: np.ndarray, sampling: str, quality: int = 100) -> Path:
    codes = np.rint(srgb_encode(np.clip(linear, 0, 1)) * 255).astype(np.uint8)
    Image.fromarray(codes).save(path, format="JPEG", quality=quality, subsampling=SUBSAMPLING[sampling])
    return path


def _block_mean(linear: np.ndarray, k: int) -> np.ndarray:
    h, w = linear.shape[0] // k, linear.shape[1] // k
    return linear[: h * k, : w * k].reshape(h, k, w, k, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("k", [2, 4])
def test_422_rings_load_as_well_as_420(tmp_path, k):
    linear = _rings(768, 768)
    truth = _block_mean(srgb_decode(np.rint(srgb_encode(linear) * 255) / 255), k)
    errors = {}
    for sampling in SUBSAMPLING:
        image = load_photo(_jpeg(tmp_path / f"{sampling[-1]}.jpg", linear, sampling), max_side=768 // k)
        assert image.rgb.shape == truth.shape and image.scale == k
        errors[sampling] = float(np.mean(np.abs(image.rgb - truth)))
    # libjpeg's own scaled decode of the 4:2:2 file was 0.038 off at k = 4 (0.0105 at k = 2).
    assert errors["4:2:2"] < 1.5 * max(errors["4:2:0"], errors["4:4:4"]) + 1e-3
    assert errors["4:2:2"] < 0.008


def test_422_keeps_mean_radiance_colour_and_saturation(tmp_path):
    linear = _rings(512, 640) * 0.5
    y, x = np.mgrid[0:512, 0:640]
    linear[np.hypot(x - 160, y - 128) < 40] = 1.0  # a clipped spot
    image = load_photo(_jpeg(tmp_path / "s.jpg", linear, "4:2:2", quality=95), max_side=160)
    assert image.scale == 4.0 and image.rgb.shape == (128, 160, 3)
    truth = _block_mean(linear, 4)
    np.testing.assert_allclose(image.rgb.reshape(-1, 3).mean(axis=0), truth.reshape(-1, 3).mean(axis=0), rtol=0.02)
    yy, xx = np.mgrid[0:128, 0:160] + 0.5
    d = np.hypot(xx - 40, yy - 32)
    assert image.saturated[d < 8].all() and not image.saturated[d > 12].any()


def test_422_odd_sizes_drop_the_remainder_like_other_formats(tmp_path):
    linear = _rings(203, 309)
    jpeg = load_photo(_jpeg(tmp_path / "odd.jpg", linear, "4:2:2"), max_side=100)
    assert jpeg.scale == 4.0 and jpeg.rgb.shape == (203 // 4, 309 // 4, 3)
    assert jpeg.original_size == (309, 203)
    assert np.all(np.isfinite(jpeg.rgb))


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(height=st.integers(16, 90), width=st.integers(16, 90), max_side=st.integers(16, 64),
       seed=st.integers(0, 2**16), quality=st.integers(1, 100))
def test_any_422_jpeg_gives_a_finite_image_or_photo_error(tmp_path, height, width, max_side, seed, quality):
    codes = np.random.default_rng(seed).integers(0, 256, (height, width, 3), dtype=np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(codes).save(buffer, format="JPEG", quality=quality, subsampling=1)
    path = tmp_path / "r.jpg"
    path.write_bytes(buffer.getvalue())
    try:
        image = load_photo(path, max_side=max_side)
    except PhotoError:
        return
    assert np.all(np.isfinite(image.rgb)) and image.rgb.min() >= 0 and image.rgb.max() <= 1
    assert max(image.rgb.shape[:2]) <= max(max_side, 16)


@pytest.mark.slow
def test_24mp_422_jpeg_loads_quickly(tmp_path):
    """Timed as a ratio to a bare decode of the same file in this process, interleaved, so a busy
    shared machine slows both (absolute milliseconds: make bench)."""
    y = np.arange(4000, dtype=np.float32)[:, None] / 70.0
    x = np.arange(6000, dtype=np.float32)[None, :]
    codes = np.empty((4000, 6000, 3), np.uint8)
    for c in range(3):
        codes[..., c] = 127 + 100 * np.sin(x / (50.0 + 20 * c) + y)
    path = tmp_path / "dslr.jpg"
    Image.fromarray(codes).save(path, quality=95, subsampling=1)
    load_photo(path)
    ours, bare = [], []
    for _ in range(3):
        bare.append(_bare_decode(path))
        ours.append(_timed(path))
    ratio = min(ours) / min(bare)
    print(f"\n24 MP 4:2:2 JPEG → 1024 px: {min(ours) * 1e3:.0f} ms, bare full decode {min(bare) * 1e3:.0f} ms "
          f"(ratio {ratio:.2f})")
    # ≈ 1.7–1.8 (a full-size YCbCr decode plus Pillow's box means); 2.3–3.2 with the means taken
    # by strided numpy adds, ≈ 10 averaging in float64 by reshape. Bounded with room for a busy
    # machine: the full-size decode alone is a ratio of 1.
    assert ratio < 4.0, (ours, bare)


def _timed(path: Path) -> float:
    start = time.perf_counter()
    load_photo(path)
    return time.perf_counter() - start


def _bare_decode(path: Path) -> float:
    """Seconds Pillow takes to decode the whole file at full size (RGB): the yardstick."""
    start = time.perf_counter()
    with Image.open(path) as im:
        im.load()
    return time.perf_counter() - start


@pytest.mark.parametrize(("sampling", "max_side", "colour_px"),
                         [("4:2:0", 256, 2.0), ("4:2:2", 256, 2.0), ("4:4:4", 256, 1.0),
                          ("4:2:0", 128, 1.0), ("4:2:2", 128, 1.0), ("4:2:0", 64, 1.0)])
def test_a_pixel_finer_than_the_files_colour_says_so(tmp_path, sampling, max_side, colour_px):
    """A subsampled JPEG read at full size holds one colour per 2 pixels (what the lamp-size search
    must not read as a lamp's blur); a draft or box of 2 or more gives every pixel its own."""
    path = _jpeg(tmp_path / "rings.jpg", _rings(256, 256), sampling)
    assert load_photo(path, max_side=max_side).colour_px == colour_px


def test_other_formats_hold_a_colour_per_pixel(tmp_path):
    codes = np.rint(srgb_encode(_rings(64, 64)) * 255).astype(np.uint8)
    Image.fromarray(codes).save(tmp_path / "rings.png")
    assert load_photo(tmp_path / "rings.png").colour_px == 1.0
