"""Broken and hostile agents against a real SimHost, over real Zenoh, on a real MuJoCo episode.

Every bad request gets exactly one ``error`` reply with the right code, is counted in
``HostOutcome.protocol_errors``, changes nothing (same seq, same simulator state), and the
host then serves the next valid request normally. Requests are built by hand and published
on a bare Zenoh session, the way a broken client would send them.
"""

from __future__ import annotations

import signal
import struct
import subprocess
import sys
import textwrap
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _raw_agent import GO, RawAgent, frame

from schemas import (
    Answer,
    EndStage,
    ErrorReply,
    Hello,
    HelloReply,
    ObservationReply,
    Reset,
    Step,
)
from simhost._wire import MAGIC, encode


@pytest.fixture
def connect():
    """``connect(handle) -> RawAgent``; every agent is closed at teardown."""
    agents: list[RawAgent] = []

    def make(handle) -> RawAgent:
        agents.append(RawAgent(handle.endpoint, handle.episode))
        return agents[-1]

    yield make
    for a in agents:
        a.close()


@pytest.fixture
def agent(host_episode, connect) -> RawAgent:
    return connect(host_episode)


def expect_error(agent: RawAgent, buf: bytes, code: str, handle=None) -> ErrorReply:
    """Sends ``buf``; checks the error reply and that nothing moved."""
    seq = agent.seq
    state = handle.host.episode.state_hash() if handle is not None else None
    reply = agent.send(buf)
    assert isinstance(reply, ErrorReply), reply
    assert (reply.code, reply.fatal, reply.seq) == (code, False, seq), reply
    assert reply.message
    if handle is not None:
        assert handle.host.episode.state_hash() == state, "a refused request moved the world"
    return reply


def serves_normally(agent: RawAgent) -> None:
    seq = agent.seq
    reply = agent.call(Step, action=GO)
    assert isinstance(reply, ObservationReply), reply
    assert reply.seq == seq + 1 and reply.action is not None and reply.action.applied


def finish(agent: RawAgent, handle):
    """Ends both stages properly; checks one reply per request; returns the outcome."""
    while not agent.call(EndStage).episode_over:
        pass
    outcome = handle.outcome()
    time.sleep(0.05)
    assert agent.replies.empty(), "the host sent a reply nobody asked for"
    assert outcome.end_reason == "completed"
    return outcome


# ------------------------------------------------------------------------ malformed
def _nbytes_mismatch(seq: int) -> bytes:
    t = {"name": "velocity", "dtype": "float32", "shape": [2], "offset": 0, "nbytes": 4}
    return frame({"kind": "step", "seq": seq, "tensors": [t]}, bytes(8))


def _tensor_past_end(seq: int) -> bytes:
    t = {"name": "velocity", "dtype": "float32", "shape": [2], "offset": 8, "nbytes": 8}
    return frame({"kind": "step", "seq": seq, "tensors": [t]}, bytes(8))


def _huge_shape(seq: int) -> bytes:
    t = {"name": "velocity", "dtype": "uint8", "shape": [2**62, 4], "offset": 0, "nbytes": 0}
    return frame({"kind": "step", "seq": seq, "tensors": [t]})


def _empty_with_huge_dim(seq: int) -> bytes:
    t = {"name": "velocity", "dtype": "uint8", "shape": [0, 2**70], "offset": 0, "nbytes": 0}
    return frame({"kind": "step", "seq": seq, "tensors": [t]})


def _velocity_frame(seq: int, offset: int, block: bytes, nbytes: int = 8) -> bytes:
    t = {"name": "velocity", "dtype": "float32", "shape": [2], "offset": offset,
         "nbytes": nbytes}
    return frame({"kind": "step", "seq": seq, "tensors": [t]}, block)


_GO = np.array([0.9, 0.9], np.float32).tobytes()  # a valid action, if it were applied
_BAD_HEADER = b'{"kind": "step", "seq": 0, "action": {"velocity": [0.9, 0.9]}}'


def _unpadded_header(seq: int) -> bytes:
    header = _BAD_HEADER.replace(b'"seq": 0', f'"seq": {seq}'.encode())
    header += b" " * ((-(8 + len(header))) % 8 + 1)  # one space too many
    return struct.pack("<4sI", MAGIC, len(header)) + header + bytes(7)


