"""The frozen final (paper Table IX; issue 34 §4): what a finalist freezes, the manifest the
channel signs at the deadline, the campaign made from it, and the checks anyone can run.

Before the final phase's deadline (its ``closes``) a finalist **freezes** one submission of
its own that passed its pre-flight (queued, running or scored): its image (the repository
and manifest digest, and the image ID the pre-flight recorded), its resource disclosure
(the text it was submitted with), a technical report (PDF or Markdown) and, optionally, an
open-source statement (``schemas.OpenSourceStatement``, YAML or JSON). A second freeze
before the deadline replaces the first. The files are kept under ``<data>/final/<team>/``
with their SHA-256 in the channel's database (table ``finals``).

At the deadline the channel writes the **manifest**: canonical JSON (sorted keys, no
spaces) naming the challenge and phase, the phase's campaign (splits, limits, the seed
secret's location) and its seed commitment, eagc's version and source digest (the
fan-out's ``code_version``), and per finalist the submission, ``repository@digest``, the
image ID and each file's SHA-256. ``manifest.sig`` beside it is the base64 Ed25519
signature of ``manifest.json``'s bytes, by the key made once under
``<data>/keys/manifest.ed25519`` (0600); ``<data>/keys/manifest.pub`` (PEM) is the public
key to publish. Once written, no freeze of the phase is accepted, and writing it again
gives the same bytes (kept in table ``manifests``).

``manifest_campaign`` turns a manifest into the ``CampaignSpec`` the existing runner reads:
its submissions are exactly the frozen images, pinned by image ID. ``verify`` checks a
manifest's signature, its files and, given a campaign's runs folder, that the results ran
exactly the manifest's images on the committed seeds.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import shutil
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from orchestrator._channel.channel import Channel
from orchestrator._channel.db import ChannelError
from schemas import (
    CampaignSpec,
    ChallengePhase,
    OpenSourceStatement,
    SchemaError,
    Submission,
    SubmissionState,
    parse_json,
    parse_when,
)

S = SubmissionState
FORMAT = "eagc-final-manifest/v1"
#: Submissions a finalist may freeze: those past their pre-flight.
FREEZABLE = (S.QUEUED, S.RUNNING, S.SCORED)
REPORT_SUFFIXES = {".pdf": ".pdf", ".md": ".md", ".markdown": ".md"}
MAX_FILE_BYTES = 50 * 2**20
#: The names a team uploads its freeze's files as: its report, then its statement.
UPLOADS = ("report.pdf", "report.md", "statement.yaml", "statement.json")

_DDL = (
    "CREATE TABLE IF NOT EXISTS finals ("
    " phase TEXT NOT NULL, team TEXT NOT NULL, submission TEXT NOT NULL,"
    " repository TEXT NOT NULL, digest TEXT NOT NULL, image_id TEXT NOT NULL,"
    " files TEXT NOT NULL, frozen_at REAL NOT NULL, PRIMARY KEY (phase, team))",
    "CREATE TABLE IF NOT EXISTS manifests ("
    " phase TEXT PRIMARY KEY, written_at REAL NOT NULL, manifest BLOB NOT NULL)",
)


@dataclass(frozen=True)
class Frozen:
    """A finalist's frozen submission: ``files`` maps ``disclosure``/``report``/
    ``statement`` to ``{"name": "<team>/<file>", "sha256": …}`` (name relative to
    ``<data>/final``)."""

    phase: str
    team: str
    submission: str
    repository: str
    digest: str
    image_id: str
    files: dict[str, dict[str, str]]
    frozen_at: float


@dataclass(frozen=True)
class Check:
    """One line of ``verify``: what was checked, whether it holds, and the detail."""

    name: str
    ok: bool
    detail: str


def _tables(channel: Channel) -> None:
    with channel.db.tx() as db:
        for statement in _DDL:
            db.execute(statement)


def final_folder(channel: Channel) -> Path:
    return channel.data / "final"


def final_phase(channel: Channel, name: str | None = None) -> ChallengePhase:
    """The phase named, else the challenge's one phase of kind ``final``."""
    if name is not None:
        return channel.phase(name)
    finals = [p for p in channel.spec.phases if p.kind == "final"]
    if len(finals) != 1:
        raise ChannelError(f"the challenge has {len(finals)} phases of kind 'final': name "
                           "the phase (--phase)")
    return finals[0]


