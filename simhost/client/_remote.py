"""The plain client behind ``simhost.client``: ``RemoteEnv`` and what its calls return.

Teams import it through ``simhost.client``; the gymnasium-style client
(``simhost.client._gym_client``) is built on top of this module, never the other way round.
"""

from __future__ import annotations

import atexit
import os
import secrets
import threading
import time
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

import numpy as np
import zenoh

from schemas import (
    CONTAINER,
    PROTOCOL_VERSION,
    ActionResult,
    Answer,
    EndReason,
    EndStage,
    ErrorReply,
    FieldSpec,
    Hello,
    HelloReply,
    HostMessage,
    Reset,
    StageInfo,
)
from simhost import _transport
from simhost._errors import SimHostError
from simhost._wire import decode_observation, decode_reply, encode

#: How long a call waits for its reply by default. A live host answers within milliseconds
#: (a stage end with the track's bookkeeping within seconds); a dead one is noticed at once
#: through its liveliness token, so this bounds only a host that hangs.
DEFAULT_TIMEOUT_S = 60.0
_MATCH_WAIT_S = 5.0  # at most this long for the host's subscriber before the first hello
_HELLO_RESEND_S = 0.5  # then hello is resent at this interval until a reply comes
_JOIN_S = 2.0  # close() waits this long for its watcher threads to end
_END_REASONS = {r.value: r for r in EndReason}


class HostError(SimHostError, RuntimeError):
    """Raised when the host answers a request with an error reply."""

    def __init__(self, code: str, message: str, fatal: bool) -> None:
        super().__init__(f"[{code}{', fatal' if fatal else ''}] {message}")
        self.code = code
        self.fatal = fatal


class HostLost(HostError):
    """Raised when the host's liveliness token goes: the sim host ended or died, no reply
    will come, and the episode is over (the agent should exit)."""

    def __init__(self) -> None:
        super().__init__("host_lost", "the sim host is gone (its liveliness token went): the "
                         "episode is over", True)


class TimeStep(NamedTuple):
    """One reply: the observation and where the episode stands (a named tuple, as dm_env's)."""

    observation: dict[str, Any]
    stage: str
    stage_index: int
    time_left_s: float
    steps_left: int | None
    action: ActionResult | None
    messages: tuple[HostMessage, ...]
    episode_over: bool
    end_reason: EndReason | None
    seq: int

    def message(self, type_: str) -> HostMessage | None:
        """The first host message of a type (e.g. 'instruction', 'queries'), if any."""
        return next((m for m in self.messages if m.type == type_), None)


