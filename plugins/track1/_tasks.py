"""Tasks: goals drawn from a house's initial ground truth, said in the instruction grammar.

A ``place`` goal moves an object (never a tool) to a receptacle in another room, named
unambiguously (a container with probability 0.6). A ``use`` goal applies a tool to a target
in the affordance's before-state (a dirty surface, a whole apple or bread, a dry plant; not
inside a container). On the official splits an instruction has ``goals`` clauses (2 or 3);
a clause may follow up on the one before: "slice the red apple with the black knife, then
put it in the fridge in the kitchen", "clean the desk in the bedroom with the blue cloth and
then put the cloth in the drawer in the kitchen" (a follow-up names the tool by category).
The dev split keeps one clause in today's six templates, and states the substitute rule.

The planned exception needs a goal it can matter to: a place goal into a container that has
a free container beside it (container unavailable), a use goal (tool substitution), a place
goal whose object is outside the storage room (object relocation); a door lock works on any
task (it targets the route).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from plugins.track1._language import (
    SUBSTITUTE_RULE,
    Describer,
    join,
    place_clause,
    use_clause,
    words,
)
from plugins.track1._types import Goal, PlannedException, Task
from simhost.worlds.track1 import AFFORDANCE_EFFECTS, HouseLayout, HouseTruth

_TRIES = 30


@dataclass
class _Draft:
    """Goals chosen so far, and what they use up."""

    goals: list[Goal] = field(default_factory=list)
    clauses: list[str] = field(default_factory=list)
    steps: list[str] = field(default_factory=list)
    moved: set[int] = field(default_factory=set)
    filled: dict[int, int] = field(default_factory=dict)


class TaskMaker:
    """Draws goals of one house."""

    def __init__(self, layout: HouseLayout, truth: HouseTruth, *, dev: bool) -> None:
        self.layout, self.truth, self.dev = layout, truth, dev
        self.say = Describer(truth)
        self.rec = self.say.rec
        self.items = self.say.items
        self.containers = {c.id for c in truth.containers}

    # ------------------------------------------------------------------ helpers
    def free(self, rec_id: int, draft: _Draft) -> int:
        """Free slots of a receptacle, minus what the draft already puts there."""
        rec = self.layout.entity(rec_id)
        used = sum(1 for o in self.truth.objects if o.receptacle == rec_id)
        return rec.slots - used - draft.filled.get(rec_id, 0)  # type: ignore[union-attr]

    def room_containers(self, room: int, but: int, draft: _Draft) -> tuple[int, ...]:
        return tuple(c.id for c in self.truth.containers
                     if c.room == room and c.id != but and self.free(c.id, draft) > 0)

    def _name(self, entity_id: int, rng: np.random.Generator) -> str | None:
        return self.say.thing(entity_id, None if self.dev else rng)

    # ------------------------------------------------------------------ goals
    def place_goal(self, rng: np.random.Generator, draft: _Draft, *, inside: bool | None,
                   need_substitute: bool = False, obj: int | None = None) -> bool:
        """Adds a place goal (``obj``: of that object, said as "it")."""
        if obj is not None:
            objects = [obj]
        else:
            objects = [o.id for o in self.truth.objects
                       if o.kind == "object" and o.id not in draft.moved]
            objects = [objects[i] for i in rng.permutation(len(objects))]
        if inside is None:
            inside = bool(rng.random() < 0.6)
        for oid in objects:
            o = self.items[oid]
            if obj is None:
                name = self._name(oid, rng)
            elif draft.goals and draft.goals[-1].tool == obj:
                name = f"the {words(o.category)}"  # the tool just used
            else:
                name = "it"  # the thing just acted on
            if name is None:
                continue
            recs = [r for r in self.rec.values() if r.room != o.room and r.id != o.receptacle
                    and (r.id in self.containers) == inside and self.free(r.id, draft) > 0
                    and self.say.receptacle(r.id) is not None]
            if need_substitute:
                recs = [r for r in recs if self.room_containers(r.room, r.id, draft)]
            if not recs:
                continue
            r = recs[int(rng.integers(len(recs)))]
            rname = self.say.receptacle(r.id)
            assert rname is not None
            subs = self.room_containers(r.room, r.id, draft) if inside else ()
            subgoals = ("picked", "reached", "opened", "placed") if inside else (
                "picked", "reached", "placed")
            draft.goals.append(Goal(kind="place", object=oid, receptacle=r.id, container=inside,
                                    substitutes=subs, subgoals=subgoals))
            draft.clauses.append(place_clause(None if self.dev else rng, name, rname, inside))
            thing = self.say.item(oid) or "it"
            draft.steps += [f"go to {thing}", f"pick up {thing}", f"go to {rname}"]
            if inside:
                draft.steps.append(f"open {rname}")
            draft.steps.append(f"put {thing} {'in' if inside else 'on'} {rname}")
            draft.moved.add(oid)
            draft.filled[r.id] = draft.filled.get(r.id, 0) + 1
            return True
        return False

    def use_goal(self, rng: np.random.Generator, draft: _Draft) -> bool:
        """Adds a use goal."""
        options = []
        for aff, (before, _after) in AFFORDANCE_EFFECTS.items():
            targets = [o.id for o in self.truth.objects if o.state == before
                       and o.receptacle not in self.containers and o.id not in draft.moved]
            targets += [f.id for f in self.truth.furniture if f.state == before]
            used = {g.target for g in draft.goals}
            for target in targets:
                if target in used:
                    continue
                for tool in self.truth.tools:
                    if aff in tool.affordances and tool.id not in draft.moved:
                        options.append((aff, target, tool.id))
        for k in rng.permutation(len(options)).tolist():
            aff, target, tool = options[k]
            tname, gname = self._name(tool, rng), self._name(target, rng)
            if tname is None or gname is None:
                continue
            subs = tuple(t.id for t in self.truth.tools if aff in t.affordances and t.id != tool)
            draft.goals.append(Goal(kind="use", target=target, tool=tool, affordance=aff,
                                    substitutes=subs, subgoals=("picked", "reached", "used")))
            draft.clauses.append(use_clause(None if self.dev else rng, aff, gname, tname))
            plain_t, plain_g = self.say.thing(tool) or tname, self.say.thing(target) or gname
            draft.steps += [f"go to {plain_t}", f"pick up {plain_t}", f"go to {plain_g}",
                            use_clause(None, aff, plain_g, plain_t)]
            draft.moved.add(tool)
            return True
        return False

    def follow_up(self, rng: np.random.Generator, draft: _Draft) -> bool:
        """After a use goal: put its target (an item, said as "it") or its tool (said by its
        category: "the sponge") somewhere."""
        last = draft.goals[-1]
        if last.kind != "use":
            return False
        choices = [last.tool]
        if last.target in self.items:
            choices.append(last.target)
        chosen = choices[int(rng.integers(len(choices)))]
        assert chosen is not None
        draft.moved.discard(chosen)
        if self.place_goal(rng, draft, inside=None, obj=chosen):
            return True
        draft.moved.add(chosen)
        return False

    # ------------------------------------------------------------------ tasks
    def make(self, rng: np.random.Generator, n_goals: int, exception: str | None
             ) -> tuple[Task, int] | None:
        """A task of ``n_goals`` clauses and the goal the exception targets, or None."""
        for _ in range(_TRIES):
            draft = _Draft()
            target = int(rng.integers(n_goals)) if exception != "door_lock" else 0
            ok = True
            for k in range(n_goals):
                if k == target and exception == "container_unavailable":
                    ok = self.place_goal(rng, draft, inside=True, need_substitute=True)
                elif k == target and exception == "tool_substitution":
                    ok = self.use_goal(rng, draft)
                elif k == target and exception == "object_relocation":
                    ok = self.place_goal(rng, draft, inside=None)
                elif k > 0 and not self.dev and rng.random() < 0.35 and self.follow_up(rng, draft):
                    ok = True
                elif rng.random() < 0.5:
                    ok = self.place_goal(rng, draft, inside=None) or self.use_goal(rng, draft)
                else:
                    ok = self.use_goal(rng, draft) or self.place_goal(rng, draft, inside=None)
                if not ok:
                    break
            if ok:  # a substitute container must not be another clause's destination
                taken = {g.destination for g in draft.goals}
                draft.goals = [g.model_copy(update={"substitutes": tuple(
                    s for s in g.substitutes if s not in taken)}) if g.container else g
                    for g in draft.goals]
                if exception == "container_unavailable":
                    ok = bool(draft.goals[target].substitutes)
            if ok and exception == "object_relocation":
                g = draft.goals[target]
                ok = self.items[g.fetched].room != self.truth.backup_room
            if ok:
                text = join(None if self.dev else rng, draft.clauses)
                return Task(text=text, steps=tuple(draft.steps), goals=tuple(draft.goals),
                            substitute_rule=SUBSTITUTE_RULE if self.dev else ""), target
        return None


def make_task(layout: HouseLayout, truth: HouseTruth, rng: np.random.Generator, *, dev: bool,
              n_goals: int, exceptions: Sequence[str]) -> tuple[Task, PlannedException | None]:
    """A task fitting the first of ``exceptions`` that fits one (none: a task with no
    exception).

    Raises ``LookupError`` when the house has no task at all.
    """
    maker = TaskMaker(layout, truth, dev=dev)
    for exception in exceptions:
        made = maker.make(rng, n_goals, exception)
        if made is not None:
            task, goal = made
            return task, PlannedException(type=exception, goal=goal)  # type: ignore[arg-type]
    for n in range(n_goals, 0, -1):
        made = maker.make(rng, n, None)
        if made is not None:
            return made[0], None
    raise LookupError(f"house {layout.seed} has no feasible task")


__all__ = ["TaskMaker", "make_task", "words"]