MALFORMED: dict[str, Callable[[int], bytes]] = {
    # Framing that is almost right: each would apply a plausible action if it were read.
    "trailing bytes": lambda seq: _velocity_frame(seq, 0, _GO + bytes(8)),
    "missing bytes": lambda seq: _velocity_frame(seq, 0, _GO[:4]),
    "misaligned tensor": lambda seq: _velocity_frame(seq, 4, bytes(4) + _GO + bytes(4)),
    "tensor after a gap": lambda seq: _velocity_frame(seq, 8, bytes(8) + _GO),
    "header padding wrong": _unpadded_header,
    "padding not zero": lambda seq: frame(
        {"kind": "step", "seq": seq, "tensors": [{"name": "velocity", "dtype": "uint8",
                                                   "shape": [2], "offset": 0, "nbytes": 2}]},
        b"\x01\x01" + b"\x01" * 6),

    "empty": lambda seq: b"",
    "shorter than the frame": lambda seq: MAGIC + b"\x01",
    "not the magic": lambda seq: b"EGC0" + encode(Step(seq=seq, action=GO))[4:],
    "bad JSON header": lambda seq: frame(b'{"kind": "step", "seq": '),
    "header not an object": lambda seq: frame(b"[1, 2, 3]"),
    "header past the end": lambda seq: frame({"kind": "step", "seq": seq}, hlen=4096),
    "tensor nbytes != shape": _nbytes_mismatch,
    "tensor past the end": _tensor_past_end,
    "unknown kind": lambda seq: frame({"kind": "teleport", "seq": seq}),
    "unknown header field": lambda seq: frame({"kind": "step", "seq": seq, "speed": 9}),
    "negative seq": lambda seq: frame({"kind": "step", "seq": -1}),
    "huge tensor shape": _huge_shape,
    "empty tensor, huge dimension": _empty_with_huge_dim,
}


# What the error reply must name, for the framing cases.
NAMED = {
    "trailing bytes": "8 trailing byte",
    "missing bytes": "ends 4 byte(s) early",
    "misaligned tensor": "'velocity' at offset 4 is misaligned",
    "tensor after a gap": "'velocity' at offset 8 leaves a gap",
    "header padding wrong": "must be a multiple of 8",
    "padding not zero": "padding after it is not zero",
}


@pytest.mark.parametrize("name", MALFORMED)
def test_malformed_request_is_refused_and_counted(host_episode, agent, name):
    agent.start()
    reply = expect_error(agent, MALFORMED[name](agent.seq), "malformed", host_episode)
    assert NAMED.get(name, "") in reply.message
    serves_normally(agent)
    outcome = finish(agent, host_episode)
    assert dict(outcome.protocol_errors) == {"malformed": 1}
    assert (outcome.invalid_actions, outcome.steps) == (0, 1)


def test_oversized_request_is_refused(sim_host, connect):
    handle = sim_host(max_request_bytes=4096)
    agent = connect(handle)
    agent.start()

    def step_of_size(n: int) -> bytes:
        header = Step(seq=agent.seq, action=GO).model_dump_json().encode()
        return frame(header + b" " * (n - 8 - len(header)))

    assert isinstance(agent.send(step_of_size(4096)), ObservationReply)  # at the limit: fine
    expect_error(agent, step_of_size(4104), "oversized", handle)
    big = encode(Step(seq=agent.seq), {"velocity": np.zeros(2048, np.float32)})
    expect_error(agent, big, "oversized", handle)
    serves_normally(agent)
    outcome = finish(agent, handle)
    assert dict(outcome.protocol_errors) == {"oversized": 2}
    assert outcome.steps == 2


# ---------------------------------------------------------------------------- order
def test_stale_and_duplicate_requests_are_refused(host_episode, agent):
    agent.start()
    seq = agent.seq
    expect_error(agent, encode(Step(seq=seq - 1, action=GO)), "stale", host_episode)
    expect_error(agent, encode(Step(seq=seq + 5, action=GO)), "stale", host_episode)
    once = encode(Step(seq=seq, action=GO))
    assert agent.send(once).seq == seq + 1
    expect_error(agent, once, "stale", host_episode)  # the same request again: not re-applied
    serves_normally(agent)
    outcome = finish(agent, host_episode)
    assert dict(outcome.protocol_errors) == {"stale": 3}
    assert outcome.steps == 2


