"""A submission's resource disclosure (``schemas.ResourceDisclosure``): read and checked,
kept beside the pinned image, and read back for the organizer's report and the audit.

A submission names its file with ``disclosure:`` beside ``image:`` in the campaign file
(YAML or JSON, relative to the campaign file). ``load_campaign`` refuses a campaign whose
named file does not validate (``disclosure_problems``, the same grouped, path-bearing lines
as ``eagc check-files``). When the driver pins the images it calls ``keep_disclosures``,
which writes, per team::

    <output>/<campaign>/submissions/<team>.json               the pinned image and the
                                                               disclosure (``KeptDisclosure``)
    <output>/<campaign>/submissions/<team>.disclosure<.ext>   the file as the team gave it

``kept_disclosures`` reads them back for every team of the campaign: the kept copy, else
the file the campaign names (a campaign run before it was kept), else *missing*, which is
shown as such and is never an error.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

from schemas import (
    CampaignSpec,
    FileProblems,
    Problem,
    ResourceDisclosure,
    SchemaError,
    parse_json,
)

#: The folder of a campaign's kept disclosures, under its campaign folder.
FOLDER = "submissions"


class KeptDisclosure(BaseModel):
    """A team's disclosure as the campaign keeps it, beside the image it ran."""

    model_config = ConfigDict(frozen=True)

    team: str
    image: str | None = None
    """What the campaign runs for the team: the pinned image ID (or the command of a
    local-runtime campaign); None when read before the images were pinned."""
    digest: str | None = None
    """The pinned image ID, when there is one."""
    status: Literal["ok", "missing", "invalid"]
    """``missing``: the submission names no disclosure; ``invalid``: the file named is not
    there or does not validate (``problems``)."""
    source: str | None = None
    """The file the submission names."""
    sha256: str | None = None
    """Of the file's bytes as given."""
    kept: bool = False
    """True when read from the campaign's kept copy, False when read from ``source`` now."""
    disclosure: ResourceDisclosure | None = None
    problems: tuple[str, ...] = ()


def _document(data: bytes, suffix: str) -> Any:
    """The file's document: YAML for ``.yaml``/``.yml``, else JSON text as it is."""
    if suffix.lower() not in (".yaml", ".yml"):
        return None
    import yaml

    try:
        return yaml.safe_load(data.decode("utf-8", errors="replace"))
    except yaml.YAMLError as e:
        raise FileProblems("", [_whole(f"not valid YAML: {e}")]) from None


def _whole(msg: str) -> Problem:
    return Problem((), " ".join(msg.split()), whole=True)


def parse_disclosure(data: bytes, *, source: str, suffix: str = ".json"
                     ) -> ResourceDisclosure:
    """The disclosure in ``data`` (YAML when ``suffix`` says so, else JSON); raises
    ``FileProblems`` naming ``source`` with every problem at its field path."""
    try:
        doc = _document(data, suffix)
    except FileProblems as e:
        raise FileProblems(source, e.found, ResourceDisclosure) from None
    text = data if doc is None else json.dumps(doc, default=str)
    try:
        return parse_json(text, ResourceDisclosure, source=source)
    except FileProblems as e:
        raise FileProblems(source, e.found, ResourceDisclosure) from None


def read_disclosure(path: Path) -> ResourceDisclosure:
    """Reads and checks a disclosure file; ``SchemaError`` (every problem, by field path)
    when it cannot be read or does not validate."""
    try:
        data = path.read_bytes()
    except OSError as e:
        raise SchemaError(str(path), [f"cannot read the disclosure: {e.strerror or e}"]
                          ) from None
    return parse_disclosure(data, source=str(path), suffix=path.suffix)


def disclosure_problems(path: Path) -> list[str]:
    """Every problem of a disclosure file, one line per field path (the lines of
    ``schemas._io.problem_lines``); empty when it validates."""
    try:
        read_disclosure(path)
    except FileProblems as e:
        return list(e.lines)
    except SchemaError as e:
        return list(e.problems)
    return []


def _slug(team: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]", "_", team) or "_"


