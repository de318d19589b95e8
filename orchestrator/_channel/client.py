"""The channel's clients: a team's (``eagc login``, ``submit``, ``submissions``,
``freeze``) and the
runner's, both over the channel's HTTP API; and the push of a local image to the channel's
registry, which ``eagc submit`` does so that a team never types the registry's address.

A team's login is kept in ``$XDG_CONFIG_HOME/eagc/channel.json`` (``~/.config``), mode 0600;
``EAGC_CHANNEL_URL``, ``EAGC_CHANNEL_TEAM`` and ``EAGC_CHANNEL_TOKEN`` override it.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from orchestrator._channel.db import ChannelError
from schemas import FreezeRequest, QuotaView, SubmissionView, SubmitRequest

ENV = {"url": "EAGC_CHANNEL_URL", "team": "EAGC_CHANNEL_TEAM", "token": "EAGC_CHANNEL_TOKEN"}


def config_path() -> Path:
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "eagc" / "channel.json"


@dataclass(frozen=True)
class Login:
    url: str
    team: str
    token: str


def save_login(login: Login) -> Path:
    path = config_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "w") as f:
        json.dump(asdict(login), f, indent=2)
    path.chmod(0o600)
    return path


def load_login() -> Login:
    """The saved login with the environment's overrides; ChannelError when incomplete."""
    saved: dict[str, Any] = {}
    path = config_path()
    if path.is_file():
        try:
            saved = json.loads(path.read_text())
        except (OSError, ValueError) as e:
            raise ChannelError(f"{path} is not readable ({e}): log in again with `eagc "
                               "login URL --team NAME --token TOKEN`") from None
    values = {k: os.environ.get(env) or saved.get(k) for k, env in ENV.items()}
    missing = [k for k, v in values.items() if not v]
    if missing:
        raise ChannelError("not logged in to a channel (no " + ", ".join(missing) + "): "
                           "`eagc login URL --team NAME --token TOKEN` (or set "
                           + ", ".join(ENV[k] for k in missing) + ")")
    return Login(**{k: str(v) for k, v in values.items()})


class ChannelClient:
    """JSON over HTTP to the channel; every refusal becomes a one-line ChannelError."""

    def __init__(self, url: str, token: str, timeout_s: float = 30.0) -> None:
        import requests

        self.url = url.rstrip("/")
        self.session = requests.Session()
        self.session.headers["Authorization"] = f"Bearer {token}"
        self.timeout_s = timeout_s

    def call(self, method: str, path: str, body: Any = None, *, data: Any = None) -> Any:
        """``body`` goes as JSON; ``data`` (bytes or an open file, streamed) as it is."""
        import requests

        try:
            r = self.session.request(method, self.url + path, json=body, data=data,
                                     timeout=self.timeout_s)
        except requests.RequestException as e:
            raise ChannelError(f"the channel at {self.url} does not answer "
                               f"({type(e).__name__}): check the URL of `eagc login`", 503
                               ) from None
        if r.status_code == 204:
            return None
        try:
            doc = r.json()
        except ValueError:
            doc = {"detail": r.text.strip()[:200] or r.reason}
        if r.status_code >= 400:
            detail = doc.get("detail") if isinstance(doc, dict) else None
            raise ChannelError(str(detail or f"HTTP {r.status_code}"), r.status_code)
        return doc

    def whoami(self) -> dict[str, Any]:
        return dict(self.call("GET", "/api/v1/whoami"))

    def submit(self, req: SubmitRequest) -> SubmissionView:
        return SubmissionView.model_validate(
            self.call("POST", "/api/v1/submissions", req.model_dump(mode="json")))

    def submissions(self) -> list[SubmissionView]:
        return [SubmissionView.model_validate(s) for s in self.call("GET", "/api/v1/submissions")]

    def cancel(self, sid: str) -> SubmissionView:
        return SubmissionView.model_validate(
            self.call("POST", f"/api/v1/submissions/{sid}/cancel"))

    def quota(self) -> QuotaView:
        return QuotaView.model_validate(self.call("GET", "/api/v1/quota"))

    def submission(self, sid: str) -> SubmissionView:
        return SubmissionView.model_validate(self.call("GET", f"/api/v1/submissions/{sid}"))


def _is_pushed(image: str) -> bool:
    """A reference into the channel's registry (the channel checks whose it is)."""
    return image.startswith("teams/")