class RemoteEnv:
    """Talks to the sim host of one episode.

    Args:
        endpoint: Zenoh endpoint of the host (default ``$EAGC_ENDPOINT``).
        episode: The opaque episode id (default ``$EAGC_EPISODE``).
        timeout_s: How long to wait for a reply before raising ``TimeoutError`` (default
            ``DEFAULT_TIMEOUT_S``, 60 s; None waits as long as the host lives). The request
            still counts: the next call first waits (as long again) for that late reply,
            takes its seq and drops it, so that the next request is not refused as stale.

    Raises ``HostLost`` from any call once the host is gone.
    """

    def __init__(
        self,
        endpoint: str | None = None,
        episode: str | None = None,
        *,
        timeout_s: float | None = DEFAULT_TIMEOUT_S,
    ) -> None:
        endpoint = endpoint or os.environ.get(CONTAINER.env_endpoint)
        episode = episode or os.environ.get(CONTAINER.env_episode)
        if not endpoint or not episode:
            raise ValueError(
                f"no endpoint/episode: pass them or set {CONTAINER.env_endpoint} and "
                f"{CONTAINER.env_episode} (the evaluator sets both in the container)"
            )
        if timeout_s is not None and not timeout_s > 0:
            raise ValueError(f"timeout_s must be > 0 or None, not {timeout_s!r}")
        self.episode = episode
        self._timeout = timeout_s
        self._keys = _transport.keys(episode)
        self._session = zenoh.open(_transport.agent_config(endpoint))
        self._token = self._session.liveliness().declare_token(self._keys.alive)
        # A FIFO channel, not a Python callback: a callback subscriber keeps the interpreter
        # from exiting until the session is closed (seen with zenoh 1.10), and it is slower.
        self._sub = self._session.declare_subscriber(self._keys.rep)
        self._pub = self._session.declare_publisher(
            self._keys.req, congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        # Wakes a call blocked on the reply channel (host gone, deadline): a message to this
        # session's own reply channel that never leaves the process.
        self._wake_token = b"wake:" + secrets.token_bytes(16)
        self._waker = self._session.declare_publisher(
            self._keys.rep, allowed_destination=zenoh.Locality.SESSION_LOCAL
        )
        self._host_seen = False
        self._host_gone = False
        self._seq = 0
        self._next_id = 1
        self._late: list[int] = []  # ids of requests that timed out: their replies are due
        self._deadline: float | None = None  # of the call under way
        self._tensors: dict[str, np.ndarray] = {}
        self._results: dict[tuple[bool, bool, str], ActionResult] = {}
        self._closed = False
        self._stop = threading.Event()
        self.spec: HelloReply | None = None
        # The host's token, watched from a daemon thread blocked on a FIFO channel: a Python
        # callback would run on a non-daemon thread that keeps the interpreter from exiting.
        self._host_watch = self._session.liveliness().declare_subscriber(
            self._keys.host_alive, zenoh.handlers.FifoChannel(16), history=True
        )
        self._watchers = [threading.Thread(target=self._watch_host, daemon=True,
                                           name=f"eagc-host-{episode}")]
        if timeout_s is not None:
            self._watchers.append(threading.Thread(target=self._watch_deadlines, daemon=True,
                                                   name=f"eagc-deadline-{episode}"))
        for watcher in self._watchers:
            watcher.start()
        atexit.register(self.close)

    # ------------------------------------------------------------------ public calls
    def hello(self, agent: str = "") -> HelloReply:
        """Opens the episode. The reply holds the observation/action specs and stages."""
        # A put is delivered only to subscribers this session already knows of: wait
        # (briefly) until the host's request subscriber is known, so the first hello is not
        # lost. It is still resent until a reply comes; the host answers a resent hello
        # with the same reply, and the client skips the duplicates by their id.
        deadline = time.monotonic() + _MATCH_WAIT_S
        # zenoh's stub types matching_status as bool; zenoh 1.x returns a MatchingStatus.
        while (not self._pub.matching_status.matching  # type: ignore[attr-defined]
               and time.monotonic() < deadline):
            if self._host_gone:
                raise HostLost()
            time.sleep(0.001)
        reply = self._call(
            lambda rid: Hello(seq=self._seq, id=rid, protocol=PROTOCOL_VERSION, agent=agent),
            {}, resend_every_s=_HELLO_RESEND_S,
        )
        assert isinstance(reply, HelloReply)
        self.spec = reply
        return reply

    def reset(self) -> TimeStep:
        """Starts the first stage."""
        return self._timestep(self._call(lambda rid: Reset(seq=self._seq, id=rid), {}))

    def step(self, action: Mapping[str, Any]) -> TimeStep:
        """Applies one action; numpy arrays travel as binary tensors."""
        plain: dict[str, Any] = {}
        tensors: dict[str, np.ndarray] = {}
        for k, v in action.items():
            if isinstance(v, np.ndarray) and v.size > 16:
                tensors[k] = v
            elif isinstance(v, np.ndarray | np.generic):
                plain[k] = v.tolist()
            else:
                plain[k] = v
        # A plain dict with Step's fields: the host validates every request anyway.
        return self._timestep(self._call(
            lambda rid: {"kind": "step", "seq": self._seq, "id": rid, "action": plain}, tensors
        ))

    def answer(self, answers: Mapping[str, Any]) -> TimeStep:
        """Answers the host's queries (keyed by query id)."""
        return self._timestep(self._call(
            lambda rid: Answer(seq=self._seq, id=rid, answers=dict(answers)), {}))

    def end_stage(self, payload: Mapping[str, Any] | None = None) -> TimeStep:
        """Ends the current stage early (Track 1: the plan goes in ``payload``)."""
        return self._timestep(self._call(
            lambda rid: EndStage(seq=self._seq, id=rid, payload=dict(payload or {})), {}))

    @property
    def observation_spec(self) -> tuple[FieldSpec, ...]:
        return self._require_spec().observation_spec

    @property
    def action_spec(self) -> tuple[FieldSpec, ...]:
        return self._require_spec().action_spec

    @property
    def stages(self) -> tuple[StageInfo, ...]:
        return self._require_spec().stages

    @property
    def host_alive(self) -> bool:
        """False once the host is known to be gone."""
        return not self._host_gone

    def close(self) -> None:
        """Leaves the episode (the host sees the liveliness token go). Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        atexit.unregister(self.close)
        for undeclare in (self._host_watch, self._waker, self._pub, self._sub, self._token):
            try:
                undeclare.undeclare()
            except Exception:  # noqa: BLE001 - closing must not raise
                pass
        self._session.close()
        # The host watcher returns once its channel closed with the subscriber. Waited for:
        # a daemon thread still inside zenoh's recv when the interpreter finalizes is ended
        # by pthread_exit, whose unwinding through zenoh's Rust frames aborts the process
        # ("FATAL: exception not rethrown", exit -6) after the episode went well.
        for watcher in self._watchers:  # neither ever calls close()
            watcher.join(timeout=_JOIN_S)

    def __enter__(self) -> RemoteEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _require_spec(self) -> HelloReply:
        if self.spec is None:
            raise RuntimeError("call hello() first")
        return self.spec

    def _watch_host(self) -> None:
        """Follows the host's liveliness token (its own thread, until the client closes)."""
        recv = self._host_watch.recv
        while not self._closed:
            try:
                sample = recv()
            except Exception:  # noqa: BLE001 - the channel closed with the client
                return
            if sample.kind == zenoh.SampleKind.PUT:
                self._host_seen = True
            elif self._host_seen:
                self._host_gone = True
                self._wake()

    def _wake(self) -> None:
        try:
            self._waker.put(self._wake_token)
        except Exception:  # noqa: BLE001 - closed meanwhile: nobody is waiting
            pass

    def _watch_deadlines(self) -> None:
        """Wakes the call under way when its deadline passes (its own thread)."""
        timeout = self._timeout or 1.0
        woken: float | None = None
        while not self._stop.is_set():
            deadline, now = self._deadline, time.monotonic()
            if deadline is None:
                wait = timeout  # a call starting now ends no sooner than this
            elif now < deadline:
                wait = deadline - now
            else:
                if deadline != woken:
                    woken = deadline
                    self._wake()
                wait = timeout
            self._stop.wait(wait)

    def _call(
        self,
        build: Callable[[int], Any],
        tensors: dict[str, np.ndarray],
        *,
        resend_every_s: float | None = None,
    ) -> Any:
        if self._closed:
            raise RuntimeError("this RemoteEnv is closed")
        if self._late:
            self._settle()
        if self._host_gone:
            raise HostLost()
        rid = self._next_id
        self._next_id += 1
        buf = encode(build(rid), tensors)
        deadline = None if self._timeout is None else time.monotonic() + self._timeout
        self._deadline = deadline
        self._pub.put(buf)
        try:
            while True:
                payload = self._wait(buf, deadline, resend_every_s)
                fast = decode_observation(payload)
                if fast is not None:  # the common case: the trusted host's reply, unvalidated
                    doc = fast[0]
                    got = doc.get("id")
                    if got is not None and got != rid:
                        self._drop(got, doc["seq"])
                        continue
                    self._seq = doc["seq"]
                    self._tensors = fast[1]
                    return doc
                reply, rtensors = decode_reply(payload)
                if reply.id is not None and reply.id != rid:
                    self._drop(reply.id, reply.seq)
                    continue
                break
        except TimeoutError:
            self._late.append(rid)  # the host answers every request: its reply comes later
            raise
        finally:
            self._deadline = None
        self._seq = reply.seq
        if isinstance(reply, ErrorReply):
            raise HostError(reply.code, reply.message, reply.fatal)
        self._tensors = rtensors
        return reply

    def _drop(self, rid: int | None, seq: int) -> None:
        """A reply to another request: the late reply to one that timed out (its seq is
        the host's latest), or a second reply to a resent hello (nothing to take). A reply
        without an id comes from a host older than request ids: it is taken in order."""
        if rid in self._late:
            self._late.remove(rid)
            self._seq = seq

    def _settle(self) -> None:
        """Takes the replies still due to requests that timed out, so that the next request
        carries the host's current seq. Their content is dropped (the caller already got
        TimeoutError)."""
        deadline = None if self._timeout is None else time.monotonic() + self._timeout
        self._deadline = deadline
        try:
            while self._late:
                payload = self._wait(b"", deadline, None)  # TimeoutError: still due
                fast = decode_observation(payload)
                if fast is not None:
                    rid, seq = fast[0].get("id"), fast[0]["seq"]
                else:
                    reply = decode_reply(payload)[0]
                    rid, seq = reply.id, reply.seq
                self._drop(self._late[0] if rid is None else rid, seq)
        finally:
            self._deadline = None

    def _raise_if_due(self, deadline: float | None) -> None:
        if self._host_gone:
            raise HostLost()
        if deadline is not None and time.monotonic() >= deadline:
            raise TimeoutError(f"no reply from the host within {self._timeout} s")

    def _wait(self, buf: bytes, deadline: float | None, resend_every_s: float | None) -> bytes:
        wake = self._wake_token
        if resend_every_s is None:
            recv = self._sub.recv
            while True:  # blocks; the deadline watcher or a lost host wakes it
                payload = recv().payload.to_bytes()
                if payload != wake:
                    return payload
                self._raise_if_due(deadline)
        started = time.monotonic()
        resend_at = started + resend_every_s
        while True:
            sample = self._sub.try_recv()
            if sample is not None:
                payload = sample.payload.to_bytes()
                if payload != wake:
                    return payload
            self._raise_if_due(deadline)
            now = time.monotonic()
            if now >= resend_at:
                # Only hello is resent (the host answers a resent hello with the same reply).
                self._pub.put(buf)
                resend_at = now + resend_every_s
            # A FIFO channel has no timed wait: poll, yielding at once while a reply is
            # likely close, then gently.
            time.sleep(0 if now - started < 0.005 else 0.0002)

    def _timestep(self, reply: dict[str, Any]) -> TimeStep:
        obs = reply.get("observation") or {}
        obs = {**obs, **self._tensors} if obs else self._tensors
        action = reply.get("action")
        if action is not None:  # frozen models: the few distinct results are shared
            key = (action["applied"], action["ok"], action.get("reason", ""))
            action = self._results.get(key)
            if action is None:
                action = self._results[key] = ActionResult.model_construct(
                    applied=key[0], ok=key[1], reason=key[2])
                if len(self._results) > 256:
                    self._results.clear()
        messages = reply.get("messages")
        end = reply.get("end_reason")
        return TimeStep(
            observation=obs,
            stage=reply["stage"],
            stage_index=reply["stage_index"],
            time_left_s=reply["time_left_s"],
            steps_left=reply.get("steps_left"),
            action=action,
            messages=tuple(HostMessage.model_construct(**m) for m in messages) if messages
            else (),
            episode_over=reply.get("episode_over", False),
            end_reason=None if end is None else _END_REASONS.get(end, end),
            seq=reply["seq"],
        )
