"""Many photos in one call: the same estimates as one by one, in order, and never a registered
(Blender) decoder off the main thread."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from cd_spectra_addon.core.errors import PhotoError
from cd_spectra_addon.core.inverse.batch import estimate_photos
from cd_spectra_addon.core.inverse.estimate import estimate_photo
from cd_spectra_addon.core.photo import images
from cd_spectra_addon.core.scene.capture import DEFAULT_PRESET

SAMPLE = Path(__file__).resolve().parents[1] / "samples" / "cd_photo.jpg"  # `make sample-photo`: the default preset


@pytest.mark.slow  # ten full estimates of the sample photo (5 s): make test only
def test_the_same_estimates_as_one_by_one_in_order(tmp_path: Path) -> None:
    second = tmp_path / "copy.jpg"
    second.write_bytes(SAMPLE.read_bytes())
    options = dict(preset=DEFAULT_PRESET, model=None, method="prior")
    batch = list(estimate_photos([SAMPLE, second, SAMPLE], **options))
    single = [estimate_photo(p, **options) for p in (SAMPLE, second, SAMPLE)]
    assert [b.source for b in batch] == [str(SAMPLE), str(second), str(SAMPLE)]
    for b, s in zip(batch, single):
        assert np.array_equal(b.spd, s.spd)
        assert b.timing_ms["load"] > 0 and b.timing_ms["total"] >= b.timing_ms["load"]


def test_a_bad_photo_stops_the_batch_where_it_stands(tmp_path: Path) -> None:
    bad = tmp_path / "bad.jpg"
    bad.write_bytes(b"not a photo")
    results = estimate_photos([SAMPLE, bad, SAMPLE], preset=DEFAULT_PRESET, model=None, method="prior")
    assert next(results).source == str(SAMPLE)
    with pytest.raises(PhotoError, match="bad.jpg"):
        next(results)


def test_a_registered_decoder_runs_on_the_calling_thread(tmp_path: Path) -> None:
    """Blender's loader (registered as a fallback decoder by the CLI and the add-on) must never
    run on the prefetching thread: bpy off the main thread crashed the process."""
    seen: list[str] = []

    def decoder(path, header):  # a file no built-in decoder reads: say which thread asked
        seen.append(threading.current_thread().name)
        return None

    from training.reliability.hostile import _tiff

    odd = tmp_path / "odd.tif"
    odd.write_bytes(_tiff(np.full((96, 128, 3), 0.5, dtype=np.float32)))  # float RGB TIFF: Pillow cannot read it
    images.register_decoder(decoder)
    try:
        with pytest.raises(PhotoError):
            list(estimate_photos([SAMPLE, odd], preset=DEFAULT_PRESET, model=None, method="prior"))
    finally:
        images.unregister_decoder(decoder)
    assert seen and all(name == threading.current_thread().name for name in seen)


def test_a_bulk_run_can_skip_the_rendition_figures() -> None:
    """``rendition=False`` (the CLI's --no-rendition) reaches every estimate of a batch: no figures,
    no time spent on them; by default each estimate has them, timed."""
    options = dict(preset=DEFAULT_PRESET, model=None, method="prior")
    bare, = estimate_photos([SAMPLE], rendition=False, **options)
    assert bare.rendition is None and "rendition" not in bare.timing_ms and "rendition" not in bare.to_json()
    full, = estimate_photos([SAMPLE], **options)
    assert full.rendition["defined"] and full.timing_ms["rendition"] > 0
    assert np.array_equal(full.spd, bare.spd)