def push(image: str, login: Login, registry: str,
         say: Callable[[str], None] = lambda _: None) -> str:
    """Tags the local ``image`` as ``<registry>/teams/<team>/<name>:<tag>``, pushes it with
    the team's credentials and returns ``teams/<team>/<name>@<digest>``."""
    import docker
    from docker.errors import APIError, DockerException, ImageNotFound

    from orchestrator._channel.channel import split_reference

    try:
        client = docker.from_env()
        local = client.images.get(image)
    except ImageNotFound:
        raise ChannelError(f"no local image {image!r}: build it first (`docker build -t "
                           f"{image} .`), or give an image already pushed as "
                           f"teams/{login.team}/<name>:<tag>") from None
    except DockerException as e:
        raise ChannelError(f"cannot reach the Docker engine to push {image}: {e}") from None
    repo, tag = split_reference(image)
    if tag.startswith("sha256:"):
        tag = "latest"
    name = repo.rsplit("/", 1)[-1].lower()
    target = f"{registry}/teams/{login.team}/{name}"
    local.tag(target, tag)
    say(f"pushing {image} as teams/{login.team}/{name}:{tag}")
    digest = None
    try:
        for line in client.images.push(target, tag, stream=True, decode=True,
                                       auth_config={"username": login.team,
                                                    "password": login.token}):
            if "error" in line:
                raise ChannelError(f"the registry refused the push: {_push_error(line)}")
            aux = line.get("aux") or {}
            digest = aux.get("Digest") or digest
    except APIError as e:
        raise ChannelError(f"the push failed: {e.explanation or e}") from None
    finally:
        try:
            client.images.remove(f"{target}:{tag}", noprune=True)
        except DockerException:
            pass
    if not digest:
        raise ChannelError("the registry did not return the pushed image's digest")
    return f"teams/{login.team}/{name}@{digest}"


def _push_error(line: dict[str, Any]) -> str:
    text = str(line.get("error") or "").strip()
    if "denied" in text or "unauthorized" in text:
        return f"{text} (is the token still valid? `eagc submissions` tells)"
    return text


def submit(image: str, login: Login, *, note: str = "", disclosure: Path | None = None,
           say: Callable[[str], None] = lambda _: None) -> SubmissionView:
    """``eagc submit``: pushes a local image (or takes one already pushed) and submits it
    by its manifest digest."""
    client = ChannelClient(login.url, login.token)
    who = client.whoami()  # checks the token before anything is pushed
    text = None
    if disclosure is not None:
        try:
            text = disclosure.read_text()
        except OSError as e:
            raise ChannelError(f"cannot read the disclosure {disclosure}: "
                               f"{e.strerror or e}") from None
    if not _is_pushed(image) and who.get("storage_bytes", 0) >= who.get("storage_cap_bytes", 1):
        raise ChannelError(f"your team's images take {who['storage_bytes'] / 2**20:,.0f} MB "
                           f"of the registry, its cap ({who['storage_cap_bytes'] / 2**20:,.0f}"
                           " MB): submit an image already pushed (teams/<team>/<name>@<digest>)"
                           " or ask the organizers")
    ref = image if _is_pushed(image) else push(image, login, who["registry"], say)
    return client.submit(SubmitRequest(image=ref, note=note, disclosure=text))


#: What ``eagc freeze`` uploads a file as, by its suffix.
_UPLOAD_AS = {".pdf": "report.pdf", ".md": "report.md", ".markdown": "report.md",
              ".yaml": "statement.yaml", ".yml": "statement.yaml",
              ".json": "statement.json"}


def _upload_name(path: Path, kind: str) -> str:
    name = _UPLOAD_AS.get(path.suffix.lower(), "")
    if not name.startswith(kind):
        allowed = sorted(s for s, n in _UPLOAD_AS.items() if n.startswith(kind))
        raise ChannelError(f"{path}: a {kind} is {', '.join(allowed)}, not "
                           f"{path.suffix or 'a file without a suffix'}")
    return name


def freeze(sid: str, report: Path, login: Login, *, statement: Path | None = None,
           phase: str | None = None) -> dict[str, Any]:
    """``eagc freeze``: uploads the technical report (and the open-source statement),
    freezes submission ``sid`` with them, and checks that what the channel keeps has the
    local files' SHA-256; returns the frozen record."""
    client = ChannelClient(login.url, login.token, timeout_s=300.0)
    local: dict[str, str] = {}
    for kind, path in (("report", report), ("statement", statement)):
        if path is None:
            continue
        name = _upload_name(path, kind)
        try:
            with path.open("rb") as f:
                local[kind] = hashlib.file_digest(f, "sha256").hexdigest()
                f.seek(0)
                got = client.call("PUT", f"/api/v1/final/files/{name}", data=f)
        except OSError as e:
            raise ChannelError(f"cannot read {path}: {e.strerror or e}") from None
        if got["sha256"] != local[kind]:
            raise ChannelError(f"the channel received {path} altered (sha256 "
                               f"{got['sha256'][:12]}, not {local[kind][:12]}): upload again")
    req = FreezeRequest(submission=sid, statement=statement is not None, phase=phase)
    record: dict[str, Any] = client.call("POST", "/api/v1/final/freeze",
                                         req.model_dump(mode="json"))
    for kind, digest in local.items():
        if record["files"][kind]["sha256"] != digest:
            raise ChannelError(f"the frozen {kind} is not the file sent (sha256 "
                               f"{record['files'][kind]['sha256'][:12]}): freeze again")
    return record
