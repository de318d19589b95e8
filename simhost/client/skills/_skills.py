"""Blocking Track 1 skills: each call steps the episode until the skill is done or failed.

``Skills`` wraps a ``RemoteEnv`` and an ``Explorer`` (the occupancy map, the world model and
the motion the Track 1 baselines use). Every step a skill sends goes through ``Skills.step``,
which feeds the reply's observation to the explorer, so the map and the model are the
agent's own, from what the host sent it and nothing else.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Generator, Mapping
from dataclasses import dataclass
from typing import Any, Literal

from simhost._errors import SimHostError
from simhost.client._remote import RemoteEnv, TimeStep
from simhost.client.skills._explorer import Explorer
from simhost.client.skills._model import Thing, WorldModel
from simhost.client.skills._navigation import Action, DoorOpener, face, near, reach_radius

RETRY_REASONS = frozenset({"out_of_reach", "not_visible", "blocked_by_robot"})
"""Host failure reasons a skill answers by moving (closer, around, to face the thing) and
trying again, up to ``Skills.attempts`` times; any other reason ends the skill at once."""

#: The skills' own failure reasons (every other reason is the host's, as it gave it).
NOT_IN_MODEL = "not_in_model"
"""The id or room is not in the agent's world model (never seen)."""
UNREACHABLE = "unreachable"
"""No path to it on the map, even through closed doors."""
NOT_HOLDING = "not_holding"
"""``place`` of a thing the robot does not hold."""
EXPLORED = "explored"
"""``explore_next``: no frontier, unexplored doorway or closed container is left."""
STAGE_ENDING = "stage_ending"
"""The stage's steps or time ran down to the reserve (``Skills.reserve_steps``,
``reserve_s``): what is left is the agent's, to write its files and end the stage."""
STAGE_OVER = "stage_over"
"""The stage ended (or the episode did) while the skill ran."""
GAVE_UP = "gave_up"
"""The skill's own step limit (``max_steps``) ran out."""

DETECT_WINDOW = 30
"""Steps after an exception's first observable effect within which Track 1 counts its
``exception_detected`` record (``plugins/track1/_score.py``'s ``DETECT_WINDOW``; the scoring
is not importable in a team's container, a test keeps the two equal)."""
FETCH_PATIENCE = DETECT_WINDOW // 2
"""Steps ``fetch`` keeps trying once the thing looks absent (the host said ``not_visible``,
or the robot stood in its room within ``ABSENCE_RANGE`` of where it was seen, facing it,
without seeing it) before it fails ``not_visible``: half the detection window, so that the
caller still has the other half to log the exception (the host may have counted the
effect a few steps before the skill could be sure)."""
ABSENCE_RANGE = 2.5
"""How near to where an item was seen the robot must be, facing it, for not seeing it to
count as a sign that it is gone (Track 1 counts its old place seen within 2.5 m as the
relocation's first observable effect: ``plugins/track1/_exceptions.py``'s
``EFFECT_RADIUS``)."""
UNREACHABLE_OPENS = 2
"""``explore_next``: ``out_of_reach`` replies to the goal's ``open`` after which the goal is
set aside (the door or container is left for a later skill's way past it)."""


@dataclass(frozen=True)
class Outcome:
    """What a skill did.

    Attributes:
        status: "done" (it holds now: arrived, holding it, placed, open) or "failed".
        reason: Why it failed: the host's failure reason as the host gave it (``locked``,
            ``unavailable``, ``out_of_reach``, ``not_visible``, ``hand_full``, …) when
            ``by_host``, else one of the skills' own (``not_in_model``, ``unreachable``,
            ``not_holding``, ``explored``, ``stage_ending``, ``stage_over``, ``gave_up``).
            Empty when done.
        by_host: Whether ``reason`` is the host's reply to an action.
        steps: Step requests this skill sent.
        target: The id it acted on or went to, when there was one.
        locked: The doors an ``open`` sent during this call found locked (the host said
            ``locked``), in the order met, also when the skill went round them and is done.
        unavailable: The containers an ``open`` or ``place`` sent during this call found
            unavailable (the host said ``unavailable``).
    """

    status: Literal["done", "failed"]
    reason: str = ""
    by_host: bool = False
    steps: int = 0
    target: int | None = None
    locked: tuple[int, ...] = ()
    unavailable: tuple[int, ...] = ()

    @property
    def ok(self) -> bool:
        """Whether the skill is done."""
        return self.status == "done"


_Body = Generator[Action, TimeStep, Outcome]
"""A skill's body: yields actions, is sent each reply, returns the outcome."""


