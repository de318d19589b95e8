"""Track 1's words on the protocol page (``Track1.vocabulary``), from where they live: the
categories and affordances, the failure reasons an action result carries, the reach and
motion limits of every split, and the planning messages with a sampled instruction."""

from __future__ import annotations

import ast
import inspect
import json
import math
import textwrap
from typing import Any, get_args

from plugins._base import TrackPlugin
from plugins.track1 import _types
from plugins.track1._episode import PLANNING
from plugins.track1._types import Track1Scenario


def vocabulary(plugin: TrackPlugin[Track1Scenario, Any]) -> str:
    """The Markdown that ends Track 1's section of the protocol page."""
    from simhost.worlds.track1 import (
        AFFORDANCE_EFFECTS,
        CONTAINER_CATEGORIES,
        FURNITURE_CATEGORIES,
        OBJECT_CATEGORIES,
        REASONS,
        ROOM_TYPES,
        TOOL_CATEGORIES,
    )

    rows = ["| split | pick, use on an item (to its centre) | open, close, place, use "
            "(to a footprint) | a door (to its centre) | `move` forward = 1 | "
            "`move` turn = 1 |", "|---|---|---|---|---|---|"]
    for split in plugin.split_names():
        c = Track1Scenario.of(plugin.make_scenario(
            seed=0, split=split, params={}, index=0)).split.config
        rows.append(f"| `{split}` | {c.reach:g} m | {c.furniture_reach:g} m | "
                    f"{c.door_reach:g} m | {c.max_forward:g} m | "
                    f"{math.degrees(c.max_turn):g}° |")
    instruction = instruction_lines(plugin)
    effects = ", ".join(f"`{a}` ({b} → {c})" for a, (b, c) in AFFORDANCE_EFFECTS.items())
    return "\n".join([
        "Categories (`simhost.worlds.track1._catalogue`): rooms "
        + ", ".join(f"`{x}`" for x in dict.fromkeys(ROOM_TYPES)) + "; objects "
        + ", ".join(f"`{x}`" for x in OBJECT_CATEGORIES) + "; tools "
        + ", ".join(f"`{x}`" for x in TOOL_CATEGORIES) + "; containers "
        + ", ".join(f"`{x}`" for x in CONTAINER_CATEGORIES) + "; furniture "
        + ", ".join(f"`{x}`" for x in FURNITURE_CATEGORIES) + ". The graded inventory "
        "(`objects` of `world_model.json`) counts objects and tools, not furniture or "
        "containers (those go in `containers`). Affordances (`affordances`, the queries' "
        f"`tools_for`), with the state each takes a target from and to: {effects}.",
        "",
        "Failure reasons an action result may carry (`ok` false; "
        "`simhost.worlds.track1.REASONS`): " + ", ".join(f"`{r}`" for r in REASONS) + ".",
        "",
        "Reach (the robot's centre to the target) and motion per `move` step, by split:",
        "",
        *rows,
        "",
        *instruction,
    ])


def attribute_doc(cls: type, name: str) -> str:
    """The docstring written under attribute ``name`` in ``cls``'s source (``""``)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):
        return ""
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    for here, after in zip(body, body[1:], strict=False):
        if (isinstance(here, ast.AnnAssign) and isinstance(here.target, ast.Name)
                and here.target.id == name and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):
            return " ".join(after.value.value.split())
    return ""


def instruction_lines(plugin: TrackPlugin[Track1Scenario, Any]) -> list[str]:
    """Track 1's planning messages (``instruction``, ``queries``): their keys, what each
    holds (``_types.Task``'s attribute docs), the query kinds, and the instruction of a
    sampled scenario as the host sends it."""
    keys: dict[str, dict[str, list[str]]] = {}
    example: dict[str, Any] = {}
    splits = plugin.split_names()
    for split in splits:
        episode = plugin.make_episode(plugin.make_scenario(seed=0, split=split, params={},
                                                           index=0))
        try:
            episode.reset()
            for m in episode.on_stage_start(PLANNING):
                for k in m.data:
                    keys.setdefault(m.type, {}).setdefault(k, []).append(split)
                if m.type == "instruction" and not example:
                    example = dict(m.data)
        finally:
            episode.close()
    said = {"steps": attribute_doc(_types.Task, "steps").rstrip("."),
            "substitutes": attribute_doc(_types.Task, "substitute_rule").rstrip(".")}

    def cell(msg: str, k: str) -> str:
        where = keys[msg][k]
        only = "" if len(where) == len(splits) else (
            " (only on " + ", ".join(f"`{x}`" for x in where) + ")")
        return f"`{k}`{only}" + (f": {said[k]}" if msg == "instruction" and k in said else "")

    kinds = ", ".join(f"`{k}`" for k in get_args(_types.QueryKind))
    return [
        "Planning messages (sampled on every split): `instruction` holds "
        + "; ".join(cell("instruction", k) for k in keys.get("instruction", {}))
        + ". `queries` holds " + "; ".join(cell("queries", k) for k in keys.get("queries", {}))
        + f"; each query has an `id`, a `kind` ({kinds}), its `text` and the description's "
        "fields. For example (seed 0, split " + f"`{splits[0]}`):",
        "",
        "```json",
        json.dumps(dict(example.items()), indent=1, ensure_ascii=False),
        "```",
    ]
