"""Helpers of the campaign tests (no tests here): campaign files, free ports, Prometheus."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path
from typing import Any

import pytest
import yaml

#: Short episodes: the sanity agent finishes in a second or two; the step cap bounds the rest.
FAST_LIMITS = {"memory_mb": 512, "max_steps_per_stage": 400, "startup_s": 60.0}


def short_dir(prefix: str) -> Path:
    """A short folder under /tmp (unix socket paths are limited to 108 bytes)."""
    return Path(tempfile.mkdtemp(prefix=prefix, dir="/tmp"))


def write_campaign(folder: Path, name: str, submissions: dict[str, str], *,
                   standard: int = 2, challenge: int = 2, retries: int = 2,
                   limits: dict[str, Any] | None = None) -> Path:
    doc = {
        "name": name, "track": "sanity", "phase": "local",
        "splits": [{"name": "standard", "weight": 0.6, "episodes": standard},
                   {"name": "challenge", "weight": 0.4, "episodes": challenge}],
        "submissions": [{"team": t, "image": i} for t, i in submissions.items()],
        "limits": limits or FAST_LIMITS, "retries": retries, "output": str(folder / "out"),
    }
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Prometheus:
    """A real Prometheus server (Debian's package) on a free port, with a temp storage dir."""

    def __init__(self, folder: Path, targets: list[str], rule_files: list[Path]) -> None:
        binary = shutil.which("prometheus")
        if binary is None:
            msg = "prometheus is not installed (apt-get install prometheus)"
            if os.environ.get("CI"):
                pytest.fail(msg)
            pytest.skip(msg)
        self.port = free_port()
        config = {
            "global": {"scrape_interval": "1s", "evaluation_interval": "1s"},
            "rule_files": [str(p) for p in rule_files],
            "scrape_configs": [{"job_name": "eagc-driver",
                                "static_configs": [{"targets": targets}]}],
        }
        (folder / "prometheus.yml").write_text(yaml.safe_dump(config))
        self.log = (folder / "prometheus.log").open("w")
        self.proc = subprocess.Popen(
            [binary, f"--config.file={folder / 'prometheus.yml'}",
             f"--storage.tsdb.path={folder / 'data'}",
             f"--web.listen-address=127.0.0.1:{self.port}"],
            stdout=self.log, stderr=subprocess.STDOUT)
        deadline = time.time() + 30
        while time.time() < deadline:
            try:
                urllib.request.urlopen(f"http://127.0.0.1:{self.port}/-/ready", timeout=1)
                return
            except OSError:
                time.sleep(0.2)
        self.stop()
        raise RuntimeError(f"prometheus did not start: {(folder / 'prometheus.log').read_text()}")

    def api(self, path: str, **params: str) -> Any:
        url = f"http://127.0.0.1:{self.port}/api/v1/{path}?{urllib.parse.urlencode(params)}"
        try:
            with urllib.request.urlopen(url, timeout=10) as r:
                return json.load(r)
        except urllib.error.HTTPError as e:  # a bad query: the body says why
            return json.load(e)

    def query(self, expr: str) -> Any:
        return self.api("query", query=expr)

    def stop(self) -> None:
        self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()


CONTAINERS = Path(__file__).resolve().parents[1] / "containers"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def build_campaign_images(engine: Any, *tests: str) -> None:
    """The sanity example agent and the named test containers, built offline.

    Only what the campaign tests run (the ``images`` fixture builds every example agent,
    including other tracks' that may be work in progress).
    """
    from orchestrator._images.build import build_agent_base, build_folder

    quiet = lambda m: None  # noqa: E731
    build_agent_base(engine, quiet)
    build_folder(engine, EXAMPLES / "sanity_agent", "eagc/sanity-agent:latest", quiet)
    for name in tests:
        build_folder(engine, CONTAINERS / name, f"eagc-test/{name}:latest", quiet)


# ---------------------------------------------------------------------------- processes
def _ppid(pid: int) -> int:
    return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])