def test_requests_out_of_order_are_refused(host_episode, agent):
    for model, fields in ((Reset, {}), (Step, {"action": GO}), (EndStage, {}),
                          (Answer, {"answers": {}})):
        expect_error(agent, encode(model(seq=0, **fields)), "bad_order")  # before hello
    hello = agent.call(Hello)
    assert isinstance(hello, HelloReply) and hello.seq == 1
    # A resent hello (its reply was lost) gets the same reply again and is not an error.
    again = agent.send(encode(Hello(seq=0)))
    assert again == hello
    expect_error(agent, encode(Hello(seq=1)), "bad_order")  # hello twice
    expect_error(agent, encode(Step(seq=1, action=GO)), "bad_order")  # before reset
    agent.call(Reset)
    expect_error(agent, encode(Reset(seq=agent.seq)), "bad_order", host_episode)  # reset twice
    serves_normally(agent)
    outcome = finish(agent, host_episode)
    assert dict(outcome.protocol_errors) == {"bad_order": 7}


# -------------------------------------------------------------------------- actions
def _literal(text: str) -> Callable[[int], bytes]:
    return lambda seq: frame(f'{{"kind": "step", "seq": {seq}, "action": {text}}}')


def _tensor(value: np.ndarray, **plain: Any) -> Callable[[int], bytes]:
    return lambda seq: encode(Step(seq=seq, action=plain), {"velocity": value})


INVALID_ACTIONS: dict[str, Callable[[int], bytes]] = {
    "NaN tensor": _tensor(np.array([np.nan, 0.0], np.float32)),
    "Inf tensor": _tensor(np.array([0.0, -np.inf], np.float64)),
    "NaN in JSON": _literal('{"velocity": [NaN, 0.0]}'),
    "Infinity in JSON": _literal('{"velocity": [0.0, Infinity]}'),
    "above the bound": lambda seq: encode(Step(seq=seq, action={"velocity": [1.5, 0.0]})),
    "below the bound": lambda seq: encode(Step(seq=seq, action={"velocity": [0.0, -1.01]})),
    "unknown field": lambda seq: encode(Step(seq=seq, action={**GO, "teleport": [1, 1]})),
    "wrong shape": lambda seq: encode(Step(seq=seq, action={"velocity": [0.1, 0.2, 0.3]})),
    "not a number": lambda seq: encode(Step(seq=seq, action={"velocity": ["a", "b"]})),
    "null": lambda seq: encode(Step(seq=seq, action={"velocity": None})),
    "JSON and tensor": _tensor(np.zeros(2, np.float32), velocity=[0.0, 0.0]),
}


@pytest.mark.parametrize("make", INVALID_ACTIONS.values(), ids=INVALID_ACTIONS.keys())
def test_invalid_action_is_refused_before_the_world(host_episode, agent, make):
    agent.start()
    serves_normally(agent)  # the robot moves, so a leaked action would show in the state
    expect_error(agent, make(agent.seq), "invalid_action", host_episode)
    serves_normally(agent)
    outcome = finish(agent, host_episode)
    assert dict(outcome.protocol_errors) == {"invalid_action": 1}
    assert (outcome.invalid_actions, outcome.steps) == (1, 2)


def test_action_the_world_refuses_is_not_a_protocol_error(host_episode, agent):
    agent.start()
    reply = agent.call(Step, action={})  # valid for the spec, but no velocity: refused
    assert isinstance(reply, ObservationReply)
    assert reply.action is not None and not reply.action.ok and reply.action.reason
    serves_normally(agent)
    outcome = finish(agent, host_episode)
    assert not outcome.protocol_errors
    assert outcome.invalid_actions == 1


def test_hello_with_another_protocol_ends_the_episode(host_episode, agent):
    reply = agent.call(Hello, protocol="eagc/v0")
    assert isinstance(reply, ErrorReply) and reply.code == "malformed" and reply.fatal
    assert host_episode.outcome(timeout=1.0).end_reason == "protocol_violation"


