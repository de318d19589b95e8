"""``events.jsonl``: what a campaign's driver saw, one event a line (no seeds).

One discriminated union, ``CampaignEvent``, keyed by ``event``: the driver writes these
models and ``rebuild-store`` reads them back. Readers ignore fields they do not know, so a
newer driver's extra fields do not break an older reader.
"""

from __future__ import annotations

import time
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter, ValidationError


class _Event(BaseModel):
    model_config = ConfigDict(frozen=True, extra="ignore")

    at: float = Field(default_factory=time.time, description="Unix time it was written.")


class EpisodeWhere(BaseModel):
    """Which attempt of which episode of which submission an event is about."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    submission: str
    split: str
    index: int
    retry: int = 0
    episode: str


class Submitted(_Event):
    """Episodes were handed to Ray."""

    event: Literal["submitted"] = "submitted"
    episodes: int
    board_node: str | None = None


class Started(_Event, EpisodeWhere):
    """A worker started an episode."""

    event: Literal["started"] = "started"
    node: str | None = None
    host: str | None = None
    pid: int | None = None


class Committed(_Event, EpisodeWhere):
    """An episode's final result was committed to the store (``duplicate``: it already
    had one, and nothing changed)."""

    event: Literal["committed", "duplicate"] = "committed"
    node: str | None = None
    status: str
    score: float


class Retried(_Event, EpisodeWhere):
    """An infrastructure failure that is retried (``retry``) or, past the campaign's
    retries, held back (``quarantined``)."""

    event: Literal["retry", "quarantined"] = "retry"
    node: str | None = None
    message: str = ""


class Finished(_Event):
    """The driver ended its run."""

    event: Literal["finished"] = "finished"
    committed: int
    cancelled: bool
    wall_s: float


class Stopped(_Event):
    """The driver stopped early: cancelled (Ctrl-C) or failed (the store or the cluster)."""

    event: Literal["cancelled", "failed"] = "cancelled"
    pending: int
    reason: Literal["cluster", "store"] | None = None
    message: str = ""


CampaignEvent = Annotated[Submitted | Started | Committed | Retried | Finished | Stopped,
                          Field(discriminator="event")]
_ADAPTER: TypeAdapter[CampaignEvent] = TypeAdapter(CampaignEvent)


def event_line(event: CampaignEvent) -> str:
    """One line of ``events.jsonl`` (with its newline)."""
    return event.model_dump_json() + "\n"


def parse_event(line: str) -> CampaignEvent | None:
    """The event of one line; None for a line cut short (a full disk, a kill) or one of a
    kind this reader does not know."""
    try:
        return _ADAPTER.validate_json(line)
    except (ValidationError, ValueError):
        return None
