"""``python -m orchestrator.cli``: the same as the ``eagc`` console script."""

from orchestrator.cli.main import main

main()
