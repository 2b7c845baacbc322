"""Progress for long work: Blender's progress cursor plus a status-bar message."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

ProgressFn = Callable[[float, str], None]


@contextmanager
def progress(context: Any) -> Iterator[ProgressFn]:
    """Yield ``update(fraction 0–1, message)``; the cursor and status text reset on exit."""
    wm = context.window_manager
    workspace = getattr(context, "workspace", None)
    wm.progress_begin(0.0, 1.0)

    def update(fraction: float, message: str = "") -> None:
        wm.progress_update(min(max(float(fraction), 0.0), 1.0))
        if workspace is not None and message:
            workspace.status_text_set(f"CD Spectra: {message}")

    try:
        yield update
    finally:
        wm.progress_end()
        if workspace is not None:
            workspace.status_text_set(None)
