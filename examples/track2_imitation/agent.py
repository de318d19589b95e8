"""Imitation baseline for Track 2 (T-OSVI style): a one-shot imitation policy conditioned on the
demonstration, learned offline, with no explicit world model.

Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), ``schemas``, numpy and the
standard library. ``policy.npz`` holds one weight matrix per family, fitted by
``train.py`` on expert rollouts the gymnasium benches generate; ``policy.py`` says how the
policy reads the demonstration. Each attempt runs the policy from the demonstration's start
to its end (then holds a few steps and ends the attempt); nothing is verified, nothing is
remembered between attempts. The task model is what the packet's manifest says: the family
and its stages.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
from policy import Policy

from schemas import DemoManifest, TaskModel
from simhost.client import OutputFiles, RemoteEnv

HERE = Path(__file__).resolve().parent
INPUT = Path(os.environ.get("EAGC_INPUT", "/input"))
HOLD_AFTER = 10


def main() -> int:
    files = OutputFiles()
    weights = dict(np.load(HERE / "policy.npz", allow_pickle=False))
    attention = json.loads(weights.pop("attention").tobytes())
    steps = 0
    with RemoteEnv() as env:
        env.hello(agent="eagc-track2-imitation/1")
        ts = env.reset()
        policy: Policy | None = None
        attempt, after = 0, 0
        while not ts.episode_over:
            if ts.stage in ("demonstration", "parsing"):
                if policy is None:
                    msg = ts.message("demonstration")
                    folder = INPUT / (msg.data.get("folder", "demo") if msg else "demo")
                    man = DemoManifest.model_validate_json((folder / "manifest.json").read_text())
                    with np.load(folder / "trajectory.npz", allow_pickle=False) as npz:
                        prop, parts, acts = npz["obs_proprio"], npz["obs_parts"], npz["actions"]
                    stages = [(ks.name, ks.start, ks.end) for ks in man.key_stages]
                    grasps = [e.step for e in man.events if e.event == "grasped"]
                    policy = Policy(weights[man.family], attention[man.family], prop, parts,
                                    acts, stages, grasps)
                    files.write(TaskModel(step=steps, family=man.family, stages=man.stage_names))
                    files.log(step=steps, stage=ts.stage, event="plan",
                              data={"demo_steps": man.num_steps})
                ts = env.end_stage()
                continue
            assert policy is not None
            if ts.observation.get("attempt", 0) != attempt:
                attempt, after = int(ts.observation["attempt"]), 0
                policy.reset()
                files.log(step=steps, stage=ts.stage, event="attempt", data={"attempt": attempt})
            steps += 1
            if policy.done:
                after += 1
            if after > HOLD_AFTER:  # through the demonstration and not done: give up
                ts = env.step({"end_attempt": 1})
            else:
                ts = env.step({"motion": policy(ts.observation)})
            for m in ts.messages:
                if m.type == "attempt_result":
                    files.log(step=steps, stage=ts.stage, event="attempt", data=dict(m.data))
        files.log(step=steps, stage=ts.stage, event="note", data={"end": ts.end_reason})
    files.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
