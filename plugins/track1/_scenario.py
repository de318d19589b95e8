"""Hidden Track 1 scenarios: a house, an ALFRED-like task, a planned exception and queries.

Everything comes from the episode seed: the house is ``generate_house(seed, params)`` (the
generator is public; the seed is what is hidden), and ``numpy.random.default_rng([seed, 1])``
draws, in order, whether there is an exception and which type (Table III), a task that the
exception can matter to, and the queries asked at the end of exploration.

Split parameters (``KNOWN_PARAMS``): ``rooms`` (inclusive range), ``exception_probability``,
``exceptions`` (the allowed types), ``house_params`` (an organizer parameter pack, the fields
of ``simhost.track1.HouseParams``), ``render_rgbd`` and ``image_size`` (camera images in the
observation).

Task kinds (instruction templates, names written with spaces):

- ``place``: "put the red mug in the cabinet in the kitchen" (a container) or "… on the table
  in the living room" (a surface). Key subgoals: picked, reached the receptacle holding it,
  opened it (containers), placed.
- ``use``: "clean the table in the kitchen with the yellow sponge", "slice the red apple with
  the black knife", "water the green plant with the blue jug". Key subgoals: tool picked,
  reached the target holding it, used.

A functional substitute is accepted when the named container or tool cannot be used: any
other container of the same room, any other tool with the same use (the instruction says so).
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from typing import Any

import numpy as np

from plugins._registry import PluginError

EXCEPTION_TYPES = ("door_lock", "object_relocation", "container_unavailable", "tool_substitution")
KNOWN_PARAMS = ("rooms", "exception_probability", "exceptions", "house_params", "render_rgbd",
                "image_size")
VERBS = {"wipe": "clean", "cut": "slice", "water": "water"}
SUBSTITUTE_RULE = (
    "If a named container or tool turns out to be unusable, a functional substitute is "
    "accepted: another container in the same room, or another tool with the same use."
)
QUERY_PLAN = (("object_room", 3), ("door_state", 2), ("room_neighbours", 2),
              ("container_state", 1), ("tools_for", 2))


def words(name: str) -> str:
    """A vocabulary name as it reads in an instruction (``living_room`` → ``living room``)."""
    return "storage room" if name == "storage" else name.replace("_", " ")


def house_pack(params: Mapping[str, Any]) -> dict[str, Any]:
    """The house generator's parameters a split sets (JSON): its pack plus ``rooms``."""
    pack = dict(params.get("house_params") or {})
    if "rooms" in params:
        pack["rooms"] = list(params["rooms"])
    return pack


def house_params(pack: Mapping[str, Any]) -> Any:
    """The ``HouseParams`` of a house pack (see ``house_pack``)."""
    from simhost.track1 import HouseParams

    try:
        return HouseParams.model_validate(pack)
    except Exception as e:  # noqa: BLE001 - pydantic's error names the field
        raise PluginError(f"track1: bad house parameters {pack!r}: {e}") from e


def check_params(params: Mapping[str, Any]) -> None:
    """Raises PluginError naming an unknown or bad split parameter."""
    for key in params:
        if key not in KNOWN_PARAMS:
            near = difflib.get_close_matches(key, KNOWN_PARAMS, n=1)
            hint = f" Did you mean {near[0]!r}?" if near else ""
            raise PluginError(f"track1: unknown scenario parameter {key!r}.{hint} "
                              f"Known: {list(KNOWN_PARAMS)}")
    bad = [t for t in params.get("exceptions", ()) if t not in EXCEPTION_TYPES]
    if bad:
        raise PluginError(f"track1: unknown exception types {bad}; known: {EXCEPTION_TYPES}")
    p = float(params.get("exception_probability", 0.5))
    if not 0.0 <= p <= 1.0:
        raise PluginError(f"track1: exception_probability must be in [0, 1], got {p}")


