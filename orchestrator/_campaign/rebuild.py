"""Rebuilding a campaign's rows of the results store from its folder (``rebuild-store``).

Every episode folder keeps its ``host/result.json`` and the driver keeps ``events.jsonl``
(which episode id ran which key, at which retry, on which node; what was committed, retried
or quarantined). Together they hold everything the store holds for a campaign, so a store
that was lost, truncated, overwritten or corrupted can be rebuilt, and one that missed
rows (a disk that filled up) can be repaired:

* a damaged file is moved aside (``results.sqlite.damaged-<time>``) and a new one started;
* a sound one is kept and completed: commits are once-only, so nothing in it changes;
* final results (agent outcomes) are committed, the one ``events.jsonl`` names as committed
  first, else the earliest; infrastructure failures and killed attempts (a ``retry`` event
  without a result) become attempts; a key whose last word is ``quarantined`` and that has
  no final result is quarantined again;
* the tallies are recounted from the rows.

A damaged store file may have held other campaigns too: rebuild each of them the same way.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field
from pathlib import Path

from orchestrator._results.store import (
    EpisodeKey,
    ResultsStore,
    StoreDamaged,
)
from schemas import (
    CampaignEvent,
    CampaignSpec,
    Committed,
    EpisodeResult,
    EpisodeWhere,
    Retried,
    Started,
    parse_event,
)


@dataclass
class RebuildReport:
    """What ``rebuild_store`` did."""

    store: Path
    moved_aside: Path | None = None
    results_read: int = 0
    committed: int = 0
    already: int = 0
    attempts: int = 0
    quarantined: int = 0
    unattributed: list[str] = field(default_factory=list)  # results with no key in events
    unreadable: list[str] = field(default_factory=list)  # result.json that did not parse


def read_events(path: Path) -> list[CampaignEvent]:
    """``events.jsonl``; a line cut short (a full disk, a kill) is skipped."""
    if not path.exists():
        return []
    lines = path.read_text(errors="replace").splitlines()
    return [ev for ev in map(parse_event, lines) if ev is not None]


def committed_episodes(events: list[CampaignEvent]) -> set[str]:
    """Episode ids ``events.jsonl`` says were committed."""
    return {e.episode for e in events if isinstance(e, Committed) and e.event == "committed"}


def _move_aside(path: Path) -> Path:
    stamp = time.strftime("%Y%m%d-%H%M%S")
    target = path.with_name(f"{path.name}.damaged-{stamp}")
    for suffix in ("", "-wal", "-shm"):
        src = path.with_name(path.name + suffix)
        if src.exists():
            shutil.move(str(src), str(target.with_name(target.name + suffix)))
    return target


def open_or_replace(path: Path) -> tuple[ResultsStore, Path | None]:
    """The store at ``path`` if it is sound, else a new one (the old file moved aside)."""
    try:
        store = ResultsStore(path)
        try:
            store.check()
        except StoreDamaged:
            store.close()
            raise
        return store, None
    except StoreDamaged:
        aside = _move_aside(path)
        return ResultsStore(path), aside


def rebuild_store(spec: CampaignSpec, folder: Path, store_file: Path, *, commitment: str,
                  planned: int) -> RebuildReport:
    """Rebuilds (or completes) ``spec``'s rows in ``store_file`` from ``folder``."""
    events = read_events(folder / "events.jsonl")
    where: dict[str, EpisodeWhere] = {}
    node: dict[str, str | None] = {}
    for ev in events:
        if isinstance(ev, Started | Committed | Retried):
            where[ev.episode] = ev
            node[ev.episode] = ev.node or node.get(ev.episode)
    named = committed_episodes(events)

    store, aside = open_or_replace(store_file)
    report = RebuildReport(store_file, moved_aside=aside)
    with store:
        store.register(spec, commitment, planned)
        finals: dict[EpisodeKey, list[tuple[bool, float, EpisodeResult, EpisodeWhere]]] = {}
        seen_attempts: set[str] = set()
        for path in sorted(folder.glob("ep*/host/result.json")):
            try:
                result = EpisodeResult.model_validate_json(path.read_bytes())
            except (OSError, ValueError) as e:
                report.unreadable.append(f"{path}: {str(e).splitlines()[0][:120]}")
                continue
            report.results_read += 1
            info = where.get(result.episode)
            if info is None:
                report.unattributed.append(result.episode)
                continue
            key = EpisodeKey(info.submission, info.split, info.index)
            if result.status.failure_kind == "infra":
                message = result.failure.message if result.failure else "infrastructure failure"
                store.record_attempt(spec.name, key, retry=info.retry,
                                     episode=result.episode, message=message,
                                     node=node.get(result.episode), result=result,
                                     at=result.finished_at)
                seen_attempts.add(result.episode)
                continue
            finals.setdefault(key, []).append(
                (result.episode not in named, result.finished_at, result, info))
        for key, candidates in finals.items():
            candidates.sort(key=lambda c: (c[0], c[1]))
            _, at, result, info = candidates[0]
            if store.commit(spec.name, key, result, retry=info.retry,
                            node=node.get(result.episode), at=at):
                report.committed += 1
            else:
                report.already += 1
        # Attempts whose worker died: only the driver's "retry"/"quarantined" events tell.
        last_word: dict[EpisodeKey, Retried] = {}
        for ev in events:
            if not isinstance(ev, Retried):
                continue
            key = EpisodeKey(ev.submission, ev.split, ev.index)
            if ev.episode not in seen_attempts:
                store.record_attempt(spec.name, key, retry=ev.retry, episode=ev.episode,
                                     message=ev.message, node=ev.node, result=None, at=ev.at)
                seen_attempts.add(ev.episode)
            last_word[key] = ev
        done = store.done(spec.name)
        for key, ev in last_word.items():
            if ev.event == "quarantined" and key not in done:
                store.quarantine(spec.name, key, episode=ev.episode, message=ev.message,
                                 retries=ev.retry)
                report.quarantined += 1
        store.retally()
        report.attempts = store.counts(spec.name).retries
    return report


def rebuild(spec: CampaignSpec) -> RebuildReport:
    """``eagc campaign rebuild-store``: ``rebuild_store`` at the campaign's own paths."""
    from orchestrator._campaign.seeds import commitment, load_secret, seed_list
    from orchestrator._campaign.spec import campaign_dir, plan, store_path

    seeds = seed_list(spec, load_secret(spec))
    return rebuild_store(spec, campaign_dir(spec), store_path(spec),
                         commitment=commitment(spec, seeds), planned=len(plan(spec)))
