"""Reading structured files with errors that name the file, the field and the problem.

Every report of a file's problems (``eagc check-files``, ``eagc test``, the score card,
the failure report, ``eagc leaderboard --team``) prints the lines ``problem_lines`` makes:
the keys nothing reads first, then one line per field path and problem, list indices
gathered (``objects.*.id: Field required (objects 0-3, 7)``), with "did you mean" where a
key or value is close to one the schema takes.
"""

from __future__ import annotations

import difflib
import json
import re
import types
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError

from schemas._errors import SchemaError
from schemas._files import EVENT_MEANINGS, LogRecord, NearMiss

M = TypeVar("M", bound=BaseModel)

#: The prefix of a problem about keys a file holds that no field takes.
IGNORED = "not graded, ignored"
#: Keys a team is likely to write for a field of another name (field → its likely names),
#: answered with "did you mean" when the field is missing.
LIKELY_NAMES: dict[str, tuple[str, ...]] = {
    "event": ("type", "kind", "event_type", "name"),
    "exception_type": ("exception", "type", "kind"),
    "step": ("t", "timestep", "step_count", "steps", "time"),
    "id": ("instance_id", "object_id", "uid", "name"),
    "state": ("status",),
    "tool": ("tool_id",),
    "affordance": ("action", "affordances"),
    "rooms": ("from", "to", "between"),
    "category": ("class", "label", "type", "name"),
}

#: Values a team is likely to write for one of ours, by field (their value → ours): only
#: words that mean the same thing (a value not here gets the list of ours, never a guess
#: by spelling: ``execution_start`` is no ``exception_detected``).
VALUE_SYNONYMS: dict[str, dict[str, str]] = {
    "event": {
        "perception": "observation", "observe": "observation", "observed": "observation",
        "sensing": "observation",
        "act": "action", "action_taken": "action", "execute_action": "action",
        "planning": "plan", "plan_created": "plan", "new_plan": "plan",
        "replanning": "replan", "plan_changed": "replan", "plan_update": "replan",
        "world_model_update": "model_update", "model_updated": "model_update",
        "belief_update": "model_update", "map_update": "model_update",
        "exception": "exception_detected", "execution_exception": "exception_detected",
        "exception_detection": "exception_detected", "detected_exception":
            "exception_detected", "exception_found": "exception_detected",
        "execution_start": "stage", "exploration_start": "stage", "planning_start": "stage",
        "stage_start": "stage", "stage_begin": "stage", "stage_change": "stage",
        "new_stage": "stage",
        "retry": "attempt", "attempt_start": "attempt",
        "comment": "note", "info": "note", "message": "note", "log": "note",
    },
    "exception_type": {
        "locked_door": "door_lock", "door_locked": "door_lock",
        "object_relocated": "object_relocation", "object_moved": "object_relocation",
        "relocation": "object_relocation",
        "container_locked": "container_unavailable",
        "target_relocated": "target_moved",
    },
}


def value_hint(field: str, value: str, choices: Sequence[str]) -> str:
    """What a bad ``value`` of ``field`` gets in the report: ours where ``VALUE_SYNONYMS``
    has it (with its meaning for an event), else the values we take; "" for a field
    the table does not cover."""
    table = VALUE_SYNONYMS.get(field)
    if table is None:
        return ""
    ours = table.get(value) or table.get(value.strip().lower())
    if ours is not None and ours in choices:
        meaning = f" ({EVENT_MEANINGS[ours]})" if field == "event" else ""
        how = " with its stage named in 'stage'" if ours == "stage" else ""
        return f"got {value!r}, not ours: write {ours!r}{how}{meaning}"
    return (f"got {value!r}, not one of ours ({', '.join(choices)}"
            + ("; `eagc check-files` lists what each means" if field == "event" else "")
            + ")")


