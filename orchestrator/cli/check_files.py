"""``eagc check-files DIR --track T [--stage S] [--disclosure FILE]``: a team's files, checked
offline as the host checks them, and its resource disclosure as a campaign checks it.

The folder is read as the host reads ``/output`` (``orchestrator._episode.collect``: top-level
regular files only, nothing followed, the default size caps) and checked by the track's own
``TrackPlugin.verify_files``, the code the host runs. Each file gets every problem, one line
per field path (``schemas._io.problem_lines``: the keys nothing grades first, then what fails),
then a valid example of each object that failed and where its JSON Schema is. A resource
disclosure (``--disclosure``) gets the same lines, from the check ``load_campaign`` runs
(``orchestrator._campaign.disclosure``).

Mount with ``app.command("check-files", epilog=CHECK_FILES_CODES)(check_files_cmd)``.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path
from typing import Annotated, Any

import typer
from pydantic import BaseModel, ValidationError
from rich.console import Console

from orchestrator._errors import UsageError
from orchestrator.cli.common import ExitCode, _suggest, check_track

CHECK_FILES_CODES = ("Exit codes: 0 every file validates (keys nothing grades are listed, "
                     "not errors); 1 a file (or the disclosure) does not validate, a log "
                     "has lines left out (the host grades the rest), or a required file is "
                     "missing; 2 usage error (no such folder, file, track or stage).")

out = Console(highlight=False, soft_wrap=True, markup=False)


def example_of(model: type[BaseModel]) -> Any:
    """A valid instance of ``model`` as JSON: its schema's first example, else what its
    defaults make (None when it has required fields and no example)."""
    examples = (model.model_config.get("json_schema_extra") or {})
    if isinstance(examples, dict) and examples.get("examples"):
        return examples["examples"][0]
    try:
        return model().model_dump(mode="json")
    except ValidationError:
        return None


def schema_of(top: type[BaseModel], model: type[BaseModel]) -> str:
    """Where the JSON Schema of ``model`` (a part of file model ``top``) is."""
    from schemas import JSON_DIR, TARGETS

    name = next((n for n, t in TARGETS.items() if t is top), None)
    if name is None:
        return ""
    # by its path in the repository, wherever eagc is installed or run from
    shown = f"{JSON_DIR.parent.name}/{JSON_DIR.name}/{name}.json"
    return shown + ("" if model is top else f"#/$defs/{model.__name__}")


def _spans(numbers: tuple[int, ...]) -> str:
    """``1-3, 7`` for 1, 2, 3, 7 (sorted numbers)."""
    runs: list[list[int]] = []
    for i in numbers:
        if runs and runs[-1][1] == i - 1:
            runs[-1][1] = i
        else:
            runs.append([i, i])
    return ", ".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def meaning_lines(left_out: list[str]) -> list[str]:
    """The events we take, one line each with its meaning, when a left-out line held an
    event value with no synonym of ours (``schemas.VALUE_SYNONYMS``)."""
    from schemas import EVENT_MEANINGS

    if not any(": event" in x and "not one of ours" in x for x in left_out):
        return []
    return ["the events a log takes:", *(f"  {e}: {m}" for e, m in EVENT_MEANINGS.items())]


def failing_models(top: type[BaseModel], data: bytes, jsonl: bool
                   ) -> list[type[BaseModel]]:
    """The models (``top`` or its parts) of the objects that failed, in file order."""
    from schemas import FileProblems, model_at, parse_episode_log, parse_json

    try:
        if jsonl:
            parse_episode_log(data)
        else:
            parse_json(data, top, source="-")
    except FileProblems as e:
        found: list[type[BaseModel]] = []
        for p in e.found:
            if p.unknown:
                continue
            loc = p.loc[2:] if p.loc[:1] == ("line",) else p.loc
            if p.whole:
                continue
            model = model_at(top, loc)[0]
            if model not in found:
                found.append(model)
        return found
    return []


def check_folder(folder: Path, track: str, stage: str | None = None) -> tuple[bool, list[str]]:
    """Checks ``folder`` as the host checks ``/output``; returns (ok, report lines)."""
    from orchestrator._episode.collect import collect
    from orchestrator._results.score_card import file_lines
    from schemas import IGNORED, Limits, LogRecord, ignored_note, parse_episode_log

    def wrapped(text: str, limit: int, indent: str = "") -> list[str]:
        return textwrap.wrap(text, limit, initial_indent=indent,
                             subsequent_indent=indent + "    ", break_long_words=False,
                             break_on_hyphens=False)

    plugin = check_track(track)
    stages = [s.name for s in plugin.stages()]
    if stage is not None and stage not in stages:
        raise UsageError(f"track {track!r} has no stage {stage!r}.{_suggest(stage, stages)} "
                         f"Its stages: {', '.join(stages)}")
    if not folder.is_dir():
        raise UsageError(f"{folder} is not a folder: give the folder your agent writes "
                         "(its /output)")
    limits = Limits()
    got = collect(folder, max_file_bytes=limits.output_file_mb << 20,
                  max_total_bytes=limits.output_mb << 20)
    _, checks = plugin.verify_files(got.files)
    limit = 80
    when = f"the snapshot at the end of stage {stage}" if stage else "the end of the episode"
    lines = wrapped(f"{track} files in {folder}, checked as the host checks them at {when}:",
                    limit)
    ok = True
    for c in (*checks, *got.refused):
        rule = plugin.files.get(c.name)
        log = (parse_episode_log(got.files[c.name], source=c.name)
               if c.ok and rule is not None and rule.jsonl else None)
        if log is not None and log.left_lines:
            ok = False
            n = len(log.left_lines)
            lines += wrapped(f"{c.name}: {n} of {log.lines} line{'s' * (log.lines > 1)} "
                             f"left out, not graded (line{'s' * (n > 1)} "
                             f"{_spans(log.left_lines)}); the rest is graded", limit)
            ignored = ignored_note(c.name, log)
            keys = [] if ignored is None or f"{IGNORED}: " not in ignored else [
                ignored.removeprefix(f"{c.name}: ").split("; ")[0]]
            for line in [*keys, *log.left_out]:
                lines += wrapped(line, limit, "  ")
            for line in meaning_lines(list(log.left_out)):
                lines += wrapped(line, limit, "  ")
            continue
        if c.ok:
            lines.append(f"{c.name}: ok")
            for line in file_lines(c.reason):
                lines += wrapped(line, limit, "  ")
            continue
        if c.reason == "missing" and stage is not None:
            lines += wrapped(f"{c.name}: not there (a stage's snapshot holds what was "
                             "written by then)", limit)
            continue
        ok = False
        problems = file_lines(c.reason) or ["refused"]
        data = got.files.get(c.name, b"")
        count = sum(1 for x in data.decode("utf-8", "replace").splitlines() if x.strip())
        if rule is not None and rule.jsonl and c.name in got.files:
            # refused whole: no line holds a valid record
            lines.append(f"{c.name}: FAILS (" + (f"all {count} lines" if count > 1 else
                                                 "its one line" if count else "empty") + ")")
        else:
            lines.append(f"{c.name}: FAILS")
        for line in problems:
            lines += wrapped(line, limit, "  ")
        for line in meaning_lines(problems):
            lines += wrapped(line, limit, "  ")
        if rule is None or c.size is None:
            continue
        top = rule.model or LogRecord
        for model in failing_models(top, got.files.get(c.name, b""), rule.jsonl):
            example = example_of(model)
            if example is not None:
                lines += wrapped(f"a valid {model.__name__}: "
                                 f"{json.dumps(example, separators=(', ', ': '))}",
                                 limit, "  ")
            where = schema_of(top, model)
            if where:
                lines += wrapped(f"its schema: {where}", limit, "  ")
    for name in sorted(set(got.files) - set(plugin.files)):
        lines.append(f"{name}: not a file of {track} (not read)")
    lines.append("every file validates" if ok else "a file does not validate (or lines of "
                 "a log were left out)")
    return ok, lines


def check_disclosure(path: Path) -> tuple[bool, list[str]]:
    """Checks a resource disclosure file (``schemas.ResourceDisclosure``, YAML or JSON) as
    a campaign checks it; returns (ok, report lines)."""
    from orchestrator._campaign.disclosure import KeptDisclosure as Kept
    from orchestrator._campaign.disclosure import (
        disclosure_problems,
        read_disclosure,
        summary_lines,
    )
    from schemas import ResourceDisclosure

    if not path.is_file():
        raise UsageError(f"{path} is not a file: give your resource disclosure "
                         "(YAML or JSON)")
    limit = 80
    wrap = lambda text, indent="": textwrap.wrap(  # noqa: E731
        text, limit, initial_indent=indent, subsequent_indent=indent + "    ",
        break_long_words=False, break_on_hyphens=False)
    problems = disclosure_problems(path)
    lines = wrap(f"resource disclosure {path}, checked as a campaign checks it:")
    if not problems:
        kept = Kept(team="-", status="ok", source=str(path), disclosure=read_disclosure(path))
        lines.append(f"{path.name}: ok")
        for line in summary_lines(kept)[1:]:
            lines += wrap(line, "  ")
        return True, lines
    lines.append(f"{path.name}: FAILS ({len(problems)} line{'s' * (len(problems) > 1)})")
    for line in problems:
        lines += wrap(line, "  ")
    example = example_of(ResourceDisclosure)
    lines += wrap(f"a valid ResourceDisclosure: {json.dumps(example, separators=(', ', ': '))}",
                  "  ")
    lines += wrap(f"its schema: {schema_of(ResourceDisclosure, ResourceDisclosure)}", "  ")
    return False, lines


def check_files_cmd(
    folder: Annotated[Path | None, typer.Argument(
        help="The folder your agent writes (its /output).")] = None,
    track: Annotated[str | None, typer.Option(
        help="The track whose files these are (needed with FOLDER).")] = None,
    stage: Annotated[str | None, typer.Option(
        help="Check it as the snapshot at this stage's end (missing files are fine).")
                     ] = None,
    disclosure: Annotated[Path | None, typer.Option(
        help="Check this resource disclosure file too (YAML or JSON), as a campaign "
        "that names it in `disclosure:` does.")] = None,
) -> None:
    """Check your agent's files offline, exactly as the host checks them: every problem by
    field path, a valid example of what failed and its JSON Schema."""
    if folder is None and disclosure is None:
        raise UsageError("give the folder your agent writes (with --track), or "
                         "--disclosure FILE, or both")
    if folder is not None and track is None:
        raise UsageError("--track: which track's files are in "
                         f"{folder}? (e.g. --track track1)")
    ok, lines = True, []
    if folder is not None and track is not None:
        ok, lines = check_folder(folder, track, stage)
    if disclosure is not None:
        good, more = check_disclosure(disclosure)
        ok, lines = ok and good, [*lines, *([""] if lines else []), *more]
    out.print("\n".join(lines))
    raise typer.Exit(ExitCode.OK if ok else ExitCode.ERROR)
