"""Demo-parser baseline for Track 2: segment the demonstration, call scripted controllers.

(``agent.py`` is the entry point; the task-model baseline builds on this module.)

Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), ``schemas`` (the packet's
``DemoManifest``, ``TaskModel``), numpy and the standard library.

- ``demonstration``: reads the packet where the host says (``$EAGC_INPUT/<folder>``) and
  ends the stage.
- ``parsing``: cuts the demonstration into phases (``parse.py``: which row the hand held,
  how, relative to what, where it ended or how it moved), takes from the packet what the
  observation cannot show (the goal annotation's magnitude, the last key stage, the
  mechanism kind the annotations name, the slot whose tool it took), writes
  ``task_model.json`` and ends the stage. Nothing moves here.
- ``execution``: the generic controller of each phase in turn (``generic.py``: carry, drive,
  tool), closed on filtered observations (``perception.py``); when it is through without
  success it ends the attempt and runs again.

It does what the demonstration did, with the same phases, end states and tool slot; it
does not check whether the instance's mechanism, direction or useful tool differ.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from controllers import View
from generic import execute
from parse import DemoParse, parse
from taskmodel import task_model

from schemas import DemoManifest
from simhost.client import OutputFiles, RemoteEnv

GIVE_UP_STEPS = 10  # idle steps after the controller is through before ending the attempt
GOAL_EVENTS = ("turned", "opened", "closed", "inserted", "pressed", "aligned")
# Goal annotations that name a state (the part ends somewhere relative to the others); the
# others name a motion (the part moves by what the demonstration moved it).
STATE_EVENTS = ("opened", "closed", "inserted", "placed", "aligned")


def read_packet(folder: Path) -> tuple[DemoManifest, dict[str, np.ndarray]]:
    manifest = DemoManifest.model_validate_json((folder / "manifest.json").read_text())
    with np.load(folder / "trajectory.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return manifest, arrays


def segment(man: DemoManifest, arrays: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """The demonstration's key stages with their steps, hand travel and state changes."""
    tcp = arrays["obs_proprio"][:, :3]
    out = []
    for ks in man.key_stages:
        a, b = ks.start, ks.end
        events = [e for e in man.events if a <= e.step < b + 1]
        out.append({"stage": ks.name, "start": a, "end": b,
                    "travel_m": float(np.sum(np.linalg.norm(np.diff(tcp[a:b + 1], axis=0),
                                                            axis=1))),
                    "events": [f"{e.event}:{e.part}" for e in events]})
    return out


def demo_hints(man: DemoManifest, arrays: dict[str, np.ndarray]) -> dict[str, Any]:
    """What the controllers need and the observation does not show, read off the packet."""
    hints: dict[str, Any] = {}
    goal = next((e for e in man.events if e.event in GOAL_EVENTS and e.value is not None), None)
    if man.family == "rotation":
        if goal is not None:
            hints["turn"] = goal.value
        else:  # the hand's yaw change while it held the handle
            grasp = next((e.step for e in man.events if e.event == "grasped"), 0)
            let_go = next((e.step for e in man.events if e.event == "released"), -1)
            yaw = np.unwrap(arrays["obs_proprio"][:, 3])
            hints["turn"] = float(yaw[let_go] - yaw[grasp])
    elif man.family == "opening":
        hints["mode"] = man.stage_names[2]
        # the annotations name the part the hand took: drawer, cover or lid
        kinds = {"drawer": "drawer", "cover": "sliding_cover", "lid": "swivel_lid"}
        hints["kind"] = next((kinds[e.part] for e in man.events if e.part in kinds), "drawer")
        if goal is not None:
            hints["fraction"] = goal.value
    elif man.family == "insertion" and goal is not None:
        hints["depth"] = goal.value
    elif man.family == "tool_use":
        hints["mechanism"] = man.stage_names[-1]
        # the slot whose tool the demonstration took: the tool row that moved most
        parts = arrays["obs_parts"]
        moved = [float(np.linalg.norm(parts[-1, 2 * s, 1:3] - parts[0, 2 * s, 1:3]))
                 if parts[0, 2 * s, 0] > 0.5 else -1.0 for s in (0, 1)]
        hints["slot"] = int(np.argmax(moved))
        if hints["mechanism"] == "press":  # how far the target went down, at rest before/after
            z = parts[:, 4, 3]
            hints["press_depth"] = round(float(np.mean(z[:8]) - np.mean(z[-8:])), 3)
    return hints


