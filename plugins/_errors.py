"""``PluginError``: the root of every error the plugins package raises."""

from __future__ import annotations

from schemas import EagcError


class PluginError(EagcError, RuntimeError):
    """Raised when a track cannot be found, loaded or used (the root of plugins' errors)."""
