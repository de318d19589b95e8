"""The agent-side client a team's container imports: ``from simhost.agent import RemoteEnv``.

Needs only pydantic, eclipse-zenoh and numpy. One episode, one client::

    env = RemoteEnv()                    # endpoint and episode from EAGC_* variables
    spec = env.hello(agent="my-team/1.0")
    ts = env.reset()
    while not ts.episode_over:
        ts = env.step({"velocity": [0.5, 0.0]})
    env.close()

Every call sends one request and returns exactly one reply. Protocol errors (malformed,
stale, out-of-range, …) raise ``HostError``; an action the world refused is not an error,
it comes back in ``TimeStep.action`` with ``ok=False`` and a reason.
"""

from __future__ import annotations

import atexit
import os
import time
from collections.abc import Mapping
from typing import Any, NamedTuple

import numpy as np
import zenoh

from schemas._contract import CONTAINER
from schemas._protocol import (
    PROTOCOL_VERSION,
    ActionResult,
    Answer,
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
from simhost._outputs import OutputFileError, OutputFiles
from simhost._wire import decode_observation, decode_reply, encode

__all__ = ["HostError", "OutputFileError", "OutputFiles", "RemoteEnv", "TimeStep"]

_MATCH_WAIT_S = 5.0  # at most this long for the host's subscriber before the first hello
_HELLO_RESEND_S = 0.5  # then hello is resent at this interval until a reply comes


class HostError(SimHostError, RuntimeError):
    """Raised when the host answers a request with an error reply."""

    def __init__(self, code: str, message: str, fatal: bool) -> None:
        super().__init__(f"[{code}{', fatal' if fatal else ''}] {message}")
        self.code = code
        self.fatal = fatal


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
    end_reason: str | None
    seq: int

    def message(self, type_: str) -> HostMessage | None:
        """The first host message of a type (e.g. 'instruction', 'queries'), if any."""
        return next((m for m in self.messages if m.type == type_), None)


class RemoteEnv:
    """Talks to the sim host of one episode.

    Args:
        endpoint: Zenoh endpoint of the host (default ``$EAGC_ENDPOINT``).
        episode: The opaque episode id (default ``$EAGC_EPISODE``).
        timeout_s: How long to wait for a reply before raising ``TimeoutError``
            (None, the default: as long as the host takes; the host's stage budgets and the
            evaluator's clock bound every episode anyway). The request still counts: the
            next call first waits (as long again) for that late reply and drops it, so that
            requests and replies stay paired.
    """

    def __init__(
        self,
        endpoint: str | None = None,
        episode: str | None = None,
        *,
        timeout_s: float | None = None,
    ) -> None:
        endpoint = endpoint or os.environ.get(CONTAINER.env_endpoint)
        episode = episode or os.environ.get(CONTAINER.env_episode)
        if not endpoint or not episode:
            raise ValueError(
                f"no endpoint/episode: pass them or set {CONTAINER.env_endpoint} and "
                f"{CONTAINER.env_episode} (the evaluator sets both in the container)"
            )
        self.episode = episode
        self._timeout = timeout_s
        self._keys = _transport.keys(episode)
        self._session = zenoh.open(_transport.agent_config(endpoint))
        self._token = self._session.liveliness().declare_token(self._keys["alive"])
        # A FIFO channel, not a Python callback: a callback subscriber keeps the interpreter
        # from exiting until the session is closed (seen with zenoh 1.10), and it is slower.
        self._sub = self._session.declare_subscriber(self._keys["rep"])
        self._pub = self._session.declare_publisher(
            self._keys["req"], congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        self._seq = 0
        self._owed = 0  # replies still due to requests that timed out
        self._tensors: dict[str, np.ndarray] = {}
        self._results: dict[tuple[bool, bool, str], ActionResult] = {}
        self._closed = False
        self.spec: HelloReply | None = None
        atexit.register(self.close)

    # ------------------------------------------------------------------ public calls
    def hello(self, agent: str = "") -> HelloReply:
        """Opens the episode. The reply holds the observation/action specs and stages."""
        # A put is delivered only to subscribers this session already knows of: wait
        # (briefly) until the host's request subscriber is known, so the first hello is not
        # lost. It is still resent until a reply comes; the host answers a resent hello
        # with the same reply, and _call skips the duplicates.
        deadline = time.monotonic() + _MATCH_WAIT_S
        while not self._pub.matching_status.matching and time.monotonic() < deadline:
            time.sleep(0.001)
        reply = self._call(Hello(seq=self._seq, protocol=PROTOCOL_VERSION, agent=agent), {},
                           resend_every_s=_HELLO_RESEND_S)
        assert isinstance(reply, HelloReply)
        self.spec = reply
        return reply

    def reset(self) -> TimeStep:
        """Starts the first stage."""
        self._settle()
        return self._timestep(self._call(Reset(seq=self._seq), {}))

    def step(self, action: Mapping[str, Any]) -> TimeStep:
        """Applies one action; numpy arrays travel as binary tensors."""
        if self._owed:
            self._settle()
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
        return self._timestep(
            self._call({"kind": "step", "seq": self._seq, "action": plain}, tensors)
        )

    def answer(self, answers: Mapping[str, Any]) -> TimeStep:
        """Answers the host's queries (keyed by query id)."""
        self._settle()
        return self._timestep(self._call(Answer(seq=self._seq, answers=dict(answers)), {}))

    def end_stage(self, payload: Mapping[str, Any] | None = None) -> TimeStep:
        """Ends the current stage early (Track 1: the plan goes in ``payload``)."""
        self._settle()
        return self._timestep(self._call(EndStage(seq=self._seq, payload=dict(payload or {})), {}))

    @property
    def observation_spec(self) -> tuple[FieldSpec, ...]:
        return self._require_spec().observation_spec

    @property
    def action_spec(self) -> tuple[FieldSpec, ...]:
        return self._require_spec().action_spec

    @property
    def stages(self) -> tuple[StageInfo, ...]:
        return self._require_spec().stages

    def close(self) -> None:
        """Leaves the episode (the host sees the liveliness token go). Idempotent."""
        if self._closed:
            return
        self._closed = True
        atexit.unregister(self.close)
        for undeclare in (self._pub, self._sub, self._token):
            try:
                undeclare.undeclare()
            except Exception:  # noqa: BLE001 - closing must not raise
                pass
        self._session.close()

    def __enter__(self) -> RemoteEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ internals
    def _require_spec(self) -> HelloReply:
        if self.spec is None:
            raise RuntimeError("call hello() first")
        return self.spec

    def _call(
        self, msg: Any, tensors: dict[str, np.ndarray], *, resend_every_s: float | None = None
    ) -> Any:
        buf = encode(msg, tensors)
        self._pub.put(buf)
        deadline = None if self._timeout is None else time.monotonic() + self._timeout
        while True:
            try:
                payload = self._wait(buf, deadline, resend_every_s)
            except TimeoutError:
                self._owed += 1  # the host answers every request: its reply comes later
                raise
            fast = decode_observation(payload)
            if fast is not None:  # the common case: no validation of the trusted host's reply
                self._seq = fast[0]["seq"]
                self._tensors = fast[1]
                return fast[0]
            reply, rtensors = decode_reply(payload)
            # A second answer to a resent hello: it answers nothing that is waiting now.
            if not isinstance(reply, HelloReply) or isinstance(msg, Hello):
                break
        if isinstance(reply, ErrorReply):
            self._seq = reply.seq
            raise HostError(reply.code, reply.message, reply.fatal)
        self._seq = reply.seq
        self._tensors = rtensors
        return reply

    def _settle(self) -> None:
        """Takes the replies still due to requests that timed out, so that the next request
        and its reply pair up again: the host answers every request exactly once, in order.
        Their content is dropped (the caller already got TimeoutError); their seq is kept."""
        while self._owed:
            deadline = None if self._timeout is None else time.monotonic() + self._timeout
            payload = self._wait(b"", deadline, None)  # TimeoutError: still due, still owed
            self._owed -= 1
            fast = decode_observation(payload)
            self._seq = fast[0]["seq"] if fast is not None else decode_reply(payload)[0].seq

    def _wait(self, buf: bytes, deadline: float | None, resend_every_s: float | None) -> bytes:
        if deadline is None and resend_every_s is None:
            return self._sub.recv().payload.to_bytes()
        started = time.monotonic()
        resend_at = None if resend_every_s is None else started + resend_every_s
        while True:
            sample = self._sub.try_recv()
            if sample is not None:
                return sample.payload.to_bytes()
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                raise TimeoutError(f"no reply from the host within {self._timeout} s")
            if resend_at is not None and now >= resend_at:
                # Only hello is resent (the host answers a resent hello with the same reply).
                self._pub.put(buf)
                resend_at = now + (resend_every_s or 1.0)
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
            end_reason=reply.get("end_reason"),
            seq=reply["seq"],
        )
