"""Errors of the schemas package, and ``EagcError``, the root of every eagc error.

Each package has one root: ``schemas.SchemaError``, ``simhost.SimHostError``,
``plugins.PluginError``, ``orchestrator.OrchestratorError``; all four derive from
``EagcError``, so the command line turns any of them into one line.
"""

from __future__ import annotations

from pydantic import ValidationError


class EagcError(Exception):
    """Raised when eagc cannot do what was asked, for a reason the message states."""


class SchemaError(EagcError, ValueError):
    """Raised when a file or message does not match its schema; names the file and fields.

    The first line of the message is the whole story in short: the file and its first
    problem (``world_model.json: version: Input should be 'eagc-world-model/v1'``), with
    the number of further problems; every problem follows on its own line.
    """

    def __init__(self, source: str, problems: list[str]) -> None:
        self.source = source
        self.problems = problems or ["(no detail)"]
        super().__init__(f"{self.summary}\n" + "\n".join(f"  - {p}" for p in self._shown))

    @property
    def summary(self) -> str:
        """One line: the source, its first problem and how many more there are."""
        return f"{self.source}: {self._first}"

    @property
    def detail(self) -> str:
        """The message without the source's name (for a report that names it already)."""
        return f"{self._first}\n" + "\n".join(f"  - {p}" for p in self._shown)

    @property
    def _first(self) -> str:
        first, more = self.problems[0], len(self.problems) - 1
        return first + (f" (and {more} more problem{'s' if more > 1 else ''})" if more else "")

    @property
    def _shown(self) -> list[str]:
        extra = len(self.problems) - 20
        return self.problems[:20] + ([f"… and {extra} more"] if extra > 0 else [])


def describe(err: ValidationError) -> list[str]:
    """One line per problem: the field path and what is wrong with it."""
    out = []
    for e in err.errors(include_url=False):
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        out.append(f"{loc}: {e['msg']}")
    return out
