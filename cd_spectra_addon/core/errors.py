"""The one exception type users see: a specific, plain-language reason, never a traceback."""

from __future__ import annotations

__all__ = ["CDSpectraError", "PhotoError", "NoDiscError", "ModelError"]


class CDSpectraError(ValueError):
    """Bad input or an impossible request. ``str(exc)`` is the message shown to the user."""


class PhotoError(CDSpectraError):
    """The photo cannot be read or used (unreadable, too large, black, saturated, ...)."""


class NoDiscError(CDSpectraError):
    """No CD ring pattern was found in the photo."""


class ModelError(CDSpectraError):
    """The model file or its metadata is missing, corrupt or does not match this version."""