# ------------------------------------------------------------------ ending the episode
@pytest.mark.parametrize("started", [True, False], ids=["running", "before hello"])
def test_too_many_protocol_errors_end_the_episode(sim_host, connect, started):
    handle = sim_host(max_protocol_errors=3)
    agent = connect(handle)
    if started:
        agent.start()
    garbage = b"EGC0 not a message"
    expect_error(agent, garbage, "malformed")
    expect_error(agent, encode(Step(seq=agent.seq + 1, action=GO)), "stale")
    last = agent.send(garbage)
    assert isinstance(last, ErrorReply) and last.fatal and "limit" in last.message
    outcome = handle.outcome(timeout=5.0)
    assert outcome.end_reason == "protocol_violation"
    assert dict(outcome.protocol_errors) == {"malformed": 2, "stale": 1}


def test_agent_leaving_ends_the_episode_quickly(host_episode, agent):
    agent.start()
    serves_normally(agent)
    t0 = time.monotonic()
    agent.close()  # without finishing: the liveliness token goes with the session
    outcome = host_episode.outcome(timeout=10.0)
    assert outcome.end_reason == "agent_lost"
    assert time.monotonic() - t0 < 5.0  # the stage budget is 60 s
    assert outcome.stage_ends == {"explore": "stopped"}


_KILLED_AGENT = textwrap.dedent(
    """
    import sys, time
    from simhost.client import RemoteEnv
    env = RemoteEnv(sys.argv[1], sys.argv[2], timeout_s=10)
    env.hello(agent="doomed/1")
    env.reset()
    env.step({"velocity": [0.1, 0.1]})
    print("ready", flush=True)
    time.sleep(60)
    """
)


def test_killed_agent_process_ends_the_episode_quickly(host_episode):
    proc = subprocess.Popen(
        [sys.executable, "-c", _KILLED_AGENT, host_episode.endpoint, host_episode.episode],
        stdout=subprocess.PIPE, text=True, cwd=Path(__file__).parents[2],
    )
    try:
        assert proc.stdout is not None and proc.stdout.readline().strip() == "ready"
        t0 = time.monotonic()
        proc.send_signal(signal.SIGKILL)  # no goodbye: the socket just closes
        outcome = host_episode.outcome(timeout=10.0)
    finally:
        proc.kill()
        proc.wait()
    assert outcome.end_reason == "agent_lost"
    assert time.monotonic() - t0 < 5.0
    assert outcome.steps == 1


def test_silent_agent_runs_out_of_stage_budgets(sim_host, connect):
    handle = sim_host(time_scale=0.005)  # 60 s stages → 0.3 s
    agent = connect(handle)
    agent.start()
    outcome = handle.outcome(timeout=10.0)
    assert outcome.end_reason == "budget"
    assert outcome.stage_ends == {"explore": "budget", "reach": "budget"}
    assert all(d >= 0.29 for d in outcome.stage_durations_s.values())


def test_request_after_the_end_gets_episode_over(sim_host, connect):
    handle = sim_host(time_scale=0.005)
    agent = connect(handle)
    agent.start()
    assert handle.outcome(timeout=10.0).end_reason == "budget"
    agent.timeout_s = 1.0  # none comes today: do not wait long
    after = agent.call(Step, action=GO)
    assert isinstance(after, ErrorReply) and after.code == "episode_over" and after.fatal


def test_agent_that_never_says_hello_runs_out_of_startup_time(sim_host, connect):
    handle = sim_host(startup_s=0.3)
    connect(handle)  # connected (liveliness token up), but silent
    outcome = handle.outcome(timeout=10.0)
    assert outcome.end_reason == "startup_timeout"
    assert outcome.stages_reached == []


# -------------------------------------------------------------------------- startup
def test_resent_hello_is_answered_again_and_the_client_skips_the_second_reply(host_episode):
    """A hello is resent when its reply is slow; the host answers every copy with the same
    reply (echoing the copy's id), and RemoteEnv must not take a second one for the reply
    to reset: it matches replies by request id."""
    from simhost.client import RemoteEnv

    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=10.0)
    try:
        spec = env.hello(agent="resend/1")
        # What a resend whose first reply came late looks like on the wire (the client's
        # own publisher: the host sees the same session send hello again, with the same id).
        env._pub.put(encode(Hello(seq=0, id=spec.id, agent="resend/1")))
        ts = env.reset()
        assert ts.stage == "explore" and ts.seq == spec.seq + 1
        ts = env.step(GO)
        assert ts.action is not None and ts.action.applied and ts.seq == spec.seq + 2
    finally:
        env.close()
    outcome = host_episode.outcome()
    assert sum(outcome.protocol_errors.values()) == 0, outcome.protocol_errors


