"""Demo-parser baseline for Track 2: segment the demonstration, call scripted controllers.

Uses only ``simhost.agent.RemoteEnv``, numpy and the standard library (the packet is read
with ``json`` and ``numpy.load(allow_pickle=False)``).

- ``demonstration``: reads the packet where the host says (``$EAGC_INPUT/<folder>``) and
  ends the stage.
- ``parsing``: segments the demonstration into its key stages (manifest labels and
  state-change annotations: grasp, release, …), keeps the source's parameters the
  observation cannot show, writes ``task_model.json`` for the hidden instance it observes,
  and ends the stage. Nothing moves here.
- ``execution``: the family's scripted controller (``controllers.py``), closed on the
  observations; when it finishes without success it ends the attempt and tries again (an
  opening's measured range is kept across attempts), and rewrites the task model when it
  learned something.

Files go to ``$EAGC_OUTPUT`` (``/output``), written to a temporary name and renamed.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np
from controllers import CONTROLLERS, View
from taskmodel import task_model

from simhost.agent import RemoteEnv

OUT = Path(os.environ.get("EAGC_OUTPUT", "/output"))
INPUT = Path(os.environ.get("EAGC_INPUT", "/input"))
GIVE_UP_STEPS = 10  # idle steps after the controller is through before ending the attempt


def read_packet(folder: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    manifest = json.loads((folder / "manifest.json").read_text())
    with np.load(folder / "trajectory.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return manifest, arrays


def segment(manifest: dict[str, Any], arrays: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """The demonstration's key stages with their steps, hand travel and state changes."""
    tcp = arrays["obs_proprio"][:, :3]
    out = []
    for ks in manifest["key_stages"]:
        a, b = ks["start"], ks["end"]
        events = [e for e in manifest["events"] if a <= e["step"] < b + 1]
        out.append({"stage": ks["name"], "start": a, "end": b,
                    "travel_m": float(np.sum(np.linalg.norm(np.diff(tcp[a:b + 1], axis=0),
                                                            axis=1))),
                    "events": [f"{e['event']}:{e['part']}" for e in events]})
    return out


class Agent:
    def __init__(self) -> None:
        OUT.mkdir(parents=True, exist_ok=True)
        self.log_file = (OUT / "episode_log.jsonl").open("a")
        self.view = View()
        self.steps = 0
        self.hints: dict[str, Any] = {}
        self.family = ""
        self.source: dict[str, Any] = {}
        self.first_view = View()

    def log(self, event: str, stage: str, **data: Any) -> None:
        self.log_file.write(json.dumps({"step": self.steps, "stage": stage, "event": event,
                                        "data": data}) + "\n")
        self.log_file.flush()

    def write_model(self, stage: str) -> None:
        doc = task_model(self.family, self.first_view, self.source, self.hints, self.steps)
        tmp = OUT / ".task_model.json.tmp"
        tmp.write_text(json.dumps(doc, indent=1))
        tmp.replace(OUT / "task_model.json")
        self.log("model_update", stage, stages=doc["stages"])

    def receive(self, ts: Any) -> Any:
        msg = ts.message("demonstration")
        folder = INPUT / (msg.data.get("folder", "demo") if msg is not None else "demo")
        self.manifest, self.arrays = read_packet(folder)
        self.family = self.manifest["family"]
        self.source = self.manifest["source"]
        self.log("observation", ts.stage, demo=str(folder), family=self.family,
                 demo_steps=self.manifest["num_steps"])
        return ts

    def parse(self, ts: Any) -> None:
        segments = segment(self.manifest, self.arrays)
        self.log("plan", ts.stage, segments=segments)
        self.hints = {"well_depth": self.source["geometry"].get("well_depth"),
                      "initial_joint": self.first_view.joint(0)}
        self.write_model(ts.stage)

    def run(self, env: RemoteEnv) -> None:
        env.hello(agent="eagc-track2-demoparser/1")
        ts = env.reset()
        self.view.update(ts.observation, reset=True)
        self.first_view.update(ts.observation, reset=True)
        attempt, plan, idle = 0, None, 0
        while not ts.episode_over:
            if ts.stage == "demonstration":
                self.receive(ts)
                ts = env.end_stage()
                continue
            if ts.stage == "parsing":
                if not self.family:
                    self.receive(ts)
                self.parse(ts)
                ts = env.end_stage()
                continue
            if ts.observation.get("attempt", 0) != attempt:
                attempt = int(ts.observation["attempt"])
                self.view.update(ts.observation, reset=True)
                plan, idle = CONTROLLERS[self.family](self.view, self.hints), 0
                self.log("attempt", ts.stage, attempt=attempt)
            assert plan is not None
            try:
                action = next(plan)
            except StopIteration:
                idle += 1
                action = self.view.command(self.view.target[:3], self.view.target[3],
                                           float(self.view.obs["proprio"][4]))
                if idle > GIVE_UP_STEPS:
                    self.steps += 1
                    ts = env.step({"end_attempt": 1})
                    self.after(ts)
                    continue
            self.steps += 1
            ts = env.step({"motion": action.astype(np.float32).tolist()})
            self.view.update(ts.observation)
            self.after(ts)
        if "range_measured" in self.hints:
            self.write_model(ts.stage)
        self.log("note", ts.stage, end=ts.end_reason)

    def after(self, ts: Any) -> None:
        for m in ts.messages:
            if m.type == "attempt_result":
                self.log("attempt", ts.stage, **m.data)
                if "range_measured" in self.hints:
                    self.write_model(ts.stage)


def main() -> int:
    agent = Agent()
    with RemoteEnv() as env:
        agent.run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
