"""Property-based tests of the core: whatever finite input, a specific error or a sane answer.

The estimator must answer a photo with a ``CDSpectraError`` or an SPD that is finite, ≥ 0,
81 long and peaks at exactly 1 -- for any image size, encoding, exposure, noise, crop, flip and
focal length hypothesis draws. The model's input vector and its wrapper must stay finite for
any finite profile. Spectra tables and resampling must take any table a meter could write
(and many it could not) without NaN or a non-``ValueError`` exception. Example counts are
kept small so the file runs in well under a minute on two cores.
"""

from __future__ import annotations

import math
import string
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from cd_spectra_addon.core.spectra.cameras import DEFAULT_CAMERA, load_camera
from cd_spectra_addon.core.errors import CDSpectraError
from cd_spectra_addon.core.inverse.estimate import estimate_image
from cd_spectra_addon.core.photo.images import ExifInfo, LinearImage
from cd_spectra_addon.core.spectrum.model import INPUT_SIZE, load_model, model_inputs
from cd_spectra_addon.core.readout.readout import FEATURE_LAMBDA_NM, N_FEATURES, Readout
from cd_spectra_addon.core.spectra.spectra_files import read_spectra_csv
from cd_spectra_addon.core.spectra.grid import N_BANDS, WAVELENGTHS_NM, resample_to_grid
from training.reliability import hostile

