"""The probe agent of the runtime conformance suite (``orchestrator.conformance``).

A standalone script (standard library only) that a runtime under test starts as its agent.
It reads what to do from ``$EAGC_INPUT/probe.json``, writes what it found to
``$EAGC_OUTPUT/probe-result.json`` (written again after every task, so that a task that gets
the probe killed still leaves the earlier findings), and ends the way the last task says.

Tasks (``{"do": [{"task": ..., ...}, ...]}``):

- ``report``: identity, capabilities, the environment, mounts and network interfaces;
- ``filesystem``: tries to write the root, ``/tmp`` (past ``tmp_mb``) and the input folder;
- ``network``: tries TCP to an outside address and to the host, and a DNS lookup;
- ``print``: prints ``lines`` numbered lines;
- ``spawn``: starts a child that touches ``$EAGC_OUTPUT/heartbeat-<name>`` every 0.1 s,
  in the probe's process group or, with ``detached``, double-forked into a new session;
- ``forks``: forks up to ``count`` sleeping children and counts how many it got;
- ``memory``: allocates and touches ``mb`` MiB in 16 MiB chunks;
- ``exit``: exits with ``code``;
- ``hang``: ignores SIGTERM and sleeps until killed.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import sys
import time
from pathlib import Path
from typing import Any

RESULT = "probe-result.json"


def _save(found: dict[str, Any]) -> None:
    out = Path(os.environ["EAGC_OUTPUT"])
    tmp = out / f".{RESULT}.tmp"
    tmp.write_text(json.dumps(found, indent=1, default=str))
    tmp.rename(out / RESULT)


def _status() -> dict[str, str]:
    fields = {}
    with open("/proc/self/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("CapEff", "CapPrm", "CapBnd", "NoNewPrivs", "Seccomp"):
                fields[key] = value.strip()
    return fields


def _attempt(action: Any) -> str:
    try:
        action()
        return "ok"
    except OSError as e:
        return f"failed: {e.strerror or e}"


def _tcp(host: str, port: int) -> str:
    def go() -> None:
        socket.create_connection((host, port), timeout=2).close()

    return _attempt(go)


def _gateway() -> str | None:
    try:
        with open("/proc/net/route") as f:
            for line in f.readlines()[1:]:
                parts = line.split()
                if parts[1] == "00000000":
                    return socket.inet_ntoa(bytes.fromhex(parts[2])[::-1])
    except OSError:
        pass
    return None


def report() -> dict[str, Any]:
    try:
        interfaces = sorted(os.listdir("/sys/class/net"))
    except OSError:
        interfaces = []
    return {
        "uid": os.getuid(), "gid": os.getgid(), "euid": os.geteuid(),
        "status": _status(),
        "env": dict(os.environ),
        "mounts": Path("/proc/self/mounts").read_text(),
        "interfaces": interfaces,
        "input_listing": sorted(os.listdir(os.environ["EAGC_INPUT"])),
    }


def filesystem(tmp_mb: int) -> dict[str, Any]:
    def write(path: str, mb: int = 0) -> None:
        with open(path, "wb") as f:
            chunk = b"\0" * (1 << 20)
            f.write(b"x")
            for _ in range(mb):
                f.write(chunk)
                f.flush()

    tmp_big = f"/tmp/probe-{os.getpid()}"
    found = {
        "root": _attempt(lambda: write(f"/probe-{os.getpid()}")),
        "etc": _attempt(lambda: write("/etc/probe")),
        "input": _attempt(lambda: write(os.path.join(os.environ["EAGC_INPUT"], "probe"))),
        "tmp_small": _attempt(lambda: write(f"/tmp/probe-small-{os.getpid()}")),
        "tmp_past_cap": _attempt(lambda: write(tmp_big, tmp_mb + 4)),
        "output": _attempt(lambda: write(os.path.join(os.environ["EAGC_OUTPUT"], "probe"))),
    }
    for leftover in (tmp_big, f"/tmp/probe-small-{os.getpid()}"):
        try:
            os.unlink(leftover)
        except OSError:
            pass
    return found


def network() -> dict[str, Any]:
    gateway = _gateway()

    def dns() -> None:
        try:
            socket.getaddrinfo("pypi.org", 443)
        except socket.gaierror as e:
            raise OSError(str(e)) from None

    return {
        "outside": _tcp("1.1.1.1", 53),
        "docker_bridge": _tcp("172.17.0.1", 22),
        "gateway": None if gateway is None else _tcp(gateway, 22),
        "dns": _attempt(dns),
    }


def _heartbeat(path: str) -> None:
    while True:
        try:
            with open(path, "w") as f:
                f.write(repr(time.time()))
        except OSError:
            pass
        time.sleep(0.1)


def spawn(name: str, detached: bool) -> int:
    path = os.path.join(os.environ["EAGC_OUTPUT"], f"heartbeat-{name}")
    pid = os.fork()
    if pid == 0:
        if detached:  # a daemon: a new session, then reparented away from the probe
            os.setsid()
            if os.fork() != 0:
                os._exit(0)
        _heartbeat(path)
    if detached:
        os.waitpid(pid, 0)
    deadline = time.monotonic() + 5
    while not os.path.exists(path) and time.monotonic() < deadline:
        time.sleep(0.02)
    return pid


def forks(count: int) -> int:
    children = []
    for _ in range(count):
        try:
            pid = os.fork()
        except OSError:
            break
        if pid == 0:
            time.sleep(30)
            os._exit(0)
        children.append(pid)
    for pid in children:
        try:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        except OSError:
            pass
    return len(children)


def memory(mb: int) -> int:
    held = []
    for _ in range(mb // 16):
        block = bytearray(16 << 20)
        block[::4096] = b"\1" * len(block[::4096])  # touch every page
        held.append(block)
    return len(held) * 16


def main() -> int:
    tasks = json.loads(Path(os.environ["EAGC_INPUT"], "probe.json").read_text())["do"]
    found: dict[str, Any] = {"pid": os.getpid(), "done": []}
    for task in tasks:
        kind = task["task"]
        if kind == "report":
            found["report"] = report()
        elif kind == "filesystem":
            found["filesystem"] = filesystem(int(task["tmp_mb"]))
        elif kind == "network":
            found["network"] = network()
        elif kind == "print":
            for i in range(int(task["lines"])):
                print(f"probe line {i}")
            sys.stdout.flush()
        elif kind == "spawn":
            found.setdefault("spawned", {})[task["name"]] = spawn(
                task["name"], bool(task.get("detached")))
        elif kind == "forks":
            found["forks"] = forks(int(task["count"]))
        elif kind == "memory":
            found["memory_mb"] = memory(int(task["mb"]))
        elif kind == "exit":
            found["done"].append(kind)
            _save(found)
            return int(task["code"])
        elif kind == "hang":
            found["done"].append(kind)
            _save(found)
            signal.signal(signal.SIGTERM, signal.SIG_IGN)
            while True:
                time.sleep(3600)
        else:
            raise SystemExit(f"probe: unknown task {kind!r}")
        found["done"].append(kind)
        _save(found)
    return 0


if __name__ == "__main__":
    sys.exit(main())
