"""Errors of the Track 2 bench: one root, one subclass per kind of mistake."""

from __future__ import annotations

from simhost._errors import SimHostError


class Track2Error(SimHostError):
    """Raised when a Track 2 bench cannot be built, changed or restored (root of its errors)."""


class InstanceParamsError(Track2Error, ValueError):
    """Raised when instance parameters do not match their family's parameter table."""


class StateError(Track2Error, ValueError):
    """Raised when ``BenchEnv.set_state`` receives bytes that are not a state of this instance."""


class DemoPacketError(Track2Error, ValueError):
    """Raised when a demonstration packet folder is missing, malformed or inconsistent."""


class SplitConfigError(Track2Error, ValueError):
    """Raised when a split name is not one of the presets (``dev``, ``standard``, ``challenge``)."""
