"""The version of eagc: the installed distribution's, so ``pyproject.toml`` is its one source.

What changed for teams in each version is in ``CHANGELOG.md``.
"""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("eagc")
except PackageNotFoundError:  # a source tree on sys.path that was never installed
    __version__ = "0+unknown"
