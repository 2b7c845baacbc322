"""Many photos in one call: the next photo is read while this one is estimated.

Decoding a JPEG runs in libjpeg without Python's lock, and the estimate is mostly numpy and
Python; so one background thread that loads photo i + 1 while photo i is estimated hides most of
the decoding (a 24 MP JPEG: a third of the time per photo) on a machine with two cores, and
costs nothing on one. Results come back in the order given; a photo that cannot be read raises
the same error, at the same place in the sequence, as reading them one by one would. Where a
fallback decoder that must run on the main thread is registered (Blender's loader, which the CLI
registers for formats Pillow cannot read), photos are read one after the other instead.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any

from ..photo.images import LinearImage, decoders_need_main_thread
from ..scene.capture import Preset, load_preset
from .estimate import estimate_image
from .load import load_for_estimate
from .result import Estimate

__all__ = ["estimate_photos"]


def _loaded(path: str | Path, preset: Preset) -> tuple[LinearImage, float]:
    t0 = time.perf_counter()
    image = load_for_estimate(path, preset)
    return image, (time.perf_counter() - t0) * 1e3


def estimate_photos(paths: Sequence[str | Path], *, preset: str | Preset, **options: Any) -> Iterator[Estimate]:
    """``estimate_photo`` of each path in turn (same ``options``), the next one loading in the
    background. A generator: stop iterating and no further photo is read."""
    preset_obj = preset if isinstance(preset, Preset) else load_preset(preset)
    if decoders_need_main_thread():
        for path in paths:
            image, load_ms = _loaded(path, preset_obj)
            yield _timed(estimate_image(image, preset=preset_obj, **options), load_ms)
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="cd-spectra-load") as pool:
        pending: Future[tuple[LinearImage, float]] | None = pool.submit(_loaded, paths[0], preset_obj) if paths else None
        for i in range(len(paths)):
            assert pending is not None
            image, load_ms = pending.result()  # re-raises the loader's own error for this photo
            pending = pool.submit(_loaded, paths[i + 1], preset_obj) if i + 1 < len(paths) else None
            yield _timed(estimate_image(image, preset=preset_obj, **options), load_ms)


def _timed(result: Estimate, load_ms: float) -> Estimate:
    result.timing_ms["load"] = load_ms
    result.timing_ms["total"] += load_ms
    return result
