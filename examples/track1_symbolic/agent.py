"""Track 1 symbolic agent built only on the public skills (``simhost.client.skills``,
docs/skills.md).

It has no motion code of its own: it explores with ``explore_next()`` until nothing is left
(or the stage runs down), writes ``world_model.json``, answers the queries from the model,
then reads the instruction's ``steps`` ("go to the white jug", "pick up the white jug",
"open the cabinet in the kitchen", "put the white jug in the cabinet in the kitchen",
"water the green plant with the white jug") into ``go_to`` / ``fetch`` / ``open`` /
``place`` / ``use`` calls on the things its model matches (a close reading before one from
afar, which may be a look-alike). A door a skill found locked, a container it found
unavailable (``Outcome.locked``, ``Outcome.unavailable``, also when the skill went round),
an item no longer where it was (``fetch`` fails ``not_visible``, within half of the
detection window) is logged as the exception it shows, and the step is tried again on what
the model offers instead.
"""

from __future__ import annotations

import math
import re
import sys
from typing import Any

from simhost.client import OutputFiles, RemoteEnv, TimeStep
from simhost.client.skills import (
    AFFORDANCES,
    EXPLORED,
    NOT_IN_MODEL,
    STAGE_ENDING,
    STAGE_OVER,
    Outcome,
    Skills,
    Thing,
    thing,
)

SHOWS = {"locked": "door_lock", "unavailable": "container_unavailable"}
"""Host failure reasons and the exception they show (Table III)."""
STOPS = (EXPLORED, STAGE_ENDING, STAGE_OVER)
"""Outcomes of ``explore_next`` after which exploring more is pointless."""
_USE = re.compile(r"^(?:clean|wipe|slice|cut|water) (?P<target>.+) with (?P<tool>.+)$")


