"""Building images offline: no registry is needed (docs/architecture.md, deploy/).

- ``eagc/base:bookworm``: a Debian root with python3 made by ``mmdebstrap`` from the Debian
  mirror apt already uses, then ``docker import``-ed.
- ``eagc/agent-base:latest``: the base plus the agent client (this repository's wheel and
  its three light dependencies: pydantic, eclipse-zenoh, numpy; ``simhost.client`` and the
  Track 1 skills ``simhost.client.skills`` are what an agent imports), installed from wheels
  downloaded on the host with ``pip install --no-index``; built with no network. The eagc
  wheel is written by ``orchestrator._images.wheel`` (no build backend, no download: it works the
  same in a fresh venv, as root with the system Python, or offline).
- example images (``examples/*/Dockerfile``) and test containers built ``FROM`` it, or
  ``FROM`` another example's image (a parent is built before the folders that build on it:
  ``eagc/track2-taskmodel`` on ``eagc/track2-demoparser``, the Track 1 baselines on
  ``eagc/track1-common``, their shared library, which is an image but not an agent).

Each image carries a label with the hash of what it was built from, so a changed client or
agent is rebuilt and an unchanged one is reused.
"""

from __future__ import annotations

import hashlib
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from orchestrator._errors import OrchestratorError
from orchestrator._runtimes.docker import docker_client
from schemas import CONTAINER

REPO = Path(__file__).resolve().parents[2]
BASE_IMAGE = "eagc/base:bookworm"
AGENT_BASE_IMAGE = "eagc/agent-base:latest"
HASH_LABEL = "eagc.build-hash"
MIRROR = "http://deb.debian.org/debian"
CLIENT_SOURCES = ("pyproject.toml", "schemas", "simhost/__init__.py", "simhost/_wire.py",
                  "simhost/_transport.py", "simhost/_errors.py", "simhost/client")


def example_images() -> dict[str, Path]:
    """Every ``examples/<name>/Dockerfile``, as tag ``eagc/<name with - for _>:latest``, in
    build order: a folder whose Dockerfile builds ``FROM eagc/<other example>`` comes after
    that one (at any depth)."""
    found = {
        f"eagc/{d.name.replace('_', '-')}:latest": d
        for d in sorted((REPO / "examples").iterdir())
        if (d / "Dockerfile").is_file()
    }
    ordered: dict[str, Path] = {}

    def visit(tag: str, chain: tuple[str, ...]) -> None:
        if tag in ordered:
            return
        if tag in chain:
            raise ImageBuildError(f"examples build FROM each other in a circle: "
                                  f"{' -> '.join((*chain, tag))}")
        parent = _parent(found[tag])
        if parent in found:
            visit(parent, (*chain, tag))
        ordered[tag] = found[tag]

    for tag in found:
        visit(tag, ())
    return ordered


def example_agents() -> dict[str, Path]:
    """The example images that are agents (their folder has an ``agent.py``), in build
    order. A library image such as ``eagc/track1-common`` is built but is not an agent."""
    return {t: d for t, d in example_images().items() if (d / "agent.py").is_file()}


Say = Callable[[str], None]


def _parent(folder: Path) -> str:
    """The image a folder's Dockerfile builds ``FROM`` (its first FROM line)."""
    for line in (folder / "Dockerfile").read_text().splitlines():
        words = line.split()
        if len(words) >= 2 and words[0].upper() == "FROM":
            return words[1]
    return AGENT_BASE_IMAGE


class ImageBuildError(OrchestratorError, RuntimeError):
    """Raised when an image cannot be built; the message says which step and why.

    The message is one line; ``detail`` keeps the tool's own output (its last lines).
    """

    def __init__(self, message: str, detail: str = "") -> None:
        super().__init__(message)
        self.detail = detail


def _hash_paths(paths: Iterable[Path], extra: str = "") -> str:
    h = hashlib.sha256(extra.encode())
    for root in paths:
        files = sorted(p for p in root.rglob("*") if p.is_file()) if root.is_dir() else [root]
        for f in files:
            if "__pycache__" in f.parts or f.suffix == ".pyc":
                continue
            h.update(str(f.relative_to(REPO) if f.is_relative_to(REPO) else f).encode())
            h.update(f.read_bytes())
    return h.hexdigest()[:16]


def _label(client: Any, tag: str) -> str | None:
    import docker

    try:
        return (client.images.get(tag).labels or {}).get(HASH_LABEL)
    except docker.errors.ImageNotFound:
        return None


def _last_error(output: str) -> str:
    """The line of a tool's output that says what went wrong (pip: ``ERROR: …``)."""
    lines = [ln.strip() for ln in output.splitlines() if ln.strip()]
    errors = [ln for ln in lines if ln.lower().startswith(("error", "e:"))]
    return (errors or lines or ["no output"])[-1][:300]


def _run(cmd: list[str], what: str) -> None:
    try:
        r = subprocess.run(cmd, capture_output=True, text=True)
    except OSError as e:
        raise ImageBuildError(f"{what} failed: cannot run {cmd[0]}: {e.strerror}") from None
    if r.returncode != 0:
        out = r.stderr + r.stdout
        raise ImageBuildError(f"{what} failed ({cmd[0].rsplit('/', 1)[-1]} exited "
                              f"{r.returncode}): {_last_error(out)}", out[-3000:])


