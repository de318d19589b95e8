"""Deadline day: the submission channel accepting and refusing submissions under load
(issue 33 §6), beside the framework's hello-world endpoint measured in the same run.

What runs, all real and on loopback:

- the channel as organizers start it, ``eagc challenge serve CHALLENGE.yaml --no-runner``
  (FastAPI on uvicorn in its own process, Debian's CNCF ``docker-registry`` as its child in
  token mode), from a temporary CHALLENGE.yaml naming ``--teams`` teams, one phase open,
  quota ``per_day: --per-team`` and ``concurrent: 2 × --per-team``. No runner: submissions
  stay ``received`` (an image that passes its pre-flight at once is the same to the API);
  what is measured is acceptance;
- each team's token, made on the served database (``ChannelDB.new_token``, what
  ``eagc challenge teams token`` does);
- one tiny image (``docker import`` of a tar holding one 13-byte file), tagged and pushed
  once per team through the Docker engine with the team's credentials to
  ``<registry>/teams/<team>/tiny:v1`` (as ``eagc submit`` pushes: the engine asks the
  channel's ``/auth/token`` for a registry token);
- the floor: a minimal FastAPI app with one ``GET /hello`` route (a sync ``def``, as the
  channel's routes are: both run in Starlette's thread pool) on uvicorn, in its own process.

The load: a pool of ``--clients`` threads in this process (``requests``, one keep-alive
session per thread; no asyncio HTTP client is installed), all started together, takes
requests from one list in team-interleaved order and sends each as soon as it is free
(a closed loop: everyone presses submit at once). In order:

1. hello world: ``teams × per-team`` GETs (the first half of the floor);
2. accept: ``teams × per-team`` ``POST /api/v1/submissions`` with
   ``{"image": "teams/<team>/tiny@sha256:…"}`` and the team's Bearer token: all 201;
3. refuse: as many again, each team now over its ``per_day``: all 429;
4. hello world again (the second half of the floor).

Per row: requests per second (the count over the wall time from the first send to the last
answer), p50 and p99 of each request's latency as the client sees it (a closed loop: with
every client busy, latency is about clients ÷ throughput, so read it beside the floor's),
the CPU the server process used per request (``/proc/PID/stat``: on a shared 2-core machine
the steadier figure) and, for submits, its registry's (one manifest ``HEAD`` per accepted
submit; an over-quota one is refused before the registry is asked), and peak RSS
(``VmHWM``) of the channel's process, of its registry and of the hello-world process.

``--history N`` first fills the database with N scored submissions of the 30 days before
(30000: a month of 100 teams × 10 a day), the database a channel holds on the last day of
a phase.

Then the channel is killed (SIGKILL: nothing may depend on a clean shutdown) and its
database read: every accepted id must be there exactly once, in ``received``, with one
history row; no refused submit may have left a row. ``lost`` counts accepted ids missing;
``extra`` counts rows no 201 answered.

Run:  python tests/benchmarks/bench_channel.py [--teams 100] [--per-team 10] [--clients 100]
          [--history 30000]
Goal (issue 33 §6): 1,000 accepted within 60 s with nothing lost, the 1,000 over quota
refused (429).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _machine import load_average, machine_line  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TINY = "eagc-bench/tiny"
CLK_TCK = os.sysconf("SC_CLK_TCK")


# ---------------------------------------------------------------------- the floor
def hello_main(port: int) -> None:
    """The hello-world server (a child process): one GET route, as small as FastAPI gets."""
    import uvicorn
    from fastapi import FastAPI

    app = FastAPI(docs_url=None, redoc_url=None)

    @app.get("/hello")
    def hello() -> dict[str, str]:
        return {"hello": "world"}

    uvicorn.run(app, host="127.0.0.1", port=port, log_level="warning", access_log=False)


# ---------------------------------------------------------------------- processes
def proc_status(pid: int, key: str) -> float:
    """A ``/proc/PID/status`` figure in MiB (``VmHWM``, ``VmRSS``)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith(key + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (all its threads)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / CLK_TCK


def children(pid: int) -> list[int]:
    out: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            out += [int(c) for c in (task / "children").read_text().split()]
    return out


def free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_http(url: str, proc: subprocess.Popen[bytes], log: Path, timeout_s: float = 120) -> None:
    import requests

    deadline = time.monotonic() + timeout_s
    while True:
        if proc.poll() is not None:
            raise RuntimeError(f"{proc.args} exited {proc.returncode}:\n{log.read_text()[-2000:]}")
        try:
            requests.get(url, timeout=2)
            return
        except requests.ConnectionError:
            if time.monotonic() > deadline:
                raise RuntimeError(f"{url} did not answer in {timeout_s:.0f} s") from None
            time.sleep(0.2)


def fill_history(db_path: Path, teams: list[str], n: int, days: int = 30) -> None:
    """``n`` scored submissions of the ``days`` before today, spread over the teams: the
    database a channel holds on the last day of a month-long phase (ids ``h-…``)."""
    from orchestrator._channel.db import ChannelDB

    db = ChannelDB(db_path)
    now = time.time()
    rows = []
    for i in range(n):
        team, ago = teams[i % len(teams)], 1 + (i // len(teams)) % days
        t = now - ago * 86400
        rows.append((f"h-{i:07d}", team, "final", f"teams/{team}/tiny", "sha256:" + "0" * 64,
                     "", "scored", "scored", t, t, 2, 1, db.day(t)))
    db.db.execute("BEGIN")
    db.db.executemany(
        "INSERT INTO submissions (id, team, phase, repository, digest, note, state, reason, "
        "created_at, updated_at, episodes_planned, charged, day) "
        "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)
    db.db.executemany("INSERT INTO history VALUES (?, ?, 'scored', 'scored')",
                      [(r[0], r[8]) for r in rows])
    db.db.execute("COMMIT")
    db.close()


def challenge_yaml(teams: list[str], per_team: int) -> str:
    return "\n".join([
        "name: deadline-day",
        "track: sanity",
        f"teams: [{', '.join(teams)}]",
        "token_days: 30",
        "phases:",
        "  - name: final",
        "    kind: testing",
        "    opens: start",
        "    splits: [{name: standard, episodes: 2}]",
        f"    quota: {{per_day: {per_team}, concurrent: {2 * per_team}}}",
        "",
    ])


# ---------------------------------------------------------------------- the image
def tiny_image(engine) -> str:  # noqa: ANN001
    """``docker import`` of a tar holding one small file; returns its id."""
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as tar:
        data = b"deadline day\n"
        info = tarfile.TarInfo("hello.txt")
        info.size, info.mtime = len(data), 0
        tar.addfile(info, io.BytesIO(data))
    engine.api.import_image_from_data(buf.getvalue(), repository=TINY, tag="v1")
    return str(engine.images.get(f"{TINY}:v1").id)


def push(engine, registry: str, team: str, token: str) -> str:  # noqa: ANN001
    """Pushes the tiny image as ``teams/<team>/tiny:v1`` with the team's credentials;
    returns ``teams/<team>/tiny@<digest>``."""
    target = f"{registry}/teams/{team}/tiny"
    engine.images.get(f"{TINY}:v1").tag(target, "v1")
    digest = None
    try:
        for line in engine.images.push(target, "v1", stream=True, decode=True,
                                       auth_config={"username": team, "password": token}):
            if "error" in line:
                raise RuntimeError(f"push of {target} refused: {line['error']}")
            digest = (line.get("aux") or {}).get("Digest") or digest
    finally:
        engine.images.remove(f"{target}:v1", noprune=True)
    if not digest:
        raise RuntimeError(f"push of {target}: no digest")
    return f"teams/{team}/tiny@{digest}"


# ---------------------------------------------------------------------- the load
@dataclass
class Phase:
    """What one burst of requests gave: wall time, each answer's latency, status, body,
    and the server's CPU seconds over the burst."""

    name: str
    wall_s: float = 0.0
    cpu_s: float = 0.0
    latencies: list[float] = field(default_factory=list)
    statuses: list[int] = field(default_factory=list)
    bodies: list[dict] = field(default_factory=list)

    def add(self, other: Phase) -> Phase:
        return Phase(self.name, self.wall_s + other.wall_s, self.cpu_s + other.cpu_s,
                     self.latencies + other.latencies, self.statuses + other.statuses,
                     self.bodies + other.bodies)

    @property
    def n(self) -> int:
        return len(self.latencies)

    def pct(self, q: float) -> float:
        xs = sorted(self.latencies)
        return 1000 * xs[min(len(xs) - 1, int(q * len(xs)))]


Request = tuple[str, str, dict[str, str], dict | None]  # method, url, headers, json


def burst(name: str, requests_: list[Request], clients: int, pids: list[int]) -> Phase:
    """Sends every request from ``clients`` threads at once (closed loop); the answers in
    request order."""
    import requests

    local = threading.local()
    start = threading.Barrier(clients + 1)
    out: list[tuple[float, int, dict]] = [(0.0, 0, {})] * len(requests_)
    cursor = iter(range(len(requests_)))
    lock = threading.Lock()

    def session() -> requests.Session:
        if not hasattr(local, "s"):
            local.s = requests.Session()
        return local.s

    def worker() -> None:
        s = session()
        start.wait()
        while True:
            with lock:
                i = next(cursor, None)
            if i is None:
                return
            method, url, headers, body = requests_[i]
            t = time.perf_counter()
            try:
                r = s.request(method, url, headers=headers, json=body, timeout=120)
                status, doc = r.status_code, r.json()
            except Exception as e:  # noqa: BLE001 - counted as an error, shown below
                status, doc = 0, {"detail": f"{type(e).__name__}: {e}"}
            out[i] = (time.perf_counter() - t, status, doc)

    cpu0 = sum(cpu_s(p) for p in pids)
    with ThreadPoolExecutor(clients) as pool:
        for _ in range(clients):
            pool.submit(worker)
        start.wait()
        t0 = time.perf_counter()
    wall = time.perf_counter() - t0
    cpu = sum(cpu_s(p) for p in pids) - cpu0
    return Phase(name, wall, cpu, [o[0] for o in out], [o[1] for o in out], [o[2] for o in out])


def unexpected(phase: Phase, want: int) -> list[str]:
    """One line per kind of answer other than ``want``."""
    seen: dict[str, int] = {}
    for status, body in zip(phase.statuses, phase.bodies, strict=True):
        if status != want:
            key = f"{status}: {str(body.get('detail', body))[:60]}"
            seen[key] = seen.get(key, 0) + 1
    return [f"  {phase.name}: {n} × {k}" for k, n in sorted(seen.items())]


# ---------------------------------------------------------------------- the audit
def audit(db_path: Path, accepted: list[str], refused_bodies: list[dict]) -> dict[str, int]:
    """The database against the answers: lost (accepted, not there), twice, wrong state or
    history, extra (there, never accepted)."""
    db = sqlite3.connect(f"file:{db_path}?mode=ro", uri=True)
    rows = db.execute("SELECT id, state FROM submissions WHERE id NOT LIKE 'h-%'").fetchall()
    hist = dict(db.execute("SELECT submission, COUNT(*) FROM history GROUP BY submission"))
    db.close()
    ids = [r[0] for r in rows]
    state = dict(rows)
    want = set(accepted)
    return {
        "accepted": len(accepted),
        "rows": len(rows),
        "lost": len(want - set(ids)),
        "twice": len(ids) - len(set(ids)) + len(accepted) - len(want),
        "not received": sum(1 for i in want if i in state and state[i] != "received"),
        "history": sum(1 for i in want if hist.get(i, 0) != 1),
        "extra": len(set(ids) - want),
        "refused with an id": sum(1 for b in refused_bodies if "id" in b),
    }


# ---------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--teams", type=int, default=100)
    ap.add_argument("--per-team", type=int, default=10,
                    help="accepted submissions per team (its per_day); as many refused")
    ap.add_argument("--clients", type=int, default=100, help="concurrent client threads")
    ap.add_argument("--history", type=int, default=0,
                    help="earlier days' submissions already in the database (a month of "
                    "100 teams × 10 a day: 30000)")
    ap.add_argument("--keep", action="store_true", help="keep the channel's data folder")
    ap.add_argument("--hello", type=int, help=argparse.SUPPRESS)  # the floor's child
    args = ap.parse_args()
    if args.hello:
        hello_main(args.hello)
        return

    import docker

    from orchestrator._channel.db import ChannelDB

    print(machine_line("fastapi", "uvicorn", "starlette", "requests",
                       extra=f"sqlite {sqlite3.sqlite_version}"))
    print(f"load average before: {load_average()}")
    if args.history:
        print(f"the database holds {args.history:,} submissions of the 30 days before")
    teams = [f"team-{i:03d}" for i in range(args.teams)]
    n = args.teams * args.per_team
    tmp = Path(tempfile.mkdtemp(prefix="eagc-bench-ch-", dir="/tmp"))
    data = tmp / "data"
    (tmp / "CHALLENGE.yaml").write_text(challenge_yaml(teams, args.per_team))
    procs: list[subprocess.Popen[bytes]] = []
    registry_pid = None
    engine = docker.from_env()
    try:
        if args.history:
            data.mkdir(mode=0o700)
            fill_history(data / "channel.sqlite", teams, args.history)
        # The channel, as organizers start it, and the floor.
        port, hello_port = free_port(), free_port()
        log = tmp / "serve.log"
        channel = subprocess.Popen(
            [sys.executable, "-m", "orchestrator.cli", "challenge", "serve",
             str(tmp / "CHALLENGE.yaml"), "--data", str(data), "--port", str(port),
             "--no-runner"], stdout=log.open("wb"), stderr=subprocess.STDOUT, cwd=REPO,
            start_new_session=True)
        procs.append(channel)
        hello_log = tmp / "hello.log"
        hello = subprocess.Popen([sys.executable, __file__, "--hello", str(hello_port)],
                                 stdout=hello_log.open("wb"), stderr=subprocess.STDOUT)
        procs.append(hello)
        url, hello_url = f"http://127.0.0.1:{port}", f"http://127.0.0.1:{hello_port}"
        wait_http(url + "/api/v1/whoami", channel, log)
        wait_http(hello_url + "/hello", hello, hello_log)
        registry = json.loads((data / "serve.json").read_text())["registry"]
        registry_pid = next(p for p in children(channel.pid)
                            if Path(f"/proc/{p}/comm").read_text().strip() == "docker-registry")

        # Tokens, and each team's image pushed once.
        t = time.perf_counter()
        db = ChannelDB(data / "channel.sqlite")
        tokens = {team: db.new_token(team, 30)[0] for team in teams}
        db.close()
        tiny_image(engine)
        with ThreadPoolExecutor(8) as pool:
            images = dict(zip(teams, pool.map(lambda tm: push(engine, registry, tm,
                                                              tokens[tm]), teams), strict=True))
        print(f"{args.teams} teams, tokens made and tiny images pushed in "
              f"{time.perf_counter() - t:.1f} s (one digest: "
              f"{len({i.split('@')[1] for i in images.values()}) == 1})")

        # Warm both servers up (every team's token once, the floor as often).
        warm_channel = [("GET", url + "/api/v1/whoami",
                         {"Authorization": f"Bearer {tokens[tm]}"}, None) for tm in teams]
        warm_hello = [("GET", hello_url + "/hello", {}, None)] * len(teams)
        burst("warm-up", warm_channel, args.clients, [channel.pid])
        burst("warm-up", warm_hello, args.clients, [hello.pid])
        rss_before = proc_status(channel.pid, "VmRSS")

        order = [tm for _ in range(args.per_team) for tm in teams]
        submits: list[Request] = [
            ("POST", url + "/api/v1/submissions", {"Authorization": f"Bearer {tokens[tm]}"},
             {"image": images[tm]}) for tm in order]
        gets: list[Request] = [("GET", hello_url + "/hello", {}, None)] * n
        print(f"load average at the start: {load_average()}; {args.clients} client threads")
        floor = burst("hello world", gets, args.clients, [hello.pid])
        reg = [cpu_s(registry_pid)]
        accept = burst("accept", submits, args.clients, [channel.pid])
        reg.append(cpu_s(registry_pid))
        refuse = burst("refuse", submits, args.clients, [channel.pid])
        reg.append(cpu_s(registry_pid))
        floor = floor.add(burst("hello world", gets, args.clients, [hello.pid]))
        load_after = load_average()
        peak = {"channel": proc_status(channel.pid, "VmHWM"),
                "registry": proc_status(registry_pid, "VmHWM"),
                "hello": proc_status(hello.pid, "VmHWM")}
        rss_after = proc_status(channel.pid, "VmRSS")
        reg_rss = proc_status(registry_pid, "VmRSS")

        # Kill the channel (no clean shutdown), then read its database.
        os.killpg(channel.pid, signal.SIGKILL)
        channel.wait(10)
        accepted = [b["id"] for s, b in zip(accept.statuses, accept.bodies, strict=True)
                    if s == 201]
        found = audit(data / "channel.sqlite", accepted, refuse.bodies)
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait(10)
        if registry_pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(registry_pid, signal.SIGTERM)
        with contextlib.suppress(Exception):
            engine.images.remove(f"{TINY}:v1")
        if args.keep:
            print(f"kept: {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)

    def row(label: str, p: Phase, reg_s: float | None, mib: float | None) -> str:
        return (f"{label:<24}{p.n:>6,}{p.n / p.wall_s:>7,.0f}{p.pct(0.5):>8.1f}"
                f"{p.pct(0.99):>8.1f}{1000 * p.cpu_s / p.n:>7.2f}"
                + (f"{1000 * reg_s / p.n:>8.2f}" if reg_s is not None else f"{'-':>8}")
                + (f"{mib:>9.0f}" if mib is not None else ""))

    print()
    print(f"{'':<24}{'n':>6}{'req/s':>7}{'p50 ms':>8}{'p99 ms':>8}{'CPU ms':>7}{'+reg ms':>8}"
          f"{'peak MiB':>9}")
    print(row("channel: accepted (201)", accept, reg[1] - reg[0], peak["channel"]))
    print(row("channel: refused (429)", refuse, reg[2] - reg[1], None))
    print(f"{'  its registry':<24}{'':>44}{peak['registry']:>9.0f}")
    print(row("hello world GET (floor)", floor, None, peak["hello"]))
    print(f"lost: {found['lost']}  (accepted {found['accepted']:,}, rows {found['rows']:,}, "
          f"twice {found['twice']}, extra {found['extra']}, refused with an id "
          f"{found['refused with an id']})")
    problems = unexpected(accept, 201) + unexpected(refuse, 429) + unexpected(floor, 200)
    if problems or found["not received"] or found["history"]:
        print("unexpected:")
        print("\n".join(problems))
        if found["not received"] or found["history"]:
            print(f"  database: {found['not received']} not 'received', {found['history']} "
                  "without exactly one history row")
    print()
    print(f"accepted {len(accepted):,} of {n:,} in {accept.wall_s:.1f} s "
          f"({'within' if accept.wall_s <= 60 else 'NOT within'} 60 s); accept ÷ floor "
          f"throughput {accept.n / accept.wall_s / (floor.n / floor.wall_s):.2f}, "
          f"CPU per request {accept.cpu_s / accept.n / (floor.cpu_s / floor.n):.1f}×")
    print(f"channel RSS {rss_before:.0f} MiB before the submits, {rss_after:.0f} after; "
          f"registry RSS now {reg_rss:.0f} MiB")
    print("CPU ms: the server process's CPU per request; +reg ms: its registry's")
    print(f"load average after: {load_after}")


if __name__ == "__main__":
    main()