def deadline(channel: Channel, phase: ChallengePhase) -> datetime | None:
    """The phase's freeze deadline (its ``closes``); None: closed by hand (the manifest)."""
    return None if phase.closes is None else parse_when(phase.closes, channel.started)


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _read(path: Path, what: str) -> bytes:
    try:
        data = path.read_bytes()
    except OSError as e:
        raise ChannelError(f"cannot read the {what} {path}: {e.strerror or e}") from None
    if len(data) > MAX_FILE_BYTES:
        raise ChannelError(f"the {what} {path} is {len(data) / 2**20:.0f} MB; at most "
                           f"{MAX_FILE_BYTES // 2**20} MB")
    return data


def _report(path: Path) -> tuple[bytes, str]:
    suffix = REPORT_SUFFIXES.get(path.suffix.lower())
    if suffix is None:
        raise ChannelError(f"the technical report {path} is neither PDF (.pdf) nor Markdown "
                           "(.md): export it as one of them")
    data = _read(path, "technical report")
    if suffix == ".pdf" and not data.startswith(b"%PDF-"):
        raise ChannelError(f"the technical report {path} is named .pdf but is not a PDF")
    if suffix == ".md":
        try:
            data.decode("utf-8")
        except UnicodeDecodeError:
            raise ChannelError(f"the technical report {path} is not UTF-8 Markdown") from None
    return data, suffix


def _statement(path: Path) -> tuple[bytes, str]:
    import yaml

    data = _read(path, "open-source statement")
    suffix = ".json" if path.suffix.lower() == ".json" else ".yaml"
    try:
        doc = yaml.safe_load(data.decode("utf-8"))
    except (yaml.YAMLError, UnicodeDecodeError) as e:
        raise ChannelError(f"the open-source statement {path} is not YAML or JSON: "
                           f"{str(e).splitlines()[0]}") from None
    try:
        parse_json(json.dumps(doc, default=str), OpenSourceStatement, source=str(path))
    except SchemaError as e:
        raise ChannelError(f"the open-source statement {path} does not validate: "
                           + "; ".join(e.problems)) from None
    return data, suffix


def _disclosure(sid: str, text: str | None) -> tuple[bytes, str]:
    from orchestrator._campaign.disclosure import parse_disclosure

    if not text:
        raise ChannelError(f"submission {sid} carries no resource disclosure: a finalist "
                           "freezes one that does (`eagc submit IMAGE --disclosure FILE`)")
    data = text.encode("utf-8")
    suffix = ".json" if text.lstrip().startswith("{") else ".yaml"
    try:
        parse_disclosure(data, source=f"{sid}'s disclosure", suffix=suffix)
    except SchemaError as e:
        raise ChannelError(f"submission {sid}'s resource disclosure does not validate: "
                           + "; ".join(e.problems)) from None
    return data, suffix


def may_freeze(channel: Channel, team: str, phase: str | None = None,
               now: datetime | None = None) -> ChallengePhase:
    """The final ``team`` may freeze for now; ChannelError (403) after its deadline or its
    manifest, or for a team that is not one of its finalists."""
    _tables(channel)
    final = final_phase(channel, phase)
    now = now or channel.clock.utc()
    due = deadline(channel, final)
    if due is not None and now >= due:
        raise ChannelError(f"the final {final.name}'s freeze deadline passed at "
                           f"{due:%Y-%m-%d %H:%M} UTC: nothing can be frozen any more", 403)
    if _stored_manifest(channel, final.name) is not None:
        raise ChannelError(f"the final {final.name}'s manifest is written: nothing can be "
                           "frozen any more", 403)
    if final.who == "finalists" and team not in channel.finalists(final):
        raise ChannelError(f"team {team} is not a finalist of {final.name}", 403)
    return final


