"""A Track 1 agent handed the hidden truth, for the audit's test only (a cheat, planted).

The test writes the hidden scenario's entities and its planned exception to a JSON file
and names it in ``EAGC_PLANTED_TRUTH``; this agent moves a little, then writes what it
could not have seen: a ``world_model.json`` listing every room and every object, door and
container of the house, and an ``exception_detected`` record of the planned exception,
naming its subject, at its first step (before anything could show it).

Run as a local process: ``python tests/orchestrator/_planted_agent.py``.
"""

from __future__ import annotations

import json
import os
import sys

from simhost.client import OutputFiles, RemoteEnv

MOVES = 12


def main() -> int:
    truth = json.loads(open(os.environ["EAGC_PLANTED_TRUTH"]).read())
    files = OutputFiles()
    step = 0
    with RemoteEnv() as env:
        env.hello(agent="planted/1")
        ts = env.reset()
        files.log(step=0, stage=ts.stage, event="stage")
        exception = truth.get("exception")
        if exception:
            files.log(step=1, stage=ts.stage, event="exception_detected",
                      exception_type=exception["type"], data={"item": exception["subject"]})
        files.write({
            "version": "eagc-world-model/v1", "step": 0,
            "rooms": [{"id": r} for r in truth["rooms"]],
            "doors": [{"id": d, "state": "closed"} for d in truth["doors"]],
            "containers": [{"id": c, "state": "closed"} for c in truth["containers"]],
            "objects": [{"id": o} for o in truth["objects"]],
        }, "world_model.json")
        while not ts.episode_over:
            if ts.stage == "planning":
                ts = env.end_stage({})
            elif ts.stage == "exploration" and step < MOVES:
                step += 1
                ts = env.step({"primitive": "move", "move": [0.5, 0.3]})
            elif ts.stage == "exploration":
                ts = env.end_stage()
            else:
                step += 1
                ts = env.step({"primitive": "done"})
    return 0


if __name__ == "__main__":
    sys.exit(main())
