"""Palette images and animated GIFs: each frame read as the composited frame a viewer shows, in
sRGB 8-bit, flagged as processed; frames named ``file.gif#N``. Every GIF is written here by
tests/gif_writer.py (not Pillow's writer), so what a viewer shows is computed independently."""

from __future__ import annotations

import io
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image, ImageCms

from cd_spectra_addon.core.errors import PhotoError
from cd_spectra_addon.core.photo.frames import frame_count, photo_frames, split_frame, with_frame
from cd_spectra_addon.core.photo.images import BLACK_LEVEL, SATURATION_8BIT, load_photo
from cd_spectra_addon.core.photo.srgb import srgb_decode
from gif_writer import Frame, composite, gif_bytes

SIZE = (72, 66)  # width, height: above the loader's 64-pixel minimum


def _put(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def _checked(name: str, codes: np.ndarray) -> None:
    """The photo ``name`` is ``codes`` read as sRGB 8-bit, saturated where a code reaches 250,
    processed (or refused as black, where it is)."""
    if srgb_decode(codes.max() / 255.0) < BLACK_LEVEL:
        with pytest.raises(PhotoError, match="black"):
            load_photo(name)
        return
    image = load_photo(name)
    np.testing.assert_allclose(image.rgb, srgb_decode(codes / 255.0), atol=1e-7)
    assert image.saturated.tolist() == (codes.max(axis=2) >= SATURATION_8BIT).tolist()
    assert image.encoding == "srgb-8" and image.scale == 1.0 and image.path == name
    assert image.processed and "palette" in image.processed_reason
    assert image.is_grey == bool((codes[..., 0] == codes[..., 1]).all() and (codes[..., 1] == codes[..., 2]).all())


@st.composite
def animations(draw):
    """An animated (or still) GIF: any palette of 1–256 colours, 1–5 frames, partial frames,
    local colour tables, transparency and the disposal methods Pillow composites as viewers do
    (see gif_writer.composite and the note in core/photo/frames.py)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    width, height = SIZE
    palette = rng.integers(0, 256, (draw(st.integers(1, 256)), 3), dtype=np.uint8)
    if draw(st.booleans()):
        palette[rng.random(len(palette)) < 0.3] = 255  # clipped entries
    transparent = draw(st.booleans())
    frames, last = [], 0
    for i in range(draw(st.integers(1, 5))):
        if i == 0:
            x = y = 0
            w, h = width, height
        else:
            x, y = draw(st.integers(0, width - 1)), draw(st.integers(0, height - 1))
            w, h = draw(st.integers(1, width - x)), draw(st.integers(1, height - y))
        local = rng.integers(0, 256, (draw(st.integers(1, 256)), 3), dtype=np.uint8) if draw(st.booleans()) else None
        n = len(local) if local is not None else len(palette)
        index = draw(st.integers(0, n - 1)) if transparent and draw(st.booleans()) else None
        choices = [1, 3] + ([2] if not transparent and local is None else []) + ([0] if last in (0, 1) else [])
        disposal = draw(st.sampled_from(choices)) if i else draw(st.sampled_from([0, 1]))
        last = disposal or last
        frames.append(Frame(rng.integers(0, n, (h, w)), x, y, disposal, index, local))
    background = draw(st.integers(0, len(palette) - 1))
    return palette, frames, background


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(animations())
def test_each_frame_is_what_a_viewer_shows(case):
    palette, frames, background = case
    shown = composite(SIZE, palette, frames, background)
    with tempfile.TemporaryDirectory() as tmp:
        path = _put(Path(tmp) / "anim.gif", gif_bytes(SIZE, palette, frames, background))
        assert frame_count(path) == len(frames)
        names = photo_frames(path)
        assert names == ([str(path)] if len(frames) == 1 else [with_frame(path, i) for i in range(len(frames))])
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            for name, codes in zip(names, shown):
                _checked(name, codes)
        _checked(with_frame(path, len(frames) - 1), shown[-1])


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 256), st.sampled_from(["none", "index", "table"]), st.sampled_from(["PNG", "GIF"]),
       st.integers(0, 2**32 - 1))
def test_palette_images_read_their_palette_colours(colours, transparency, fmt, seed):
    """A palette image, with or without transparency (one index, or PNG's alpha per entry), reads
    as its palette's colours — alpha ignored, as for RGBA — without Pillow's warnings, and is
    flagged as quantised."""
    rng = np.random.default_rng(seed)
    palette = rng.integers(0, 256, (colours, 3), dtype=np.uint8)
    palette[rng.random(colours) < 0.2] = (255, 250, 0)
    indices = rng.integers(0, colours, (SIZE[1], SIZE[0])).astype(np.uint8)
    im = Image.fromarray(indices, "P")
    im.putpalette(palette.reshape(-1).tolist())
    options = {}
    if transparency == "index":
        options["transparency"] = int(rng.integers(0, colours))
    elif transparency == "table" and fmt == "PNG":
        options["transparency"] = rng.integers(0, 256, colours, dtype=np.uint8).tobytes()
    buffer = io.BytesIO()
    im.save(buffer, format=fmt, **options)
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("error")
        path = _put(Path(tmp) / f"p.{fmt.lower()}", buffer.getvalue())
        _checked(str(path), palette[indices])
        if palette[indices].max() > 3:
            assert ("GIF" in load_photo(path).processed_reason) == (fmt == "GIF")


def test_an_animated_gif_needs_a_frame_and_names_its_range(tmp_path):
    palette = np.array([[0, 0, 0], [200, 100, 50]], np.uint8)
    frames = [Frame(np.full((SIZE[1], SIZE[0]), i % 2)) for i in range(3)]
    path = _put(tmp_path / "three.gif", gif_bytes(SIZE, palette, frames))
    with pytest.raises(PhotoError, match=r"animated GIF of 3 frames.*three\.gif#0 … .*three\.gif#2"):
        load_photo(path)
    with pytest.raises(PhotoError, match=r"frame 3 is out of range.*has 3 frames"):
        load_photo(f"{path}#3")
    with pytest.raises(PhotoError, match=r"by its number counted from 0.*not 'last'"):
        load_photo(f"{path}#last")
    assert load_photo(f"{path}#01").rgb[0, 0, 0] == pytest.approx(srgb_decode(200 / 255.0), abs=1e-7)
    still = _put(tmp_path / "still.gif", gif_bytes(SIZE, palette, frames[1:2]))
    assert load_photo(still).path == str(still) and load_photo(f"{still}#0").path == f"{still}#0"
    with pytest.raises(PhotoError, match="frame 1 is out of range.*has 1 frame: .*still.gif#0$"):
        load_photo(f"{still}#1")


def test_frame_marks_on_other_files_and_names_that_contain_them(tmp_path):
    png = tmp_path / "a.png"
    Image.fromarray(np.full((SIZE[1], SIZE[0], 3), 90, np.uint8)).save(png)
    assert load_photo(f"{png}#0").path == f"{png}#0"
    with pytest.raises(PhotoError, match="still photo, one frame.*frame 2 does not exist"):
        load_photo(f"{png}#2")
    literal = tmp_path / "b.png#2"  # a file really named so is that file
    literal.write_bytes(png.read_bytes())
    assert split_frame(literal) == (str(literal), None) and load_photo(literal).path == str(literal)
    assert split_frame(tmp_path / "missing.gif#4") == (str(tmp_path / "missing.gif"), 4)
    with pytest.raises(PhotoError, match="missing.gif: file not found"):
        load_photo(tmp_path / "missing.gif#4")
    assert photo_frames(png) == [str(png)] and frame_count(f"{png}#0") == 1
    with pytest.raises(ValueError):
        with_frame(png, -1)


def test_the_gifs_icc_profile_is_named_as_evidence(tmp_path):
    icc = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    palette = np.array([[10, 20, 30], [240, 200, 100]], np.uint8)
    frame = Frame(np.arange(SIZE[0] * SIZE[1]).reshape(SIZE[1], SIZE[0]) % 2)
    image = load_photo(_put(tmp_path / "icc.gif", gif_bytes(SIZE, palette, [frame], icc=icc)))
    assert image.exif.icc_profile and image.exif.icc_profile in image.processed_reason
    assert image.exif.focal_length_mm is None  # a GIF has no EXIF: the focal length comes from elsewhere


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(animations(), st.sampled_from(["truncate", "flip"]), st.data())
def test_damaged_gifs_give_photo_errors(case, damage, data):
    palette, frames, background = case
    raw = bytearray(gif_bytes(SIZE, palette, frames, background))
    if damage == "truncate":
        raw = raw[: data.draw(st.integers(1, len(raw) - 1))]
    else:
        for at in data.draw(st.lists(st.integers(0, len(raw) - 1), min_size=1, max_size=8)):
            raw[at] ^= 0xFF
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Pillow's notes on damaged data
        path = _put(Path(tmp) / "bad.gif", bytes(raw))
        try:
            names = photo_frames(path)
        except PhotoError as exc:
            assert str(path) in str(exc)
            return
        for name in names:
            try:
                image = load_photo(name)
            except PhotoError as exc:
                assert str(path) in str(exc)
                continue
            assert np.isfinite(image.rgb).all() and image.rgb.shape[:2] == image.saturated.shape


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(0, 9))
def test_a_frame_is_read_exactly_when_the_gif_has_it(count, frame):
    palette = np.array([[10, 10, 10], [200, 120, 40], [30, 160, 220]], np.uint8)
    frames = [Frame(np.full((SIZE[1], SIZE[0]), 1 + i % 2)) for i in range(count)]
    with tempfile.TemporaryDirectory() as tmp:
        path = _put(Path(tmp) / "n.gif", gif_bytes(SIZE, palette, frames))
        name = with_frame(path, frame)
        if frame < count:
            assert load_photo(name).rgb[0, 0, 0] == pytest.approx(srgb_decode(palette[1 + frame % 2, 0] / 255.0))
        else:
            with pytest.raises(PhotoError, match=f"frame {frame} is out of range; .* has {count} frame"):
                load_photo(name)