class _Stop(SimHostError):
    """Raised when the stage runs down or ends inside a skill (carries the reason; caught
    by the skill, which returns it as its outcome)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


class Skills:
    """Track 1 skills on the agent's own map, one blocking call each.

    Args:
        env: The episode's client, after ``hello``.
        ts: The latest reply (``env.reset()``'s); every later reply must come through these
            skills or ``observe`` so that the map misses nothing.
        explorer: The map, model and motion to use (default: a new ``Explorer``).
        reserve_steps: A skill stops (``stage_ending``) when the stage has this many steps
            left, or fewer.
        reserve_s: ... or this many seconds.
        attempts: How many times an action is tried after ``out_of_reach``,
            ``not_visible`` or ``blocked_by_robot``.
        on_reply: Called with every reply the skills take, after the map and the model
            have it (to log, or to notice what the agent's own rules look for). An
            exception it raises ends the running skill at once and reaches the skill's
            caller (no ``Outcome``; ``ts`` and the map hold the reply).

    Attributes:
        ts: The latest reply. ``explorer``: the map and model (``explorer.model``, a
        ``WorldModel``: ``model.write(OutputFiles())`` writes ``world_model.json``).
        messages: Every host message received so far, in order. steps: step requests sent
        (the step of the latest reply, the one ``Thing.last_seen`` and the log count).
    """

    def __init__(self, env: RemoteEnv, ts: TimeStep, *, explorer: Explorer | None = None,
                 reserve_steps: int = 2, reserve_s: float = 5.0, attempts: int = 4,
                 on_reply: Callable[[TimeStep], None] | None = None) -> None:
        self.env = env
        self.on_reply = on_reply
        self.explorer = explorer if explorer is not None else Explorer()
        self.reserve_steps, self.reserve_s, self.attempts = reserve_steps, reserve_s, attempts
        self.messages: list[Any] = []
        self.steps = 0
        self._last: dict[str, Any] | None = None
        self._met: dict[str, list[int]] = {"locked": [], "unavailable": []}
        self.ts = ts
        self.observe(ts)

    @property
    def model(self) -> WorldModel:
        """The agent's world model."""
        return self.explorer.model

    # ------------------------------------------------------------------ the episode
    def observe(self, ts: TimeStep) -> None:
        """Takes a reply the agent got itself (``env.end_stage``, ``env.answer``)."""
        self.ts = ts
        self.messages += ts.messages
        if "odometry" in ts.observation:
            self.explorer.sense(ts.observation)
        self._learn(ts)
        if self.on_reply is not None:
            self.on_reply(ts)

    def step(self, action: Mapping[str, Any]) -> TimeStep:
        """Sends one action and takes its reply (``env.step``)."""
        self.explorer.step += 1
        self.steps += 1
        self._last = dict(action)
        self.observe(self.env.step(action))
        return self.ts

    def end_stage(self, payload: Mapping[str, Any] | None = None) -> TimeStep:
        """Ends the stage (``env.end_stage``) and takes the reply."""
        self._last = None
        self.observe(self.env.end_stage(payload))
        return self.ts

    def answer(self, answers: Mapping[str, Any]) -> TimeStep:
        """Answers the host's queries (``env.answer``) and takes the reply."""
        self._last = None
        self.observe(self.env.answer(answers))
        return self.ts

    def _learn(self, ts: TimeStep) -> None:
        """What a failed action says about the world: a locked door, an unavailable
        container (they look as before), and the door opener's next try."""
        last, result = self._last, ts.action
        if last is None or result is None or result.ok:
            return
        thing = self.model.things.get(last.get("target", -1))
        if thing is None:
            return
        if result.reason == "locked":
            thing.state = "locked"
        elif result.reason == "unavailable" and thing.kind == "container":
            thing.state = "unavailable"
        met = self._met.get(result.reason)
        if met is not None and thing.id not in met:
            met.append(thing.id)
        if last.get("primitive") == "open":  # to the opener that sent it: the navigator's
            for opener in {self.explorer.nav.door, self.explorer.opener}:  # or the goal's
                if opener is not None and opener.door.id == thing.id:
                    opener.result(result.reason)

    def _check(self, stage: str) -> None:
        ts = self.ts
        if ts.episode_over or ts.stage != stage:
            raise _Stop(STAGE_OVER)
        if (ts.steps_left is not None and ts.steps_left <= self.reserve_steps) or (
                ts.time_left_s < self.reserve_s):
            raise _Stop(STAGE_ENDING)

    def _run(self, body: _Body, target: int | None, max_steps: int | None) -> Outcome:
        """Runs a skill's body (a generator of actions that returns its Outcome)."""
        start, stage = self.steps, self.ts.stage
        self.explorer.nav.reset()  # a new skill: no path or door of the last one
        self._met = {"locked": [], "unavailable": []}
        try:
            self._check(stage)
            action = next(body)
            while True:
                if max_steps is not None and self.steps - start >= max_steps:
                    raise _Stop(GAVE_UP)
                self.step(action)
                self._check(stage)
                action = body.send(self.ts)
        except StopIteration as end:
            out: Outcome = end.value
        except _Stop as stop:
            out = Outcome("failed", stop.reason)
        finally:
            body.close()  # its clean-up runs now, also when it was stopped
        return Outcome(out.status, out.reason, out.by_host, self.steps - start, target,
                       tuple(self._met["locked"]), tuple(self._met["unavailable"]))

    def _thing(self, thing_id: int) -> Thing | None:
        return self.model.things.get(thing_id)

    # ------------------------------------------------------------------ the skills
    def go_to(self, thing: int | None = None, *, room: int | str | None = None,
              max_steps: int | None = None) -> Outcome:
        """Goes within reach of a thing (by id), facing it, or into a room (by id, or by
        type such as "kitchen": the nearest of that type) the robot has been in, opening
        closed doors on the way and going round those found locked.

        Returns done on arrival; failed with ``not_in_model`` (never seen), ``unreachable``
        or a stage reason. Either way the outcome's ``locked`` names the doors found
        locked on the way.
        """
        if (thing is None) == (room is None):
            raise ValueError("go_to takes a thing id or room=, not both or neither")
        if thing is not None:
            t = self._thing(thing)
            if t is None:
                return Outcome("failed", NOT_IN_MODEL, target=thing)
            return self._run(self._go_thing(t), thing, max_steps)
        rooms = self.model.room_by_type(room) if isinstance(room, str) else [room]
        rooms = [r for r in rooms if r in self.explorer.poses]
        if not rooms:
            return Outcome("failed", NOT_IN_MODEL)
        here = self.explorer.pose[:2]
        best = min(rooms, key=lambda r: min(math.dist(p, here) for p in self.explorer.poses[r]))
        return self._run(self._go_room(best), best, max_steps)

    def _go_thing(self, t: Thing) -> _Body:
        ex = self.explorer
        # Within reach from its own room first; then from anywhere; then farther off.
        for k, (extra, own_room) in enumerate(((0.0, True), (0.0, False), (0.3, False),
                                               (0.6, False), (1.0, False))):
            goal = near(t.position, reach_radius(t) + extra)
            if own_room:
                goal = ex.in_room(goal, self.model.room_of(t))
            act = ex.nav.go(("go_to", t.id, k), goal, ex.pose, ex.collided)
            while isinstance(act, dict):
                yield act
                act = ex.nav.go(("go_to", t.id, k), goal, ex.pose, ex.collided)
            if act == "arrived":
                for _ in range(4):
                    turn = face(ex.pose, t.position)
                    if turn is None:
                        break
                    yield turn
                return Outcome("done")
        return Outcome("failed", UNREACHABLE)

    def _go_room(self, room: int) -> _Body:
        ex = self.explorer
        trail = ex.poses[room]
        cx = sum(p[0] for p in trail) / len(trail)
        cy = sum(p[1] for p in trail) / len(trail)
        spot = min(trail, key=lambda p: math.dist(p, (cx, cy)))  # a point the robot stood on
        while True:
            if ex.room == room and math.dist(ex.pose[:2], spot) < 1.0:
                return Outcome("done")
            act = ex.nav.go(("go_room", room), near(spot, 0.4), ex.pose, ex.collided)
            if isinstance(act, dict):
                yield act
                continue
            if act == "unreachable":
                return Outcome("failed", UNREACHABLE)
            if ex.room == room:
                return Outcome("done")
            return Outcome("failed", UNREACHABLE)

    def explore_next(self, max_steps: int | None = None) -> Outcome:
        """Goes to the nearest exploration goal (a frontier of the map, a closed door with
        unexplored space behind it, a closed container, opening doors and containers on the
        way) and looks. Returns done when that goal is explored or given up on, failed with
        ``explored`` when nothing is left, or with the host's reason when an ``open`` of the
        goal failed (``locked``, ``unavailable``)."""
        ex = self.explorer
        ex.goal = ex.next_goal()
        if ex.goal is None:
            return Outcome("failed", EXPLORED)
        target = ex.goal[1] if isinstance(ex.goal[1], int) else None
        return self._run(self._explore(), target, max_steps)

    def _explore(self) -> _Body:
        ex = self.explorer
        goal = ex.goal
        out_of_reach = 0
        try:
            while (act := ex.pursue()) is not None:
                ts = yield act
                if act["primitive"] != "open" or ts.action is None or ts.action.ok:
                    continue
                if ts.action.reason in ("locked", "unavailable"):
                    return Outcome("failed", ts.action.reason, True)
                if ts.action.reason == "out_of_reach" and goal is not None and isinstance(
                        goal[1], int) and act.get("target") == goal[1]:
                    out_of_reach += 1
                    if out_of_reach >= UNREACHABLE_OPENS:  # set it aside: done with it
                        ex.failed.add(goal[1])
                        return Outcome("done")
            return Outcome("done")
        finally:
            ex.goal = None

    def open(self, thing: int, max_steps: int | None = None) -> Outcome:
        """Opens a door or a container: goes within reach (clear of a door's swing), faces
        it and opens it. Done when it is open (also when the host says ``already_open``);
        failed with the host's reason (``locked``, ``unavailable``, …) otherwise."""
        t = self._thing(thing)
        if t is None:
            return Outcome("failed", NOT_IN_MODEL, target=thing)
        body = self._open_door(t) if t.kind == "door" else self._act(t, "open")
        return self._run(body, thing, max_steps)

    def _open_door(self, door: Thing) -> _Body:
        ex = self.explorer
        opener = DoorOpener(ex.grid, self.model, door)
        ex.nav.door = opener  # so that _learn passes the host's reasons to it
        reason = ""
        try:
            while True:
                step = opener.step(ex.pose)
                if step == "opened":
                    return Outcome("done")
                if step == "failed":
                    if door.state == "locked":
                        return Outcome("failed", "locked", True)
                    return Outcome("failed", reason or UNREACHABLE, bool(reason))
                assert isinstance(step, dict)
                ts = yield step
                if step["primitive"] == "open" and ts.action is not None:
                    if ts.action.ok or ts.action.reason == "already_open":
                        door.state = "open"
                        ex.grid.clear(*door.position, 0.45)
                        return Outcome("done")
                    reason = ts.action.reason
                    if reason not in RETRY_REASONS and reason != "locked":
                        return Outcome("failed", reason, True)
        finally:
            ex.nav.door = None

    def _act(self, t: Thing, primitive: str, *, patience: int | None = None,
             **extra: Any) -> _Body:
        """Reaches a thing and sends ``primitive`` on it until the host says ok.
        ``patience``: fail ``not_visible`` this many steps after the thing first looked
        absent (``_absent``), unless it was seen again meanwhile."""
        ex = self.explorer
        tries = 0
        since: int | None = None  # the step it first looked absent
        host_said = False
        while True:
            if ex.radius.get(t.id, 0.0) > reach_radius(t) + 1.5:  # widened, still no way
                return Outcome("failed", UNREACHABLE)
            if patience is not None:
                if t.id in ex.seen_now:
                    since, host_said = None, False
                elif since is None and self._absent(t):
                    since = self.steps
                if since is not None and self.steps - since >= patience:
                    return Outcome("failed", "not_visible", host_said)
            act = ex.act_on(t, primitive, **extra)
            if act is None:
                return Outcome("failed", UNREACHABLE)
            ts = yield act
            if act.get("primitive") != primitive:
                continue
            result = ts.action
            if patience is not None and result is not None and result.reason == "not_visible":
                host_said = True
                since = self.steps if since is None else since
            if result is None or result.ok or (
                    primitive == "open" and result.reason == "already_open"):
                if primitive == "open":
                    t.state = "open"
                return Outcome("done")
            tries += 1
            if result.reason not in RETRY_REASONS or tries >= self.attempts:
                return Outcome("failed", result.reason, True)
            if result.reason == "blocked_by_robot":
                yield {"primitive": "move", "move": [-0.5, 0.0]}

    def _absent(self, t: Thing) -> bool:
        """Whether not seeing a thing now is a sign that it is gone: the robot is in the
        room it was seen in, within ``ABSENCE_RANGE`` of where it was seen, facing it (the
        detector sees 60 degrees either side of ahead), with no wall on the map between."""
        ex = self.explorer
        x, y, yaw = ex.pose
        if ex.room != self.model.room_of(t) or math.dist((x, y), t.position) > ABSENCE_RANGE:
            return False
        bearing = math.atan2(t.position[1] - y, t.position[0] - x)
        if abs(math.remainder(bearing - yaw, math.tau)) > 0.9:
            return False
        d = math.dist((x, y), t.position)
        occupied = ex.grid.occupied()
        for k in range(1, int((d - 0.6) / 0.1) + 1):  # up to 0.6 m short of it: its stand
            i, j = ex.grid.cell(x + (t.position[0] - x) * k * 0.1 / d,
                                y + (t.position[1] - y) * k * 0.1 / d)
            if occupied[i, j]:
                return False
        return True

    def fetch(self, thing: int, max_steps: int | None = None) -> Outcome:
        """Picks a thing up: opens the closed container it was seen in, goes within reach on
        the side it was seen from, faces it and picks it. Done when the robot holds it;
        failed with the host's reason (``hand_full``, …) otherwise, and with
        ``not_visible`` at most ``FETCH_PATIENCE`` steps after the thing first looked
        absent (the host said ``not_visible``, or the robot faced where it was seen, near,
        without seeing it): it is not where it was seen. ``by_host`` says whether the host
        said so; either way the caller has half of Track 1's detection window left."""
        t = self._thing(thing)
        if t is None:
            return Outcome("failed", NOT_IN_MODEL, target=thing)
        if self.explorer.held == thing:
            return Outcome("done", target=thing)
        return self._run(self._fetch(t), thing, max_steps)

    def _fetch(self, t: Thing) -> _Body:
        box = self.explorer.box_of(t)
        if box is not None and box.state == "closed":
            opened = yield from self._act(box, "open")
            if not opened.ok:
                return opened
        return (yield from self._act(t, "pick", patience=FETCH_PATIENCE))

    def place(self, thing: int, receptacle: int, max_steps: int | None = None) -> Outcome:
        """Puts the thing the robot holds on or in a receptacle (opening a closed container
        first). Done when the host says ok; failed with ``not_holding``, or the host's
        reason (``receptacle_full``, ``unavailable``, ``locked``, …)."""
        r = self._thing(receptacle)
        if r is None:
            return Outcome("failed", NOT_IN_MODEL, target=receptacle)
        if self.explorer.held != thing:
            return Outcome("failed", NOT_HOLDING, target=receptacle)
        return self._run(self._place(r), receptacle, max_steps)

    def _place(self, r: Thing) -> _Body:
        if r.kind == "container" and r.state == "closed":
            opened = yield from self._act(r, "open")
            if not opened.ok:
                return opened
        return (yield from self._act(r, "place"))

    def drop(self, max_steps: int | None = None) -> Outcome:
        """Puts down what the robot holds, on the nearest furniture or open container of
        the model (the next nearest when the host says ``receptacle_full``,
        ``unavailable`` or ``not_a_receptacle``; three at most). Done when the hand is
        empty; failed with ``not_holding`` (nothing held), ``not_in_model`` (nothing to put
        it on) or the last host reason. ``target`` is the receptacle it put it on."""
        if self.explorer.held < 0:
            return Outcome("failed", NOT_HOLDING)
        here = self.explorer.pose[:2]
        spots = sorted((t for t in self.model.of_kind("furniture", "container")
                        if t.state not in ("closed", "locked", "unavailable")),
                       key=lambda t: math.dist(t.position, here))[:3]
        if not spots:
            return Outcome("failed", NOT_IN_MODEL)
        where: list[int] = []
        out = self._run(self._drop(spots, where), None, max_steps)
        return Outcome(out.status, out.reason, out.by_host, out.steps,
                       where[-1] if where else None, out.locked, out.unavailable)

    def _drop(self, spots: list[Thing], where: list[int]) -> _Body:
        out = Outcome("failed", NOT_IN_MODEL)
        for spot in spots:
            where.append(spot.id)
            out = yield from self._act(spot, "place")
            if out.ok or out.reason not in ("receptacle_full", "unavailable",
                                            "not_a_receptacle"):
                return out
        return out

    def use(self, tool: int, target: int, max_steps: int | None = None) -> Outcome:
        """Uses the tool the robot holds on a target (wipe, cut, water: the host picks the
        tool's use). Done when the host says ok; failed with ``not_holding`` or the host's
        reason."""
        t = self._thing(target)
        if t is None:
            return Outcome("failed", NOT_IN_MODEL, target=target)
        if self.explorer.held != tool:
            return Outcome("failed", NOT_HOLDING, target=target)
        return self._run(self._act(t, "use", tool=tool), target, max_steps)
