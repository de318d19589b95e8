"""Look-alike tables of Track 1's simulated detector (pure data, no simulator import).

From afar a detector may report a look-alike category or colour instead of the true one
(``simhost/worlds/track1/_perception.py``). An agent can read these tables in the agent
base image: ``from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS``. Both map a true
name to the names it may be read as; a name with no entry is never confused.
"""

from __future__ import annotations

CONFUSABLE: dict[str, tuple[str, ...]] = {
    "table": ("desk",),
    "desk": ("table",),
    "counter": ("table",),
    "bed": ("sofa",),
    "sofa": ("bed",),
    "shelf": ("table",),
    "cabinet": ("drawer",),
    "drawer": ("cabinet",),
    "fridge": ("cabinet",),
    "bin": ("drawer",),
    "mug": ("bowl", "bottle"),
    "bowl": ("mug", "plate"),
    "plate": ("bowl",),
    "book": ("towel",),
    "towel": ("book",),
    "bottle": ("mug",),
    "apple": ("bread",),
    "bread": ("apple",),
    "plant": ("bottle",),
    "sponge": ("cloth",),
    "cloth": ("sponge",),
    "knife": ("scissors",),
    "scissors": ("knife",),
    "watering_can": ("jug",),
    "jug": ("watering_can",),
}
"""Look-alike categories a detector may report instead (always of the same kind); doors are
never confused."""

CONFUSABLE_COLOURS: dict[str, tuple[str, ...]] = {
    "red": ("orange",),
    "orange": ("red", "yellow"),
    "yellow": ("orange", "white"),
    "white": ("yellow",),
    "blue": ("purple",),
    "purple": ("blue",),
    "green": ("yellow",),
    "black": ("blue",),
}
"""Look-alike colours a detector may report instead."""
