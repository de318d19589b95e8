"""The challenge's image registry: the CNCF distribution registry (Debian's
``docker-registry``) as a child process in ``token`` auth mode, and the tokens it accepts.

The channel signs short-lived JWTs (ES256) that name what their bearer may do: a team may
push and pull ``teams/<team>/…`` and nothing else; the runner may pull every team's
repository. The registry checks each token against the channel's certificate, so a team
with another team's repository in its scope never gets a token for it. The token's ``kid``
is the key's libtrust fingerprint, which is how registry 2.x finds the key in the bundle.

Registry docs: https://distribution.github.io/distribution/spec/auth/token/ and
``…/auth/jwt/``.
"""

from __future__ import annotations

import base64
import hashlib
import os
import re
import secrets
import shutil
import signal
import socket
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

from orchestrator._errors import OrchestratorError

SERVICE = "eagc-registry"
ISSUER = "eagc-channel"
#: Who asks for a token: a team (its name) or the runner.
RUNNER = "runner"
#: How long a registry token lasts: enough for one push of a large layer to start.
TOKEN_S = 900
_COMPONENT = r"[a-z0-9]+(?:(?:[._]|__|-+)[a-z0-9]+)*"
_REPO = re.compile(rf"^teams/([a-z0-9][a-z0-9_-]*)/{_COMPONENT}(?:/{_COMPONENT})*$")
REGISTRY_BINARY = "docker-registry"


class RegistryError(OrchestratorError):
    """Raised when the registry cannot start, or answers what the channel cannot use."""


def libtrust_kid(public_der: bytes) -> str:
    """The libtrust key ID of a public key (DER SubjectPublicKeyInfo): base32 of the first
    240 bits of its SHA-256, in twelve groups of four."""
    b32 = base64.b32encode(hashlib.sha256(public_der).digest()[:30]).decode()
    return ":".join(b32[i:i + 4] for i in range(0, 48, 4))


class Keys:
    """The channel's ES256 signing key and its self-signed certificate (the registry's
    ``rootcertbundle``), made once in ``folder`` and kept (the key 0600)."""

    def __init__(self, folder: Path) -> None:
        from cryptography.hazmat.primitives import serialization
        from cryptography.hazmat.primitives.asymmetric import ec

        folder.mkdir(parents=True, exist_ok=True)
        folder.chmod(0o700)
        self.key_path, self.cert_path = folder / "token.key", folder / "token.crt"
        if not self.key_path.is_file() or not self.cert_path.is_file():
            self._make(ec.generate_private_key(ec.SECP256R1()))
        self.private = serialization.load_pem_private_key(self.key_path.read_bytes(), None)
        der = self.private.public_key().public_bytes(
            serialization.Encoding.DER, serialization.PublicFormat.SubjectPublicKeyInfo)
        self.kid = libtrust_kid(der)

    def _make(self, key: Any) -> None:
        from cryptography import x509
        from cryptography.hazmat.primitives import hashes, serialization
        from cryptography.x509.oid import NameOID

        name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, ISSUER)])
        now = datetime.now(UTC)
        cert = (x509.CertificateBuilder().subject_name(name).issuer_name(name)
                .public_key(key.public_key()).serial_number(x509.random_serial_number())
                .not_valid_before(now - timedelta(days=1))
                .not_valid_after(now + timedelta(days=3650))
                .sign(key, hashes.SHA256()))
        pem = key.private_bytes(serialization.Encoding.PEM,
                                serialization.PrivateFormat.PKCS8,
                                serialization.NoEncryption())
        fd = os.open(self.key_path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "wb") as f:
            f.write(pem)
        self.cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))

    def token(self, subject: str, access: list[dict[str, Any]],
              ttl_s: int = TOKEN_S) -> dict[str, Any]:
        """The token endpoint's answer: a JWT granting ``access`` to ``subject``."""
        import jwt

        now = int(time.time())
        claims = {"iss": ISSUER, "sub": subject, "aud": SERVICE, "iat": now, "nbf": now - 5,
                  "exp": now + ttl_s, "jti": secrets.token_hex(12), "access": access}
        token = jwt.encode(claims, self.private, algorithm="ES256",  # type: ignore[arg-type]
                           headers={"kid": self.kid})
        issued = datetime.fromtimestamp(now, UTC).isoformat().replace("+00:00", "Z")
        return {"token": token, "access_token": token, "expires_in": ttl_s,
                "issued_at": issued}


def repository_team(name: str) -> str | None:
    """The team whose repository ``name`` is (``teams/<team>/<image>``), or None for a name
    outside ``teams/`` or not in the registry's grammar (``..``, upper case, …)."""
    m = _REPO.match(name)
    return m.group(1) if m else None


def grant(who: str, scopes: Sequence[str]) -> list[dict[str, Any]]:
    """What ``who`` (a team, or ``RUNNER``) may do of each requested scope
    (``repository:teams/a/x:pull,push``): a team pushes and pulls its own repositories; the
    runner pulls every team's. Anything else is left out (the registry then says denied)."""
    out: list[dict[str, Any]] = []
    for scope in scopes:
        kind, _, rest = scope.partition(":")
        name, _, actions = rest.rpartition(":")
        if kind != "repository" or not name:
            continue
        owner = repository_team(name)
        if owner is None:
            continue
        asked = set(actions.split(","))
        allowed = {"pull"} if who == RUNNER else {"pull", "push"} if owner == who else set()
        if asked & allowed:
            out.append({"type": "repository", "name": name,
                        "actions": sorted(asked & allowed)})
    return out


