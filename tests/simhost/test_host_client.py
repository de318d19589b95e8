"""Host and client together: request ids, the host's liveliness token, the reply timeout
and the serving thread's progress, with real processes over real Zenoh on a real episode.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path
from typing import Any

import pytest
from _raw_agent import GO, RawAgent, frame

from schemas import ErrorReply, Hello, HelloReply, ObservationReply, Reset, Step
from simhost._wire import encode

ROOT = Path(__file__).parents[2]


def test_replies_echo_the_request_id(host_episode):
    agent = RawAgent(host_episode.endpoint, host_episode.episode)
    try:
        hello = agent.send(encode(Hello(seq=0, id=11)))
        assert isinstance(hello, HelloReply) and hello.id == 11
        again = agent.send(encode(Hello(seq=0, id=12)))  # a resent hello with another id
        assert isinstance(again, HelloReply) and again.id == 12 and again.seq == hello.seq
        first = agent.send(encode(Reset(seq=agent.seq, id=13)))
        assert isinstance(first, ObservationReply) and first.id == 13
        stale = agent.send(encode(Step(seq=0, id=14, action=GO)))
        assert isinstance(stale, ErrorReply) and (stale.code, stale.id) == ("stale", 14)
        # A malformed frame whose header can still be read: its error names the request.
        broken = frame({"kind": "step", "seq": agent.seq, "id": 15, "action": GO}, bytes(8))
        bad = agent.send(broken)
        assert isinstance(bad, ErrorReply) and (bad.code, bad.id) == ("malformed", 15)
        assert "trailing" in bad.message
        plain = agent.send(encode(Step(seq=agent.seq, action=GO)))  # the id is optional
        assert isinstance(plain, ObservationReply) and plain.id is None
        done = agent.send(encode(Step(seq=agent.seq, id=2**53 - 1, action=GO)))
        assert isinstance(done, ObservationReply) and done.id == 2**53 - 1
        host_episode.stop.set()
        host_episode.outcome()
        agent.timeout_s = 5.0
        over = agent.send(encode(Step(seq=agent.seq, id=16, action=GO)))  # the late replier
        assert isinstance(over, ErrorReply) and (over.code, over.id) == ("episode_over", 16)
    finally:
        agent.close()


def test_an_error_reply_to_a_resent_hello_does_not_put_the_client_out_of_step(host_episode):
    """A hello resent after the episode began gets a "stale" error; matched by count (as
    before request ids), that error would be taken for the reply to the next step."""
    from simhost.client import RemoteEnv

    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=10.0)
    try:
        spec = env.hello(agent="resend/1")
        first = env.reset()
        # The copy of hello the client resent while the first reply was on its way.
        env._pub.put(encode(Hello(seq=0, id=spec.id, agent="resend/1")))
        ts = env.step(GO)
        assert ts.seq == first.seq + 1 and ts.action is not None and ts.action.applied
        ts = env.step(GO)
        assert ts.seq == first.seq + 2
    finally:
        env.close()
    outcome = host_episode.outcome()
    assert dict(outcome.protocol_errors) == {"stale": 1}  # the host did refuse the copy
    assert outcome.steps == 2


def test_close_leaves_no_watcher_thread_inside_zenoh(host_episode, monkeypatch):
    """A watcher thread still blocked in zenoh's recv when the interpreter finalizes is ended
    by pthread_exit, whose unwinding through Rust frames aborts the agent's process ("FATAL:
    exception not rethrown", exit -6) after a good episode: close() waits for its watchers.
    Here the host watcher is slow to leave, as it is on a loaded machine."""
    from simhost.client import RemoteEnv

    watch = RemoteEnv._watch_host

    def slow_to_leave(self: RemoteEnv) -> None:
        watch(self)
        time.sleep(0.5)

    monkeypatch.setattr(RemoteEnv, "_watch_host", slow_to_leave)
    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=10.0)
    env.hello(agent="close/1")
    env.reset()
    names = {f"eagc-{what}-{host_episode.episode}" for what in ("host", "deadline")}
    mine = [t for t in threading.enumerate() if t.name in names]
    assert len(mine) == 2
    env.close()
    assert [t.name for t in mine if t.is_alive()] == []


def test_the_default_reply_timeout_is_documented_and_finite():
    import inspect

    from simhost.client import DEFAULT_TIMEOUT_S, RemoteEnv

    default = inspect.signature(RemoteEnv).parameters["timeout_s"].default
    assert default == DEFAULT_TIMEOUT_S and 0 < default < float("inf")
    assert f"{DEFAULT_TIMEOUT_S:g} s" in (RemoteEnv.__doc__ or "")


def test_a_host_that_closes_ends_the_call_under_way(host_episode):
    """No reply timeout at all: only the host's liveliness token can end this call."""
    from simhost.client import HostLost, RemoteEnv

    episode = host_episode.host.episode
    entered = threading.Event()
    release = threading.Event()
    real_step = episode.step

    def hung_step(stage: str, action: Any) -> Any:
        entered.set()
        release.wait(30.0)
        return real_step(stage, action)

    episode.step = hung_step
    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=None)
    try:
        env.hello(agent="lost/1")
        env.reset()
        closer = threading.Thread(target=lambda: (entered.wait(10.0), host_episode.host.close()))
        closer.start()
        with pytest.raises(HostLost, match="host is gone"):
            env.step(GO)
        assert not env.host_alive
        with pytest.raises(HostLost):  # and every later call, at once
            env.step(GO)
    finally:
        release.set()
        env.close()
    # serve() itself ends cleanly when close() comes from another thread (a watchdog's way
    # out), once the track code it was running returns.
    assert host_episode.outcome().end_reason == "stopped"