def freeze(channel: Channel, team: str, submission_id: str, report_path: Path,
           statement: Path | None = None, *, phase: str | None = None,
           now: datetime | None = None, who: str = "") -> Frozen:
    """Freezes ``team``'s submission ``submission_id`` for the final ``phase`` (module doc);
    ChannelError after the deadline or the manifest, for a submission that is not the
    team's or not past its pre-flight, or for a file that does not validate."""
    final = may_freeze(channel, team, phase, now)
    now = now or channel.clock.utc()
    row = channel.row_for(submission_id, team)
    if row.state not in FREEZABLE:
        raise ChannelError(f"submission {row.id} is {row.state}: freeze one that passed its "
                           "pre-flight (queued, running or scored)", 409)
    if not row.image_id:
        raise ChannelError(f"submission {row.id} has no image ID recorded yet (its "
                           "pre-flight records it): freeze it once it is queued", 409)
    parts = {"disclosure": _disclosure(row.id, row.disclosure),
             "report": _report(report_path)}
    if statement is not None:
        parts["statement"] = _statement(statement)
    base = final_folder(channel)
    folder = base / team
    tmp = base / f".{team}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir(parents=True, mode=0o700)
    files: dict[str, dict[str, str]] = {}
    for kind, (data, suffix) in parts.items():
        (tmp / f"{kind}{suffix}").write_bytes(data)
        files[kind] = {"name": f"{team}/{kind}{suffix}",
                       "sha256": hashlib.sha256(data).hexdigest()}
    record = Frozen(final.name, team, row.id, row.repository, row.digest, row.image_id,
                    files, now.timestamp())
    with channel.db.tx() as db:
        db.execute("INSERT OR REPLACE INTO finals VALUES (?, ?, ?, ?, ?, ?, ?, ?)",
                   (final.name, team, row.id, row.repository, row.digest, row.image_id,
                    json.dumps(files, sort_keys=True), record.frozen_at))
        channel.db.record_action(db, who or team, "freeze", f"{team} {row.id}",
                                 f"final {final.name}: {row.repository}@{row.digest}")
        shutil.rmtree(folder, ignore_errors=True)
        os.replace(tmp, folder)
    return record


def upload_folder(channel: Channel, team: str) -> Path:
    """Where a team's files for its freeze wait (``PUT /api/v1/final/files/NAME``)."""
    return final_folder(channel) / ".uploads" / team


def freeze_uploaded(channel: Channel, team: str, submission_id: str, *,
                    statement: bool = False, phase: str | None = None) -> Frozen:
    """``freeze`` with the files ``team`` uploaded (its newest report and, when
    ``statement``, its newest statement); the uploads are gone once frozen."""
    folder = upload_folder(channel, team)

    def newest(kind: str, names: tuple[str, ...]) -> Path:
        got = [folder / n for n in names if (folder / n).is_file()]
        if not got:
            raise ChannelError(f"no {kind} uploaded: `eagc freeze` uploads it, or PUT it "
                               f"to /api/v1/final/files/{names[0]}", 409)
        return max(got, key=lambda p: p.stat().st_mtime_ns)

    report = newest("technical report", UPLOADS[:2])
    extra = newest("open-source statement", UPLOADS[2:]) if statement else None
    got = freeze(channel, team, submission_id, report, extra, phase=phase, who=team)
    shutil.rmtree(folder, ignore_errors=True)
    return got


def frozen(channel: Channel, phase: str) -> list[Frozen]:
    """The phase's frozen submissions, by team."""
    _tables(channel)
    return [Frozen(p, t, s, r, d, i, json.loads(f), at) for p, t, s, r, d, i, f, at in
            channel.db.db.execute("SELECT * FROM finals WHERE phase=? ORDER BY team",
                                  (phase,))]


