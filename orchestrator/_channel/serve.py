"""``eagc challenge serve``: the registry, the API and a runner, together.

The registry and the runner are child processes; the API runs in this one (uvicorn). What
it serves, and where, is written to ``<data>/serve.json`` and printed on one line. Ctrl-C
or SIGTERM stops all three; a runner whose channel process is gone stops by itself.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from orchestrator._channel.channel import Channel
from orchestrator._channel.db import ChannelDB, ChannelError, Clock
from orchestrator._channel.registry import RegistryProcess, die_with_parent, free_port
from schemas import ChallengeSpec, SchemaError, parse_json

Say = Callable[[str], None]
log = logging.getLogger("eagc.channel")


def load_challenge(path: Path) -> ChallengeSpec:
    """Reads and validates ``CHALLENGE.yaml``; SchemaError names the file and the field."""
    import yaml

    from plugins import PluginError, load_track

    try:
        doc = yaml.safe_load(path.read_text())
    except OSError as e:
        raise SchemaError(str(path), [f"cannot read the challenge file: {e.strerror or e}"]
                          ) from None
    except yaml.YAMLError as e:
        raise SchemaError(str(path), [f"not valid YAML: {e}"]) from None
    if not isinstance(doc, dict):
        raise SchemaError(str(path), ["(top level): a challenge file is a mapping (name: …)"])
    spec = parse_json(json.dumps(doc, default=str), ChallengeSpec, source=str(path))
    try:
        plugin = load_track(spec.track)
    except PluginError as e:
        raise SchemaError(str(path), [f"track: {e}"]) from None
    problems = [f"phases.{i}.splits.{j}.name: track {spec.track!r} has no split {s.name!r}"
                for i, p in enumerate(spec.phases) for j, s in enumerate(p.splits)
                if s.name not in plugin.split_names() and not s.params]
    if problems:
        raise SchemaError(str(path), problems)
    return spec


@dataclass(frozen=True)
class Served:
    url: str
    registry: str
    data: Path


def open_db(data: Path) -> ChannelDB:
    """The channel's database, for the commands that work on it while it serves or not."""
    if not (data / "channel.sqlite").is_file():
        raise ChannelError(f"{data} holds no channel: start one with `eagc challenge serve "
                           f"CHALLENGE.yaml --data {data}`")
    return ChannelDB(data / "channel.sqlite")


def serving(data: Path) -> bool:
    """Whether a channel process serves ``data`` now."""
    try:
        pid = int(json.loads((data / "serve.json").read_text())["pid"])
        os.kill(pid, 0)
    except (OSError, ValueError, KeyError):
        return False
    return True


def open_channel(data: Path) -> Channel:
    """The channel over ``data`` with the challenge file it last served (the organizer's
    commands, serving or not)."""
    db = open_db(data)
    text, clock = db.meta("spec"), db.meta("clock")
    db.close()
    if text is None:
        raise ChannelError(f"{data} holds no challenge yet: serve it once")
    return Channel(ChallengeSpec.model_validate_json(text), data, clock=Clock.of(clock))


def serve(spec: ChallengeSpec, data: Path, *, host: str = "127.0.0.1", port: int = 0,
          registry_port: int = 0, workers: int = 1, address: str | None = None,
          runner: bool = True, clock: Clock | None = None, say: Say = print) -> None:
    """Serves until interrupted."""
    import uvicorn

    from orchestrator._channel.api import create_app, manifest_pem

    data = data.resolve()
    port = port or free_port(host)
    channel = Channel(spec, data, clock=clock)
    channel.db.set_meta("token_days", str(spec.token_days))
    channel.db.set_meta("spec", spec.model_dump_json())  # for `eagc challenge` off-line
    state = channel.clock.state()
    if state is not None:  # a compressed clock: every process on the data reads it
        channel.db.set_meta("clock", state)
    else:
        with channel.db.tx() as db:
            db.execute("DELETE FROM meta WHERE key='clock'")
    registry = RegistryProcess(data / "registry", channel.keys,
                               realm=f"http://{host}:{port}/auth/token", host=host,
                               port=registry_port)
    registry.start()
    channel.registry = registry
    for team in channel.add_spec_teams():
        say(f"team {team} added (give it a token: eagc challenge teams token {team} "
            f"--data {data})")
    for phase in spec.phases:
        if phase.secret is None:
            channel.phase_secret(phase)
    channel.check_seeds_apart()
    manifest_pem(channel)  # the final's key, made before the calendar shows it
    served = Served(f"http://{host}:{port}", registry.address, data)
    (data / "serve.json").write_text(json.dumps(
        {"url": served.url, "registry": served.registry, "pid": os.getpid()}))
    runners = [_start_runner(served, workers, address)] if runner else []
    say(f"channel {spec.name}: {served.url}  registry {served.registry}  data {data}"
        + ("" if runners else "  (no runner)"))
    config = uvicorn.Config(create_app(channel), host=host, port=port, log_level="warning",
                            access_log=False)
    stop = threading.Event()

    def runner_again() -> None:
        """A runner that exited (a lost Ray cluster ends its process) is started again;
        what it held comes back to the queue when its lease runs out."""
        if runners and runners[0].poll() is not None and not stop.is_set():
            log.warning("the runner exited (%s): starting another", runners[0].returncode)
            runners[0] = _start_runner(served, workers, address)

    threading.Thread(target=_watch, args=(channel, registry, stop, runner_again),
                     daemon=True, name="eagc-watch").start()
    try:
        uvicorn.Server(config).run()
    finally:
        stop.set()
        for child in runners:
            _stop(child)
        registry.stop()
        channel.db.close()
        (data / "serve.json").unlink(missing_ok=True)


def _watch(channel: Channel, registry: RegistryProcess, stop: threading.Event,
           runner_again: Callable[[], None], every_s: float = 5.0) -> None:
    """Puts back what a dead runner held, even when no runner is left to claim work;
    starts the registry again should it die (on the same port: pushes resume), and the
    runner."""
    while not stop.wait(every_s):
        runner_again()
        try:
            for sid in channel.expire_leases():
                log.warning("%s: its runner stopped answering; back in line", sid)
        except Exception as e:  # noqa: BLE001 - a busy database: try again next time
            log.warning("expiring leases: %s", e)
        if not registry.alive() and not stop.is_set():
            log.warning("the registry exited (%s): starting it again",
                        registry.process.returncode if registry.process else "?")
            try:
                registry.start()
            except Exception as e:  # noqa: BLE001 - said, and tried again next time
                log.warning("the registry did not start again: %s", e)


def _start_runner(served: Served, workers: int, address: str | None) -> subprocess.Popen[Any]:
    cmd = [sys.executable, "-m", "orchestrator.cli", "challenge", "runner", served.url,
           "--token-file", str(served.data / "runner.token"),
           "--runs", str(served.data / "runs"), "--workers", str(workers)]
    if address:
        cmd += ["--address", address]
    log = (served.data / "runner.log").open("ab")
    # SIGTERM when this process dies, even by SIGKILL: the runner's cancel path runs
    # (its containers removed) and its submission's lease runs out for the next runner.
    return subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                            start_new_session=True, preexec_fn=die_with_parent(signal.SIGTERM))


def _stop(child: subprocess.Popen[Any], grace_s: float = 30.0) -> None:
    if child.poll() is not None:
        return
    os.killpg(child.pid, signal.SIGTERM)
    deadline = time.monotonic() + grace_s
    while child.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    if child.poll() is None:
        os.killpg(child.pid, signal.SIGKILL)
        child.wait(5)
