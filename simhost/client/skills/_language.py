"""Reading a Track 1 instruction into goals, and a description into a reference.

The grammar is public (``plugins/track1/_language.py``): clauses joined by ", then ",
" and then ", ". After that, " or ", and "; a clause puts an item somewhere ("put|place|move
the red mug in|into|on|onto the cabinet in the kitchen", "bring the red mug to the table in
the living room") or uses a tool ("clean|wipe|slice|cut|water the X with the Y", "use the Y
to clean the X"). An item is named by colour and category, with its room or what it rests
on or in when a look-alike exists ("the red mug in the kitchen", "the red mug on the shelf",
"the red mug in the drawer in the bedroom"); "it" is the thing acted on in the clause
before, "the sponge" the tool just used.

``parse(text)`` returns a list of goals, each a dict:

- ``{"kind": "place", "item": Ref, "dest": Ref, "container": bool}``
- ``{"kind": "use", "affordance": "wipe"|"cut"|"water", "tool": Ref, "target": Ref}``

where a ``Ref`` is ``{"category", "colour" (or None), "room" (a room type or None),
"on" (the category of what it rests on or in, or None)}``. Unreadable clauses are skipped.
``thing(phrase)`` reads one description ("the red mug on the shelf", as the instruction's
``steps`` say them) into a ``Ref``; ``WorldModel.matches(ref)`` finds the things that fit it.
"""

from __future__ import annotations

import re
from typing import Any

ROOMS = {"kitchen": "kitchen", "living room": "living_room", "bedroom": "bedroom",
         "bathroom": "bathroom", "hallway": "hallway", "storage room": "storage"}
COLOURS = ("red", "green", "blue", "yellow", "white", "black", "orange", "purple")
FURNITURE = ("table", "counter", "shelf", "bed", "desk", "sofa")
CONTAINERS = ("cabinet", "drawer", "fridge", "bin")
ITEMS = ("mug", "apple", "book", "plate", "towel", "bottle", "bowl", "bread", "plant",
         "sponge", "cloth", "knife", "scissors", "watering can", "jug")
VERBS = {"clean": "wipe", "wipe": "wipe", "slice": "cut", "cut": "cut", "water": "water"}
_JOIN = re.compile(r", then |, and then | and then |\. After that, |, and ")
_ROOM = "|".join(sorted(ROOMS, key=len, reverse=True))
_REC = "|".join(FURNITURE + CONTAINERS)
_ITEM = "|".join(sorted(ITEMS, key=len, reverse=True))
_COLOUR = "|".join(COLOURS)
_THING = re.compile(
    rf"^the (?:(?P<colour>{_COLOUR}) )?(?P<cat>{_ITEM}|{_REC})"
    rf"(?: (?:in|on) the (?P<on>{_REC}))?(?: in the (?P<room>{_ROOM}))?$")
_PLACE = re.compile(rf"^(?:put|place|move|bring) (?P<item>.+?) (?:in|into|on|onto|to) "
                    rf"(?P<dest>the (?:{_REC}) in the (?:{_ROOM}))$")
_USE = re.compile(rf"^(?P<verb>clean|wipe|slice|cut|water) (?P<target>.+) with "
                  rf"(?P<tool>the (?:(?:{_COLOUR}) )?(?:{_ITEM})(?: .+)?)$")
_USE_TO = re.compile(r"^use (?P<tool>the .+?) to (?P<verb>clean|wipe|slice|cut|water) "
                     r"(?P<target>the .+)$")
Ref = dict[str, Any]


def name(words: str) -> str:
    """A category as the vocabulary spells it (``watering can`` → ``watering_can``)."""
    return words.replace(" ", "_")


def thing(phrase: str) -> Ref | None:
    """A referring expression as a Ref, or None."""
    m = _THING.match(phrase.strip())
    if m is None:
        return None
    return {"category": name(m["cat"]), "colour": m["colour"],
            "room": ROOMS[m["room"]] if m["room"] else None, "on": m["on"]}


def _clause(text: str, previous: dict[str, Any] | None) -> dict[str, Any] | None:
    text = text.strip().rstrip(".")
    m = _PLACE.match(text)
    if m:
        dest = thing(m["dest"])
        if m["item"] == "it" and previous is not None and previous["kind"] == "use":
            item = previous["target"]
        else:
            item = thing(m["item"])
            if (item is not None and previous is not None and previous["kind"] == "use"
                    and item["colour"] is None and item["category"] ==
                    previous["tool"]["category"]):
                item = previous["tool"]  # "the sponge": the tool just used
        if item is None or dest is None:
            return None
        return {"kind": "place", "item": item, "dest": dest,
                "container": dest["category"] in CONTAINERS}
    m = _USE.match(text) or _USE_TO.match(text)
    if m:
        tool, target = thing(m["tool"]), thing(m["target"])
        if tool is None or target is None:
            return None
        return {"kind": "use", "affordance": VERBS[m["verb"]], "tool": tool, "target": target}
    return None


def parse(text: str) -> list[dict[str, Any]]:
    """The goals of an instruction, in order."""
    goals: list[dict[str, Any]] = []
    for part in _JOIN.split(text):
        goal = _clause(part, goals[-1] if goals else None)
        if goal is not None:
            goals.append(goal)
    return goals