def test_progress_shows_a_busy_serving_thread(host_episode):
    from simhost.client import RemoteEnv

    host = host_episode.host
    episode = host.episode
    entered = threading.Event()
    release = threading.Event()
    real_step = episode.step

    def slow_step(stage: str, action: Any) -> Any:
        entered.set()
        release.wait(30.0)
        return real_step(stage, action)

    episode.step = slow_step
    env = RemoteEnv(host_episode.endpoint, host_episode.episode, timeout_s=30.0)
    try:
        env.hello(agent="progress/1")
        env.reset()
        idle = _settled(host)  # the reply may reach the agent before the counter moves
        assert idle.busy_since is None and idle.requests == 2 and idle.phase == "running"
        result: list[Any] = []
        caller = threading.Thread(target=lambda: result.append(env.step(GO)))
        caller.start()
        assert entered.wait(10.0)
        busy = host.progress()
        assert busy.busy_since is not None and busy.busy_since <= time.monotonic()
        frames = sys._current_frames()
        assert busy.thread_id in frames  # a watchdog can dump exactly this stack
        assert "slow_step" in "".join(
            f.f_code.co_name + " " for f in _stack(frames[busy.thread_id]))
        release.set()
        caller.join(10.0)
        assert result and result[0].action.applied
        assert _settled(host).requests == 3
    finally:
        release.set()
        env.close()


def _settled(host: Any) -> Any:
    """The host's progress once its serving thread is idle again (at most 10 s)."""
    deadline = time.monotonic() + 10.0
    while (progress := host.progress()).busy_since is not None:
        assert time.monotonic() < deadline, "the serving thread never went idle"
        time.sleep(0.001)
    return progress


def _stack(frame: Any) -> list[Any]:
    out = []
    while frame is not None:
        out.append(frame)
        frame = frame.f_back
    return out


# --------------------------------------------------------- an agent never outlives its host
_HOST = textwrap.dedent(
    """
    import secrets, sys, threading, time
    from pathlib import Path
    from plugins import load_track
    from schemas import unix_endpoint
    from simhost import HostConfig, SimHost

    sock = Path(sys.argv[1])
    track = load_track("sanity")
    episode = track.make_episode(track.make_scenario(seed=3, split="standard", params={}))
    real_step = episode.step
    def step(stage, action):
        if sys.argv[2] == "hang":
            print("in step", flush=True)
            time.sleep(3600)  # the agent now waits for this reply
        return real_step(stage, action)
    episode.step = step
    ep = secrets.token_hex(8)
    host = SimHost(episode, track.stages(), HostConfig(
        episode=ep, track="sanity", endpoints=(unix_endpoint(str(sock)),), socket_path=sock))
    host.open()
    print(unix_endpoint(str(sock)), ep, flush=True)
    host.serve()
    """
)

_AGENT = textwrap.dedent(
    """
    import sys, time
    from simhost.client import RemoteEnv
    env = RemoteEnv(sys.argv[1], sys.argv[2], timeout_s=None)  # no timeout: liveliness only
    env.hello(agent="orphan/1")
    env.reset()
    print("running", flush=True)
    while True:
        env.step({"velocity": [0.0, 0.0]})
        time.sleep(0.2)
    """
)


@pytest.mark.parametrize("when", ["hang", "between"],
                         ids=["waiting for a reply", "between calls"])
def test_agent_process_ends_when_its_host_process_is_killed(tmp_path_factory, when):
    sock = tmp_path_factory.mktemp("ep") / "zenoh.sock"
    cwd = str(ROOT)
    host = subprocess.Popen([sys.executable, "-c", _HOST, str(sock), when],
                            stdout=subprocess.PIPE, text=True, cwd=cwd)
    agent = None
    try:
        assert host.stdout is not None
        endpoint, episode = host.stdout.readline().split()
        agent = subprocess.Popen([sys.executable, "-c", _AGENT, endpoint, episode],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                 cwd=cwd)
        assert agent.stdout is not None
        assert agent.stdout.readline().strip() == "running"
        if when == "hang":
            assert host.stdout.readline().strip() == "in step"  # the agent's step is pending
        host.send_signal(signal.SIGKILL)
        host.wait()
        try:  # a bound only so that a failing test cannot hang; the agent has no timeout
            agent.wait(timeout=60)
        except subprocess.TimeoutExpired:
            pytest.fail("the agent outlived its host")
        err = agent.stderr.read() if agent.stderr is not None else ""
        assert agent.returncode != 0
        assert "HostLost" in err and "host is gone" in err, err[-2000:]
    finally:
        for p in (host, agent):
            if p is not None and p.poll() is None:
                p.kill()
                p.wait()
