"""``OrchestratorError``: the root of every error the orchestrator package raises.

``UsageError`` is what the command line raises for a value it cannot use (a track or split
that does not exist, a folder that is not an episode): the CLI prints it as one line and
exits 2, like any other usage error.
"""

from __future__ import annotations

from schemas import EagcError


class OrchestratorError(EagcError):
    """Raised when a campaign, an episode's runtime, the store or an image build fails."""


class UsageError(OrchestratorError):
    """Raised when a command gets a value it cannot use; the message says what would do."""
