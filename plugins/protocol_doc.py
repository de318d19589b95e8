"""The generated parts of ``schemas/PROTOCOL.md``, so that the page never goes stale.

    python -m plugins.protocol_doc          # rewrite the generated sections
    python -m plugins.protocol_doc --check  # exit 1 when any of them is stale

Pages (``PAGES``): ``schemas/PROTOCOL.md`` and ``docs/contract.md``. Their hand-written text
explains; the tables come from the code: the message fields
from the ``schemas`` models, the error codes and end reasons from their definitions, a
byte-exact example from the encoder, and, per installed track, the stages
(``TrackPlugin.stages()``), the observation and action specs (``TrackEpisode``'s
``FieldSpec``s, sampled over several scenarios of every split, since a track's spec may
depend on its scenario) and the files it collects; the contract's environment variables
(``schemas.CONTAINER.variables()``), how log steps are numbered, the Python client's calls
and ``TimeStep`` fields, and each track's vocabulary (failure reasons, reach, categories,
affordances, planning messages; Track 2's packet keys, task-model names and how they are
compared). Each generated section sits between
``<!-- generated:NAME … -->`` and ``<!-- end generated:NAME -->``; a track without a section
yet gets one before ``<!-- end tracks -->``. A test fails when the page and the code differ.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
import types
from collections.abc import Callable, Iterable
from enum import Enum
from pathlib import Path
from typing import Annotated, Any, Literal, Union, get_args, get_origin

import numpy as np
from pydantic import BaseModel

import schemas
from plugins._base import TrackPlugin
from plugins._registry import available_tracks, load_track
from schemas import _protocol as proto
from simhost.host._episode import StageSpec

DOC = Path(schemas.__file__).with_name("PROTOCOL.md")
_ROOT = DOC.parent.parent
#: Every page with generated sections: the protocol page (which also gets a section per
#: installed track) and the contract (its environment table and the client's types).
PAGES = (DOC, _ROOT / "docs" / "contract.md")
#: Scenarios sampled per split (seeds and indexes 0..SAMPLES-1).
SAMPLES = 5
_TRACKS_END = "<!-- end tracks -->"
_SECTION = re.compile(
    r"(<!-- generated:(?P<name>[\w:.-]+) [^>]*-->\n)(?P<body>.*?)"
    r"(<!-- end generated:(?P=name) -->)",
    re.S,
)
_TRACK_ORDER = ("sanity", "track1", "track2")


def _marker(name: str) -> str:
    return f"<!-- generated:{name} (python -m plugins.protocol_doc; do not edit) -->"


# ------------------------------------------------------------------------- type names
_SIMPLE = {int: "integer", float: "number", str: "string", bool: "boolean", Any: "any",
           type(None): "null"}


def type_name(t: Any) -> str:
    """A JSON-ish name of a field's type: ``integer | null``, ``list of TensorMeta``."""
    origin, args = get_origin(t), get_args(t)
    if origin is Annotated:
        return type_name(args[0])
    if origin is Literal:
        return " \\| ".join(json.dumps(a) for a in args)
    if origin in (Union, types.UnionType):
        return " \\| ".join(type_name(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"list of {type_name(args[0])}"
        return "[" + ", ".join(type_name(a) for a in args) + "]"
    if origin is list:
        return f"list of {type_name(args[0])}"
    if origin is dict:
        return "object"
    if isinstance(t, type) and issubclass(t, Enum):
        return "string (an end reason)"
    if isinstance(t, type) and issubclass(t, BaseModel):
        return t.__name__
    return _SIMPLE.get(t, getattr(t, "__name__", str(t)))


def _cell(text: Any) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _first_line(doc: str | None) -> str:
    return " ".join((doc or "").strip().split("\n\n")[0].split())


def model_table(model: type[BaseModel]) -> str:
    """One table row per field of a message model: name, type, default, meaning."""
    rows = ["| field | type | default | meaning |", "|---|---|---|---|"]
    for name, f in model.model_fields.items():
        if name == "kind":
            default = "required"
        elif f.is_required():
            default = "required"
        elif f.default_factory is not None:
            default = "`" + json.dumps(f.default_factory(), default=list) + "`"  # type: ignore[call-arg]
        else:
            default = f"`{json.dumps(f.default)}`"
        kind = type_name(f.annotation)
        if name == "kind":
            kind = f"`{json.dumps(f.default)}`"
        rows.append(f"| `{name}` | {kind} | {default} | {_cell(f.description or '')} |")
    return "\n".join(rows)


# ------------------------------------------------------------------- protocol sections
REQUESTS = (proto.Hello, proto.Reset, proto.Step, proto.Answer, proto.EndStage)
REPLIES = (proto.HelloReply, proto.ObservationReply, proto.ErrorReply)
PARTS = (proto.TensorMeta, proto.FieldSpec, proto.StageInfo, proto.HostMessage,
         proto.ActionResult)
#: The requests the host's step count counts (``SimHost._step``); a test plays the others
#: through a real host and checks they leave the count alone.
COUNTED = ("step",)


def messages_section() -> str:
    out = []
    for title, models in (("Requests (agent → host)", REQUESTS),
                          ("Replies (host → agent)", REPLIES),
                          ("Parts of messages", PARTS)):
        out.append(f"#### {title}\n")
        for m in models:
            kind = m.model_fields.get("kind")
            head = f"`{kind.default}`" if kind is not None else f"`{m.__name__}`"
            label = f" ({m.__name__})" if kind is not None else ""
            out.append(f"**{head}**{label} — {_first_line(m.__doc__)}\n")
            out.append(model_table(m) + "\n")
    return "\n".join(out)


def errors_section() -> str:
    rows = ["| code | meaning |", "|---|---|"]
    rows += [f"| `{code}` | {_cell(text)} |" for code, text in proto.ERROR_CODES.items()]
    return "\n".join(rows) + "\n"


def end_reasons_section() -> str:
    rows = ["| end_reason | meaning |", "|---|---|"]
    rows += [f"| `{r.value}` | {_cell(r.description)} |" for r in proto.EndReason]
    return "\n".join(rows) + "\n"


def _hex(data: bytes) -> str:
    return " ".join(f"{b:02x}" for b in data)


def example_section() -> str:
    """A step request with one tensor, byte by byte, as the encoder writes it."""
    from simhost._wire import encode

    velocity = np.array([0.5, -0.25], dtype=np.float32)
    mask = np.array([1, 0, 1], dtype=np.uint8)
    buf = encode(proto.Step(seq=3, id=7, action={"mode": "walk"}),
                 {"velocity": velocity, "mask": mask})
    hlen = int.from_bytes(buf[4:8], "little")
    header = buf[8 : 8 + hlen]
    json_part = header.rstrip(b" ")
    block = buf[8 + hlen :]
    lines = [
        "```text",
        f"offset  bytes{'':38}meaning",
        f"0       {_hex(buf[:4]):<43}magic \"EGC1\"",
        f"4       {_hex(buf[4:8]):<43}header length H = {hlen} (u32 little-endian)",
        f"8       the {len(json_part)} bytes of this JSON text, then "
        f"{hlen - len(json_part)} spaces (8 + H = {8 + hlen}, a multiple of 8):",
        f"        {json_part.decode()}",
        f"{8 + hlen:<8}{_hex(block[0:8]):<43}tensor \"velocity\": float32 [0.5, -0.25] "
        "(block offset 0)",
        f"{8 + hlen + 8:<8}{_hex(block[8:16]):<43}tensor \"mask\": uint8 [1, 0, 1] "
        "(block offset 8), 5 zero bytes of padding",
        f"{len(buf):<8}(end: the buffer is exactly {len(buf)} bytes)",
        "```",
    ]
    return "\n".join(lines) + "\n"


# ------------------------------------------------------- the contract and the client
def environment_section() -> str:
    """Every environment variable of the container contract (``schemas.CONTAINER``): the
    value a container sees and what it means."""
    rows = ["| variable | in a container | meaning |", "|---|---|---|"]
    for v in schemas.CONTAINER.variables():
        rows.append(f"| `{v.name}` | `{v.value}` | {_cell(v.meaning)} |")
    return "\n".join(rows) + "\n\nNothing else is in the environment.\n"


def attribute_doc(cls: type, name: str) -> str:
    """The docstring written under attribute ``name`` in ``cls``'s source (``""``)."""
    import ast
    import inspect
    import textwrap

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


def log_steps_section() -> str:
    """How ``episode_log.jsonl``'s ``step`` is numbered: the host's count, which requests
    it counts (``COUNTED``), and the slack a record is given (``plugins._audit``)."""
    from plugins import _audit

    counted = [m for m in REQUESTS if m.model_fields["kind"].default in COUNTED]
    not_counted = [m for m in REQUESTS if m not in counted]
    names = lambda ms: ", ".join(f"`{m.model_fields['kind'].default}`" for m in ms)  # noqa: E731
    step = (schemas.LogRecord.model_fields["step"].description or "").removeprefix(
        "Graded. ")
    rule = next(" ".join(p.split()) for p in (_audit.__doc__ or "").split("\n\n")
                if "names the host's step" in p).split(". ")[0]
    return "\n".join([
        f"`LogRecord.step` (graded): {_cell(step)} {rule}. That is, the host counts "
        f"{names(counted)} requests it served (an action the world refused included: it "
        "has a reply with `ok` false); "
        f"{names(not_counted)} requests, and those answered with an `error` reply, are "
        f"not steps. A record may name the step it is about to make or the one it just "
        f"made (`plugins._audit.STEP_SLACK` = {_audit.STEP_SLACK}); a record past the "
        "host's count is flagged in the audit and noted on the score card.",
    ]) + "\n"


def _signature(fn: Callable[..., Any]) -> str:
    import inspect

    sig = inspect.signature(fn)
    params = [p for p in sig.parameters.values() if p.name != "self"]
    shown = []
    for p in params:
        if p.kind is p.VAR_KEYWORD:
            shown.append(f"**{p.name}")
        elif p.kind is p.KEYWORD_ONLY and not any(x.startswith("*") for x in shown):
            shown += ["*", p.name if p.default is p.empty else f"{p.name}=…"]
        else:
            shown.append(p.name if p.default is p.empty else f"{p.name}=…")
    ret = sig.return_annotation
    ret = ret if isinstance(ret, str) else getattr(ret, "__name__", str(ret))
    return f"{fn.__name__}({', '.join(shown)}) → {ret}"


def client_section() -> str:
    """What the Python client (``simhost.client``) returns: ``RemoteEnv``'s calls, the
    fields of its ``TimeStep`` (their meaning from the reply they come from), and
    ``OutputFiles``' calls."""
    from typing import get_type_hints

    from simhost import client as agent

    remote = ["| call | what it does |", "|---|---|"]
    for name in ("hello", "reset", "step", "answer", "end_stage", "close"):
        fn = getattr(agent.RemoteEnv, name)
        remote.append(f"| `{_cell(_signature(fn))}` | {_cell(_first_line(fn.__doc__))} |")
    for name in ("observation_spec", "action_spec", "stages"):
        said = proto.HelloReply.model_fields[name].description or ""
        remote.append(f"| `.{name}` | {_cell(said.rstrip('.'))} (from the hello reply) |")
    hints = get_type_hints(agent.TimeStep)
    reply = proto.ObservationReply.model_fields
    fields = ["| field | type | meaning |", "|---|---|---|"]
    for name in agent.TimeStep._fields:
        meaning = reply[name].description if name in reply else ""
        if name == "observation":  # RemoteEnv merges the tensors in
            meaning = (f"{meaning.rstrip('.')}, and the reply's tensors as numpy arrays, "
                       "by name (the specs say which entry travels how).")
        fields.append(f"| `{name}` | {type_name(hints[name])} | {_cell(meaning or '')} |")
    files = ["| call | what it does |", "|---|---|"]
    for name in ("write", "log", "close"):
        fn = getattr(agent.OutputFiles, name)
        files.append(f"| `{_cell(_signature(fn))}` | {_cell(_first_line(fn.__doc__))} |")
    return "\n".join([
        f"`RemoteEnv` — {_cell(_first_line(agent.RemoteEnv.__doc__))}", "", *remote, "",
        f"`TimeStep` — {_cell(_first_line(agent.TimeStep.__doc__))} "
        "`ts.message(type)` gives the first host message of a type.", "", *fields, "",
        f"`OutputFiles` — {_cell(_first_line(agent.OutputFiles.__doc__))}", "", *files,
    ]) + "\n"


# ---------------------------------------------------------------------- track sections
def _num(x: float | None) -> str:
    if x is None:
        return ""
    return f"{x:g}"


def _range(f: proto.FieldSpec) -> str:
    if f.choices is not None:
        names = ", ".join(f.choices)
        return f"index or name of: {names}" if f.dtype != "str" else f"one of: {names}"
    if f.low is None and f.high is None:
        return ""
    return f"{_num(f.low) or '−∞'} … {_num(f.high) or '∞'}"


def _shape(shape: tuple[int, ...]) -> str:
    return "scalar" if not shape else "[" + ", ".join(str(d) for d in shape) + "]"


def _travels(f: proto.FieldSpec) -> str:
    return "tensor" if f.tensor else "JSON"


def _merged(values: Iterable[str]) -> str:
    distinct = list(dict.fromkeys(values))
    return " / ".join(v for v in distinct if v) if len(distinct) > 1 else distinct[0]


def spec_table(samples: list[tuple[proto.FieldSpec, ...]], *, observation: bool) -> str:
    """One row per field name over every sampled spec; values that differ between
    scenarios are joined by `` / ``."""
    order: dict[str, list[proto.FieldSpec]] = {}
    for spec in samples:
        for f in spec:
            order.setdefault(f.name, []).append(f)
    head = "| name | dtype | shape | range | sent as | meaning |" if observation else (
        "| name | dtype | shape | range | meaning |")
    rows = [head, "|---|---|---|---|---|---|" if observation else "|---|---|---|---|---|"]
    for name, fields in order.items():
        cols = [
            f"`{name}`",
            _merged(f.dtype for f in fields),
            _merged(_shape(tuple(f.shape)) for f in fields),
            _cell(_merged(_range(f) for f in fields)),
        ]
        if observation:
            cols.append(_merged(_travels(f) for f in fields))
        text = _cell(_merged(f.description for f in fields))
        if len(fields) < len(samples):
            text = (text + " " if text else "") + "(only in some scenarios)"
        cols.append(text)
        rows.append("| " + " | ".join(cols) + " |")
    return "\n".join(rows)


def _budget(seconds: float) -> str:
    if seconds % 60 == 0:
        return f"{seconds / 60:g} min"
    return f"{seconds:g} s"


def stages_table(stages: list[StageSpec]) -> str:
    rows = ["| # | stage | official budget | step cap | the robot may move | what happens |",
            "|---|---|---|---|---|---|"]
    for i, s in enumerate(stages):
        cap = "" if s.max_steps is None else str(s.max_steps)
        rows.append(f"| {i} | `{s.name}` | {_budget(s.budget_s)} | {cap or '—'} | "
                    f"{'yes' if s.allows_motion else 'no'} | {_cell(s.description)} |")
    return "\n".join(rows)


def sample_specs(
    plugin: TrackPlugin, split: str
) -> tuple[list[tuple[proto.FieldSpec, ...]], list[tuple[proto.FieldSpec, ...]]]:
    """The observation and action specs of ``SAMPLES`` scenarios of ``split``."""
    observations, actions = [], []
    for i in range(SAMPLES):
        scenario = plugin.make_scenario(seed=i, split=split, params={}, index=i)
        episode = plugin.make_episode(scenario)
        try:
            observations.append(tuple(episode.observation_spec))
            actions.append(tuple(episode.action_spec))
        finally:
            episode.close()
    return observations, actions


def _by_split(tables: dict[str, str], what: str) -> list[str]:
    """One table per group of splits whose tables are the same."""
    groups: dict[str, list[str]] = {}
    for split, table in tables.items():
        groups.setdefault(table, []).append(split)
    out = []
    for table, splits in groups.items():
        names = ", ".join(f"`{s}`" for s in splits)
        out += [f"{what} on split{'s' if len(splits) > 1 else ''} {names} (sampled over "
                f"{SAMPLES} scenarios of each):", "", table, ""]
    return out


def _split_names(plugin: TrackPlugin) -> tuple[str, ...]:
    names = getattr(plugin, "split_names", None)
    return tuple(names()) if callable(names) else tuple(plugin.splits)


def _parts(model: type[BaseModel]) -> list[type[BaseModel]]:
    """``model`` and the models its fields hold, depth first, each once."""
    out = [model]
    for f in model.model_fields.values():
        for a in _models_of(f.annotation):
            out += [m for m in _parts(a) if m not in out]
    return out


def _models_of(t: Any) -> list[type[BaseModel]]:
    if isinstance(t, type) and issubclass(t, BaseModel):
        return [t]
    return [m for a in get_args(t) for m in _models_of(a)]


def _is_graded(f: Any) -> bool:
    extra = f.json_schema_extra
    return isinstance(extra, dict) and extra.get("graded") is True


def fields_table(models: Iterable[type[BaseModel]]) -> str:
    """Per object of the files: the fields it must have, those a score reads (graded),
    and those nothing grades."""
    rows = ["| object | required | graded | not graded |", "|---|---|---|---|"]
    seen: list[type[BaseModel]] = []
    for top in models:
        seen += [m for m in _parts(top) if m not in seen]
    for m in seen:
        fields = m.model_fields
        req = [n for n, f in fields.items() if f.is_required()]
        graded = [n for n, f in fields.items() if _is_graded(f)]
        rest = [n for n, f in fields.items() if not _is_graded(f)]
        cell = lambda names: ", ".join(f"`{n}`" for n in names) or "—"  # noqa: E731
        rows.append(f"| `{m.__name__}` | {cell(req)} | {cell(graded)} | {cell(rest)} |")
    return "\n".join(rows)


# ------------------------------------------------------------------- vocabularies
def track1_vocabulary(plugin: TrackPlugin) -> str:
    """Track 1's words and limits, from where they live: the failure reasons an action
    result carries, and the reach and motion limits of every split."""
    from simhost.worlds.track1._actions import REASONS

    rows = ["| split | pick, use on an item (to its centre) | open, close, place, use "
            "(to a footprint) | a door (to its centre) | `move` forward = 1 | "
            "`move` turn = 1 |", "|---|---|---|---|---|---|"]
    for split in _split_names(plugin):
        c = plugin.hidden(plugin.make_scenario(
            seed=0, split=split, params={}, index=0)).split.config
        rows.append(f"| `{split}` | {c.reach:g} m | {c.furniture_reach:g} m | "
                    f"{c.door_reach:g} m | {c.max_forward:g} m | "
                    f"{math.degrees(c.max_turn):g}° |")
    instruction = instruction_lines(plugin)
    from simhost.worlds.track1 import _catalogue as cat

    effects = ", ".join(f"`{a}` ({b} → {c})" for a, (b, c) in cat.AFFORDANCE_EFFECTS.items())
    return "\n".join([
        "Categories (`simhost.worlds.track1._catalogue`): rooms "
        + ", ".join(f"`{x}`" for x in dict.fromkeys(cat.ROOM_TYPES)) + "; objects "
        + ", ".join(f"`{x}`" for x in cat.OBJECT_CATEGORIES) + "; tools "
        + ", ".join(f"`{x}`" for x in cat.TOOL_CATEGORIES) + "; containers "
        + ", ".join(f"`{x}`" for x in cat.CONTAINER_CATEGORIES) + "; furniture "
        + ", ".join(f"`{x}`" for x in cat.FURNITURE_CATEGORIES) + ". The graded inventory "
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


def instruction_lines(plugin: TrackPlugin) -> list[str]:
    """Track 1's planning messages (``instruction``, ``queries``): their keys, what each
    holds (``plugins.track1._types.Task``'s attribute docs), the query kinds, and the
    instruction of a sampled scenario as the host sends it."""
    from plugins.track1 import _types

    keys: dict[str, dict[str, list[str]]] = {}
    example: dict[str, Any] = {}
    for split in _split_names(plugin):
        episode = plugin.make_episode(plugin.make_scenario(seed=0, split=split, params={},
                                                           index=0))
        try:
            episode.reset()
            for m in episode.on_stage_start("planning"):
                for k in m.data:
                    keys.setdefault(m.type, {}).setdefault(k, []).append(split)
                if m.type == "instruction" and not example:
                    example = dict(m.data)
        finally:
            episode.close()
    splits = _split_names(plugin)
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
        json.dumps({k: v for k, v in example.items()}, indent=1, ensure_ascii=False),
        "```",
    ]


def track2_vocabulary(plugin: TrackPlugin) -> str:
    """Track 2's task-model names, per family, from the truths of sampled instances (what
    ``task_model.json`` is compared with), and how values are compared."""
    from plugins.track2._scoring import close
    from simhost.worlds.track2 import task_truth

    split = next(iter(plugin.splits))
    truths: dict[str, Any] = {}
    for i in range(SAMPLES):
        s = plugin.hidden(plugin.make_scenario(
            seed=i, split=split, params={"demo_frames": False}, index=i))
        truths.setdefault(s.family, task_truth(s.instance, s.bench))
    rows = ["| family | stages | variables | constraints | preconditions | success |",
            "|---|---|---|---|---|---|"]
    for family, t in sorted(truths.items()):
        pre = "; ".join(f"`{k}`: " + ", ".join(f"`{r}`" for r in v)
                        for k, v in t.preconditions.items())
        rows.append(
            f"| `{family}` | " + " ".join(f"`{x}`" for x in t.stages) + " | "
            + ", ".join(f"`{v.name}`" for v in t.state_variables) + " | "
            + ", ".join(f"`{c.name}`" for c in t.constraints) + f" | {pre or '—'} | "
            + ", ".join(f"`{c.variable} {c.op}`" for c in t.success) + " |")
    examples = [(0.0105, 0.01), (0.011, 0.01), (0.012, 0.01), (1.1, 1.0), ([1.0, 2.2],
                [1.0, 2.0]), (True, True), ("Peg", "peg")]
    cases = "; ".join(f"`{json.dumps(p)}` for `{json.dumps(t)}`: {close(p, t):.2f}"
                      for p, t in examples)
    from plugins.track2 import _scoring

    rule = next(" ".join(b.split()) for b in (_scoring.__doc__ or "").split("\n- ")
                if b.startswith("``task_model``"))
    weights = ", ".join(f"{k} {w:g}" for k, w in _scoring.MODEL_WEIGHTS.items())
    return "\n".join([
        *packet_keys(plugin, split),
        f"Task-model names per family (the truths of sampled `{split}` instances; "
        "`simhost.worlds.track2.task_truth`): a model of another family scores 0.",
        "",
        *rows,
        "",
        "How a model is compared with the truth (`plugins.track2._scoring`, weights "
        f"`MODEL_WEIGHTS`: {weights}): {rule.removeprefix('``task_model``: ')}",
        "",
        "Values (constraints, success criteria) are compared by "
        "`plugins.track2._scoring.close`, credit in [0, 1]; for example " + cases + ".",
    ])


def packet_keys(plugin: TrackPlugin, split: str) -> list[str]:
    """The arrays of the demonstration packet's ``trajectory.npz`` (written for sampled
    instances of every family; T is the number of actions)."""
    import tempfile


    shapes: dict[str, dict[str, str]] = {}
    for i in range(SAMPLES):
        scenario = plugin.make_scenario(seed=i, split=split, params={"demo_frames": False},
                                        index=i)
        family = plugin.hidden(scenario).family
        with tempfile.TemporaryDirectory(prefix="eagc-doc-") as tmp:
            plugin.write_inputs(scenario, Path(tmp))
            with np.load(next(Path(tmp).rglob("trajectory.npz"))) as z:
                steps = len(z["actions"]) if "actions" in z.files else -1
                for key in z.files:
                    a = z[key]
                    lead = {steps: "T", steps + 1: "T+1"}.get(a.shape[0], str(a.shape[0])) \
                        if a.shape else ""
                    dims = " × ".join([lead, *map(str, a.shape[1:])]) if a.shape else "scalar"
                    shapes.setdefault(key, {})[family] = f"{a.dtype} {dims}"
    rows = ["| array | dtype and shape |", "|---|---|"]
    for key, by in shapes.items():
        kinds = set(by.values())
        cell = next(iter(kinds)) if len(kinds) == 1 else "; ".join(
            f"{f}: {v}" for f, v in sorted(by.items()))
        rows.append(f"| `{key}` | {cell} |")
    return ["The demonstration packet's `trajectory.npz` (`$EAGC_INPUT/demo`, beside "
            "`manifest.json`, [`DemoManifest`](json/demo_manifest.json)); T is the number "
            "of actions:", "", *rows, ""]


#: Track → its vocabulary section (the words its scores and results use).
VOCABULARY: dict[str, Callable[[TrackPlugin], str]] = {
    "track1": track1_vocabulary, "track2": track2_vocabulary}


def track_section(name: str) -> str:
    plugin = load_track(name)
    observations: dict[str, str] = {}
    actions: dict[str, str] = {}
    for split in _split_names(plugin):
        obs, act = sample_specs(plugin, split)
        observations[split] = spec_table(obs, observation=True)
        actions[split] = spec_table(act, observation=False)
    extra = [s for s in _split_names(plugin) if s not in plugin.splits]
    files = ["| file | schema | required |", "|---|---|---|"]
    for fname, rule in plugin.files.items():
        if rule.jsonl:
            schema = "one [`LogRecord`](json/episode_log_record.json) per line"
        elif rule.model is not None:
            stem = re.sub(r"(?<!^)(?=[A-Z])", "_", rule.model.__name__).lower()
            schema = f"[`{rule.model.__name__}`](json/{stem}.json)"
        else:
            schema = ""
        files.append(f"| `{fname}` | {schema} | {'yes' if rule.required else 'no'} |")
    return "\n".join([
        f"Stages, in order (`{type(plugin).__name__}.stages()`; a campaign may scale the "
        "budgets, and an episode may announce smaller step caps at `hello`):",
        "",
        stages_table(plugin.stages()),
        "",
        *([f"Public extra split{'s' if len(extra) > 1 else ''}, outside the final score: "
           + ", ".join(f"`{s}`" for s in extra) + ".", ""] if extra else []),
        *_by_split(observations, "Observation"),
        "Action (fields may be left out; the track decides what a missing one means):",
        "",
        *([next(iter(actions.values())), ""] if len(set(actions.values())) == 1
          else _by_split(actions, "Action")),
        "Files collected from `/output` (checked against their schema):",
        "",
        "\n".join(files),
        "",
        "What each object of the files holds: the fields it must have (the others are "
        "optional), those the track's score reads (graded) and those nothing grades. Any "
        "other key is "
        "allowed: it is ignored and listed in the score card's notes, and so is a field "
        "nothing grades whose value cannot be read (it is left out). A file is refused "
        "only when a graded field (or `version`) cannot be read; `eagc check-files "
        f"FOLDER --track {name}` says what the host would.",
        "",
        fields_table([r.model or schemas.LogRecord for r in plugin.files.values()]),
        "",
        *([VOCABULARY[name](plugin), ""] if name in VOCABULARY else []),
    ])


# ---------------------------------------------------------------------------- the page
def sections(tracks: Iterable[str] | None = None) -> dict[str, Callable[[], str]]:
    """Generated section name → a function that renders it."""
    out: dict[str, Callable[[], str]] = {
        "example": example_section,
        "messages": messages_section,
        "errors": errors_section,
        "end-reasons": end_reasons_section,
        "environment": environment_section,
        "log-steps": log_steps_section,
        "client": client_section,
    }
    names = list(tracks if tracks is not None else available_tracks())
    names.sort(key=lambda n: (_TRACK_ORDER.index(n) if n in _TRACK_ORDER else 99, n))
    for t in names:
        out[f"track:{t}"] = lambda t=t: track_section(t)
    return out


def render(text: str, tracks: Iterable[str] | None = None, *, add_tracks: bool = True
           ) -> str:
    """``text`` with every generated section rewritten (and, with ``add_tracks``, missing
    tracks added)."""
    todo = sections(tracks)
    present = {m.group("name") for m in _SECTION.finditer(text)}
    missing = [n for n in todo if n.startswith("track:") and n not in present
               ] if add_tracks else []
    if missing:
        if _TRACKS_END not in text:
            raise ValueError(f"{DOC.name} has no {_TRACKS_END!r} marker to add tracks before")
        add = "".join(
            f"### Track `{n.split(':', 1)[1]}`\n\n{_marker(n)}\n<!-- end generated:{n} -->\n\n"
            for n in missing
        )
        text = text.replace(_TRACKS_END, add + _TRACKS_END)

    def fill(m: re.Match[str]) -> str:
        name = m.group("name")
        if name not in todo:
            return m.group(0)  # e.g. a track that is not installed here: left as it is
        return f"{_marker(name)}\n{todo[name]().rstrip()}\n{m.group(4)}"

    return _SECTION.sub(fill, text)


def stale(path: Path = DOC) -> list[str]:
    """Names of the generated sections that differ from the code (empty: up to date)."""
    text = path.read_text()
    fresh = render(text, add_tracks=path.name == DOC.name)
    if fresh == text:
        return []
    old = {m.group("name"): m.group(0) for m in _SECTION.finditer(text)}
    new = {m.group("name"): m.group(0) for m in _SECTION.finditer(fresh)}
    return sorted(n for n in new if old.get(n) != new[n])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="exit 1 if the page is stale")
    args = ap.parse_args(argv)
    if args.check:
        bad = 0
        for page in (p for p in PAGES if p.exists()):
            names = stale(page)
            if names:
                bad += 1
                print(f"{page} is stale in: {', '.join(names)}; run python -m "
                      "plugins.protocol_doc", file=sys.stderr)
            else:
                print(f"{page} is up to date")
        return 1 if bad else 0
    for page in (p for p in PAGES if p.exists()):
        text = page.read_text()
        page.write_text(render(text, add_tracks=page == DOC))
        print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
