"""``OutputFiles``: how an agent writes its files to ``/output`` (light: pydantic only).

The host snapshots ``/output`` at every stage end and at exit, reads regular files only and
validates them against ``schemas/``. So a file must never be seen half-written: each model
file is written to a temporary name starting with a dot and renamed over the real one, and
each log record is appended as one line in one write. Models are checked here, before they
are written, so that an agent learns of a bad file at once instead of from its score card::

    files = OutputFiles()                      # $EAGC_OUTPUT, /output in a container
    files.write(WorldModel(...))               # -> world_model.json
    files.log(step=12, stage="execution", event="exception_detected",
              exception_type="door_lock")      # -> one line of episode_log.jsonl
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from schemas import CONTAINER, LogRecord, TaskModel, WorldModel
from simhost._errors import SimHostError

__all__ = ["LOG_FILE", "MODEL_FILES", "OutputFiles", "OutputFileError"]

#: The model file each schema model is written to.
MODEL_FILES: dict[type[BaseModel], str] = {
    WorldModel: "world_model.json",
    TaskModel: "task_model.json",
}
#: The log every track reads.
LOG_FILE = "episode_log.jsonl"


class OutputFileError(SimHostError, ValueError):
    """Raised when a file would not pass the host's schema check (the message names the
    field and the problem), or its name is not a plain file name."""


def _first_problem(e: ValidationError) -> str:
    first = e.errors(include_url=False)[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(document)"
    return f"{loc}: {first['msg']}"


class OutputFiles:
    """Writes ``/output``'s files atomically, checked against their schemas.

    Args:
        folder: where to write (default ``$EAGC_OUTPUT``, else the contract's ``/output``).
    """

    def __init__(self, folder: str | os.PathLike[str] | None = None) -> None:
        self.folder = Path(folder or os.environ.get(CONTAINER.env_output)
                           or CONTAINER.output_dir)
        self._log_fd: int | None = None

    def write(self, doc: BaseModel | Mapping[str, Any], name: str | None = None) -> Path:
        """Writes a model file atomically (temporary dot-name, then rename).

        ``doc`` is a schema model (``WorldModel`` → ``world_model.json``, ``TaskModel`` →
        ``task_model.json``) or a plain mapping with ``name`` given; a mapping for one of
        those two names is validated against its model first. Raises ``OutputFileError``.
        """
        models = {v: k for k, v in MODEL_FILES.items()}
        if isinstance(doc, BaseModel):
            name = name or MODEL_FILES.get(type(doc))
            if name is None:
                raise OutputFileError(f"{type(doc).__name__}: pass the file name")
            data = doc.model_dump_json(exclude_none=True).encode()
        else:
            if name is None:
                raise OutputFileError("a plain mapping needs its file name")
            model = models.get(name)
            try:
                checked = (model or _Any).model_validate(dict(doc))
            except ValidationError as e:
                raise OutputFileError(f"{name}: {_first_problem(e)}") from None
            data = checked.model_dump_json(exclude_none=True).encode()
        if not name or "/" in name or name.startswith("."):
            raise OutputFileError(f"{name!r} is not a plain file name")
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = self.folder / f".{name}.tmp"
        tmp.write_bytes(data)
        os.replace(tmp, self.folder / name)
        return self.folder / name

    def log(self, record: LogRecord | Mapping[str, Any] | None = None, **fields: Any) -> None:
        """Appends one record to ``episode_log.jsonl``: a ``LogRecord``, a mapping, or its
        fields as keywords (``step``, ``stage``, ``event``, ``exception_type``, ``data``).
        Raises ``OutputFileError`` for a record the host would reject."""
        if not isinstance(record, LogRecord):
            try:
                record = LogRecord.model_validate({**dict(record or {}), **fields})
            except ValidationError as e:
                raise OutputFileError(f"{LOG_FILE}: {_first_problem(e)}") from None
        line = record.model_dump_json(exclude_none=True).encode() + b"\n"
        if self._log_fd is None:
            self.folder.mkdir(parents=True, exist_ok=True)
            self._log_fd = os.open(self.folder / LOG_FILE,
                                   os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        os.write(self._log_fd, line)  # one write: a snapshot never sees half a line

    def close(self) -> None:
        """Closes the log (idempotent)."""
        if self._log_fd is not None:
            os.close(self._log_fd)
            self._log_fd = None


class _Any(BaseModel):
    """Any JSON object (files without a schema model)."""

    model_config = {"extra": "allow"}