class Agent:
    name = "eagc-track2-demoparser/2"

    def __init__(self) -> None:
        self.files = OutputFiles()
        self.input = Path(os.environ.get("EAGC_INPUT", "/input"))
        self.steps = 0
        self.hints: dict[str, Any] = {}
        self.measured: dict[str, Any] = {}
        self.family = ""
        self.view: View | None = None
        self.first: View | None = None
        self.dev = False
        self.dp: DemoParse | None = None

    def log(self, event: str, stage: str, **data: Any) -> None:
        self.files.log(step=self.steps, stage=stage, event=event, data=data)

    def write_model(self, stage: str) -> None:
        assert self.first is not None
        doc = task_model(self.family, self.first, self.hints, self.measured, self.steps,
                         dev=self.dev)
        self.files.write(doc)
        self.log("model_update", stage, stages=doc.stages)

    def receive(self, ts: Any) -> None:
        msg = ts.message("demonstration")
        folder = self.input / (msg.data.get("folder", "demo") if msg is not None else "demo")
        self.manifest, self.arrays = read_packet(folder)
        self.family = self.manifest.family
        self.log("observation", ts.stage, demo=str(folder), family=self.family,
                 demo_steps=self.manifest.num_steps)

    def parse(self, ts: Any) -> None:
        self.log("plan", ts.stage, segments=segment(self.manifest, self.arrays))
        self.hints = demo_hints(self.manifest, self.arrays)
        self.measured = self.hints  # the controllers add what they measure (a range, ...)
        self.write_model(ts.stage)

    def demo_parse(self) -> DemoParse:
        if self.dp is None:
            self.dp = parse(self.manifest, self.arrays)
        return self.dp

    def make_view(self, obs: dict[str, Any]) -> View:
        dp = self.demo_parse()
        view = View(len(obs["parts"]), dp.movable, dp.reach, dp.links)
        view.update(obs, reset=True)
        return view

    def controller(self, view: View) -> Any:
        goal = next((e for e in self.manifest.events if e.event in GOAL_EVENTS), None)
        return execute(view, self.demo_parse(), goal is not None and goal.event in STATE_EVENTS)

    def after_attempt(self, data: dict[str, Any]) -> None:
        """Rewrite the task model when the attempt measured something (an opening's range)."""
        if "range_measured" in self.measured and not self.measured.get("written"):
            self.measured["written"] = True
            self.write_model("execution")

    def run(self, env: RemoteEnv) -> None:
        env.hello(agent=self.name)
        ts = env.reset()
        self.dev = "goal" in ts.observation
        attempt, plan, idle = 0, None, 0
        while not ts.episode_over:
            if ts.stage == "demonstration":
                self.receive(ts)
                ts = env.end_stage()
                continue
            if ts.stage == "parsing":
                if not self.family:
                    self.receive(ts)
                if self.first is None:
                    self.first = self.make_view(ts.observation)
                self.parse(ts)
                ts = env.end_stage()
                continue
            if ts.observation.get("attempt", 0) != attempt:
                attempt = int(ts.observation["attempt"])
                self.view = self.make_view(ts.observation)
                plan, idle = self.controller(self.view), 0
                self.log("attempt", ts.stage, attempt=attempt)
            assert plan is not None and self.view is not None
            try:
                action = next(plan)
            except StopIteration:
                idle += 1
                action = self.view.command(self.view.target[:3], self.view.target[3],
                                           self.view.width())
                if idle > GIVE_UP_STEPS:
                    self.steps += 1
                    ts = env.step({"end_attempt": 1})
                    self.heard(ts)
                    continue
            self.steps += 1
            ts = env.step({"motion": action.astype(np.float32)})
            self.view.update(ts.observation)
            self.heard(ts)
        self.log("note", ts.stage, end=ts.end_reason)

    def heard(self, ts: Any) -> None:
        for m in ts.messages:
            if m.type == "attempt_result":
                self.log("attempt", ts.stage, **m.data)
                self.after_attempt(dict(m.data))


def main(agent: Agent | None = None) -> int:
    agent = agent or Agent()
    with RemoteEnv() as env:
        agent.run(env)
    agent.files.close()
    return 0