# ---------------------------------------------------------------------- signing
def signing_key(keys: Path) -> Any:
    """The manifest's Ed25519 key (``keys/manifest.ed25519``, 0600), made once, with its
    public key exported beside it (``keys/manifest.pub``, PEM)."""
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

    path, pub = keys / "manifest.ed25519", keys / "manifest.pub"
    if not path.is_file():
        keys.mkdir(parents=True, exist_ok=True, mode=0o700)
        pem = Ed25519PrivateKey.generate().private_bytes(
            serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption())
        tmp = keys / f".manifest.{os.getpid()}.tmp"
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(pem)
        try:  # the first of two makers wins; the other reads its key
            os.link(tmp, path)
        except FileExistsError:
            pass
        finally:
            tmp.unlink()
    key = serialization.load_pem_private_key(path.read_bytes(), None)
    if not isinstance(key, Ed25519PrivateKey):
        raise ChannelError(f"{path} is not an Ed25519 key")
    if not pub.is_file():
        tmp = keys / f".manifest.pub.{os.getpid()}.tmp"
        tmp.write_bytes(public_pem(key))
        os.replace(tmp, pub)
    return key


def public_pem(key: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return bytes(key.public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo))


def canonical(doc: Mapping[str, Any]) -> bytes:
    """JSON with sorted keys and no spaces: the bytes that are signed."""
    return json.dumps(doc, sort_keys=True, separators=(",", ":"),
                      ensure_ascii=False).encode("utf-8")


# ---------------------------------------------------------------------- the manifest
@dataclass(frozen=True)
class Written:
    manifest: Path
    signature: Path
    public_key: Path
    campaign: Path


def _stored_manifest(channel: Channel, phase: str) -> bytes | None:
    _tables(channel)
    got = channel.db.db.execute("SELECT manifest FROM manifests WHERE phase=?",
                                (phase,)).fetchone()
    return None if got is None else bytes(got[0])


def build_manifest(channel: Channel, phase: ChallengePhase, *, written_at: datetime
                   ) -> dict[str, Any]:
    """The manifest's document (module doc) from the phase's frozen submissions."""
    from orchestrator._campaign.fanout import code_version
    from orchestrator._campaign.seeds import commitment, load_secret, seed_list
    from schemas import __version__

    finals = frozen(channel, phase.name)
    if not finals:
        raise ChannelError(f"no finalist froze a submission for the final {phase.name}", 409)
    spec = channel.campaign(phase, channel.data / "runs")
    due = deadline(channel, phase)
    return {
        "format": FORMAT,
        "challenge": channel.spec.name,
        "phase": phase.name,
        "deadline": None if due is None else due.isoformat(),
        "written_at": written_at.isoformat(),
        "eagc": {"version": __version__, "code_version": code_version()},
        "seed_commitment": commitment(spec, seed_list(spec, load_secret(spec))),
        "campaign": spec.model_dump(mode="json", include={
            "name", "track", "phase", "splits", "limits", "retries", "secret", "runtime"}),
        "finalists": [{
            "team": f.team, "submission": f.submission,
            "image": f"{f.repository}@{f.digest}", "image_id": f.image_id,
            "frozen_at": channel.clock.utc(f.frozen_at).isoformat(), "files": f.files,
        } for f in finals],
    }


