"""Leaderboards and per-team reports as plain text that fits a given width (80 by default).

The layout never cuts a team name or a value. In order, it tries:

1. one table in the track's column order, headers wrapped at spaces (``Task Succ. %``
   over three lines if need be);
2. the same columns in at most three tables, each repeating ``#`` and ``Team`` (the
   final score first), as many columns in each as the width allows;
3. one block per team, ``Title value`` pairs flowing over the lines.

The width is ``$COLUMNS`` when set, else the terminal's, else 80 (``shutil``), whether or
not the output is a terminal.
"""

from __future__ import annotations

import shutil
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass

GAP = "  "
#: More tables than this for one leaderboard: one block per team reads better.
MAX_TABLES = 3


def width() -> int:
    """``$COLUMNS``, else the terminal's width, else 80."""
    return max(20, shutil.get_terminal_size((80, 24)).columns)


@dataclass(frozen=True)
class TextColumn:
    """A column to lay out: its title, its cells, and whether it is right-justified."""

    title: str
    cells: tuple[str, ...]
    right: bool = True

    @property
    def min_width(self) -> int:
        longest_word = max((len(w) for w in self.title.split()), default=0)
        return max([longest_word, *(len(c) for c in self.cells)])

    def header(self, w: int) -> list[str]:
        return textwrap.wrap(self.title, w, break_long_words=False) or [""]


def table_lines(columns: Sequence[TextColumn]) -> list[str]:
    widths = [c.min_width for c in columns]
    heads = [c.header(w) for c, w in zip(columns, widths, strict=True)]
    depth = max(len(h) for h in heads)
    lines: list[str] = []
    for i in range(depth):
        cells = []
        for c, w, h in zip(columns, widths, heads, strict=True):
            text = h[i - (depth - len(h))] if i >= depth - len(h) else ""
            cells.append(text.rjust(w) if c.right else text.ljust(w))
        lines.append(GAP.join(cells).rstrip())
    lines.append(GAP.join("─" * w for w in widths))
    for r in range(len(columns[0].cells)):
        cells = [c.cells[r].rjust(w) if c.right else c.cells[r].ljust(w)
                 for c, w in zip(columns, widths, strict=True)]
        lines.append(GAP.join(cells).rstrip())
    return lines


def _fits(columns: Sequence[TextColumn], limit: int) -> bool:
    return sum(c.min_width for c in columns) + len(GAP) * (len(columns) - 1) <= limit


def layout(title: str, key: Sequence[TextColumn], columns: Sequence[TextColumn],
           first: int, limit: int, lead: int = 1) -> list[str]:
    """Lines of a table of ``key`` columns (``#``, ``Team``) then ``columns``, within
    ``limit`` characters (module docstring); ``columns[first:first + lead]`` lead when it
    is split."""
    out = textwrap.wrap(title, limit) or [""]
    if _fits([*key, *columns], limit):
        return [*out, *table_lines([*key, *columns])]
    ordered = [*columns[first:first + lead], *columns[:first], *columns[first + lead:]]
    groups: list[list[TextColumn]] = [[]]
    for c in ordered:
        if groups[-1] and not _fits([*key, *groups[-1], c], limit):
            groups.append([])
        groups[-1].append(c)
    if len(groups) > MAX_TABLES or not all(_fits([*key, *g], limit) for g in groups):
        return [*out, *_cards(key, ordered, limit)]
    for i, group in enumerate(groups):
        if i:
            out.append("")
        out.extend(table_lines([*key, *group]))
    return out


def _cards(key: Sequence[TextColumn], columns: Sequence[TextColumn], limit: int) -> list[str]:
    """One block per row: the key cells on the first line, then ``Title value`` pairs."""
    out: list[str] = []
    for r in range(len(key[0].cells)):
        out.extend(flow([k.cells[r] for k in key], limit, "", GAP))
        out.extend(flow([f"{c.title} {c.cells[r]}" for c in columns], limit, "    "))
    return out


def flow(items: Sequence[str], limit: int, indent: str, sep: str = " · ") -> list[str]:
    """``items`` joined by ``sep`` over as many lines as ``limit`` needs, never splitting
    an item (one longer than the line gets a line of its own)."""
    lines: list[str] = []
    line = ""
    for item in items:
        if line and len(indent) + len(line) + len(sep) + len(item) > limit:
            lines.append(indent + line)
            line = ""
        line = f"{line}{sep}{item}" if line else item
    if line:
        lines.append(indent + line)
    return lines


def wrapped(text: str, limit: int, indent: str = "") -> list[str]:
    """``text`` wrapped at ``limit`` with ``indent`` on every line; long words kept whole."""
    return textwrap.wrap(text, limit, initial_indent=indent, subsequent_indent=indent,
                         break_long_words=False, break_on_hyphens=False) or [indent.rstrip()]
