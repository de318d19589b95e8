"""The files a track collects from ``/output``, and the one check of them.

``check_files`` is ``TrackPlugin.verify_files``' default: the host runs it on the collected
files and ``eagc check-files`` on a team's folder, so that a team sees what the host sees.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from pydantic import BaseModel

from schemas import (
    FileCheck,
    LogRecord,
    SchemaError,
    ignored_note,
    parse_episode_log,
    parse_json,
)

#: A collected file as ``check_files`` parsed it: its ``FileRule.model``, or the records of
#: a JSON-lines log.
ParsedFile = BaseModel | list[LogRecord]
#: The episode log every track collects (``FileRule(None, jsonl=True)``).
EPISODE_LOG = "episode_log.jsonl"


@dataclass(frozen=True)
class FileRule:
    """A file the agent writes to /output: its model (``None``: JSON lines of log records,
    checked by ``schemas.parse_episode_log``)."""

    model: type[BaseModel] | None
    required: bool = True
    jsonl: bool = False


def check_files(rules: Mapping[str, FileRule], files: Mapping[str, bytes]
                ) -> tuple[dict[str, ParsedFile], list[FileCheck]]:
    """The files of ``rules`` that parse, and one check per expected or present file: a
    refused file's ``reason`` holds every problem, one line per field path
    (``schemas._io.problem_lines``); a passed file's, the keys nothing grades (they are
    ignored, never a reason to refuse the file)."""
    parsed: dict[str, ParsedFile] = {}
    checks: list[FileCheck] = []
    for fname, rule in rules.items():
        data = files.get(fname)
        if data is None:
            if rule.required:
                checks.append(FileCheck(name=fname, ok=False, reason="missing"))
            continue
        try:
            if rule.jsonl:
                parsed[fname] = parse_episode_log(data, source=fname)
            else:
                assert rule.model is not None
                parsed[fname] = parse_json(data, rule.model, source=fname)
            note = ignored_note(fname, parsed[fname])
            checks.append(FileCheck(name=fname, ok=True, size=len(data),
                                    reason="" if note is None
                                    else note.removeprefix(f"{fname}: ")))
        except SchemaError as e:
            checks.append(FileCheck(name=fname, ok=False, size=len(data), reason=e.detail))
    return parsed, checks
