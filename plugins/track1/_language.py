"""The instruction grammar: how a goal is said (ALFRED-like, with paraphrases).

Referring expressions name one thing of the house. An item is named by colour and category
and, when a look-alike of the same category and colour exists, by its room or what it
rests on or in: "the red mug", "the red mug in the kitchen", "the red mug on the shelf",
"the red mug in the cabinet in the bedroom". A receptacle or a surface is named by category
and room: "the cabinet in the kitchen". Rooms read as words ("living room", "storage
room").

Clauses (``verb`` paraphrases chosen by the scenario's generator):

- place: "put|place|move the <item> in|into|on|onto the <receptacle>", "bring the <item>
  to the <receptacle>"; a follow-up on the item of the clause before uses "it".
- use: "clean|wipe the <surface> with the <tool>", "slice|cut the <item> with the
  <tool>", "water the <plant> with the <tool>", or "use the <tool> to <verb> the <thing>".

Clauses are joined by ", then ", " and then ", ". After that, " or ", and ".
"""

from __future__ import annotations

from collections import Counter

import numpy as np

from simhost.worlds.track1 import HouseTruth

VERBS = {"wipe": ("clean", "wipe"), "cut": ("slice", "cut"), "water": ("water",)}
"""Verbs of each affordance; the first is the dev split's."""
PLACE_VERBS = ("put", "place", "move")
JOINS = (", then ", " and then ", ". After that, ", ", and ")
SUBSTITUTE_RULE = (
    "If a named container or tool turns out to be unusable, a functional substitute is "
    "accepted: another container in the same room, or another tool with the same use."
)


def words(name: str) -> str:
    """A vocabulary name as it reads in an instruction (``living_room`` → ``living room``)."""
    return "storage room" if name == "storage" else name.replace("_", " ")


class Describer:
    """Referring expressions over a house's ground truth."""

    def __init__(self, truth: HouseTruth) -> None:
        self.truth = truth
        self.rec = {f.id: f for f in (*truth.furniture, *truth.containers)}
        self.items = {o.id: o for o in truth.objects}
        rtype = {r.id: r.type for r in truth.rooms}
        self.rtype = rtype
        self._keys: list[Counter[tuple[str, ...]]] = [Counter() for _ in range(4)]
        for o in truth.objects:
            for level, key in enumerate(self._item_keys(o.id)):
                self._keys[level][key] += 1
        self._rec_keys = Counter((f.category, rtype[f.room]) for f in self.rec.values())

    def _item_keys(self, item_id: int) -> list[tuple[str, ...]]:
        o = self.items[item_id]
        rec = self.rec[o.receptacle]
        room = self.rtype[o.room]
        return [(o.category, o.colour), (o.category, o.colour, room),
                (o.category, o.colour, rec.category),
                (o.category, o.colour, rec.category, room)]

    def room(self, room_id: int) -> str:
        return words(self.rtype[room_id])

    def receptacle(self, rec_id: int) -> str | None:
        """ "the cabinet in the kitchen", or None when that names more than one."""
        f = self.rec[rec_id]
        if self._rec_keys[(f.category, self.rtype[f.room])] != 1:
            return None
        return f"the {words(f.category)} in the {self.room(f.room)}"

    def item(self, item_id: int, rng: np.random.Generator | None = None) -> str | None:
        """The shortest unambiguous name of an item (with ``rng``: any unambiguous one,
        shorter ones first), or None."""
        o = self.items[item_id]
        rec = self.rec[o.receptacle]
        prep = "in" if rec.kind == "container" else "on"
        base = f"the {o.colour} {words(o.category)}"
        forms = [base, f"{base} in the {self.room(o.room)}",
                 f"{base} {prep} the {words(rec.category)}",
                 f"{base} {prep} the {words(rec.category)} in the {self.room(o.room)}"]
        keys = self._item_keys(item_id)
        unique = [f for f, k, c in zip(forms, keys, self._keys, strict=True) if c[k] == 1]
        if not unique:
            return None
        if rng is None or len(unique) == 1:
            return unique[0]
        return unique[0] if rng.random() < 0.6 else unique[int(rng.integers(1, len(unique)))]

    def thing(self, entity_id: int, rng: np.random.Generator | None = None) -> str | None:
        """An item or a receptacle."""
        if entity_id in self.items:
            return self.item(entity_id, rng)
        return self.receptacle(entity_id)


def pick(rng: np.random.Generator, options: tuple[str, ...] | list[str]) -> str:
    return options[int(rng.integers(len(options)))]


def place_clause(rng: np.random.Generator | None, obj: str, rec: str, container: bool) -> str:
    """ "put the red mug in the cabinet in the kitchen" and its paraphrases."""
    if rng is None:
        return f"put {obj} {'in' if container else 'on'} {rec}"
    if rng.random() < 0.15:
        return f"bring {obj} to {rec}"
    prep = pick(rng, ("in", "into") if container else ("on", "onto"))
    return f"{pick(rng, PLACE_VERBS)} {obj} {prep} {rec}"


def use_clause(rng: np.random.Generator | None, affordance: str, target: str, tool: str) -> str:
    """ "clean the table in the kitchen with the yellow sponge" and its paraphrases."""
    if rng is None:
        return f"{VERBS[affordance][0]} {target} with {tool}"
    verb = pick(rng, VERBS[affordance])
    if rng.random() < 0.25:
        return f"use {tool} to {verb} {target}"
    return f"{verb} {target} with {tool}"


def join(rng: np.random.Generator | None, clauses: list[str]) -> str:
    """Clauses as one instruction."""
    text = clauses[0]
    for clause in clauses[1:]:
        text += (", then " if rng is None else pick(rng, JOINS)) + clause
    return text