class _House:
    """Lookups over a layout's initial ground truth (no MuJoCo)."""

    def __init__(self, layout: Any, truth: Mapping[str, Any]) -> None:
        self.layout = layout
        self.truth = truth
        self.room_type = {r["id"]: r["type"] for r in truth["rooms"]}
        self.receptacles = {f["id"]: f for f in truth["furniture"] + truth["containers"]}
        self.items = {o["id"]: o for o in truth["objects"]}

    def unique_receptacle(self, rec: Mapping[str, Any]) -> bool:
        """Whether "the <category> in the <room type>" names only this piece."""
        key = (rec["category"], self.room_type[rec["room"]])
        return sum((r["category"], self.room_type[r["room"]]) == key
                   for r in self.receptacles.values()) == 1

    def free(self, rec_id: int) -> bool:
        rec = self.layout.entity(rec_id)
        used = sum(1 for i in self.items.values() if i["receptacle"] == rec_id)
        return used < rec.slots

    def containers_in(self, room: int) -> list[int]:
        return [c["id"] for c in self.truth["containers"] if c["room"] == room]

    def phrase(self, entity_id: int) -> str:
        """How the instruction names an entity."""
        if entity_id in self.items:
            i = self.items[entity_id]
            return f"{i['colour']} {words(i['category'])}"
        r = self.receptacles[entity_id]
        return f"{words(r['category'])} in the {words(self.room_type[r['room']])}"


def _pick(rng: np.random.Generator, options: list[Any]) -> Any:
    return options[int(rng.integers(len(options)))] if options else None


def _place_task(h: _House, rng: np.random.Generator, exception: str | None) -> dict | None:
    objects = [o for o in h.items.values() if o["kind"] == "object"
               and o["room"] != h.truth["backup_room"]
               and h.receptacles[o["receptacle"]]["state"] != "unavailable"]
    containers = {c["id"] for c in h.truth["containers"]}
    first = exception == "container_unavailable" or rng.random() < 0.6
    kinds = [True] if exception == "container_unavailable" else [first, not first]
    for inside, obj in ((k, objects[i]) for k in kinds for i in rng.permutation(len(objects))):
        recs = [r for r in h.receptacles.values()
                if r["room"] != obj["room"] and h.unique_receptacle(r) and h.free(r["id"])
                and (r["id"] in containers) == inside]
        if exception == "container_unavailable":
            recs = [r for r in recs if any(
                c != r["id"] and h.free(c) for c in h.containers_in(r["room"]))]
        rec = _pick(rng, recs)
        if rec is None:
            continue
        subs = [c for c in h.containers_in(rec["room"]) if c != rec["id"]] if inside else []
        o, r = h.phrase(obj["id"]), words(rec["category"])
        room = words(h.room_type[rec["room"]])
        prep = "in" if inside else "on"
        text = _pick(rng, [f"put the {o} {prep} the {r} in the {room}",
                           f"place the {o} {prep} the {r} in the {room}"])
        steps = [f"go to the {o}", f"pick up the {o}", f"go to the {r} in the {room}"]
        subgoals = ["picked", "reached", "placed"]
        if inside:
            steps.append(f"open the {r}")
            subgoals.insert(2, "opened")
        steps.append(f"put the {o} {prep} the {r}")
        return {"kind": "place", "object": obj["id"], "receptacle": rec["id"],
                "substitutes": subs, "container": inside, "text": text, "steps": steps,
                "subgoals": subgoals, "rooms": [obj["room"], rec["room"]]}
    return None


