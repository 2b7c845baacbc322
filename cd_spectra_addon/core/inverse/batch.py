"""Many photos in one call: the next photo is read while this one is estimated.

Decoding a JPEG runs in libjpeg without Python's lock, and the estimate is mostly numpy and
Python; so one background thread that loads photo i + 1 while photo i is estimated hides most of
the decoding (a 24 MP JPEG: a third of the time per photo) on a machine with two cores, and
costs nothing on one. Results come back in the order given; a photo that cannot be read raises
the same error, at the same place in the sequence, as reading them one by one would. Where a
fallback decoder that must run on the main thread is registered (Blender's loader, which the CLI
registers for formats Pillow cannot read), photos are read one after the other instead.
:func:`prefetched` is that loading on its own, for any caller that works through photos in
turn (the batch here, the joint estimate of :mod:`.joint`).
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import CDSpectraError
from ..photo.decoders import decoders_need_main_thread
from ..photo.frames import split_frame
from ..photo.images import LinearImage
from ..scene.capture import Preset, load_preset
from .estimate import estimate_image
from .load import load_for_estimate
from .stages import series_focal_px
from .result import Estimate

__all__ = ["Loaded", "prefetched", "estimate_photos", "frame_file", "series_lenses"]


@dataclass(frozen=True)
class Loaded:
    """One photo as :func:`prefetched` hands it over: the image, or the error reading it raised."""

    source: str
    image: LinearImage | None
    error: Exception | None
    load_ms: float


def _load(photo: str | Path | LinearImage, preset: Preset) -> Loaded:
    if isinstance(photo, LinearImage):  # already loaded: nothing to read
        return Loaded(str(photo.path), photo, None, 0.0)
    t0 = time.perf_counter()
    try:
        image = load_for_estimate(photo, preset)
    except Exception as exc:  # handed to the caller, who raises it or reports it in its place
        return Loaded(str(photo), None, exc, (time.perf_counter() - t0) * 1e3)
    return Loaded(str(photo), image, None, (time.perf_counter() - t0) * 1e3)


def prefetched(photos: Sequence[str | Path | LinearImage], presets: Preset | Sequence[Preset]
               ) -> Iterator[Loaded]:
    """Each photo loaded for the estimate (with its preset: one for all, or one each), in order,
    the next one loading in the background while the caller works on this one. A generator:
    stop iterating and no further photo is read."""
    each = [presets] * len(photos) if isinstance(presets, Preset) else list(presets)
    if decoders_need_main_thread():
        for photo, preset in zip(photos, each):
            yield _load(photo, preset)
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="cd-spectra-load") as pool:
        pending: Future[Loaded] | None = pool.submit(_load, photos[0], each[0]) if photos else None
        for i in range(len(photos)):
            assert pending is not None
            loaded = pending.result()
            pending = pool.submit(_load, photos[i + 1], each[i + 1]) if i + 1 < len(photos) else None
            yield loaded


def frame_file(photo: str | Path | LinearImage) -> str | None:
    """The file a frame (``FILE.gif#N``) comes from; None for a whole file or a loaded image."""
    if isinstance(photo, LinearImage):
        return None
    file, frame = split_frame(photo)
    return None if frame is None else str(file)


def series_lenses(photos: Sequence[str | Path | LinearImage], presets: Sequence[Preset]) -> dict[str, float]:
    """One lens per file for the frames of a GIF given together (one camera, one zoom): the median
    of their disc outlines' focal length (:func:`.stages.series_focal_px`, file pixels), used by
    the frames whose EXIF has none — a frame whose disc edge does not show borrows its neighbours'.
    Frames that fail to load are left to the main loop to report."""
    frames: dict[str, list[tuple[str | Path, Preset]]] = {}
    for photo, preset in zip(photos, presets):
        file = frame_file(photo)
        if file is not None:
            frames.setdefault(file, []).append((photo, preset))
    lenses: dict[str, float] = {}
    for file, given in frames.items():
        if len(given) < 2:
            continue
        images = []
        for photo, preset in given:
            try:
                images.append(load_for_estimate(photo, preset))
            except (CDSpectraError, OSError):  # the main loop reports it
                continue
        focal = series_focal_px(images, given[0][1]) if images else None
        if focal is not None:
            lenses[file] = focal
    return lenses


def estimate_photos(paths: Sequence[str | Path], *, preset: str | Preset, **options: Any) -> Iterator[Estimate]:
    """``estimate_photo`` of each path in turn (same ``options``), the next one loading in the
    background. A generator: stop iterating and no further photo is read."""
    preset_obj = preset if isinstance(preset, Preset) else load_preset(preset)
    lenses = series_lenses(paths, [preset_obj] * len(paths))
    for path, loaded in zip(paths, prefetched(paths, preset_obj)):
        if loaded.error is not None:
            raise loaded.error  # the loader's own error for this photo
        assert loaded.image is not None
        yield _timed(estimate_image(loaded.image, preset=preset_obj, series_focal=lenses.get(frame_file(path)),
                                    **options), loaded.load_ms)


def _timed(result: Estimate, load_ms: float) -> Estimate:
    result.timing_ms["load"] = load_ms
    result.timing_ms["total"] += load_ms
    return result