class SymbolicAgent:
    """Steps of the instruction, one skill call each (see the module)."""

    name = "eagc-track1-symbolic/1"
    skills: Skills
    """The public skills on this episode (made in ``run``, once the host said hello)."""

    def __init__(self) -> None:
        self.files = OutputFiles()
        self.it: Thing | None = None  # what the last step acted on
        self.reported: set[str] = set()

    def log(self, event: str, exception_type: str | None = None, **data: Any) -> None:
        self.files.log(step=self.skills.steps, stage=self.skills.ts.stage, event=event,
                       exception_type=exception_type, data=data)

    def run(self, env: RemoteEnv) -> None:
        """Plays the episode: explore, plan, the instruction's steps, done."""
        env.hello(agent=self.name)
        sk = self.skills = Skills(env, env.reset(), on_reply=self.notice)
        self.log("stage")
        while sk.explore_next().reason not in STOPS:
            pass
        sk.model.write(self.files)
        if sk.ts.stage == "exploration" and not sk.ts.episode_over:
            sk.end_stage()
        instruction = next((m.data for m in sk.messages if m.type == "instruction"), {})
        queries = next((m.data.get("queries", []) for m in sk.messages if m.type == "queries"),
                       [])
        answers = {q["id"]: a for q in queries if (a := sk.model.answer(q)) is not None}
        if answers and sk.ts.stage == "planning":
            sk.answer(answers)
        steps = list(instruction.get("steps", []))
        self.log("plan", subgoals=steps)
        if sk.ts.stage == "planning":
            sk.end_stage({"plan": {"subgoals": steps}})
        self.log("stage")
        for text in steps:
            if sk.ts.stage != "execution" or not self.do(text):
                break
        sk.model.write(self.files)
        if not sk.ts.episode_over:
            sk.step({"primitive": "done"})

    # ------------------------------------------------------------------ steps
    def do(self, text: str) -> bool:
        """Carries out one step, trying again on what the model offers after a failure."""
        for _ in range(3):
            out = self.attempt(text)
            if out is not None:
                self.met(out)
            if out is None or out.ok:
                return True
            self.log("note", step_text=text, failed=out.reason)
            if out.reason in (STAGE_ENDING, STAGE_OVER):
                return False
            self.learn(out)
        return False

    def attempt(self, text: str) -> Outcome | None:
        """One try at a step: its skill's outcome, None for a step it cannot read."""
        sk, missing = self.skills, Outcome("failed", NOT_IN_MODEL)
        if text.startswith("go to "):
            target = self.find(text[6:])
            return missing if target is None else sk.go_to(target.id)
        if text.startswith("pick up "):
            item = self.find(text[8:])
            return missing if item is None else sk.fetch(item.id)
        if text.startswith("open "):
            box = self.find(text[5:], receptacle=True)
            return missing if box is None else sk.open(box.id)
        if text.startswith("put "):
            for k in (m.start() for m in re.finditer(r" (?:in|on) (?=the )", text)):
                if thing(text[4:k]) is not None and thing(text[k + 4:]) is not None:
                    item, dest = self.find(text[4:k]), self.find(text[k + 4:], receptacle=True)
                    if item is None or dest is None:
                        return missing
                    return sk.place(item.id, dest.id)
            return None
        m = _USE.match(text)
        if m is None:
            return None
        tool, target = self.find(m["tool"]), self.find(m["target"])
        return missing if tool is None or target is None else sk.use(tool.id, target.id)

    def find(self, phrase: str, *, receptacle: bool = False) -> Thing | None:
        """The thing a description names: held, else the nearest match in the model
        (exploring until one shows up); for a tool that is gone, one with the same use."""
        sk, model = self.skills, self.skills.model
        ref = thing(phrase) if phrase != "it" else None
        while True:
            if ref is None:
                return self.it
            found = [t for t in model.matches(ref) if not t.gone and t.state != "unavailable"]
            if receptacle:
                found = [t for t in found if t.kind in ("furniture", "container")]
                if not found and any(t.state == "unavailable" for t in model.matches(ref)):
                    found = [t for t in model.of_kind("container")  # another, same room
                             if t.state != "unavailable"
                             and model.rooms.get(model.room_of(t)) == ref["room"]]
            use = AFFORDANCES.get(ref["category"])
            if use is not None and not found and any(
                    t.gone and t.category == ref["category"] for t in model.things.values()):
                found = [t for t in model.of_kind("tool")
                         if not t.gone and AFFORDANCES.get(t.category) == use]
            if found:
                held = [t for t in found if t.id == sk.explorer.held]
                self.it = held[0] if held else min(found, key=lambda t: (
                    t.afar, math.dist(t.position, sk.explorer.pose[:2])))
                return self.it
            if sk.explore_next().reason in STOPS and not self.search(ref):
                return None

    def search(self, ref: dict[str, Any]) -> bool:
        """Looks for a thing that vanished at every place that may hold it, the storage
        room's and closed containers first (opening them): whether it showed up."""
        sk, model = self.skills, self.skills.model
        places = sorted(model.of_kind("furniture", "container"), key=lambda t: (
            model.rooms.get(model.room_of(t)) != "storage", t.state != "closed",
            math.dist(t.position, sk.explorer.pose[:2])))
        for place in places:
            if any(not t.gone for t in model.matches(ref)):
                return True
            out = sk.open(place.id) if place.state == "closed" else sk.go_to(place.id)
            self.met(out)
            if out.reason in (STAGE_ENDING, STAGE_OVER):
                return False
        return any(not t.gone for t in model.matches(ref))

    def notice(self, ts: TimeStep) -> None:
        """After every reply: a door seen locked or a container seen unavailable during
        execution is the exception showing itself (logged at once, within its window)."""
        if ts.stage != "execution":
            return
        for t in self.skills.model.things.values():
            if t.id in self.skills.explorer.seen_now and t.state in ("locked", "unavailable"):
                self.report(SHOWS[t.state], seen=t.id)

    def met(self, out: Outcome) -> None:
        """A door or container a skill found locked or unavailable during execution, also
        when it went round it: the exception it shows."""
        if self.skills.ts.stage != "execution" and not self.skills.ts.episode_over:
            return
        for door in out.locked:
            self.report("door_lock", door=door)
        for box in out.unavailable:
            self.report("container_unavailable", container=box)

    def report(self, kind: str, **data: Any) -> None:
        if kind not in self.reported:
            self.reported.add(kind)
            self.log("exception_detected", exception_type=kind, **data)
            self.skills.model.write(self.files)

    def learn(self, out: Outcome) -> None:
        """A failure the host reported: the hand is full (put it down), or the exception it
        shows (logged once), and what the model learns from it (an item not where it was
        seen is gone from there)."""
        sk = self.skills
        if out.reason == "hand_full":  # put down what it holds, on the nearest furniture
            self.met(sk.drop())
            return
        kind = SHOWS.get(out.reason)
        target = self.skills.model.things.get(out.target or -1)
        if out.reason == "not_visible" and target is not None and target.kind in (
                "object", "tool"):
            target.gone = True
            kind = "tool_substitution" if target.kind == "tool" else "object_relocation"
        if kind is not None:
            self.report(kind, reason=out.reason)


Agent = SymbolicAgent


def main() -> int:
    with RemoteEnv() as env:
        Agent().run(env)
    return 0


if __name__ == "__main__":
    sys.exit(main())