def _use_task(h: _House, rng: np.random.Generator, exception: str | None) -> dict | None:
    from simhost.track1 import AFFORDANCE_EFFECTS

    tools = [t for t in h.items.values() if t["kind"] == "tool"]
    options = []
    for aff, (before, _after) in AFFORDANCE_EFFECTS.items():
        targets = [i["id"] for i in h.items.values() if i["state"] == before
                   and h.receptacles[i["receptacle"]]["id"] not in
                   {c["id"] for c in h.truth["containers"]}]
        targets += [r["id"] for r in h.truth["furniture"]
                    if r["state"] == before and h.unique_receptacle(r)]
        for target in targets:
            room = (h.items[target] if target in h.items else h.receptacles[target])["room"]
            for tool in (t for t in tools if aff in t["affordances"]):
                if exception == "door_lock" and tool["room"] == room:
                    continue
                options.append((aff, target, tool))
    if not options:
        return None
    aff, target, tool = options[int(rng.integers(len(options)))]
    room = (h.items[target] if target in h.items else h.receptacles[target])["room"]
    subs = [t["id"] for t in tools if aff in t["affordances"] and t["id"] != tool["id"]]
    t, g = h.phrase(tool["id"]), h.phrase(target)
    text = f"{VERBS[aff]} the {g} with the {t}"
    steps = [f"go to the {t}", f"pick up the {t}", f"go to the {g}",
             f"{VERBS[aff]} the {g} with the {t}"]
    return {"kind": "use", "affordance": aff, "target": target, "tool": tool["id"],
            "substitutes": subs, "text": text, "steps": steps,
            "subgoals": ["picked", "reached", "used"], "rooms": [tool["room"], room]}


def _queries(h: _House, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The queries asked at the end of exploration (subjects only; truth comes later)."""
    from simhost.track1 import AFFORDANCES

    pools: dict[str, list[Any]] = {
        "object_room": sorted(h.items),
        "door_state": [d["id"] for d in h.truth["doors"]],
        "room_neighbours": [r["id"] for r in h.truth["rooms"]],
        "container_state": [c["id"] for c in h.truth["containers"]],
        "tools_for": list(AFFORDANCES),
    }
    out: list[dict[str, Any]] = []
    for kind, n in QUERY_PLAN:
        pool = pools[kind]
        for k in sorted(rng.permutation(len(pool))[:n].tolist()):
            out.append({"id": f"q{len(out)}", "kind": kind, "subject": pool[k]})
    return out


def make_task(h: _House, rng: np.random.Generator, exception: str | None) -> dict | None:
    """A task the exception can matter to (None when the house has none)."""
    if exception == "tool_substitution":
        return _use_task(h, rng, exception)
    if exception == "object_relocation" and not any(
            h.free(f["id"]) for f in h.truth["furniture"] if f["room"] == h.truth["backup_room"]):
        return None  # the backup area has no free surface to move the object to
    if exception in ("container_unavailable", "object_relocation"):
        return _place_task(h, rng, exception)
    first, second = (_place_task, _use_task) if rng.random() < 0.5 else (_use_task, _place_task)
    return first(h, rng, exception) or second(h, rng, exception)


def scenario_params(seed: int, params: Mapping[str, Any]) -> dict[str, Any]:
    """The hidden scenario's parameters (JSON; organizer-only)."""
    from simhost.track1 import generate_house, initial_ground_truth

    check_params(params)
    pack = house_pack(params)
    hp = house_params(pack)
    layout = generate_house(seed, params=hp)
    h = _House(layout, initial_ground_truth(layout))
    rng = np.random.default_rng([seed, 1])
    allowed = [t for t in EXCEPTION_TYPES if t in params.get("exceptions", EXCEPTION_TYPES)]
    exception = None
    if allowed and rng.random() < float(params.get("exception_probability", 0.5)):
        exception = allowed[int(rng.integers(len(allowed)))]
    order = [exception] + [t for t in allowed if t != exception] if exception else [None]
    task = None
    for candidate in order:
        task = make_task(h, rng, candidate)
        if task is not None:
            exception = candidate
            break
    if task is None:
        exception, task = None, make_task(h, rng, None)
    if task is None:
        raise PluginError(f"track1: house {seed} has no feasible task; use another seed")
    return {
        "house": pack,
        "layout_digest": layout.digest(),
        "rooms": len(layout.rooms),
        "task": task,
        "exception": exception,
        "queries": _queries(h, rng),
        "render_rgbd": bool(params.get("render_rgbd", False)),
        "image_size": list(params.get("image_size", (128, 96))),
    }