def test_stop_ends_a_served_episode_promptly(host_episode, agent):
    agent.start()
    serves_normally(agent)
    host_episode.stop.set()  # e.g. the container exited; only the clock can wake serve()
    outcome = host_episode.outcome(timeout=5.0)
    assert outcome.end_reason == "stopped"
    agent.timeout_s = 2.0
    after = agent.call(Step, action=GO)  # answered by the late replier until close()
    assert isinstance(after, ErrorReply) and after.code == "episode_over"


def test_a_timed_out_step_does_not_put_the_client_out_of_step(host_episode):
    """With timeout_s, a slow reply raises TimeoutError; when it comes later, the next call
    skips it instead of taking it for its own reply (which would shift every reply by one)."""
    from simhost.client import RemoteEnv

    episode = host_episode.host.episode
    real_step = episode.step
    slow = [True]

    def step(stage: str, action: Any) -> Any:
        if slow[0]:
            slow[0] = False
            time.sleep(0.6)
        return real_step(stage, action)

    episode.step = step  # the host calls it on its serving thread
    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=0.2)
    try:
        env.hello(agent="timeout/1")
        first = env.reset()
        with pytest.raises(TimeoutError):
            env.step(GO)
        for _ in range(50):  # each call waits timeout_s more for the late reply first
            try:
                ts = env.step(GO)  # the late reply is dropped, then this step is served
                break
            except TimeoutError:
                continue
        assert ts.seq == first.seq + 2 and ts.action is not None and ts.action.applied
        ts2 = env.step(GO)
        assert ts2.seq == ts.seq + 1
    finally:
        env.close()
    outcome = host_episode.outcome()
    assert sum(outcome.protocol_errors.values()) == 0, outcome.protocol_errors
    assert outcome.steps == 3


def test_a_flooding_agent_cannot_hang_the_host_at_the_end(sim_host, connect):
    """An agent that floods requests without waiting fills the host's request channel; the
    clock's tick then waits for room, and serve() used to join the clock with nobody left
    to drain the channel: it never returned."""
    from simhost.host._host import EpisodeRecorder

    class SlowRecorder(EpisodeRecorder):  # each request costs the host 20 ms
        def event(self, t: float, name: str, data: Any) -> None:
            time.sleep(0.02)

    handle = sim_host(max_protocol_errors=10**9)
    handle.host.recorder = SlowRecorder()
    agent = connect(handle)
    agent.start()
    stale = encode(Step(seq=agent.seq + 7, action=GO))  # each one is refused (and logged)
    flooding, done = threading.Event(), threading.Event()

    def flood() -> None:
        flooding.set()
        while not done.is_set():
            agent.pub.put(stale)

    flooder = threading.Thread(target=flood, daemon=True)
    flooder.start()
    flooding.wait()
    time.sleep(2.0)  # the channel (256) is full long before this
    handle.stop.set()
    try:
        outcome = handle.outcome(timeout=30.0)
    finally:
        done.set()
        flooder.join(10.0)
    assert outcome.end_reason == "stopped"
    assert outcome.protocol_errors["stale"] > 0


def test_a_failing_stage_end_still_answers_once(sim_host, connect):
    """Track code that raises at a stage end: the request still gets one reply (internal,
    fatal), the stage is ended once, and serve() returns with the error recorded."""
    handle = sim_host()
    ended: list[str] = []

    def on_stage_end(stage: str, *, ended_by: str, payload: Any) -> list[Any]:
        ended.append(ended_by)
        raise OSError("disk full")

    handle.host.episode.on_stage_end = on_stage_end
    agent = connect(handle)
    agent.start()
    reply = agent.call(EndStage)
    assert isinstance(reply, ErrorReply) and reply.code == "internal" and reply.fatal, reply
    outcome = handle.outcome()
    assert outcome.internal_error and "disk full" in outcome.internal_error
    assert outcome.end_reason == "internal_error"
    assert ended == ["agent"], ended
    time.sleep(0.05)
    assert agent.replies.empty(), "the host sent a reply nobody asked for"
