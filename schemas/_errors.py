"""Errors of the schemas package."""

from __future__ import annotations

from pydantic import ValidationError


class SchemaError(ValueError):
    """Raised when a file or message does not match its schema; names the file and fields."""

    def __init__(self, source: str, problems: list[str]) -> None:
        self.source = source
        self.problems = problems
        lines = "\n".join(f"  - {p}" for p in problems[:20])
        more = f"\n  … and {len(problems) - 20} more" if len(problems) > 20 else ""
        super().__init__(f"{source}: {len(problems)} problem(s)\n{lines}{more}")


def describe(err: ValidationError) -> list[str]:
    """One line per problem: the field path and what is wrong with it."""
    out = []
    for e in err.errors(include_url=False):
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        out.append(f"{loc}: {e['msg']}")
    return out