def die_with_parent(sig: int) -> Callable[[], None]:
    """A ``preexec_fn`` that has the child sent ``sig`` when its parent dies (Linux's
    PR_SET_PDEATHSIG): a channel killed with -9 leaves no registry or runner behind."""
    def arm() -> None:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(sig), 0, 0, 0)  # PR_SET_PDEATHSIG

    return arm


def free_port(host: str = "127.0.0.1") -> int:
    with socket.socket() as s:
        s.bind((host, 0))
        return int(s.getsockname()[1])


@dataclass
class RegistryProcess:
    """``docker-registry serve`` with a config of its own: storage under ``folder``, token
    auth against ``keys``, listening on ``host:port`` (loopback unless told otherwise)."""

    folder: Path
    keys: Keys
    realm: str
    host: str = "127.0.0.1"
    port: int = 0
    process: subprocess.Popen[bytes] | None = None
    _http: Any = field(default=None, repr=False)
    _tokens: dict[str, tuple[str, float]] = field(default_factory=dict, repr=False)

    @property
    def address(self) -> str:
        return f"{self.host}:{self.port}"

    def config(self) -> str:
        storage = self.folder / "storage"
        return "\n".join([
            "version: 0.1",
            "log: {level: warn, formatter: text}",
            "storage:",
            f"  filesystem: {{rootdirectory: {storage}}}",
            "  delete: {enabled: true}",
            "http:",
            f"  addr: {self.address}",
            f"  secret: {secrets.token_hex(16)}",
            "auth:",
            "  token:",
            f"    realm: {self.realm}",
            f"    service: {SERVICE}",
            f"    issuer: {ISSUER}",
            f"    rootcertbundle: {self.keys.cert_path}",
            "",
        ])

    def start(self, timeout_s: float = 30.0) -> None:
        binary = shutil.which(REGISTRY_BINARY)
        if binary is None:
            raise RegistryError(f"{REGISTRY_BINARY} is not installed: `apt-get install "
                                "docker-registry` (Debian's CNCF distribution registry)")
        self.folder.mkdir(parents=True, exist_ok=True)
        self.port = self.port or free_port(self.host)
        conf = self.folder / "config.yml"
        conf.write_text(self.config())
        log = (self.folder / "registry.log").open("ab")
        self.process = subprocess.Popen([binary, "serve", str(conf)], stdout=log,
                                        stderr=subprocess.STDOUT, start_new_session=True,
                                        preexec_fn=die_with_parent(signal.SIGKILL))
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RegistryError(f"the registry exited at once ({self.process.returncode}):"
                                    f" see {self.folder / 'registry.log'}")
            if self._answers():
                return
            time.sleep(0.1)
        self.stop()
        raise RegistryError(f"the registry did not answer on {self.address} within "
                            f"{timeout_s:.0f} s: see {self.folder / 'registry.log'}")

    def _answers(self) -> bool:
        import requests

        try:
            return requests.get(f"http://{self.address}/v2/", timeout=1).status_code == 401
        except requests.RequestException:
            return False

    def alive(self) -> bool:
        return self.process is not None and self.process.poll() is None

    def stop(self) -> None:
        if self.process is None or self.process.poll() is not None:
            return
        os.killpg(self.process.pid, signal.SIGTERM)
        try:
            self.process.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(self.process.pid, signal.SIGKILL)
            self.process.wait(5)

    def _pull_token(self, repository: str) -> str:
        """The runner's pull token for ``repository``, signed once and reused until a
        minute before it expires (a submit asks the registry once; signing is most of
        its cost)."""
        now = time.monotonic()
        got = self._tokens.get(repository)
        if got is None or got[1] < now:
            token = self.keys.token(RUNNER, grant(RUNNER, [f"repository:{repository}:pull"])
                                    )["token"]
            got = (token, now + TOKEN_S - 60)
            if len(self._tokens) > 10_000:
                self._tokens.clear()
            self._tokens[repository] = got
        return got[0]

    def manifest_digest(self, repository: str, reference: str) -> str | None:
        """The manifest digest ``repository:reference`` resolves to (a tag or a digest),
        asked as the runner; None when the registry has no such manifest. One pool of
        keep-alive connections for every caller's thread."""
        import urllib3

        if self._http is None:
            self._http = urllib3.PoolManager(maxsize=16, block=False,
                                             timeout=urllib3.Timeout(total=10))
        accept = ", ".join([
            "application/vnd.docker.distribution.manifest.v2+json",
            "application/vnd.docker.distribution.manifest.list.v2+json",
            "application/vnd.oci.image.manifest.v1+json",
            "application/vnd.oci.image.index.v1+json",
        ])
        try:
            r = self._http.request(
                "HEAD", f"http://{self.address}/v2/{repository}/manifests/{reference}",
                headers={"Authorization": f"Bearer {self._pull_token(repository)}",
                         "Accept": accept}, retries=False)
        except urllib3.exceptions.HTTPError as e:
            raise RegistryError(f"the registry at {self.address} did not answer: {e}") from e
        if r.status == 404:
            return None
        if r.status != 200:
            raise RegistryError(f"the registry answered {r.status} for "
                                f"{repository}:{reference}")
        digest = r.headers.get("Docker-Content-Digest")
        return str(digest) if digest else None
