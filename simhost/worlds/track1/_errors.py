"""Errors of the Track 1 environment: one root, one subclass per kind of mistake."""

from __future__ import annotations

from simhost._errors import SimHostError


class HouseError(SimHostError):
    """Raised when a Track 1 house cannot be built, changed or restored (root of its errors)."""


class LayoutError(HouseError, ValueError):
    """Raised when a house cannot be generated (bad seed or unsatisfiable parameters)."""


class PerturbationError(HouseError, ValueError):
    """Raised when a perturbation cannot be applied now; the message says why and what to do."""


class StateError(HouseError, ValueError):
    """Raised when a saved state does not belong to this house or is corrupt."""


class TaskError(HouseError, ValueError):
    """Raised when a task description names unknown ids or fields."""


class ConfigError(HouseError, TypeError):
    """Raised when ``HouseEnv`` gets an option it does not know."""