def _from_file(team: str, path: Path | None) -> KeptDisclosure:
    if path is None:
        return KeptDisclosure(team=team, status="missing")
    try:
        data = path.read_bytes()
    except OSError as e:
        return KeptDisclosure(team=team, status="invalid", source=str(path),
                              problems=(f"cannot read it: {e.strerror or e}",))
    digest = "sha256:" + hashlib.sha256(data).hexdigest()
    try:
        disclosure = parse_disclosure(data, source=str(path), suffix=path.suffix)
    except FileProblems as e:
        return KeptDisclosure(team=team, status="invalid", source=str(path), sha256=digest,
                              problems=tuple(e.lines))
    return KeptDisclosure(team=team, status="ok", source=str(path), sha256=digest,
                          disclosure=disclosure)


def keep_disclosures(spec: CampaignSpec, pinned: Mapping[str, Any], folder: Path
                     ) -> list[Path]:
    """Keeps each submission's disclosure beside its pinned image (module doc).

    ``pinned``: team → the pinned image (``fanout.PinnedImage``: ``run`` and ``digest``);
    ``folder``: the campaign folder (``spec.campaign_dir(spec)``). A submission without
    a disclosure gets a record saying it is missing. Returns the files written."""
    base = folder / FOLDER
    base.mkdir(parents=True, exist_ok=True)
    base.chmod(0o700)
    written: list[Path] = []
    for sub in spec.submissions:
        pin = pinned.get(sub.team)
        record = _from_file(sub.team, sub.disclosure).model_copy(update={
            "image": getattr(pin, "run", None), "digest": getattr(pin, "digest", None),
            "kept": True})
        if record.source is not None and record.sha256 is not None:
            assert sub.disclosure is not None
            copy = base / f"{_slug(sub.team)}.disclosure{sub.disclosure.suffix or '.txt'}"
            _write_atomic(copy, sub.disclosure.read_bytes())
            written.append(copy)
        path = base / f"{_slug(sub.team)}.json"
        _write_atomic(path, (record.model_dump_json(indent=2) + "\n").encode())
        written.append(path)
    return written


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)


def kept_disclosures(spec: CampaignSpec, folder: Path) -> dict[str, KeptDisclosure]:
    """Every team's disclosure, in the campaign's order: the kept copy under the campaign
    folder ``folder``, else the file the submission names, read now (``kept`` False), else
    ``missing``."""
    base = folder / FOLDER
    out: dict[str, KeptDisclosure] = {}
    for sub in spec.submissions:
        path = base / f"{_slug(sub.team)}.json"
        try:
            out[sub.team] = KeptDisclosure.model_validate_json(path.read_bytes())
            continue
        except (OSError, ValueError):
            pass
        out[sub.team] = _from_file(sub.team, sub.disclosure)
    return out


def summary_lines(kept: KeptDisclosure) -> list[str]:
    """The disclosure in a few plain lines (unwrapped): data, pretrained models with
    their licenses, compute, dependencies, open source; or why there is none."""
    if kept.status == "missing":
        return ["missing: the submission names no resource disclosure"]
    if kept.status == "invalid" or kept.disclosure is None:
        return [f"invalid ({kept.source}): " + "; ".join(kept.problems)]
    d = kept.disclosure

    def listed(items: list[str]) -> str:
        return "; ".join(items) if items else "none declared"

    data = [f"{s.name} ({s.kind}" + (f", {s.license}" if s.license else "") + ")"
            for s in d.data]
    models = [f"{m.name} ({m.license}" + ("" if m.in_image else ", not in the image") + ")"
              for m in d.pretrained_models]
    compute = d.compute.description + "".join(
        f", {v:g} {unit}" for v, unit in ((d.compute.gpu_hours, "GPU h"),
                                         (d.compute.cpu_hours, "CPU h")) if v is not None)
    deps = [m.name + (f" {m.version}" if m.version else "")
            + (f" ({m.license})" if m.license else "") for m in d.dependencies]
    if d.open_source is None:
        released = "no statement"
    elif d.open_source.released:
        released = "released" + "".join(f", {x}" for x in (d.open_source.url,
                                                          d.open_source.license) if x)
    else:
        released = "not released"
    where = ("kept beside the pinned image" if kept.kept
             else "read now: the campaign keeps no copy yet")
    return [f"file: {kept.source} ({where}; {(kept.sha256 or '')[:19]})",
            f"data: {listed(data)}", f"pretrained models: {listed(models)}",
            f"compute: {compute}", f"dependencies: {listed(deps)}",
            f"open source: {released}"]