def write_manifest(channel: Channel, phase: str, out: Path | None = None, *,
                   now: datetime | None = None) -> Written:
    """At (or after) the phase's deadline: signs the manifest once, then writes
    ``manifest.json``, ``manifest.sig``, ``manifest.pub``, ``campaign.yaml`` and the
    frozen files (``<team>/…``) into ``out`` (default ``<data>/final``)."""
    import yaml

    final = channel.phase(phase)
    now = now or channel.clock.utc()
    due = deadline(channel, final)
    if due is not None and now < due:
        raise ChannelError(f"the final {final.name}'s freeze deadline is "
                           f"{due:%Y-%m-%d %H:%M} UTC: finalists may freeze until then, and "
                           "the manifest is written after it", 409)
    key = signing_key(channel.data / "keys")
    data = _stored_manifest(channel, final.name)
    if data is None:
        data = canonical(build_manifest(channel, final, written_at=now))
        with channel.db.tx() as db:
            db.execute("INSERT OR IGNORE INTO manifests VALUES (?, ?, ?)",
                       (final.name, now.timestamp(), data))
        data = _stored_manifest(channel, final.name) or data
    out = out or final_folder(channel)
    out.mkdir(parents=True, exist_ok=True)
    doc = json.loads(data)
    source = final_folder(channel)
    for f in doc["finalists"]:
        for entry in f["files"].values():
            target = out / entry["name"]
            if target.resolve() != (source / entry["name"]).resolve():
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(source / entry["name"], target)
    written = Written(out / "manifest.json", out / "manifest.sig", out / "manifest.pub",
                      out / "campaign.yaml")
    written.manifest.write_bytes(data)
    written.signature.write_bytes(base64.b64encode(key.sign(data)) + b"\n")
    written.public_key.write_bytes(public_pem(key))
    spec = manifest_campaign(doc, output=Path("runs") / doc["campaign"]["name"])
    written.campaign.write_text(yaml.safe_dump(spec.model_dump(mode="json", exclude_none=True),
                                               sort_keys=False))
    return written


def manifest_campaign(manifest: Mapping[str, Any], *, output: Path = Path("runs")
                      ) -> CampaignSpec:
    """The campaign the runner reads: the phase's campaign whose submissions are exactly
    the frozen images, pinned by image ID, with their frozen disclosures (paths relative
    to the manifest's folder, where ``campaign.yaml`` is written)."""
    subs = tuple(Submission(team=f["team"], image=f["image"], digest=f["image_id"],
                            disclosure=Path(f["files"]["disclosure"]["name"]))
                 for f in manifest["finalists"])
    return CampaignSpec.model_validate({**manifest["campaign"], "output": output,
                                        "submissions": subs})


# ---------------------------------------------------------------------- verify
def _public_key(manifest: Path, key: Path | None, data: Path | None) -> Path:
    candidates = ([key] if key is not None else
                  [manifest.parent / "manifest.pub"]
                  + ([data / "keys" / "manifest.pub"] if data is not None else []))
    for path in candidates:
        if path.is_file():
            return path
    raise ChannelError("no public key: give it with --key (the challenge's public page "
                       f"shows it); looked for {', '.join(str(p) for p in candidates)}")


def verify(manifest: Path, *, key: Path | None = None, files: Path | None = None,
           runs: Path | None = None, data: Path | None = None) -> Iterator[Check]:
    """The checks of ``eagc challenge verify``, one at a time: the signature, each file's
    SHA-256 (under ``files``, default the manifest's folder) and, with ``runs`` (a
    campaign's output folder, or its ``results.sqlite``), that the campaign's results ran
    exactly the manifest's images on the committed seeds."""
    from cryptography.exceptions import InvalidSignature
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

    try:
        body = manifest.read_bytes()
    except OSError as e:
        raise ChannelError(f"cannot read the manifest {manifest}: {e.strerror or e}") from None
    pub_path = _public_key(manifest, key, data)
    sig_path = manifest.with_suffix(".sig")
    try:
        pub = serialization.load_pem_public_key(pub_path.read_bytes())
        sig = base64.b64decode(sig_path.read_bytes().strip(), validate=True)
        if not isinstance(pub, Ed25519PublicKey):
            raise InvalidSignature
        pub.verify(sig, body)
        yield Check("signature", True, f"{sig_path.name} by {pub_path} "
                    f"(key sha256 {hashlib.sha256(public_pem_of(pub)).hexdigest()[:16]})")
    except (OSError, ValueError, InvalidSignature):
        yield Check("signature", False, f"{sig_path} is not a signature of {manifest.name} "
                    f"by {pub_path}")
        return
    doc = json.loads(body)
    files = files or manifest.parent
    for f in doc["finalists"]:
        for kind, entry in sorted(f["files"].items()):
            path = files / entry["name"]
            name = f"file {entry['name']}"
            if not path.is_file():
                yield Check(name, False, f"{f['team']}'s {kind}: no file {path}")
                return
            got = sha256_file(path)
            if got != entry["sha256"]:
                yield Check(name, False, f"{f['team']}'s {kind} {path} has sha256 "
                            f"{got[:16]}…, the manifest {entry['sha256'][:16]}…")
                return
            yield Check(name, True, f"{f['team']}'s {kind}, sha256 {got[:16]}…")
    if runs is not None:
        yield from _check_runs(doc, runs)