def _ancestors() -> set[int]:
    out, pid = set(), os.getpid()
    while pid > 1:
        out.add(pid)
        try:
            pid = _ppid(pid)
        except OSError:
            break
    return out


def processes_mentioning(marker: str) -> set[int]:
    """Pids whose command line names ``marker`` (a unique temp dir), with their descendants.

    This process and its ancestors are left out: the test's own command line may name it.
    """
    table: dict[int, tuple[int, bytes]] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                table[int(d.name)] = (_ppid(int(d.name)), (d / "cmdline").read_bytes())
            except (OSError, ValueError, IndexError):
                continue
    keep = _ancestors()
    found = {p for p, (_, cmd) in table.items() if marker.encode() in cmd and p not in keep}
    grew = True
    while grew:
        kids = {p for p, (pp, _) in table.items() if pp in found and p not in found}
        found |= kids
        grew = bool(kids)
    return found


def descendants(pid: int) -> set[int]:
    table = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                table[int(d.name)] = _ppid(int(d.name))
            except (OSError, ValueError, IndexError):
                continue
    found, grew = {pid}, True
    while grew:
        kids = {p for p, pp in table.items() if pp in found and p not in found}
        found |= kids
        grew = bool(kids)
    return found - {pid}


def end_processes(pids: set[int], grace_s: float = 3.0) -> None:
    """SIGTERM, then SIGKILL what is left: only the pids given (ones this test started)."""
    import signal

    for sig in (signal.SIGTERM, signal.SIGKILL):
        alive = set()
        for p in pids:
            try:
                os.kill(p, sig)
                alive.add(p)
            except ProcessLookupError:
                pass
        deadline = time.time() + grace_s
        while alive and time.time() < deadline:
            alive = {p for p in alive if Path(f"/proc/{p}").exists()
                     and "Z" not in Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1][:3]}
            time.sleep(0.1)
        if not alive:
            return
        pids = alive


class RayCluster:
    """A Ray cluster of real nodes on this machine (``ray start``), in a temp dir of its own.

    Token authentication is on (Ray 2.60's default for ``ray start --head``); nodes and
    drivers join with ``RAY_AUTH_MODE=token`` and this cluster's own token (a fresh one in
    ``RAY_AUTH_TOKEN``: on a new machine there is no ``~/.ray/auth_token`` to fall back on,
    and an old one must not decide whether the test passes). ``stop()`` ends exactly the
    processes of this cluster (found by its temp dir), never other Ray sessions on the
    machine.
    """

    def __init__(self) -> None:
        self.temp = short_dir("eagc-ray-")
        self.port = free_port()
        self.address = f"127.0.0.1:{self.port}"
        self.env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_USAGE_STATS_ENABLED": "0",
                    "RAY_AUTH_TOKEN": secrets.token_hex(32)}

    def _start(self, *args: str) -> None:
        ray_cli = Path(sys.executable).with_name("ray")  # the ray of this interpreter
        r = subprocess.run([str(ray_cli) if ray_cli.exists() else "ray", "start", *args],
                           env=self.env, capture_output=True, text=True, timeout=120)
        if r.returncode != 0:
            raise RuntimeError(f"ray start {' '.join(args)} failed:\n{r.stdout}\n{r.stderr}")

    def start_head(self, *, cpus: int, resources: dict[str, float]) -> None:
        self._start("--head", f"--port={self.port}", f"--temp-dir={self.temp}",
                    f"--num-cpus={cpus}", f"--resources={json.dumps(resources)}",
                    "--include-dashboard=false", "--disable-usage-stats")

    def add_node(self, *, cpus: int, resources: dict[str, float]) -> None:
        self._start(f"--address={self.address}", f"--num-cpus={cpus}",
                    f"--resources={json.dumps(resources)}", "--disable-usage-stats")

    def stop(self) -> None:
        end_processes(processes_mentioning(str(self.temp)))
        shutil.rmtree(self.temp, ignore_errors=True)
