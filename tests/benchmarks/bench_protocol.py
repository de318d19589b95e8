#!/usr/bin/env python
"""Protocol round-trip benchmark (issue 2): our step against raw transports.

    python tests/benchmarks/bench_protocol.py [--quick] [--only ours,unix] [--rounds R]

One process each side, every pattern over a unix domain socket in one temp dir, in the same
run: our ``RemoteEnv.step`` ↔ ``SimHost`` serving a null episode (no physics, a fixed
observation), raw Zenoh publisher/subscriber ping-pong, raw Zenoh get/queryable, a gRPC
bidirectional stream of raw bytes (dm_env_rpc's shape; generic handlers, no .proto), a
bare AF_UNIX socket with length-prefixed frames (the floor), and "minimal Python step": Zenoh
pub/sub where both sides do the least Python work a step needs (a JSON header with the
tensors' layout built and parsed, tensor views, a seq check), with no validation, no action
check and no episode logic (server on a FIFO channel, as ours): what any Python
implementation of such a protocol pays. Two payloads: a small observation (~64 B of float32
tensors) and a 640×480 RGB uint8 + 640×480 float32 depth one.
The request is always small (one 2-vector action; raw patterns send 64 B). Raw servers send
a ready-made bytes object; ours builds its reply every step (one copy of the tensors).
Cases run in interleaved rounds, so load elsewhere on the machine spreads over all of them.

The parent only orchestrates: it starts a server process, waits for it to say READY, runs a
client process that prints its latencies as JSON, then kills both (also on error, Ctrl-C or
SIGTERM; children also die with the parent through PR_SET_PDEATHSIG).

Not collected by pytest (the file is ``bench_*.py``).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import select
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from _machine import die_with_parent, load_average, machine_line, reap  # noqa: E402  (sibling)

ROOT = Path(__file__).resolve().parents[2]
H, W = 480, 640
SMALL_REPLY = 64
LARGE_REPLY = H * W * 3 + H * W * 4
REQUEST_BYTES = 64
EPISODE = "benchEpisode01"
ACTION = {"velocity": [0.5, 0.0]}

# name, label, is raw zenoh
CASES: list[tuple[str, str, bool]] = [
    ("ours", "ours: RemoteEnv.step <-> SimHost", False),
    ("zpubsub", "zenoh pub/sub (callback->queue)", True),
    ("zpubsub-fifo", "zenoh pub/sub (FIFO channel)", True),
    ("zget", "zenoh get/queryable", True),
    ("zmin", "minimal Python step over zenoh", False),
    ("grpc", "gRPC bidi stream (raw bytes)", False),
    ("unix", "bare AF_UNIX socket (floor)", False),
]
PAYLOADS = ("small", "large")


# ================================================================================ children
def _reply_size(payload: str) -> int:
    return SMALL_REPLY if payload == "small" else LARGE_REPLY


def _ready() -> None:
    print("READY", flush=True)


def _zconfig(sock: str, listen: bool) -> Any:
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    ep = json.dumps([f"unixsock-stream/{sock}"])
    conf.insert_json5("listen/endpoints", ep if listen else "[]")
    conf.insert_json5("connect/endpoints", "[]" if listen else ep)
    return conf


def _wait_forever() -> None:
    while True:
        time.sleep(3600)


# ------------------------------------------------------------------------------- servers
def serve_ours(sock: str, payload: str) -> None:

    from schemas._protocol import ActionResult, FieldSpec
    from simhost.host._episode import Observation, StageSpec, StepOutcome, TrackEpisode
    from simhost.host._host import HostConfig, SimHost

    tensors = _observation_tensors(payload)
    obs = Observation(tensors=tensors)
    ok = ActionResult(applied=True, ok=True)

    class NullEpisode(TrackEpisode):
        observation_spec = tuple(
            FieldSpec(name=k, dtype=v.dtype.name, shape=v.shape, tensor=True)
            for k, v in tensors.items()
        )
        action_spec = (FieldSpec(name="velocity", dtype="float32", shape=(2,), low=-1.0, high=1.0),)

        def reset(self) -> Observation:
            return obs

        def step(self, stage: str, action: Any) -> StepOutcome:
            return StepOutcome(observation=obs, action=ok)

        def observe(self) -> Observation:
            return obs

    config = HostConfig(
        episode=EPISODE,
        track="bench",
        endpoints=(f"unixsock-stream/{sock}",),
        socket_path=Path(sock),
        startup_s=120.0,
        max_request_bytes=1 << 20,
    )
    host = SimHost(NullEpisode(), [StageSpec(name="bench", budget_s=86400.0)], config)
    host.open()
    _ready()
    try:
        host.serve()  # returns when the agent's liveliness token goes
    finally:
        host.close()


def serve_zpubsub(sock: str, payload: str) -> None:
    import zenoh

    reply = bytes(_reply_size(payload))
    session = zenoh.open(_zconfig(sock, listen=True))
    pub = session.declare_publisher(
        "bench/pong", congestion_control=zenoh.CongestionControl.BLOCK, express=True
    )

    def on_ping(sample: Any) -> None:
        sample.payload.to_bytes()
        pub.put(reply)

    _sub = session.declare_subscriber("bench/ping", on_ping)
    _ready()
    _wait_forever()


def serve_zget(sock: str, payload: str) -> None:
    import zenoh

    reply = bytes(_reply_size(payload))
    session = zenoh.open(_zconfig(sock, listen=True))

    def on_query(query: Any) -> None:
        if query.payload is not None:
            query.payload.to_bytes()
        query.reply("bench/q", reply)

    _q = session.declare_queryable("bench/q", on_query)
    _ready()
    _wait_forever()


def _min_encode(doc: dict[str, Any], tensors: dict[str, Any]) -> bytes:
    """The least a message needs: a JSON header naming the tensors, then their bytes."""
    import pydantic_core

    metas, blobs, offset = [], [], 0
    for name, a in tensors.items():
        n = a.nbytes
        metas.append({"name": name, "dtype": a.dtype.name, "shape": a.shape, "offset": offset,
                      "nbytes": n})
        blobs.append(memoryview(a).cast("B"))
        if n % 8:
            blobs.append(bytes(8 - n % 8))
        offset += n + (-n) % 8
    doc["tensors"] = metas
    header = pydantic_core.to_json(doc)
    return b"".join([_LEN.pack(len(header)), header, *blobs])


def _min_decode(buf: bytes) -> tuple[dict[str, Any], dict[str, Any]]:
    import numpy as np
    import pydantic_core

    (n,) = _LEN.unpack_from(buf)
    doc = pydantic_core.from_json(buf[4 : 4 + n])
    block = memoryview(buf)[4 + n :]
    return doc, {
        m["name"]: np.frombuffer(block, dtype=m["dtype"], count=m["nbytes"] // np.dtype(
            m["dtype"]).itemsize, offset=m["offset"]).reshape(m["shape"])
        for m in doc["tensors"]
    }


def _observation_tensors(payload: str) -> dict[str, Any]:
    import numpy as np

    rng = np.random.default_rng(0)
    if payload == "small":  # 7 + 7 + 2 float32 = 64 B
        return {
            "qpos": rng.standard_normal(7).astype(np.float32),
            "qvel": rng.standard_normal(7).astype(np.float32),
            "force": rng.standard_normal(2).astype(np.float32),
        }
    return {
        "rgb": rng.integers(0, 256, (H, W, 3), dtype=np.uint8),
        "depth": rng.random((H, W), dtype=np.float32),
    }


def serve_zmin(sock: str, payload: str) -> None:
    import time as _time

    import zenoh

    tensors = _observation_tensors(payload)
    session = zenoh.open(_zconfig(sock, listen=True))
    pub = session.declare_publisher(
        "bench/pong", congestion_control=zenoh.CongestionControl.BLOCK, express=True
    )
    requests = session.declare_subscriber("bench/ping", zenoh.handlers.FifoChannel(64))
    _ready()
    seq = 0
    while True:
        doc, _ = _min_decode(requests.recv().payload.to_bytes())
        if doc.get("seq", seq) == seq:
            seq += 1
        reply = {"kind": "observation", "seq": seq, "stage": "bench", "stage_index": 0,
                 "time_left_s": _time.monotonic(), "steps_left": None, "observation": {},
                 "action": {"applied": True, "ok": True, "reason": ""}, "messages": [],
                 "episode_over": False, "end_reason": None}
        pub.put(_min_encode(reply, tensors))

_GRPC_OPTIONS = [
    ("grpc.max_send_message_length", 64 << 20),
    ("grpc.max_receive_message_length", 64 << 20),
]


def serve_grpc(sock: str, payload: str) -> None:
    from concurrent.futures import ThreadPoolExecutor

    import grpc

    reply = bytes(_reply_size(payload))

    def process(requests: Any, context: Any) -> Any:
        for _ in requests:
            yield reply

    handler = grpc.method_handlers_generic_handler(
        "bench.Env", {"Process": grpc.stream_stream_rpc_method_handler(process)}
    )
    server = grpc.server(ThreadPoolExecutor(max_workers=4), options=_GRPC_OPTIONS)
    server.add_generic_rpc_handlers((handler,))
    server.add_insecure_port(f"unix:{sock}")
    server.start()
    _ready()
    server.wait_for_termination()


_LEN = struct.Struct("<I")


def _recv_exact(conn: socket.socket, view: memoryview) -> None:
    got = 0
    while got < len(view):
        n = conn.recv_into(view[got:])
        if n == 0:
            raise ConnectionError("peer closed")
        got += n


def serve_unix(sock: str, payload: str) -> None:
    reply = bytes(_reply_size(payload))
    header = _LEN.pack(len(reply))
    srv = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    srv.bind(sock)
    srv.listen(1)
    _ready()
    conn, _ = srv.accept()
    hdr = bytearray(_LEN.size)
    buf = bytearray(1 << 16)
    try:
        while True:
            _recv_exact(conn, memoryview(hdr))
            (n,) = _LEN.unpack(hdr)
            if n > len(buf):
                buf = bytearray(n)
            _recv_exact(conn, memoryview(buf)[:n])
            conn.sendmsg([header, reply])
    except ConnectionError:
        pass


# ------------------------------------------------------------------------------- clients
def _measure(call: Any, warmup: int, n: int) -> list[int]:
    for _ in range(warmup):
        call()
    out = [0] * n
    clock = time.perf_counter_ns
    for i in range(n):
        t0 = clock()
        call()
        out[i] = clock() - t0
    return out


def client_ours(sock: str, payload: str, warmup: int, n: int) -> list[int]:
    from simhost.client import RemoteEnv

    env = RemoteEnv(f"unixsock-stream/{sock}", EPISODE)  # the default a team uses
    try:
        env.hello(agent="bench")
        env.reset()
        return _measure(lambda: env.step(ACTION), warmup, n)
    finally:
        env.close()


def _handshake(send: Any, recv: Any) -> None:
    """Ping until the first pong (subscriptions may still be propagating), then drain."""
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        send()
        if recv(0.2) is not None:
            time.sleep(0.2)
            while recv(0.05) is not None:
                pass
            return
    raise TimeoutError("no pong within 30 s")


def client_zpubsub(sock: str, payload: str, warmup: int, n: int, fifo: bool = False) -> list[int]:
    import queue

    import zenoh

    request = bytes(REQUEST_BYTES)
    session = zenoh.open(_zconfig(sock, listen=False))
    try:
        if fifo:
            sub = session.declare_subscriber("bench/pong", zenoh.handlers.FifoChannel(64))

            def recv(timeout: float) -> Any:
                deadline = time.monotonic() + timeout
                while True:
                    s = sub.try_recv()
                    if s is not None:
                        return s.payload.to_bytes()
                    if time.monotonic() > deadline:
                        return None
                    time.sleep(0.005)

            def wait() -> bytes:
                return sub.recv().payload.to_bytes()
        else:
            q: queue.SimpleQueue[bytes] = queue.SimpleQueue()
            sub = session.declare_subscriber("bench/pong", lambda s: q.put(s.payload.to_bytes()))

            def recv(timeout: float) -> Any:
                try:
                    return q.get(timeout=timeout)
                except queue.Empty:
                    return None

            wait = q.get
        pub = session.declare_publisher(
            "bench/ping", congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        _handshake(lambda: pub.put(request), recv)

        def call() -> None:
            pub.put(request)
            wait()

        return _measure(call, warmup, n)
    finally:
        session.close()


def client_zget(sock: str, payload: str, warmup: int, n: int) -> list[int]:
    import zenoh

    request = bytes(REQUEST_BYTES)
    session = zenoh.open(_zconfig(sock, listen=False))
    try:
        deadline = time.monotonic() + 30.0
        while True:
            got = [r for r in session.get("bench/q", payload=request, timeout=0.5) if r.ok]
            if got:
                break
            if time.monotonic() > deadline:
                raise TimeoutError("no queryable within 30 s")
            time.sleep(0.1)

        def call() -> None:
            for r in session.get("bench/q", payload=request):
                r.ok.payload.to_bytes()

        return _measure(call, warmup, n)
    finally:
        session.close()


def client_zmin(sock: str, payload: str, warmup: int, n: int) -> list[int]:
    import zenoh

    session = zenoh.open(_zconfig(sock, listen=False))
    try:
        sub = session.declare_subscriber("bench/pong", zenoh.handlers.FifoChannel(64))
        pub = session.declare_publisher(
            "bench/ping", congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        seq = [0]

        def request() -> bytes:
            return _min_encode({"kind": "step", "seq": seq[0], "action": ACTION}, {})

        def recv(timeout: float) -> Any:
            deadline = time.monotonic() + timeout
            while True:
                s = sub.try_recv()
                if s is not None:
                    seq[0] = _min_decode(s.payload.to_bytes())[0]["seq"]
                    return s
                if time.monotonic() > deadline:
                    return None
                time.sleep(0.005)

        _handshake(lambda: pub.put(request()), recv)

        def call() -> None:
            pub.put(request())
            doc, tensors = _min_decode(sub.recv().payload.to_bytes())
            seq[0] = doc["seq"]
            {**doc["observation"], **tensors}

        return _measure(call, warmup, n)
    finally:
        session.close()


def client_grpc(sock: str, payload: str, warmup: int, n: int) -> list[int]:
    import queue

    import grpc

    request = bytes(REQUEST_BYTES)
    channel = grpc.insecure_channel(f"unix:{sock}", options=_GRPC_OPTIONS)
    try:
        grpc.channel_ready_future(channel).result(timeout=30)
        requests: queue.SimpleQueue[bytes | None] = queue.SimpleQueue()
        stream = channel.stream_stream("/bench.Env/Process")(iter(requests.get, None))

        def call() -> None:
            requests.put(request)
            next(stream)

        try:
            return _measure(call, warmup, n)
        finally:
            requests.put(None)
            stream.cancel()
    finally:
        channel.close()


def client_unix(sock: str, payload: str, warmup: int, n: int) -> list[int]:
    request = _LEN.pack(REQUEST_BYTES) + bytes(REQUEST_BYTES)
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    deadline = time.monotonic() + 30.0
    while True:
        try:
            conn.connect(sock)
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.05)
    hdr = bytearray(_LEN.size)
    buf = bytearray(_reply_size(payload))

    def call() -> None:
        conn.sendall(request)
        _recv_exact(conn, memoryview(hdr))
        (m,) = _LEN.unpack(hdr)
        _recv_exact(conn, memoryview(buf)[:m])

    try:
        return _measure(call, warmup, n)
    finally:
        conn.close()


SERVERS = {
    "ours": serve_ours,
    "zpubsub": serve_zpubsub,
    "zpubsub-fifo": serve_zpubsub,
    "zget": serve_zget,
    "zmin": serve_zmin,
    "grpc": serve_grpc,
    "unix": serve_unix,
}
CLIENTS = {
    "ours": client_ours,
    "zpubsub": client_zpubsub,
    "zpubsub-fifo": lambda *a: client_zpubsub(*a, fifo=True),
    "zget": client_zget,
    "zmin": client_zmin,
    "grpc": client_grpc,
    "unix": client_unix,
}


def child_main(args: argparse.Namespace) -> int:
    die_with_parent()
    if args.role == "server":
        SERVERS[args.case](args.sock, args.payload)
        return 0
    lat = CLIENTS[args.case](args.sock, args.payload, args.warmup, args.n)
    print(json.dumps({"ns": lat}), flush=True)
    return 0


# ============================================================================ orchestrator
class Runner:
    """Starts and always reaps the children of one benchmark run."""

    def __init__(self, tmp: Path, timeout_s: float) -> None:
        self.tmp = tmp
        self.timeout_s = timeout_s
        self.procs: list[subprocess.Popen[bytes]] = []
        self.env = dict(
            os.environ,
            PYTHONPATH=os.pathsep.join([str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])]),
            PYTHONUNBUFFERED="1",
        )

    def _spawn(self, argv: list[str], log: Path) -> subprocess.Popen[bytes]:
        with open(log, "wb") as err:
            p = subprocess.Popen(
                [sys.executable, str(Path(__file__).resolve()), *argv],
                stdout=subprocess.PIPE,
                stderr=err,
                stdin=subprocess.DEVNULL,
                env=self.env,
                cwd=str(ROOT),
            )
        self.procs.append(p)
        return p

    def kill_all(self) -> None:
        reap(self.procs)

    def run(self, case: str, payload: str, warmup: int, n: int) -> list[int]:
        sock = str(self.tmp / f"{case}-{payload}.sock")
        base = ["--case", case, "--payload", payload, "--sock", sock]
        err_s = self.tmp / f"{case}-{payload}.server.log"
        err_c = self.tmp / f"{case}-{payload}.client.log"
        try:
            server = self._spawn(["--role", "server", *base], err_s)
            assert server.stdout is not None
            ready, _, _ = select.select([server.stdout], [], [], 30.0)
            line = server.stdout.readline() if ready else b""
            if line.strip() != b"READY":
                raise RuntimeError(f"server did not start:\n{err_s.read_text()[-2000:]}")
            client = self._spawn(
                ["--role", "client", *base, "--warmup", str(warmup), "--n", str(n)], err_c
            )
            try:
                out, _ = client.communicate(timeout=self.timeout_s)
            except subprocess.TimeoutExpired:
                raise RuntimeError(f"client timed out after {self.timeout_s} s") from None
            if client.returncode != 0:
                raise RuntimeError(
                    f"client failed (rc {client.returncode}):\n{err_c.read_text()[-2000:]}\n"
                    f"server log:\n{err_s.read_text()[-1000:]}"
                )
            return json.loads(out.decode().strip().splitlines()[-1])["ns"]
        finally:
            self.kill_all()
            with contextlib.suppress(FileNotFoundError):
                os.unlink(sock)


def _stats(ns: list[int]) -> dict[str, float]:
    s = sorted(ns)

    def q(p: float) -> float:
        return s[min(len(s) - 1, int(round(p * (len(s) - 1))))] / 1e3

    mean = sum(s) / len(s) / 1e3
    return {"median": q(0.5), "p99": q(0.99), "rate": 1e6 / mean, "n": len(s)}


def _machine() -> str:
    return machine_line("eclipse-zenoh", "grpcio")


def _table(results: dict[tuple[str, str], dict[str, float] | str]) -> list[str]:
    labels = {c: lab for c, lab, _ in CASES}
    raw_z = [c for c, _, z in CASES if z]
    head = (
        f"{'pattern':<34} {'payload':<7} {'median µs':>10} {'p99 µs':>10} {'steps/s':>9} "
        f"{'×zenoh*':>7} {'×gRPC':>7}  {'round medians µs':>17}"
    )
    lines = [head, "-" * len(head)]
    verdicts = []
    for payload in PAYLOADS:
        rows = {c: results.get((c, payload)) for c, _, _ in CASES}
        ok = {c: r for c, r in rows.items() if isinstance(r, dict)}
        zen = [c for c in raw_z if c in ok]
        best_z = min(zen, key=lambda c: ok[c]["median"]) if zen else None
        zmed = ok[best_z]["median"] if best_z else None
        gmed = ok["grpc"]["median"] if "grpc" in ok else None
        for c, r in rows.items():
            if r is None:
                continue
            if isinstance(r, str):
                lines.append(f"{labels[c]:<34} {payload:<7} FAILED: {r.splitlines()[0][:60]}")
                continue
            rz = f"{r['median'] / zmed:.2f}" if zmed else "-"
            rg = f"{r['median'] / gmed:.2f}" if gmed else "-"
            lines.append(
                f"{labels[c]:<34} {payload:<7} {r['median']:>10.1f} {r['p99']:>10.1f} "
                f"{r['rate']:>9.0f} {rz:>7} {rg:>7}  {r['lo']:>8.0f}–{r['hi']:<8.0f}"
            )
        lines.append("")
        if "ours" in ok:
            ours = ok["ours"]["median"]
            v1 = (
                f"{'MET' if ours <= 1.3 * zmed else 'MISSED'} ({ours / zmed:.2f}× {labels[best_z]})"
                if zmed
                else "n/a"
            )
            v2 = (
                f"{'MET' if ours < gmed else 'MISSED'} ({ours / gmed:.2f}× gRPC)" if gmed else "n/a"
            )
            floor = "n/a"
            if "zmin" in ok:
                r = ours / ok["zmin"]["median"]
                floor = f"{'MET' if r <= 1.1 else 'MISSED'} ({r:.2f}×)"
            verdicts.append(
                f"verdict [{payload}]: within 1.1× of the minimal Python step: {floor}; "
                f"faster than gRPC: {v2}; within 1.3× of the fastest raw Zenoh pattern: {v1}"
            )
    lines.append("* × the median of the fastest raw Zenoh pattern for that payload")
    return [line.rstrip() for line in lines + verdicts]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer round trips (< 30 s)")
    ap.add_argument("--only", default="", help="comma-separated cases: " + ",".join(SERVERS))
    ap.add_argument("--payloads", default=",".join(PAYLOADS))
    ap.add_argument("--n-small", type=int, default=None)
    ap.add_argument("--n-large", type=int, default=None)
    ap.add_argument("--rounds", type=int, default=None, help="interleaved rounds (default 5)")
    ap.add_argument("--json", type=Path, default=None, help="also write raw stats here")
    # child roles (internal)
    ap.add_argument("--role", choices=("server", "client"), help=argparse.SUPPRESS)
    ap.add_argument("--case", choices=tuple(SERVERS), help=argparse.SUPPRESS)
    ap.add_argument("--payload", choices=PAYLOADS, help=argparse.SUPPRESS)
    ap.add_argument("--sock", help=argparse.SUPPRESS)
    ap.add_argument("--warmup", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--n", type=int, default=0, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.role:
        return child_main(args)

    n_small = args.n_small or (500 if args.quick else 3000)
    n_large = args.n_large or (40 if args.quick else 300)
    rounds = max(1, args.rounds or (1 if args.quick else 5))
    warm = {"small": max(50, n_small // (10 * rounds)), "large": max(5, n_large // (10 * rounds))}
    n = {"small": n_small, "large": n_large}
    cases = [c for c, _, _ in CASES if not args.only or c in args.only.split(",")]
    payloads = [p for p in PAYLOADS if p in args.payloads.split(",")]

    def on_term(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    print(_machine())
    print(
        f"round trips: {n_small} small (64 B reply) / {n_large} large "
        f"({LARGE_REPLY} B reply: {W}x{H} RGB uint8 + float32 depth), after "
        f"{warm['small']}/{warm['large']} warm-up per round, {rounds} interleaved round(s); "
        f"request 64 B (ours: one 2-vector action); load average {load_average()}"
    )
    t_start = time.monotonic()
    samples: dict[tuple[str, str], list[int]] = {}
    failed: dict[tuple[str, str], str] = {}
    round_medians: dict[tuple[str, str], list[float]] = {}
    with tempfile.TemporaryDirectory(prefix="eagc-bench-") as tmp:
        runner = Runner(Path(tmp), timeout_s=30.0 if args.quick else 90.0)
        try:
            # Rounds interleave the cases, so a burst of load elsewhere on the machine
            # spreads over all of them instead of skewing one.
            for rnd in range(rounds):
                for payload in payloads:
                    per_round = -(-n[payload] // rounds)
                    for case in cases:
                        if (case, payload) in failed:
                            continue
                        t0 = time.monotonic()
                        try:
                            ns = runner.run(case, payload, warm[payload], per_round)
                        except RuntimeError as e:
                            failed[(case, payload)] = str(e)
                            print(f"  {case}/{payload}: FAILED\n{e}", file=sys.stderr)
                            continue
                        samples.setdefault((case, payload), []).extend(ns)
                        round_medians.setdefault((case, payload), []).append(
                            sorted(ns)[len(ns) // 2] / 1e3
                        )
                        print(
                            f"  round {rnd + 1}/{rounds} {case:<13} {payload:<6} "
                            f"{sorted(ns)[len(ns) // 2] / 1e3:8.1f} µs median "
                            f"({time.monotonic() - t0:.1f} s)",
                            file=sys.stderr,
                            flush=True,
                        )
        finally:
            runner.kill_all()
    results: dict[tuple[str, str], dict[str, float] | str] = {
        k: {**_stats(v), "lo": min(round_medians[k]), "hi": max(round_medians[k])}
        for k, v in samples.items()
        if k not in failed
    }
    results.update(failed)
    print()
    print("\n".join(_table(results)))
    print(f"\ntotal {time.monotonic() - t_start:.0f} s")
    if args.json:
        args.json.write_text(json.dumps({f"{c}/{p}": r for (c, p), r in results.items()}, indent=1))
    return 0 if all(isinstance(r, dict) for r in results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
