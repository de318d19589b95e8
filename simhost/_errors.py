"""``SimHostError``: the root of every error the simhost package raises.

Light (pydantic only, through ``schemas``): the agent client's errors derive from it too.
"""

from __future__ import annotations

from schemas import EagcError


class SimHostError(EagcError):
    """Raised when an environment, the sim host or the agent client cannot go on."""