@dataclass(frozen=True)
class Problem:
    """One problem at one place: ``loc`` the path (keys and list indices; a JSON-lines
    file's line number first, as ``("line", n)``), ``msg`` what is wrong."""

    loc: tuple[Any, ...]
    msg: str
    unknown: bool = False
    """A key no field takes (ignored where the model allows extra keys)."""
    whole: bool = False
    """About the file (or line) as a whole: printed without a path."""
    ungraded: bool = False
    """In a field nothing grades: alone, it would not refuse the file (printed last)."""


# --------------------------------------------------------------------------- walking
def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The models a field's annotation holds (``list[Room]``, ``Room | None``, …)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    out: list[type[BaseModel]] = []
    for a in get_args(annotation):
        out += _models_in(a)
    return out


def _names(model: type[BaseModel]) -> dict[str, str]:
    """Every key the model reads (names and aliases) → the field's name."""
    out: dict[str, str] = {}
    for name, f in model.model_fields.items():
        out[name] = name
        alias = f.validation_alias
        for choice in getattr(alias, "choices", [alias] if isinstance(alias, str) else []):
            if isinstance(choice, str):
                out[choice] = name
        if f.alias:
            out[f.alias] = name
    return out


def unknown_keys(doc: Any, model: type[BaseModel],
                 loc: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Paths of the keys in ``doc`` that no field of ``model`` (or of the models its
    fields hold) reads. Only through dicts and lists; what does not match is left to the
    validation's own errors."""
    if not isinstance(doc, dict):
        return []
    names = _names(model)
    out: list[tuple[Any, ...]] = []
    for key, value in doc.items():
        field = names.get(key)
        if field is None:
            out.append((*loc, key))
            continue
        ann = model.model_fields[field].annotation
        inner = _models_in(ann)
        if len(inner) != 1:
            continue
        sub = inner[0]
        if isinstance(value, dict):
            out += unknown_keys(value, sub, (*loc, key))
        elif isinstance(value, list) and get_origin(ann) in (list, tuple, Union,
                                                             types.UnionType, None):
            for i, v in enumerate(value):
                out += unknown_keys(v, sub, (*loc, key, i))
    return out


def model_at(model: type[BaseModel], loc: Sequence[Any]) -> tuple[type[BaseModel],
                                                                   tuple[Any, ...]]:
    """The innermost model along ``loc`` and the path to it (for an example and a
    schema reference of what failed)."""
    here: type[BaseModel] = model
    path: tuple[Any, ...] = ()
    for i, key in enumerate(loc):
        if isinstance(key, int):
            continue
        f = here.model_fields.get(_names(here).get(str(key), ""))
        if f is None:
            break
        inner = _models_in(f.annotation)
        if len(inner) != 1:
            break
        here, path = inner[0], tuple(loc[:i + 1])
        rest = loc[i + 1:]
        if rest and isinstance(rest[0], int):
            path = (*path, rest[0])
    return here, path


def _graded(model: type[BaseModel], name: str) -> bool:
    extra = model.model_fields[name].json_schema_extra
    return isinstance(extra, dict) and extra.get("graded") is True


def ungraded_at(model: type[BaseModel], loc: Sequence[Any]) -> tuple[Any, ...] | None:
    """The path (a prefix of ``loc``) of the first field along ``loc`` that no score
    reads, in a model that ignores extra keys (an agent's file); None when every field
    on the way is graded (or the file's ``version``): what fails there refuses the file."""
    here = model
    for i, key in enumerate(loc):
        if isinstance(key, int):
            continue
        name = _names(here).get(str(key))
        if name is None or name == "version" or here.model_config.get("extra") != "ignore":
            return None
        if not _graded(here, name):
            return tuple(loc[:i + 1])
        inner = _models_in(here.model_fields[name].annotation)
        if len(inner) != 1:
            return None
        here = inner[0]
    return None


def _without(doc: Any, paths: Iterable[tuple[Any, ...]]) -> Any:
    """A copy of ``doc`` without the keys at ``paths`` (each ends with a key)."""
    doc = json.loads(json.dumps(doc))
    for path in sorted(set(paths), key=len, reverse=True):
        parent = doc
        try:
            for key in path[:-1]:
                parent = parent[key]
            del parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            continue
    return doc


def _lenient(doc: Any, model: type[M], err: ValidationError
             ) -> tuple[M, list[Problem]] | None:
    """``doc`` validated without the fields nothing grades whose values failed, and the
    problems left out; None when a graded field failed too."""
    dropped: list[tuple[Any, ...]] = []
    left: list[Problem] = []
    for e in err.errors(include_url=False):
        path = ungraded_at(model, tuple(e["loc"])) if e["loc"] else None
        if path is None:
            return None
        dropped.append(path)
        left.append(Problem(tuple(e["loc"]), e["msg"]))
    try:
        return model.model_validate(_without(doc, dropped)), left
    except ValidationError:
        return None


def _quoted(text: str) -> list[str]:
    return re.findall(r"'([^']*)'", text)


def problems_of(err: ValidationError, doc: Any, model: type[BaseModel],
                prefix: tuple[Any, ...] = ()) -> list[Problem]:
    """The validation's problems, each at its path, with "did you mean" where a missing
    field or a wrong value is close to a key or value the file holds or the schema takes."""
    extras = unknown_keys(doc, model)
    errors = err.errors(include_url=False)
    # A model that forbids extra keys reports them itself, as errors: not twice, and not
    # as "ignored".
    forbidden = {tuple(e["loc"]) for e in errors if e["type"] == "extra_forbidden"}
    out = [Problem((*prefix, *x), "", True) for x in extras if tuple(x) not in forbidden]
    strict: list[Problem] = []  # reported first, as errors
    for e in errors:
        loc = tuple(e["loc"])
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            near = difflib.get_close_matches(
                str(loc[-1]), list(model_at(model, loc[:-1])[0].model_fields), n=1,
                cutoff=0.6)
            strict.append(Problem((*prefix, *loc), "unknown key: no field takes it" + (
                f" (did you mean {near[0]!r}?)" if near else "")))
            continue
        if e["type"] == "missing":
            siblings = [x[-1] for x in extras if x[:-1] == loc[:-1] and isinstance(x[-1], str)]
            hint = difflib.get_close_matches(str(loc[-1]), siblings, n=1, cutoff=0.6) or [
                k for k in LIKELY_NAMES.get(str(loc[-1]), ()) if k in siblings][:1]
            if hint:
                msg += f" (the file has {hint[0]!r}: did you mean {loc[-1]!r}?)"
        elif e["type"] in ("literal_error", "enum") and isinstance(e.get("input"), str):
            choices = _quoted(str(e.get("ctx", {}).get("expected", "")))
            field = _names(model_at(model, loc[:-1])[0]).get(str(loc[-1]), str(loc[-1]))
            told = value_hint(field, e["input"], choices)
            hint = difflib.get_close_matches(e["input"], choices, n=1, cutoff=0.6)
            if told:
                msg = told
            elif hint and len(choices) > 1:
                msg += f"; got {e['input']!r}: did you mean {hint[0]!r}?"
        ungraded = ungraded_at(model, loc) is not None
        if ungraded:
            msg += " (not graded: left out once the rest reads)"
        out.append(Problem((*prefix, *loc), msg, ungraded=ungraded))
    order = {tuple((*prefix, *x)): i for i, x in enumerate(extras)}  # the file's order
    strict.sort(key=lambda p: order.get(p.loc, len(order)))
    return [*strict, *out]


# ------------------------------------------------------------------------ the format
def _spans(numbers: Iterable[int]) -> str:
    """``1-3, 7`` for 1, 2, 3, 7."""
    runs: list[list[int]] = []
    for i in sorted(set(numbers)):
        if runs and runs[-1][1] == i - 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def _path(loc: Sequence[Any]) -> str:
    parts = [str(p) for p in loc if not (isinstance(p, str) and p == "line")]
    return ".".join(parts) or "(top level)"


def problem_lines(problems: Sequence[Problem]) -> list[str]:
    """The report of a file's problems: one line per field path and problem, the keys
    nothing reads first (gathered in one line), then the others in file order (those in
    fields nothing grades last); list
    indices (and JSON-lines line numbers) gathered: ``objects.*.id: Field required
    (objects 0-3, 7)``, ``lines 1-488: event: Field required``."""
    groups: dict[tuple[bool, str, str], list[tuple[int, ...]]] = {}
    for p in sorted(problems, key=lambda p: (not p.unknown, p.ungraded)):
        line = p.loc[1] if p.loc[:1] == ("line",) else None
        rest = p.loc[2:] if line is not None else p.loc
        pattern = ".".join("*" if isinstance(x, int) else str(x) for x in rest)
        key = (p.unknown, "line" if line is not None else "",
               "" if p.whole else pattern or "(top level)")
        nums = tuple(x for x in rest if isinstance(x, int))
        groups.setdefault((*key[:2], f"{key[2]}\0{p.msg}"), []).append(
            ((line,) if line is not None else ()) + nums)
    lines: list[str] = []
    unknown = [(k, v) for k, v in groups.items() if k[0]]
    if unknown:
        keys = []
        for (_, kind, pm), where in unknown:
            pattern = pm.split("\0")[0]
            keys.append(_where(kind, pattern, where, short=True))
        lines.append(f"{IGNORED}: " + ", ".join(keys))
    for (is_unknown, kind, pm), where in groups.items():
        if is_unknown:
            continue
        pattern, msg = pm.split("\0")
        where_ = _where(kind, pattern, where).removesuffix(": (top level)")
        lines.append(f"{where_.removesuffix(': ')}: {msg}" if where_ else msg)
    return lines


def _where(kind: str, pattern: str, where: list[tuple[int, ...]], *, short: bool = False
           ) -> str:
    """A gathered path: ``objects.3.id``, ``objects.*.id (objects 0-3)``, ``lines 1-4:
    event``."""
    lead = ""
    if kind == "line":
        lines = [w[0] for w in where]
        lead = (f"line {lines[0]}" if len(set(lines)) == 1
                else f"lines {_spans(lines)}") + ": "
        where = [w[1:] for w in where]
    distinct = sorted(set(where))
    if len(distinct) <= 1:
        nums = iter(distinct[0] if distinct else ())
        path = ".".join(str(next(nums)) if part == "*" else part
                        for part in pattern.split("."))
        return lead + path
    first_star = pattern.split(".").index("*") if "*" in pattern.split(".") else -1
    owner = pattern.split(".")[first_star - 1] if first_star > 0 else "items"
    count = len({w[:1] for w in distinct})
    at = (f"{owner} {_spans(w[0] for w in distinct)}" if all(len(w) == 1 for w in distinct)
          else f"{len(distinct)} places in {count} {owner}")
    return lead + (f"{pattern} [{at}]" if short else f"{pattern} ({at})")


def report(problems: Sequence[Problem]) -> str:
    """``problem_lines`` as one text (a ``FileCheck.reason``): the lines, one each."""
    return "\n".join(problem_lines(problems))


def reason_lines(reason: str) -> list[str]:
    """The lines of a ``FileCheck.reason`` (what ``report`` wrote, or an older one-line
    reason), without the bullets of ``SchemaError``'s text."""
    return [line.strip().removeprefix("- ").strip() for line in reason.splitlines()
            if line.strip()]


class FileProblems(SchemaError):
    """Raised when a file does not validate; ``problems`` holds every one, at its path
    (``Problem``), and ``lines`` the report (``problem_lines``)."""

    def __init__(self, source: str, found: Sequence[Problem],
                 model: type[BaseModel] | None = None) -> None:
        self.found = tuple(found)
        self.model = model
        self.lines = problem_lines(found)
        super().__init__(source, self.failing + self.ignored)

    @property
    def failing(self) -> list[str]:
        """The lines of what makes the file fail."""
        return [line for line in self.lines if not line.startswith(f"{IGNORED}: ")]

    @property
    def ignored(self) -> list[str]:
        """The line of the keys nothing reads (empty or one line)."""
        return [line for line in self.lines if line.startswith(f"{IGNORED}: ")]

    @property
    def detail(self) -> str:
        """Every line of the report (none left out), without the file's name: what
        fails first (its first line is the one-line summary), the ignored keys last."""
        return "\n".join(self.failing + self.ignored)


# -------------------------------------------------------------------------- parsing
def _record(obj: BaseModel, ignored: Sequence[str], unreadable: Sequence[str] = (),
            near: Sequence[str] = ()) -> None:
    if ignored and hasattr(obj, "_ignored"):
        obj._ignored = tuple(ignored)
    if unreadable and hasattr(obj, "_unreadable"):
        obj._unreadable = tuple(unreadable)
    if near and hasattr(obj, "_near_misses"):
        obj._near_misses = tuple(near)


def near_misses(doc: Any, model: type[BaseModel]) -> tuple[Any, list[str], set[str]]:
    """The near-miss shapes of ``model`` (its ``near_misses``) that the file's JSON
    ``doc`` holds: ``doc`` without the entries left out, a note on each shape
    (``NearMiss.note``), and the unknown top-level keys the notes say are not read."""
    misses: Sequence[NearMiss] = getattr(model, "near_misses", ())
    if not isinstance(doc, dict) or not misses:
        return doc, [], set()
    kept, notes, keys = dict(doc), [], set()
    for miss in misses:
        found, total = miss.find(doc)
        if not found:
            continue
        notes.append(miss.note(found, total, model))
        if miss.leave_out and miss.test is not None:
            kept[miss.key] = [e for e in kept[miss.key] if not miss.test(e)]
        elif miss.key not in _names(model):
            keys.add(miss.key)
    return kept, notes, keys


def _validate(doc: Any, model: type[M], prefix: tuple[Any, ...] = ()
              ) -> tuple[M | None, list[Problem]]:
    """``doc`` validated (fields nothing grades that fail are left out and reported;
    entries in a near-miss shape of a file's top object noted, some left out), or None
    and every problem."""
    lead = f"line {prefix[1]}: " if prefix else ""
    doc, near, said = near_misses(doc, model) if not prefix else (doc, [], set())
    unknown = [f"{lead}{_path(x)}" for x in unknown_keys(doc, model) if x[0] not in said]
    try:
        obj = model.model_validate(doc)
    except ValidationError as e:
        kept = _lenient(doc, model, e)
        if kept is None:
            problems = [p for p in problems_of(e, doc, model, prefix)
                        if not (p.unknown and p.loc[:1] and p.loc[0] in said)]
            return None, problems + [Problem((), n, whole=True, ungraded=True)
                                     for n in near]
        obj, left = kept
        _record(obj, unknown, [f"{lead}{line}" for line in problem_lines(left)], near)
        return obj, []
    _record(obj, unknown, (), near)
    return obj, []


class Records(list[M]):
    """``parse_jsonl``'s records, and what it left out: a record that fails is left out
    and reported by its line (``left_out``: the report, ``problem_lines``), the rest kept.

    Attributes:
        lines: the file's non-blank lines.
        left_lines: the numbers of the lines left out, in file order.
        left_out: the report of what they held that fails, by line and value.
        left_ignored: the keys of the left-out lines that no field reads (``line N: key``).
        numbers: the line of each kept record, in order.
    """

    lines: int = 0
    left_lines: tuple[int, ...] = ()
    left_out: tuple[str, ...] = ()
    left_ignored: tuple[str, ...] = ()
    numbers: tuple[int, ...] = ()


def _line_of(key: str) -> int:
    head = key.partition(": ")[0].split()
    return int(head[1]) if len(head) == 2 and head[1].isdigit() else 0


def ignored_fields(parsed: Any) -> tuple[str, ...]:
    """The paths of the keys a parsed file held that no field reads (``parse_json``'s
    model, or ``parse_jsonl``'s records, kept or left out: ``line N: key``), in file
    order."""
    if isinstance(parsed, BaseModel):
        return tuple(getattr(parsed, "_ignored", ()) or ())
    if isinstance(parsed, list | tuple):
        keys = [k for rec in parsed for k in ignored_fields(rec)]
        keys += getattr(parsed, "left_ignored", ())
        return tuple(sorted(keys, key=_line_of))
    return ()


def left_out_lines(parsed: Any) -> tuple[str, ...]:
    """The report of the records a JSON-lines file held that were left out (``Records``):
    each by its line, with the value that failed."""
    return tuple(getattr(parsed, "left_out", ()) or ())


def unreadable_fields(parsed: Any) -> tuple[str, ...]:
    """The report lines of the fields nothing grades that could not be read (left out)."""
    if isinstance(parsed, BaseModel):
        return tuple(getattr(parsed, "_unreadable", ()) or ())
    if isinstance(parsed, list | tuple):
        return tuple(k for rec in parsed for k in unreadable_fields(rec))
    return ()


def ignored_note(name: str, parsed: Any, limit: int = 12) -> str | None:
    """The score card's note on the keys of file ``name`` that were ignored, or None.

    Keys are gathered like ``problem_lines``' (``objects.*.name``), at most ``limit``."""
    keys = ignored_fields(parsed)
    bad = unreadable_fields(parsed)
    gone = left_out_lines(parsed)
    if not keys and not bad and not gone:
        return None
    unread = ("; unreadable, not graded, left out: " + "; ".join(bad[:limit])
              + (f"; … ({len(bad) - limit} more)" if len(bad) > limit else "")) if bad else ""
    if gone:
        n, total = len(parsed.left_lines), parsed.lines
        unread = (f"; {n} of {total} line{'s' * (total > 1)} left out, not graded (the "
                  "rest is): " + "; ".join(gone[:limit])
                  + (f"; … ({len(gone) - limit} more)" if len(gone) > limit else "")
                  + unread)
    if not keys:
        return f"{name}: {unread.removeprefix('; ')}"
    found = []
    for k in keys:
        line, sep, rest = k.partition(": ")
        loc: tuple[Any, ...] = tuple(int(x) if x.isdigit() else x
                                     for x in (rest if sep else k).split("."))
        if sep:
            loc = ("line", int(line.split()[1]), *loc)
        found.append(Problem(loc, "", True))
    text = problem_lines(found)[0].removeprefix(f"{IGNORED}: ")
    parts = re.split(r", (?![^\[]*\])", text)  # not inside "[objects 0-3, 7]"
    shown = ", ".join(parts[:limit]) + (f", … ({len(parts) - limit} more)"
                                         if len(parts) > limit else "")
    return f"{name}: {IGNORED}: {shown}{unread}"


def parse_json(data: bytes | str, model: type[M], *, source: str) -> M:
    """Parse one JSON document into ``model``; raise ``FileProblems`` (a SchemaError)
    naming ``source`` and every problem at its path. Keys the model ignores, and the
    fields nothing grades whose values could not be read (left out), are kept on the
    result (``ignored_fields``, ``unreadable_fields``)."""
    try:
        doc = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise FileProblems(source, [Problem((), f"not valid JSON: {e}", whole=True)],
                           model) from None
    obj, problems = _validate(doc, model)
    if obj is None:
        raise FileProblems(source, problems, model)
    return obj


def load_json(path: Path | str, model: type[M]) -> M:
    """Read and validate a JSON file."""
    return parse_json(Path(path).read_bytes(), model, source=str(path))


def parse_jsonl(
    # A TypeVar-typed parameter cannot have a default in mypy (python/mypy#3737): LogRecord
    # is an M for every call that leaves ``model`` out.
    data: bytes | str, model: type[M] = LogRecord, *,  # type: ignore[assignment]
    source: str, per_record: bool = False
) -> Records[M]:
    """Parse JSON lines; every bad line is reported by its number, none is silently dropped.

    ``per_record``: a line that is not JSON or not a valid record is left out and reported
    (``Records.left_out``), the rest kept; only a file with no valid record at all (none
    of its lines JSON, or none a record) is refused (``FileProblems``). Otherwise any bad
    line refuses the file."""
    text = data.decode("utf-8", errors="replace") if isinstance(data, bytes) else data
    records: Records[M] = Records()
    numbers: list[int] = []
    problems: list[Problem] = []
    left: list[int] = []
    ignored: list[str] = []
    unknown: list[Problem] = []
    lines = 0
    for no, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        lines += 1
        try:
            doc = json.loads(line)
        except json.JSONDecodeError as e:
            problems.append(Problem(("line", no), f"not valid JSON: {e}", whole=True))
            left.append(no)
            continue
        rec, bad = _validate(doc, model, ("line", no))
        if rec is not None:
            records.append(rec)
            numbers.append(no)
            continue
        left.append(no)
        problems += [p for p in bad if not p.unknown]
        unknown += [p for p in bad if p.unknown]
        ignored += [f"line {no}: {_path(p.loc[2:])}" for p in bad if p.unknown]
    if problems and (not per_record or not records):
        raise FileProblems(source, [*unknown, *problems], model)
    records.lines, records.numbers = lines, tuple(numbers)
    records.left_lines, records.left_ignored = tuple(left), tuple(ignored)
    records.left_out = tuple(problem_lines(problems))
    return records


def parse_episode_log(data: bytes | str, *, source: str = "episode_log.jsonl"
                      ) -> Records[LogRecord]:
    """Parse ``episode_log.jsonl``, graded per record (SchemaError only for a file that
    says nothing: empty, or no line a valid record).

    A valid log has at least one record, one ``LogRecord`` per line (blank lines are
    ignored), records in time order (``step`` never decreases from one record to the
    next) and an ``exception_type`` on every ``exception_detected`` record. A line that
    is not one (not JSON, an invalid field or value, a step before the record above it)
    is left out and reported by its line and value (``Records.left_out``); the rest is
    graded.
    """
    parsed = parse_jsonl(data, LogRecord, source=source, per_record=True)
    if not parsed.lines:
        raise FileProblems(source, [Problem((), "empty: a log holds at least one record "
                                            "(e.g. a 'stage' record as each stage begins)",
                                            whole=True)],
                           LogRecord)
    kept: Records[LogRecord] = Records()
    numbers: list[int] = []
    late: list[Problem] = []
    for no, rec in zip(parsed.numbers, parsed, strict=True):
        if kept and rec.step < kept[-1].step:
            late.append(Problem(("line", no, "step"), f"{rec.step} comes after step "
                                f"{kept[-1].step}: records are in time order"))
            continue
        kept.append(rec)
        numbers.append(no)
    if not late:
        return parsed
    kept.lines, kept.numbers = parsed.lines, tuple(numbers)
    kept.left_lines = tuple(sorted({*parsed.left_lines, *(p.loc[1] for p in late)}))
    kept.left_out = (*parsed.left_out, *problem_lines(late))
    held = {id(rec) for rec in kept}
    ignored = {k for rec in parsed if id(rec) not in held for k in ignored_fields(rec)}
    kept.left_ignored = (*parsed.left_ignored, *sorted(ignored, key=_line_of))
    return kept
