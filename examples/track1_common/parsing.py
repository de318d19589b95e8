"""The instruction reader, for the memory-free policy's ``from parsing import …``: it lives
in ``simhost.skills`` (``simhost/skills/_language.py``), one copy; this module only names it."""

from simhost.skills import AFFORDANCES, parse, thing

__all__ = ["AFFORDANCES", "parse", "thing"]
