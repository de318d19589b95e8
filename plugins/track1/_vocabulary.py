"""Track 1's words on the protocol page (``Track1.vocabulary``), from where they live: the
categories and affordances, the look-alike tables, the failure reasons an action result
carries, the reach and motion limits of every split, the planning messages with a sampled
instruction, the answers to the queries (an example and how each kind is graded) and the
plan."""

from __future__ import annotations

import ast
import inspect
import json
import math
import textwrap
from typing import Any, get_args

from plugins._base import TrackPlugin
from plugins.track1 import _exceptions, _queries, _types
from plugins.track1._episode import EXPLORATION, PLANNING
from plugins.track1._types import Track1Plan, Track1Scenario
from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS


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
    lookalike = ["| true | may be reported as |", "|---|---|"]
    lookalike += [f"| `{k}` | " + ", ".join(f"`{x}`" for x in v) + " |"
                  for k, v in (*CONFUSABLE.items(), *CONFUSABLE_COLOURS.items())]
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
        "Look-alikes (`from simhost.client import CONFUSABLE, CONFUSABLE_COLOURS`, "
        "importable in the agent base image): on the official splits some things are "
        "reported as a look-alike from afar, every time, and as what they are from "
        "closer; categories (always of the same kind; doors are never confused), then "
        "colours:",
        "",
        *lookalike,
        "",
        *action_result_lines(plugin),
        "Failure reasons an action result may carry (`ok` false; "
        "`simhost.worlds.track1.REASONS`): " + ", ".join(f"`{r}`" for r in REASONS) + ".",
        "",
        "Reach (the robot's centre to the target) and motion per `move` step, by split:",
        "",
        *rows,
        "",
        *instruction,
        "",
        *plan_lines(),
    ])


def action_result_lines(plugin: TrackPlugin[Track1Scenario, Any]) -> list[str]:
    """Where a step's result is: ``TimeStep.action`` (the protocol's ``ActionResult``) and
    the observation's JSON ``action_result`` (the primitive and ``collided``), as a real
    step of a sampled episode returns them."""
    from schemas import ActionResult

    split = plugin.split_names()[0]
    episode = plugin.make_episode(plugin.make_scenario(seed=0, split=split, params={},
                                                       index=0))
    try:
        episode.reset()
        outcome = episode.step(EXPLORATION, {"primitive": 2, "target": 0})  # open id 0
        entry = dict(outcome.observation.data)["action_result"]
    finally:
        episode.close()
    fields = ", ".join(f"`{n}`" for n in ActionResult.model_fields)
    return [
        f"A step's result comes twice. `TimeStep.action` (`ActionResult`: {fields}) says "
        "whether the host applied it and the world did it. The observation's JSON "
        "`action_result` (`ts.observation[\"action_result\"]`) adds which primitive ran "
        "and whether a move stopped on contact; for example, an `open` of id 0 (seed 0, "
        f"split `{split}`): `{json.dumps(entry)}`.",
        "",
    ]


def answer_lines(queries: list[dict[str, Any]], answer_with: str) -> list[str]:
    """The answers to the queries: an ``answer`` payload for ``queries`` (each a right
    answer's shape) and how each kind is graded, with scores ``_queries.score_answer``
    computes."""
    shapes: dict[str, tuple[Any, Any, Any]] = {  # kind: (truth, an answer, another)
        "object_room": (2, 2, 3),
        "door_state": ("locked", "locked", "closed"),
        "room_neighbours": ([0, 3], [0, 3], [0, 1, 3]),
        "container_state": ("open", "open", "unavailable"),
        "tools_for": ([41, 57], [41, 57], [41]),
        "object_count": (4, 4, 3),
    }
    rows = ["| kind | answer is | truth | an answer | its score | another | its score |",
            "|---|---|---|---|---|---|---|"]
    for kind in get_args(_types.QueryKind):
        truth, good, other = shapes[kind]
        shape = {str: "string", int: "integer", list: "list of ids"}[type(truth)]
        rows.append(
            f"| `{kind}` | {shape} | `{json.dumps(truth)}` | `{json.dumps(good)}` | "
            f"{_queries.score_answer(kind, good, truth):.2f} | `{json.dumps(other)}` | "
            f"{_queries.score_answer(kind, other, truth):.2f} |")
    payload = {q["id"]: shapes[q["kind"]][1] for q in queries}
    doc = " ".join((_queries.__doc__ or "").split())
    grading = next(x for x in doc.split(". ") if "scores 0" in x).replace("``", "`")
    return [
        f"Answers (`answer_with`: \"{answer_with}\"): one `answer` request, "
        "`env.answer({query id: answer})`, during planning; a later one adds to or "
        "replaces earlier answers by id (an id not asked is ignored, and the reply's "
        "`ok` is false). For the sampled queries above, in the right "
        f"shapes (values made up): `env.answer({json.dumps(payload)})`. {grading}. Lists "
        "are graded as sets of ids (F1), an integer answer may be a string of digits; "
        "scores of some answers (`plugins.track1._queries.score_answer`):",
        "",
        *rows,
    ]


def plan_lines() -> list[str]:
    """The plan of ``end_stage({"plan": …})``: ``Track1Plan``'s fields, and what reads
    them (no score does)."""
    rows = ["| field | type | default | meaning |", "|---|---|---|---|"]
    for name, f in Track1Plan.model_fields.items():
        default = json.dumps(f.default_factory()) if f.default_factory else ""  # type: ignore[call-arg]
        rows.append(f"| `{name}` | {_plan_type(f.annotation)} | `{default}` | "
                    f"{f.description or ''} |")
    used = " ".join((_exceptions.route_doors.__doc__ or "").split()).split(". ")[0]
    return [
        "The plan (`Track1Plan`, `end_stage({\"plan\": {...}})`): every field is optional "
        "and none is graded (no score reads the plan; an invalid one counts as "
        "none). `route` and `doors` only place a `door_lock` exception "
        f"(`plugins.track1._exceptions.route_doors`: {used}).",
        "",
        *rows,
    ]


def _plan_type(t: Any) -> str:
    return "list of " + {str: "string", int: "integer"}[get_args(t)[0]]


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
    queries: dict[str, Any] = {}
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
                if m.type == "queries" and not queries:
                    queries = dict(m.data)
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
        "",
        "and its queries:",
        "",
        "```json",
        '{"queries": [',
        ",\n".join(" " + json.dumps(q, ensure_ascii=False) for q in queries.get("queries", [])),
        ' ], "answer_with": ' + json.dumps(queries.get("answer_with", "")) + "}",
        "```",
        "",
        *answer_lines(list(queries.get("queries", [])), str(queries.get("answer_with", ""))),
    ]
