"""A campaign's spec: read from YAML, resolved and checked; its episode plan; its paths.

``load_campaign`` reads ``campaign.yaml`` into a ``schemas.CampaignSpec``, takes the
submissions' relative file paths against the campaign file's folder (``resolved``) and
checks what the schema alone cannot (``check_campaign``); ``plan`` lists every (submission,
split, index), interleaved. The driver that runs the plan is ``orchestrator._campaign.driver``.

Files (``output`` is resolved against the working directory, archives against the
campaign file's folder)::

    <output>/results.sqlite            the results store (any number of campaigns)
    <output>/<campaign>/events.jsonl   submitted / started / committed / retry / quarantined /
                                       cancelled / failed / finished
    <output>/<campaign>/driver.lock    one driver per campaign
    <output>/<campaign>/ep…/           episode folders (organizer side)

The output folder is created private (0700): episode folders hold the hidden scenario
(MCAP logs) and the seed commitment's inputs are derived there.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from schemas import CampaignSpec, SchemaError, parse_json

#: ``<runs>/ep<16 hex>/sock/zenoh.sock`` must fit the 100 bytes the worker allows.
MAX_RUNS_DIR = 100 - len("/ep0123456789abcdef/sock/zenoh.sock")


def load_campaign(path: Path | str) -> CampaignSpec:
    """Reads and validates ``campaign.yaml``; SchemaError names the file and the field."""
    import yaml

    path = Path(path)
    try:
        text = path.read_text()
    except OSError as e:
        raise SchemaError(str(path), [f"cannot read the campaign file: {e.strerror or e}"]) from e
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise SchemaError(str(path), [f"not valid YAML: {e}"]) from None
    if not isinstance(doc, dict):
        raise SchemaError(str(path), ["(top level): a campaign file is a mapping (name: …)"])
    spec = resolved(parse_json(json.dumps(doc, default=str), CampaignSpec, source=str(path)),
                    path.parent)
    check_campaign(spec, source=str(path))
    return spec


def resolved(spec: CampaignSpec, folder: Path) -> CampaignSpec:
    """The spec with its submissions' relative file paths (archive, disclosure) taken
    against ``folder``, the campaign file's."""
    def beside(p: Path | None) -> Path | None:
        return (folder / p).resolve() if p is not None and not p.is_absolute() else p

    subs = tuple(s.model_copy(update={"archive": beside(s.archive),
                                      "disclosure": beside(s.disclosure)})
                 for s in spec.submissions)
    return spec.model_copy(update={"submissions": subs})


def check_campaign(spec: CampaignSpec, *, source: str) -> None:
    """What the schema alone cannot check: the track, split names, archives, disclosures
    (every problem of a named one), path lengths."""
    from plugins import PluginError, load_track

    problems: list[str] = []
    try:
        plugin = load_track(spec.track)
    except PluginError as e:
        raise SchemaError(source, [f"track: {e}"]) from None
    for i, split in enumerate(spec.splits):
        if plugin.splits and split.name not in plugin.split_names() and not split.params:
            problems.append(f"splits.{i}.name: track {spec.track!r} has no split "
                            f"{split.name!r} (it has {sorted(plugin.split_names())}); give "
                            "the split its params to define a new one")
    for i, sub in enumerate(spec.submissions):
        if sub.archive is not None and not sub.archive.is_file():
            problems.append(f"submissions.{i}.archive: no such file {sub.archive}")
        if sub.digest is not None and not sub.digest.startswith("sha256:"):
            problems.append(f"submissions.{i}.digest: an image ID is 'sha256:<64 hex>'")
        if sub.disclosure is not None:
            from orchestrator._campaign.disclosure import disclosure_problems

            problems += [f"submissions.{i}.disclosure: {sub.disclosure.name}: {p}"
                         for p in disclosure_problems(sub.disclosure)]
    if spec.runtime == "local" and spec.phase != "local":
        problems.append("runtime: 'local' runs agents without the sandbox: local phase only")
    if len(str(campaign_dir(spec))) > MAX_RUNS_DIR:
        problems.append(f"output: {campaign_dir(spec)} is longer than {MAX_RUNS_DIR} "
                        "characters, too long for the episodes' unix sockets: choose a "
                        "shorter output folder")
    if problems:
        raise SchemaError(source, problems)


def campaign_dir(spec: CampaignSpec) -> Path:
    return spec.output.resolve() / spec.name


def store_path(spec: CampaignSpec) -> Path:
    return spec.output.resolve() / "results.sqlite"


def plan(spec: CampaignSpec) -> list[Any]:
    """Every episode key, interleaved: each submission's episode i of a split is adjacent."""
    from orchestrator._results.store import EpisodeKey

    return [EpisodeKey(sub.team, split.name, i)
            for split in spec.splits for i in range(split.episodes)
            for sub in spec.submissions]