def public_pem_of(pub: Any) -> bytes:
    from cryptography.hazmat.primitives import serialization

    return bytes(pub.public_bytes(serialization.Encoding.PEM,
                                  serialization.PublicFormat.SubjectPublicKeyInfo))


def _check_runs(doc: Mapping[str, Any], runs: Path) -> Iterator[Check]:
    from orchestrator._campaign.disclosure import FOLDER
    from orchestrator._results.store import ResultsStore

    path = runs if runs.is_file() else runs / "results.sqlite"
    name = doc["campaign"]["name"]
    if not path.is_file():
        yield Check("runs", False, f"no results store {path}")
        return
    with ResultsStore(path) as store:
        committed = store.commitment(name)
        results = store.results(name) if committed is not None else []
    if committed is None:
        yield Check("runs", False, f"{path} holds no campaign {name}")
        return
    yield Check("runs", True, f"campaign {name} in {path}: {len(results)} episodes")
    if committed != doc["seed_commitment"]:
        yield Check("seed commitment", False, f"the campaign ran seeds committed as "
                    f"{committed[:16]}…, the manifest {doc['seed_commitment'][:16]}…")
        return
    yield Check("seed commitment", True, doc["seed_commitment"][:16] + "…")
    want = {f["team"]: f["image_id"] for f in doc["finalists"]}
    disclosures = {f["team"]: f["files"]["disclosure"]["sha256"] for f in doc["finalists"]}
    ran: dict[str, set[str]] = {}
    for e in results:
        ran.setdefault(e.key.submission, set()).add(e.result.image)
    extra = sorted(set(ran) - set(want))
    if extra:
        yield Check("teams", False, f"the campaign ran teams the manifest does not name: "
                    f"{', '.join(extra)}")
        return
    for team, image_id in want.items():
        images = ran.get(team, set())
        other = sorted(images - {image_id})
        if not images or other:
            detail = (f"ran {', '.join(i[:19] for i in other)}, not the manifest's "
                      f"{image_id[:19]}" if other else "ran no episode")
            yield Check(f"image {team}", False, f"{team} {detail}")
            return
        kept = runs / name / FOLDER / f"{team}.json" if runs.is_dir() else None
        if kept is not None and kept.is_file():
            record = json.loads(kept.read_text())
            if record.get("digest") != image_id:
                yield Check(f"image {team}", False, f"the campaign pinned "
                            f"{record.get('digest')} for {team}, not the manifest's "
                            f"{image_id[:19]}")
                return
            frozen_sha = "sha256:" + disclosures[team]
            if record.get("sha256") not in (None, frozen_sha):
                yield Check(f"disclosure {team}", False, f"the campaign kept a disclosure "
                            f"for {team} other than the frozen one "
                            f"({str(record.get('sha256'))[:19]}…, not {frozen_sha[:19]}…)")
                return
        yield Check(f"image {team}", True, f"every episode ran {image_id[:19]}")
