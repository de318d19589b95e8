"""The ``eagc`` command line: ``app`` (typer) and ``main`` (the console script).

``main`` holds the commands, ``campaign`` the ``eagc campaign …`` group, ``demo`` the demo
campaigns, ``common`` the exit codes and one-line errors every command shares.
"""

from orchestrator.cli.main import app, main

__all__ = ["app", "main"]
