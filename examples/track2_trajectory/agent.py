"""Entry point of the trajectory baseline (the agent is ``trajectory.py``)."""

import sys

from trajectory import Agent, main

if __name__ == "__main__":
    sys.exit(main(Agent()))