def build_base(client: Any, say: Say = print, *, force: bool = False) -> str:
    """``eagc/base:bookworm`` from Debian packages, with no registry."""
    want = "bookworm-python3-v1"
    if not force and _label(client, BASE_IMAGE) == want:
        return BASE_IMAGE
    if shutil.which("mmdebstrap") is None:
        raise ImageBuildError("mmdebstrap is not installed: `apt-get install -y mmdebstrap`")
    say(f"building {BASE_IMAGE} with mmdebstrap (about 30 s)…")
    with tempfile.TemporaryDirectory() as tmp:
        tar = Path(tmp) / "rootfs.tar"
        _run(["mmdebstrap", "--variant=minbase", "--include=python3,python3-pip,ca-certificates",
              "bookworm", str(tar), MIRROR], "mmdebstrap")
        with tar.open("rb") as f:
            client.api.import_image_from_data(
                f.read(), repository=BASE_IMAGE.split(":")[0], tag=BASE_IMAGE.split(":")[1],
                changes=[f'LABEL {HASH_LABEL}="{want}"', 'CMD ["python3"]'],
            )
    return BASE_IMAGE


def client_wheels(dest: Path) -> list[Path]:
    """The eagc wheel (``orchestrator._images.wheel``: no build backend needed) and its light
    dependencies' wheels (downloaded by pip) in ``dest``; what the agent base installs."""
    from orchestrator._images.wheel import WheelError, build_wheel

    try:
        build_wheel(REPO, dest)
    except WheelError as e:
        raise ImageBuildError(f"building the eagc wheel failed: {e}") from None
    _run([sys.executable, "-m", "pip", "download", "-q", "--only-binary=:all:", "-d", str(dest),
          "pydantic", "eclipse-zenoh", "numpy"], "downloading the client's wheels")
    return sorted(dest.glob("*.whl"))


def _docker_build(client: Any, context: Path, tag: str, build_hash: str, say: Say) -> str:
    say(f"building {tag}…")
    try:
        image, _ = client.images.build(
            path=str(context), tag=tag, rm=True, forcerm=True, network_mode="none",
            labels={HASH_LABEL: build_hash},
        )
    except Exception as e:  # noqa: BLE001 - docker.errors.BuildError carries the log
        logs = "".join(
            str(chunk.get("stream", "")) for chunk in getattr(e, "build_log", []) or []
        )
        raise ImageBuildError(f"docker build of {tag} failed: {_last_error(str(e))}",
                              logs[-3000:]) from e
    return str(image.id)


def build_agent_base(client: Any, say: Say = print, *, force: bool = False,
                     tag: str = AGENT_BASE_IMAGE) -> str:
    """``eagc/agent-base:latest`` (or ``tag``): the base plus the agent client, built with
    no network."""
    build_base(client, say, force=False)
    want = _hash_paths([REPO / p for p in CLIENT_SOURCES], extra=str(_label(client, BASE_IMAGE)))
    if not force and _label(client, tag) == want:
        return tag
    with tempfile.TemporaryDirectory() as tmp:
        ctx = Path(tmp)
        client_wheels(ctx / "wheels")
        (ctx / "Dockerfile").write_text(
            f"FROM {BASE_IMAGE}\n"
            "COPY wheels /tmp/wheels\n"
            "RUN python3 -m pip install --no-cache-dir --break-system-packages --no-index "
            "--find-links /tmp/wheels eagc && rm -rf /tmp/wheels\n"
            "ENV HOME=/tmp PYTHONDONTWRITEBYTECODE=1\n"
            f"USER {CONTAINER.uid}:{CONTAINER.uid}\n"
        )
        _docker_build(client, ctx, tag, want, say)
    return tag


def build_folder(client: Any, folder: Path, tag: str, say: Say = print, *,
                 force: bool = False) -> str:
    """Builds a folder (a Dockerfile ``FROM eagc/agent-base`` or ``FROM`` another example's
    image) with no network. An example parent is built first where it is missing or stale
    (``force`` rebuilds this folder only); the hash covers the parent's, so a rebuilt parent
    rebuilds it."""
    parent = _parent(folder)
    parent_folder = example_images().get(parent)
    if parent_folder is not None and parent_folder.resolve() != folder.resolve():
        build_folder(client, parent_folder, parent, say)
    want = _hash_paths([folder], extra=str(_label(client, parent)))
    if not force and _label(client, tag) == want:
        return tag
    _docker_build(client, folder, tag, want, say)
    return tag


def build_all(say: Say = print, *, force: bool = False, client: Any | None = None) -> list[str]:
    """Base, agent base and every example image (agents and the libraries they build
    ``FROM``), parents first. Returns the tags."""
    client = client or docker_client()
    tags = [build_base(client, say, force=force), build_agent_base(client, say, force=force)]
    for tag, folder in example_images().items():
        tags.append(build_folder(client, folder, tag, say, force=force))
    return tags


def image_id(client: Any, tag: str) -> str:
    """The pinned digest of a local image (its ID, where no registry is at hand)."""
    return str(client.images.get(tag).id)
