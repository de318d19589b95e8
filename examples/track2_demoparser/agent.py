"""Entry point of the demo-parser baseline (the agent is ``demoparser.py``)."""

import sys

from demoparser import main

if __name__ == "__main__":
    sys.exit(main())
