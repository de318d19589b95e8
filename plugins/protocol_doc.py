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
and ``TimeStep`` fields; each track's section ends with its own words
(``TrackPlugin.vocabulary``: Track 1's failure reasons, reach, categories, affordances and
planning messages; Track 2's packet keys, task-model names and how they are compared).
Each generated section sits between ``<!-- generated:NAME … -->`` and
``<!-- end generated:NAME -->``; a track without a section yet gets one before
``<!-- end tracks -->`` (tracks in the order of their names). A test fails when the page
and the code differ.
"""

from __future__ import annotations

import argparse
import json
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
import schemas as proto
from plugins._base import TrackPlugin
from plugins._registry import available_tracks, load_track
from simhost.host import StageSpec

DOC = Path(schemas.__file__).with_name("PROTOCOL.md")
_ROOT = DOC.parent.parent
#: Every page with generated sections: the protocol page (which also gets a section per
#: installed track), the contract (its environment table and the client's types) and the
#: commands (what ``run-episode --json`` prints).
PAGES = (DOC, _ROOT / "docs" / "contract.md", _ROOT / "docs" / "commands.md")
#: Scenarios sampled per split (seeds and indexes 0..SAMPLES-1).
SAMPLES = 5
_TRACKS_END = "<!-- end tracks -->"
_SECTION = re.compile(
    r"(<!-- generated:(?P<name>[\w:.-]+) [^>]*-->\n)(?P<body>.*?)"
    r"(<!-- end generated:(?P=name) -->)",
    re.S,
)


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
    if t is proto.EndReason:
        return "string (an end reason)"
    if isinstance(t, type) and issubclass(t, Enum):
        return " \\| ".join(json.dumps(m.value) for m in t)
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
        if name == "kind" and not f.is_required():  # a message's tag
            kind = f"`{json.dumps(f.default)}`"
        rows.append(f"| `{name}` | {kind} | {default} | {_cell(f.description or '')} |")
    return "\n".join(rows)


# ------------------------------------------------------------------- protocol sections
REQUESTS = (proto.Hello, proto.Reset, proto.Step, proto.Answer, proto.EndStage)
REPLIES = (proto.HelloReply, proto.ObservationReply, proto.ErrorReply)
PARTS = (proto.TensorMeta, proto.FieldSpec, proto.StageInfo, proto.HostMessage,
         proto.ActionResult)
#: The parts of replies a ``TimeStep`` and ``RemoteEnv`` hand over, tabled in the contract.
CLIENT_PARTS = (proto.StageInfo, proto.FieldSpec, proto.ActionResult, proto.HostMessage)
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
    from simhost import encode

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
        f = proto.HelloReply.model_fields[name]
        said = (f.description or "").rstrip(".")
        remote.append(f"| `.{name}` | {_cell(said)}: a {type_name(f.annotation)} (from the "
                      "hello reply) |")
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
    parts = []
    for m in CLIENT_PARTS:
        parts += [f"`{m.__name__}` — {_cell(_first_line(m.__doc__))}", "", model_table(m), ""]
    return "\n".join([
        f"`RemoteEnv` — {_cell(_first_line(agent.RemoteEnv.__doc__))}", "", *remote, "",
        f"`TimeStep` — {_cell(_first_line(agent.TimeStep.__doc__))} "
        "`ts.message(type)` gives the first host message of a type.", "", *fields, "",
        "The parts these hold (`schemas`; the same tables as in `schemas/PROTOCOL.md`). "
        "`ActionResult` is all the protocol says of an action; a track's own account of "
        "it, where it has one, is an observation entry (Track 1: `action_result`, with "
        "the primitive and `collided`; each track's section of `schemas/PROTOCOL.md`).",
        "", *parts,
        f"`OutputFiles` — {_cell(_first_line(agent.OutputFiles.__doc__))}", "", *files,
    ]) + "\n"


def episode_result_section() -> str:
    """What ``eagc run-episode --json`` prints: one ``schemas.EpisodeResult``, every model
    it holds with its fields."""
    out = ["`eagc run-episode … --json` prints one JSON object, an `EpisodeResult` "
           "(`schemas.EpisodeResult`, JSON Schema "
           "[`schemas/json/episode_result.json`](../schemas/json/episode_result.json)); "
           "the exit code is the command's (0: the episode completed). The models it "
           "holds:", ""]
    for m in _parts(schemas.EpisodeResult):
        said = _first_line(m.__doc__)
        out += [f"`{m.__name__}`" + (f" — {_cell(said)}" if said else ""), "",
                model_table(m), ""]
    return "\n".join(out)


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


def stages_table(stages: list[StageSpec],
                 caps: dict[str, list[int]] | None = None) -> str:
    """The stages; ``caps``: the step caps episodes announced at ``hello``, by stage (those
    of the official splits' sampled scenarios), shown where the stage has none of its
    own."""
    rows = ["| # | stage | official budget | step cap | the robot may move | what happens |",
            "|---|---|---|---|---|---|"]
    for i, s in enumerate(stages):
        cap = "" if s.max_steps is None else str(s.max_steps)
        seen = (caps or {}).get(s.name)
        if not cap and seen:
            cap = (f"per episode, {min(seen)}–{max(seen)} sampled (`max_steps` at `hello`)"
                   if min(seen) != max(seen) else f"{seen[0]} (`max_steps` at `hello`)")
        rows.append(f"| {i} | `{s.name}` | {_budget(s.budget_s)} | {cap or '—'} | "
                    f"{'yes' if s.allows_motion else 'no'} | {_cell(s.description)} |")
    return "\n".join(rows)


def sample_specs(
    plugin: TrackPlugin, split: str, caps: dict[str, list[int]] | None = None
) -> tuple[list[tuple[proto.FieldSpec, ...]], list[tuple[proto.FieldSpec, ...]]]:
    """The observation and action specs of ``SAMPLES`` scenarios of ``split``; ``caps``
    gathers each stage's step cap as the episodes announce it."""
    observations, actions = [], []
    for i in range(SAMPLES):
        scenario = plugin.make_scenario(seed=i, split=split, params={}, index=i)
        episode = plugin.make_episode(scenario)
        try:
            observations.append(tuple(episode.observation_spec))
            actions.append(tuple(episode.action_spec))
            for stage in plugin.stages():
                cap = episode.step_budget(stage.name)
                if caps is not None and cap is not None:
                    caps.setdefault(stage.name, []).append(cap)
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


def split_signs(names: dict[str, set[str]]) -> list[str]:
    """How an agent tells the splits apart from the hello reply's specs: each entry that
    some splits have and others lack (``names``: split → the entry names of its sampled
    specs). Empty when every split has the same entries."""
    splits = list(names)
    every = set.intersection(*names.values()) if names else set()
    where: dict[str, list[str]] = {}
    for split in splits:
        for n in sorted(names[split] - every):
            where.setdefault(n, []).append(split)
    if not where:
        return []
    groups: dict[tuple[str, ...], list[str]] = {}
    for n, on in where.items():
        groups.setdefault(tuple(on), []).append(n)
    said = "; ".join(", ".join(f"`{n}`" for n in ns) + " only on "
                     + ", ".join(f"`{s}`" for s in on) for on, ns in groups.items())
    return [
        "Which split an episode plays is never sent (nor in the environment); the hello "
        "reply's specs tell the splits apart (`RemoteEnv.observation_spec`, "
        "`.action_spec`): " + said + ".", ""]


def track_section(name: str) -> str:
    plugin = load_track(name)
    observations: dict[str, str] = {}
    actions: dict[str, str] = {}
    entries: dict[str, set[str]] = {}
    caps: dict[str, list[int]] = {}
    for split in plugin.split_names():
        obs, act = sample_specs(plugin, split, caps if split in plugin.splits else None)
        observations[split] = spec_table(obs, observation=True)
        actions[split] = spec_table(act, observation=False)
        entries[split] = {f"{f.name}" for spec in obs for f in spec} | {
            f"{f.name} (action)" for spec in act for f in spec}
    extra = [s for s in plugin.split_names() if s not in plugin.splits]
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
        stages_table(plugin.stages(), caps),
        "",
        *([f"Public extra split{'s' if len(extra) > 1 else ''}, outside the final score: "
           + ", ".join(f"`{s}`" for s in extra) + ".", ""] if extra else []),
        *_by_split(observations, "Observation"),
        "Action (fields may be left out; the track decides what a missing one means):",
        "",
        *([next(iter(actions.values())), ""] if len(set(actions.values())) == 1
          else _by_split(actions, "Action")),
        *split_signs(entries),
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
        *([words, ""] if (words := plugin.vocabulary().rstrip()) else []),
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
        "episode-result": episode_result_section,
    }
    for t in sorted(tracks if tracks is not None else available_tracks()):
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