SLOW = settings(max_examples=40, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                       HealthCheck.function_scoped_fixture])
FAST = settings(max_examples=120, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


# --- the estimator on arbitrary photos -------------------------------------------------------


def _image(rgb: np.ndarray, saturated: np.ndarray | None = None, invalid: np.ndarray | None = None,
           encoding: str = "linear-float", exif: ExifInfo | None = None, grey: bool = False) -> LinearImage:
    h, w, _ = rgb.shape
    return LinearImage(
        rgb=np.ascontiguousarray(rgb, dtype=np.float32),
        saturated=np.zeros((h, w), bool) if saturated is None else saturated,
        invalid=np.zeros((h, w), bool) if invalid is None else invalid,
        scale=1.0, original_size=(w, h), encoding=encoding, exif=exif or ExifInfo(), path="prop.png",
        is_grey=grey)


@st.composite
def photos(draw: st.DrawFn) -> tuple[LinearImage, float | None, str]:
    """A photo the estimator may meet: the rendered disc transformed (exposure, noise, offset,
    crop, flip, transpose, downsample, quantisation, clipping) or a synthetic non-disc image."""
    base = hostile.make_base(128).linear
    kind = draw(st.sampled_from(["disc", "disc", "disc", "noise", "flat", "blocks"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    if kind == "disc":
        img = base * draw(st.sampled_from([1e-6, 0.003, 0.1, 1.0, 3.0, 50.0, 1e6]))
        img = img + draw(st.sampled_from([0.0, 0.0, -0.02, 0.01, 0.2])) \
            + rng.normal(0.0, draw(st.sampled_from([0.0, 0.001, 0.05])), img.shape)
        top, left = draw(st.integers(0, 48)), draw(st.integers(0, 48))
        height, width = draw(st.integers(64, 128 - top)), draw(st.integers(64, 128 - left))
        img = img[top:top + height, left:left + width]
        if draw(st.booleans()):
            img = img[::-1]
        if draw(st.booleans()):
            img = img.transpose(1, 0, 2)
    elif kind == "noise":
        shape = (draw(st.integers(64, 140)), draw(st.integers(64, 140)), 3)
        img = rng.random(shape) ** draw(st.sampled_from([1.0, 8.0]))
    elif kind == "flat":
        shape = (draw(st.integers(64, 100)), draw(st.integers(64, 100)), 3)
        img = np.full(shape, draw(st.sampled_from([0.0, 1e-9, 0.5, 1.0])))
    else:
        small = rng.random((draw(st.integers(1, 8)), draw(st.integers(1, 8)), 3))
        img = np.kron(small, np.ones((16, 16, 1)))
        assume(min(img.shape[:2]) >= 64)
    encoding = draw(st.sampled_from(["linear-float", "srgb-8", "srgb-16"]))
    saturated = np.zeros(img.shape[:2], bool)
    if encoding != "linear-float":
        bits = 8 if encoding == "srgb-8" else 16
        levels = (1 << bits) - 1
        saturated = np.any(img >= 250 / 255 if bits == 8 else img >= 65000 / 65535, axis=2)
        img = np.round(np.clip(img, 0.0, 1.0) * levels) / levels  # what an integer encoding keeps
    grey = draw(st.booleans()) and draw(st.booleans())
    if grey:
        img = np.repeat(img.mean(axis=2, keepdims=True), 3, axis=2)
    invalid = np.zeros(img.shape[:2], bool)
    if encoding == "linear-float" and draw(st.booleans()):
        invalid = rng.random(img.shape[:2]) < 0.05
        img = np.where(invalid[..., None], 0.0, img)  # what the loader leaves in excluded pixels
    focal = draw(st.sampled_from([None, None, 50.0, 250.0, 2000.0]))
    preset = draw(st.sampled_from(["cd-default", "cd-default", "cd-far-light", "paper"]))
    return _image(img, saturated, invalid, encoding, grey=grey), focal, preset


def _check_estimate(image: LinearImage, focal: float | None, preset: str) -> None:
    try:
        result = estimate_image(image, model=None, focal_px=focal, preset=preset)
    except CDSpectraError as exc:
        assert str(exc).strip(), "an error users see must say something"
        return
    spd = result.spd
    assert spd.shape == (N_BANDS,) and result.spd_std.shape == (N_BANDS,)
    assert np.all(np.isfinite(spd)) and spd.min() >= 0.0 and spd.max() == 1.0
    assert np.all(np.isfinite(result.spd_std))
    assert math.isfinite(result.confidence) and 0.0 <= result.confidence <= 1.0
    assert all(math.isfinite(v) for v in (*result.xy, *result.rgb_scene_linear))
    assert result.cct_k is None or math.isfinite(result.cct_k)
    assert all(isinstance(w, str) and w for w in result.warnings)
    assert all(math.isfinite(v) for v in result.disc.center_px) and math.isfinite(result.disc.radius_px)


@pytest.mark.slow
@SLOW
@given(photos())
def test_any_photo_gives_a_finite_peak_normalised_spd_or_a_specific_error(case) -> None:
    _check_estimate(*case)


@pytest.mark.slow
@settings(max_examples=12, deadline=None, derandomize=True)
@given(st.sampled_from([(8, np.uint8), (16, np.uint16)]), st.integers(64, 120), st.integers(64, 120),
       st.integers(0, 2**32 - 1))
def test_random_integer_files_through_estimate_photo(bits_dtype, height, width, seed) -> None:
    """Real files (PNG 8/16-bit) of random content through the whole path, loader included."""
    from cd_spectra_addon.core.inverse.estimate import estimate_photo
    from training.simulation.photo import write_photo

    bits, _ = bits_dtype
    img = np.random.default_rng(seed).random((height, width, 3)) ** 3
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "random.png"
        write_photo(path, img, "png" if bits == 8 else "png16")
        try:
            result = estimate_photo(path, model=None)
        except CDSpectraError:
            return
    assert np.all(np.isfinite(result.spd)) and result.spd.max() == 1.0 and result.spd.min() >= 0


# --- model inputs and the model --------------------------------------------------------------

finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False, allow_subnormal=False)


@st.composite
def profiles(draw: st.DrawFn) -> Readout:
    valid = draw(arrays(np.bool_, N_FEATURES))
    values = draw(arrays(np.float64, (N_FEATURES, 3), elements=finite))
    noise = draw(arrays(np.float64, (N_FEATURES, 3), elements=st.floats(0.0, 1e6, allow_subnormal=False)))
    sat = draw(arrays(np.float64, N_FEATURES, elements=st.floats(0.0, 1.0)))
    empty = np.zeros(0)
    from cd_spectra_addon.core.scene.diffraction import PixelDiffraction

    pixels = PixelDiffraction(**{f: empty.astype(np.int64) if f == "index" else empty.astype(bool) if f == "on_tracks"
                                 else np.zeros((3, 0)) if f in ("points_c", "view_c") else empty
                                 for f in PixelDiffraction.__dataclass_fields__})
    return Readout(lambda_nm=FEATURE_LAMBDA_NM.copy(), values=values, weight=np.ones(N_FEATURES),
                   saturated_fraction=sat, valid=valid, noise=noise, pixels=pixels,
                   pixel_bin=np.zeros(0, np.int64), pixel_weight=np.zeros(0))


@FAST
@given(profiles(), arrays(np.float64, (N_BANDS, 3), elements=st.floats(0.0, 1e3)),
       arrays(np.float64, N_BANDS, elements=st.floats(0.0, 1e30, allow_subnormal=False)),
       st.floats(0.0, 10.0), st.booleans(), st.floats(-5.0, 5.0))
def test_model_inputs_are_finite_float32_of_the_layout_size(profile, camera, physics, sigma, generic, residual) -> None:
    x = model_inputs(profile, camera, physics, sigma, generic, residual)
    assert x.dtype == np.float32 and x.shape == (INPUT_SIZE,)
    assert np.all(np.isfinite(x))


def _predict_checks(model, x: np.ndarray) -> None:
    spd, std = model.predict(x)
    assert spd.shape == (N_BANDS,) and std.shape == (N_BANDS,)
    assert np.all(np.isfinite(spd)) and np.all(np.isfinite(std)) and np.all(std > 0)


@pytest.fixture(scope="module")
def toy_model(tmp_path_factory: pytest.TempPathFactory):
    """A valid model with the shipped layout (flat SPD): tests the wrapper, not the network."""
    return load_model(hostile.write_toy_model(tmp_path_factory.mktemp("toy"), "ok"))


@settings(max_examples=40, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(arrays(np.float32, INPUT_SIZE, elements=st.floats(-1e4, 1e4, width=32)))
def test_toy_model_wrapper_on_arbitrary_inputs(toy_model, x) -> None:
    _predict_checks(toy_model, x)


@settings(max_examples=60, deadline=None, derandomize=True)
@given(arrays(np.float32, INPUT_SIZE, elements=st.floats(-1e4, 1e4, width=32)))
def test_shipped_model_on_arbitrary_finite_inputs(x) -> None:
    _predict_checks(load_model(), x)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(profiles(), st.floats(0.0, 0.05), st.booleans(), st.floats(0.0, 1.0))
def test_shipped_model_on_model_inputs_of_random_profiles(profile, sigma, generic, residual) -> None:
    camera = load_camera(DEFAULT_CAMERA).sensitivities
    physics = np.abs(np.sin(WAVELENGTHS_NM / 40.0))
    _predict_checks(load_model(), model_inputs(profile, camera, physics, sigma, generic, residual))


# --- resampling and spectra tables -----------------------------------------------------------


@st.composite
def tables(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    n = draw(st.integers(2, 300))
    start = draw(st.floats(100.0, 900.0))
    steps = draw(arrays(np.float64, n - 1, elements=st.sampled_from([1e-9, 1e-4, 0.01, 0.5, 1.0, 5.0, 10.0, 50.0])))
    wl = start + np.concatenate([[0.0], np.cumsum(steps)])
    assume(np.all(np.diff(wl) > 0))
    values = draw(arrays(np.float64, (draw(st.integers(1, 3)), n),
                         elements=st.floats(0.0, 1e300, allow_subnormal=False)))
    return wl, values


@pytest.mark.slow
@FAST
@given(tables())
def test_resample_to_grid_stays_finite_and_non_negative(table) -> None:
    wl, values = table
    try:
        out = resample_to_grid(wl, values)
    except ValueError as exc:
        assert str(exc)
        return
    assert out.shape == (values.shape[0], N_BANDS)
    assert np.all(np.isfinite(out)) and out.min() >= 0.0


@FAST
@given(st.floats(-1e3, 1e3), st.sampled_from([0.05, 0.5, 1.0, 5.0, 7.3, 20.0]))
def test_resampling_a_constant_gives_the_constant(level, step) -> None:
    wl = np.arange(300.0, 900.0 + step / 2, step)
    out = resample_to_grid(wl, np.full(wl.size, level))
    np.testing.assert_allclose(out, level, rtol=1e-9, atol=1e-9)


_CELL = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(-10**6, 10**6).map(str),
    st.sampled_from(["", " ", "nan", "inf", "-", "1,5", "1.5e3", "380", "780", "0", "-0.001", "λ", "\"q\"", "1e999"]),
    st.text(string.ascii_letters + string.digits + " .,;-+eé\t", max_size=8),
)


@st.composite
def csv_texts(draw: st.DrawFn) -> str:
    delimiter = draw(st.sampled_from([",", ";", "\t"]))
    rows = []
    if draw(st.booleans()):
        rows.append(delimiter.join(draw(st.lists(st.text(string.ascii_letters + " ", max_size=6), min_size=1,
                                                 max_size=4))))
    if draw(st.booleans()):  # mostly tables that look right, so the parser gets past the checks
        n = draw(st.integers(2, 60))
        wl = np.sort(draw(arrays(np.float64, n, elements=st.floats(300.0, 900.0), unique=True)))
        cols = draw(st.integers(1, 3))
        vals = draw(arrays(np.float64, (n, cols), elements=st.floats(-1.0, 1e12, allow_subnormal=False)))
        fmt = (lambda v: repr(float(v)).replace(".", ",")) if delimiter != "," and draw(st.booleans()) else repr
        rows += [delimiter.join([fmt(w)] + [fmt(v) for v in row]) for w, row in zip(wl, vals)]
    else:
        rows += [delimiter.join(draw(st.lists(_CELL, min_size=1, max_size=4)))
                 for _ in range(draw(st.integers(0, 12)))]
    if draw(st.booleans()):
        rows.insert(draw(st.integers(0, len(rows))), "# a comment")
    return "\n".join(rows) + draw(st.sampled_from(["", "\n", "\r\n"]))


@FAST
@given(csv_texts())
def test_read_spectra_csv_gives_a_finite_table_or_a_value_error(text) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "table.csv"
        path.write_text(text, encoding="utf-8")
        try:
            table = read_spectra_csv(path)
        except ValueError as exc:
            assert str(exc)
            return
    assert table.values.shape == (len(table.names), table.wavelengths_nm.size)
    assert np.all(np.isfinite(table.values)) and table.values.min() >= 0.0
    try:
        grid = table.on_grid()
    except ValueError:
        return
    assert grid.shape == (len(table.names), N_BANDS) and np.all(np.isfinite(grid))
