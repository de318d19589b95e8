"""Reading structured files with errors that name the file, the field and the problem."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TypeVar

from pydantic import BaseModel, ValidationError

from schemas._errors import SchemaError, describe
from schemas._files import LogRecord

M = TypeVar("M", bound=BaseModel)


def parse_json(data: bytes | str, model: type[M], *, source: str) -> M:
    """Parse one JSON document into ``model``; raise SchemaError naming ``source``."""
    try:
        doc = json.loads(data)
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise SchemaError(source, [f"not valid JSON: {e}"]) from None
    try:
        return model.model_validate(doc)
    except ValidationError as e:
        raise SchemaError(source, describe(e)) from None


def load_json(path: Path | str, model: type[M]) -> M:
    """Read and validate a JSON file."""
    return parse_json(Path(path).read_bytes(), model, source=str(path))


def parse_jsonl(
    data: bytes | str, model: type[M] = LogRecord, *, source: str  # type: ignore[assignment]
) -> list[M]:
    """Parse JSON lines; every bad line is reported by its number, none is silently dropped."""
    text = data.decode("utf-8", errors="replace") if isinstance(data, bytes) else data
    records: list[M] = []
    problems: list[str] = []
    for no, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            records.append(model.model_validate_json(line))
        except ValidationError as e:
            problems.extend(f"line {no}: {p}" for p in describe(e))
    if problems:
        raise SchemaError(source, problems)
    return records


def parse_episode_log(data: bytes | str, *, source: str = "episode_log.jsonl") -> list[LogRecord]:
    """Parse ``episode_log.jsonl`` and check what makes a log valid (SchemaError if not).

    A valid log has at least one record (an empty file says nothing: a failed check), one
    ``LogRecord`` per line (blank lines are ignored), records in time order (``step``
    never decreases from one record to the next) and an ``exception_type`` on every
    ``exception_detected`` record.
    """
    records = parse_jsonl(data, LogRecord, source=source)
    if not records:
        raise SchemaError(source, ["empty: a log holds at least one record (e.g. a 'stage' "
                                   "record as each stage begins)"])
    text = data.decode("utf-8", errors="replace") if isinstance(data, bytes) else data
    numbers = [no for no, line in enumerate(text.splitlines(), start=1) if line.strip()]
    problems = [
        f"line {no}: step: {rec.step} comes after step {prev.step}: records are in time order"
        for no, prev, rec in zip(numbers[1:], records, records[1:], strict=False)
        if rec.step < prev.step
    ]
    if problems:
        raise SchemaError(source, problems)
    return records
