"""``SimHost``: serves one episode of a track to one agent over Zenoh (schemas/PROTOCOL.md).

Requests arrive on ``eagc/v1/<episode>/agent/req`` and each gets exactly one reply on
``…/rep``, echoing the request's ``id`` when it has one. The host declares a liveliness token
on ``…/host_alive`` while its session is open, so that an agent notices a host that is gone
(``RemoteEnv`` raises ``HostLost``) instead of waiting for a reply that never comes.

One thread owns the episode: ``serve()``, on the caller's thread, blocks on the request
channel (a Zenoh FIFO: the sample is handed from Zenoh's reader straight to this
thread, with no Python callback in between) and handles each request to the end, world
step and reply included. The world is only ever touched from that thread, which also
keeps MuJoCo's GL context, bound to the thread that made it, on one thread.

The clock runs beside it: a small thread that wakes the serving thread with a local tick
(a message that never leaves this process) when something is due: a stage's budget ran
out, the agent never started, its liveliness token went, or the caller asked to stop. The
serving thread then checks the clock itself, so that a stage never ends in the middle of
a request. After the episode, late requests still get one reply each ("episode_over")
until ``close()``.
"""

from __future__ import annotations

import logging
import os
import secrets
import threading
import time
import traceback
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import zenoh

from schemas import (
    PROTOCOL_VERSION,
    ActionResult,
    Answer,
    EndReason,
    EndStage,
    ErrorReply,
    Hello,
    HelloReply,
    HostMessage,
    Reset,
    StageInfo,
    Step,
)
from simhost import _transport
from simhost._wire import WireError, decode_request, encode, request_id
from simhost.host._actions import ActionError, check_fields
from simhost.host._episode import Observation, Pose, StageEnd, StageSpec, StepOutcome, TrackEpisode

log = logging.getLogger("eagc.simhost")

_MATCH_WAIT_S = 2.0  # at most this long for the agent's reply subscriber before a reply
# How the episode ends when its last stage ends this way.
_LAST_STAGE_END: dict[StageEnd, EndReason] = {
    "agent": EndReason.COMPLETED,
    "budget": EndReason.BUDGET,
    "steps": EndReason.STEPS,
    "episode_over": EndReason.COMPLETED,
    "stopped": EndReason.STOPPED,
}


class EpisodeRecorder:
    """Receives what happens in an episode (the MCAP logger implements it). No-op default."""

    #: ``poses()`` is called after reset and every this many steps (0: never).
    pose_every: int = 0

    def request(self, t: float, kind: str, stage: str | None, data: Mapping[str, Any]) -> None:
        """A request about to be applied to the episode, with what it carries (the checked
        action, the answers, the end-of-stage payload). Logged in the order the episode sees
        them, between the stage events, so that replaying the log reproduces the episode."""

    def reply(self, t: float, reply: Any, obs: Observation | None) -> None:
        """A reply sent to the agent."""

    def event(self, t: float, name: str, data: Mapping[str, Any]) -> None:
        """A stage, exception, protocol-error or lifecycle event."""

    def state(self, t: float, step: int, state_hash: str, state: bytes | None) -> None:
        """The simulator state after a step (full ``state`` every few steps)."""

    def poses(self, t: float, step: int, poses: Mapping[str, Pose]) -> None:
        """The track's organizer-only poses (``TrackEpisode.poses()``) after a step."""


@dataclass(frozen=True)
class HostProgress:
    """What the serving thread is doing, for a watchdog on another thread.

    ``busy_since`` is set while the serving thread handles a request or ends a stage (track
    code runs then); it is None while the host waits for the agent, which is never a hang
    (stage budgets bound that). A watchdog that sees ``busy_since`` far in the past can dump
    the stack of ``thread_id`` (``sys._current_frames()``) and give up on the episode.
    """

    requests: int
    busy_since: float | None
    phase: str
    thread_id: int | None


@dataclass(frozen=True)
class HostConfig:
    """How one episode is served."""

    episode: str
    track: str
    endpoints: tuple[str, ...]
    socket_path: Path | None = None
    time_scale: float = 1.0
    max_steps_per_stage: int | None = None
    startup_s: float = 120.0
    max_request_bytes: int = 1 << 20
    max_protocol_errors: int = 1000
    full_state_every: int = 100


@dataclass
class HostOutcome:
    """How the episode ended, from the host's side."""

    end_reason: EndReason = EndReason.NOT_STARTED
    stages_reached: list[str] = field(default_factory=list)
    stage_ends: dict[str, str] = field(default_factory=dict)
    stage_durations_s: dict[str, float] = field(default_factory=dict)
    steps: int = 0
    invalid_actions: int = 0
    protocol_errors: Counter[str] = field(default_factory=Counter)
    latencies_s: list[float] = field(default_factory=list)
    agent_seen: bool = False
    hello_at: float | None = None
    last_request_at: float | None = None  # time.monotonic() of the last request received
    ended_at: float | None = None  # time.monotonic() when the episode ended
    internal_error: str | None = None
    sim_warnings: int = 0

    @property
    def last_stage(self) -> str | None:
        return self.stages_reached[-1] if self.stages_reached else None



def _release_gl_context() -> None:
    """The serving thread rendered with an EGL context that stays current to it; released
    here, so that the renderer can be closed from another thread (else EGL_BAD_ACCESS when
    the episode is closed or collected). Nothing to do without EGL or a current context."""
    import sys

    if "mujoco.egl" not in sys.modules:
        return
    try:
        from OpenGL import EGL

        if EGL.eglGetCurrentContext() != EGL.EGL_NO_CONTEXT:
            EGL.eglMakeCurrent(EGL.eglGetCurrentDisplay(), EGL.EGL_NO_SURFACE,
                               EGL.EGL_NO_SURFACE, EGL.EGL_NO_CONTEXT)
    except Exception as e:  # noqa: BLE001 - a warning at worst, never the episode's fault
        log.debug("EGL context not released: %s", e)


class SimHost:
    """Serves one episode.

    Args:
        episode: the track's live episode (world and rules).
        stages: the track's stages with their official budgets.
        config: endpoints, limits and the episode id.
        recorder: where events go (MCAP); optional.
        on_stage_end: called (on the host's thread, before the next stage starts) with the
            name of a stage that ended, e.g. to snapshot ``/output``.
    """

    def __init__(
        self,
        episode: TrackEpisode,
        stages: list[StageSpec],
        config: HostConfig,
        *,
        recorder: EpisodeRecorder | None = None,
        on_stage_end: Callable[[str], None] | None = None,
    ) -> None:
        if not stages:
            raise ValueError("a track needs at least one stage")
        self.episode = episode
        self.stages = stages
        self.config = config
        self.recorder = recorder or EpisodeRecorder()
        self._on_stage_end = on_stage_end
        self.outcome = HostOutcome()
        self._served = False  # serve() has returned
        self._closing = False
        self._tick = b"tick:" + secrets.token_bytes(16)  # no agent can send it
        self._tick_pending = False  # a tick is on its way to the serving thread
        self._wake = threading.Event()  # wakes the clock thread early
        self._late: threading.Thread | None = None
        self._phase = "hello"  # hello → reset → running → over
        self._seq = 0
        self._stage = -1
        self._stage_started = 0.0
        self._stage_deadline = float("inf")
        self._stage_steps = 0
        self._stage_cap: int | None = None  # the current stage's step cap
        self._action_fields = {f.name: f for f in episode.action_spec}
        self._pending: list[HostMessage] = []
        self._last_reply_at: float | None = None
        self._agent_lost = False
        self._session: zenoh.Session | None = None
        self._pub: Any = None
        self._ticker: Any = None
        self._requests: Any = None
        self._subs: list[Any] = []
        self._hello_model: HelloReply | None = None
        self._hello_reply: bytes | None = None
        self._rid: int | None = None  # the id of the request being answered
        self._token: Any = None
        self._rep_checked = False
        self._t0 = time.monotonic()
        self._requests_handled = 0
        self._busy_since: float | None = None
        self._thread_id: int | None = None

    # ----------------------------------------------------------------- lifecycle
    def open(self) -> None:
        """Opens the Zenoh session and starts listening; the agent may connect from now."""
        keys = _transport.keys(self.config.episode)
        conf = _transport.host_config(self.config.episode, list(self.config.endpoints))
        self._session = zenoh.open(conf)
        if self.config.socket_path is not None:
            # The container's non-root uid must be able to connect.
            os.chmod(self.config.socket_path, 0o666)
        self._pub = self._session.declare_publisher(
            keys.rep, congestion_control=zenoh.CongestionControl.BLOCK, express=True
        )
        # Ticks go to this session's own request channel and nowhere else.
        self._ticker = self._session.declare_publisher(
            keys.req, allowed_destination=zenoh.Locality.SESSION_LOCAL
        )
        self._requests = self._session.declare_subscriber(
            keys.req, zenoh.handlers.FifoChannel(256)
        )
        self._subs.append(
            self._session.liveliness().declare_subscriber(
                keys.alive, self._on_liveliness, history=True
            )
        )
        # While this token lives, the agent knows the host does; it goes with the session,
        # also when this process is killed (the agent's side of the link closes).
        self._token = self._session.liveliness().declare_token(keys.host_alive)
        self._t0 = time.monotonic()
        self.recorder.event(0.0, "host_open", {"episode": self.config.episode})

    def close(self) -> None:
        """Stops answering and closes the session. Idempotent."""
        self._closing = True
        if self._late is not None:
            if self._late.is_alive():
                # The late replier ends at this tick, after answering what is queued before
                # it. The put waits for room in a full channel: never on this thread.
                threading.Thread(target=self._send_tick, daemon=True,
                                 name=f"close-{self.config.episode}").start()
                self._late.join(5.0)
            self._late = None
        for sub in [*self._subs, self._requests, self._token]:
            try:
                if sub is not None:
                    sub.undeclare()
            except Exception:  # noqa: BLE001 - closing must not raise
                pass
        self._subs.clear()
        self._requests = None
        self._token = None
        if self._session is not None:
            self._session.close()
            self._session = None

    def serve(self, stop: threading.Event | None = None, poll_s: float = 0.05) -> HostOutcome:
        """Serves requests and keeps the episode's clock until it ends; returns how it ended.

        ``stop`` (set by another thread, e.g. when the container exits) ends the episode
        within ``poll_s``.
        """
        if self._session is None:
            self.open()
        stop = stop or threading.Event()
        self._thread_id = threading.get_ident()
        startup_deadline = time.monotonic() + self.config.startup_s
        clock = threading.Thread(
            target=self._clock, args=(stop, startup_deadline, poll_s), daemon=True,
            name=f"clock-{self.config.episode}",
        )
        clock.start()
        try:
            while True:
                try:
                    if self._check_clock(stop, startup_deadline):
                        break
                except Exception as e:  # noqa: BLE001 - track code at a stage end, on the clock
                    self._internal_error(e)
                    break
                finally:
                    self._busy_since = None
                try:
                    buf = self._requests.recv().payload.to_bytes()
                    if buf == self._tick:
                        self._tick_pending = False
                    else:
                        self._serve_one(time.monotonic(), buf)
                except Exception:
                    if not self._closing:
                        raise
                    # close() from another thread (e.g. a watchdog) while serving: stop here.
                    self._finish_closed()
                    break
        finally:
            _release_gl_context()
            self._served = True
            self._wake.set()
            # From now on every request still gets one reply: the episode is over. The late
            # replier starts before the clock is joined: it drains the channel, so that a
            # tick the clock is putting into a full channel cannot block it forever.
            self._late = threading.Thread(
                target=self._answer_late, daemon=True, name=f"late-{self.config.episode}"
            )
            self._late.start()
            clock.join()
        return self.outcome

    def _finish_closed(self) -> None:
        try:
            self._finish(EndReason.STOPPED, "stopped")
        except Exception as e:  # noqa: BLE001 - track code at the stage end
            self._internal_error(e)

    def progress(self) -> HostProgress:
        """A snapshot of the serving thread's progress (safe from any thread)."""
        return HostProgress(requests=self._requests_handled, busy_since=self._busy_since,
                            phase=self._phase, thread_id=self._thread_id)

    # ------------------------------------------------------------------ the clock
    def _check_clock(self, stop: threading.Event, startup_deadline: float) -> bool:
        """On the serving thread: ends what is due; True once the episode is over."""
        while self._phase != "over":
            now = time.monotonic()
            if stop.is_set():
                self._busy_since = now
                self._finish(EndReason.STOPPED, "stopped")
            elif self._agent_lost and self.outcome.agent_seen:
                self._busy_since = now
                self._finish(EndReason.AGENT_LOST, "stopped")
            elif self._phase in ("hello", "reset") and now > startup_deadline:
                self._busy_since = now
                self._finish(EndReason.STARTUP_TIMEOUT, "stopped")
            elif self._phase == "running" and now >= self._stage_deadline:
                self._busy_since = now
                self._advance("budget")
            else:
                return False
        return True

    def _clock(self, stop: threading.Event, startup_deadline: float, poll_s: float) -> None:
        """Beside the serving thread: ticks it when something is due. Reads, never writes,
        the episode's state (a stale read only delays a tick by one poll)."""
        while not self._served:
            now = time.monotonic()
            phase = self._phase
            due = (
                stop.is_set()
                or (self._agent_lost and self.outcome.agent_seen)
                or (phase in ("hello", "reset") and now > startup_deadline)
                or (phase == "running" and now >= self._stage_deadline)
            )
            if due and not self._tick_pending:  # one tick in flight is enough
                self._tick_pending = True
                self._send_tick()
            wait = poll_s
            if phase == "running" and not due:
                wait = min(wait, max(0.0, self._stage_deadline - now))
            self._wake.wait(wait)
            self._wake.clear()

    def _send_tick(self) -> None:
        try:
            self._ticker.put(self._tick)
        except Exception:  # noqa: BLE001 - a closed session: nothing is waiting any more
            self._tick_pending = False

    def _answer_late(self) -> None:
        while True:
            try:
                buf = self._requests.recv().payload.to_bytes()
            except Exception:  # noqa: BLE001 - the channel is gone: nothing to answer
                return
            if buf == self._tick:
                if self._closing:
                    return
            else:
                try:
                    self._rid = request_id(buf)
                    self._pub.put(self._over_reply())
                except Exception:  # noqa: BLE001 - the session is closing: nobody to answer
                    return

    # ------------------------------------------------------------------ callbacks
    def _on_liveliness(self, sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:
            self.outcome.agent_seen = True
            self._agent_lost = False
        else:
            self._agent_lost = True
        self._wake.set()  # the clock ticks the serving thread at once

    def _over_reply(self, code: str = "episode_over", message: str | None = None) -> bytes:
        return encode(ErrorReply(
            seq=self._seq, id=self._rid, code=code, fatal=True,
            message=message or f"the episode is over ({self.outcome.end_reason})"))

    def _internal_error(self, e: BaseException) -> None:
        """A host or track bug: recorded, and the episode ends (never raises)."""
        self.outcome.internal_error = "".join(traceback.format_exception(e))
        log.exception("internal error while serving episode %s", self.config.episode)
        try:
            self._event("internal_error", {"error": f"{type(e).__name__}: {e}"})
            self._finish(EndReason.INTERNAL_ERROR, "stopped")
        except Exception:  # noqa: BLE001 - the stage end failed again: end without it
            log.exception("episode %s: ending the stage failed too", self.config.episode)
            self._phase = "over"
            self.outcome.end_reason = EndReason.INTERNAL_ERROR

    def _serve_one(self, received: float, buf: bytes) -> None:
        self._busy_since = received
        self.outcome.last_request_at = received
        self._rid = None
        try:
            reply = self._handle(buf, received)
        except Exception as e:  # noqa: BLE001 - a host bug must still answer and be recorded
            self._internal_error(e)
            reply = self._over_reply("internal", f"host error: {type(e).__name__}")
        if not self._rep_checked:
            self._rep_checked = True
            self._await_agent_subscriber()
        self._last_reply_at = time.monotonic()  # before the put: the agent may answer at once
        self._pub.put(reply)
        self._requests_handled += 1
        self._busy_since = None

    def _await_agent_subscriber(self) -> None:
        """Before the first reply (once): waits briefly until this session knows the agent's
        reply subscriber. A put goes only to subscribers already known, and the agent's
        declaration may still be on its way when its first request arrives."""
        deadline = time.monotonic() + _MATCH_WAIT_S
        while time.monotonic() < deadline:
            if self._pub.matching_status.matching:
                return
            time.sleep(0.001)
        log.warning("episode %s: the agent's reply subscriber is still unknown after %.0f s",
                    self.config.episode, _MATCH_WAIT_S)

    # ------------------------------------------------------------------- handling
    def _error(self, code: str, message: str, *, fatal: bool = False) -> bytes:
        self.outcome.protocol_errors[code] += 1
        self._event("protocol_error", {"code": code, "message": message, "fatal": fatal})
        if (
            not fatal
            and sum(self.outcome.protocol_errors.values()) >= self.config.max_protocol_errors
        ):
            fatal = True
            message += f" (protocol error limit {self.config.max_protocol_errors} reached)"
            self._finish(EndReason.PROTOCOL_VIOLATION, "stopped")
        return encode(ErrorReply(seq=self._seq, id=self._rid, code=code, message=message,
                                 fatal=fatal))

    def _handle(self, buf: bytes, received: float) -> bytes:
        try:
            msg, tensors = decode_request(buf, max_bytes=self.config.max_request_bytes)
        except WireError as e:
            self._rid = request_id(buf)  # the reply names the request when it can
            return self._error(e.code, str(e))
        self._rid = msg.id
        if self._phase == "over":
            return self._error("episode_over", "the episode is over", fatal=True)
        if isinstance(msg, Hello) and self._phase == "reset" and msg.seq == 0:
            # A resent hello (its first reply may have been missed): the same reply again.
            assert self._hello_model is not None and self._hello_reply is not None
            if msg.id != self._hello_model.id:
                return encode(self._hello_model.model_copy(update={"id": msg.id}))
            return self._hello_reply
        if msg.seq != self._seq:
            return self._error("stale", f"request seq {msg.seq}, expected {self._seq}")
        if self._last_reply_at is not None and self._phase == "running":
            self.outcome.latencies_s.append(received - self._last_reply_at)
        if isinstance(msg, Hello):
            return self._hello(msg)
        if self._phase == "hello":
            return self._error("bad_order", f"{msg.kind} before hello")
        if isinstance(msg, Reset):
            if self._phase != "reset":
                return self._error("bad_order", "reset was already done: one run per episode")
            return self._reset()
        if self._phase == "reset":
            return self._error("bad_order", f"{msg.kind} before reset")
        # A request that arrives after its stage's budget ran out is not applied.
        if time.monotonic() >= self._stage_deadline:
            self._advance("budget")
            return self._observation(
                StepOutcome(
                    observation=self.episode.observe(),
                    action=ActionResult(applied=False, ok=True, reason="stage ended first"),
                )
            )
        if isinstance(msg, Step):
            return self._step(msg, tensors)
        if isinstance(msg, Answer):
            self._record("answer", {"answers": msg.answers})
            return self._after(self.episode.answer(self._stage_name, msg.answers))
        assert isinstance(msg, EndStage)
        self._record("end_stage", {"payload": msg.payload})
        self._advance("agent", msg.payload)
        return self._observation(StepOutcome(observation=self.episode.observe()))

    def _hello(self, msg: Hello) -> bytes:
        if self._phase != "hello":
            return self._error("bad_order", "hello was already done")
        if msg.protocol != PROTOCOL_VERSION:
            reply = self._error(
                "malformed", f"protocol {msg.protocol!r} not served; this host speaks "
                f"{PROTOCOL_VERSION}", fatal=True
            )
            self._finish(EndReason.PROTOCOL_VIOLATION, "stopped")
            return reply
        self.outcome.agent_seen = True
        self.outcome.hello_at = self._now()
        self._record("hello", {"agent": msg.agent, "protocol": msg.protocol})
        self._seq += 1
        self._phase = "reset"
        scale = self.config.time_scale
        reply = HelloReply(
            seq=self._seq,
            id=msg.id,
            episode=self.config.episode,
            track=self.config.track,
            observation_spec=self.episode.observation_spec,
            action_spec=self.episode.action_spec,
            stages=tuple(
                StageInfo(
                    name=s.name,
                    budget_s=s.budget_s * scale,
                    max_steps=self._step_cap(s),
                    allows_motion=s.allows_motion,
                    description=s.description,
                )
                for s in self.stages
            ),
            max_request_bytes=self.config.max_request_bytes,
            startup_budget_s=self.config.startup_s,
        )
        self._hello_model = reply
        self._hello_reply = encode(reply)
        self.recorder.reply(self._now(), reply, None)
        return self._hello_reply

    def _reset(self) -> bytes:
        self._record("reset", {})
        obs = self.episode.reset()
        self._phase = "running"
        self._start_stage(0)
        self._seq += 1
        if self.recorder.pose_every:
            self.recorder.poses(self._now(), 0, self.episode.poses())
        return self._observation(StepOutcome(observation=obs), bump=False)

    def _step(self, msg: Step, tensors: Mapping[str, np.ndarray]) -> bytes:
        try:
            action = check_fields(self._action_fields, msg.action, tensors)
        except ActionError as e:
            self.outcome.invalid_actions += 1
            return self._error("invalid_action", str(e))
        self.outcome.steps += 1
        self._stage_steps += 1
        self._record("step", {"action": action})
        out = self.episode.step(self._stage_name, action)
        if out.action is not None and not out.action.ok:
            self.outcome.invalid_actions += 1
        self.recorder.state(
            self._now(),
            self.outcome.steps,
            self.episode.state_hash(),
            self.episode.sim_state()
            if self.outcome.steps % self.config.full_state_every == 0
            else None,
        )
        every = self.recorder.pose_every
        if every and self.outcome.steps % every == 0:
            self.recorder.poses(self._now(), self.outcome.steps, self.episode.poses())
        return self._after(out)

    def _after(self, out: StepOutcome) -> bytes:
        for ev in out.events:
            self._event(str(ev.get("event", "track_event")), ev)
        if out.episode_over:
            self._finish(EndReason(out.end_reason or EndReason.COMPLETED), "episode_over")
        elif self._stage_cap is not None and self._stage_steps >= self._stage_cap:
            self._advance("steps")
        return self._observation(out)

    def _observation(self, out: StepOutcome, *, bump: bool = True) -> bytes:
        if bump:
            self._seq += 1
        messages: tuple[HostMessage, ...] = ()
        if self._pending or out.messages:
            messages = tuple(self._pending) + out.messages
            self._pending.clear()
        over = self._phase == "over"
        stage = self.stages[self._stage]
        cap = self._stage_cap
        # The hot path: a plain dict with exactly ObservationReply's fields (tests validate
        # the host's replies against the model; building the model costs more than a step).
        action = out.action
        reply = {
            "kind": "observation",
            "seq": self._seq,
            "id": self._rid,
            "stage": stage.name,
            "stage_index": self._stage,
            "time_left_s": 0.0 if over else max(0.0, self._stage_deadline - time.monotonic()),
            "steps_left": None if cap is None else max(0, cap - self._stage_steps),
            "observation": dict(out.observation.data),
            "action": None if action is None else
            {"applied": action.applied, "ok": action.ok, "reason": action.reason},
            "messages": [m.model_dump(mode="json") for m in messages] if messages else [],
            "episode_over": over,
            "end_reason": self.outcome.end_reason if over else None,
        }
        self.recorder.reply(self._now(), reply, out.observation)
        return encode(reply, out.observation.tensors)

    # --------------------------------------------------------------------- stages
    @property
    def _stage_name(self) -> str:
        return self.stages[self._stage].name

    def _step_cap(self, stage: StageSpec) -> int | None:
        caps = [c for c in (stage.max_steps, self.config.max_steps_per_stage,
                            self.episode.step_budget(stage.name)) if c is not None]
        return min(caps) if caps else None

    def _start_stage(self, index: int) -> None:
        self._stage = index
        stage = self.stages[index]
        self._stage_started = time.monotonic()
        self._stage_deadline = self._stage_started + stage.budget_s * self.config.time_scale
        self._stage_steps = 0
        self._stage_cap = self._step_cap(stage)
        self.outcome.stages_reached.append(stage.name)
        self._event("stage_start", {"stage": stage.name, "index": index})
        self._pending.append(
            HostMessage(
                type="stage_started",
                data={"stage": stage.name, "index": index, "allows_motion": stage.allows_motion},
            )
        )
        self._pending.extend(self.episode.on_stage_start(stage.name))

    def _end_stage(self, ended_by: StageEnd, payload: Mapping[str, Any]) -> None:
        name = self._stage_name
        self.outcome.stage_ends[name] = ended_by
        self.outcome.stage_durations_s[name] = time.monotonic() - self._stage_started
        self._event("stage_end", {"stage": name, "ended_by": ended_by})
        for ev in self.episode.on_stage_end(name, ended_by=ended_by, payload=payload):
            self._event(str(ev.get("event", "track_event")), ev)
        if self._on_stage_end is not None:
            self._on_stage_end(name)

    def _advance(self, ended_by: StageEnd, payload: Mapping[str, Any] | None = None) -> None:
        self._end_stage(ended_by, payload or {})
        if self._stage + 1 < len(self.stages):
            self._start_stage(self._stage + 1)
        else:
            self._phase = "over"
            self.outcome.end_reason = _LAST_STAGE_END[ended_by]
            self.outcome.ended_at = time.monotonic()
            self._event("episode_end", {"reason": self.outcome.end_reason})

    def _finish(self, reason: EndReason, ended_by: StageEnd) -> None:
        if self._phase == "over":
            return
        # A stage whose end already began (and failed) is not ended twice.
        running = self._phase == "running" and self._stage_name not in self.outcome.stage_ends
        self._phase = "over"
        self.outcome.end_reason = reason
        self.outcome.ended_at = time.monotonic()
        try:
            if running:
                self._end_stage(ended_by, {})
        finally:
            self._event("episode_end", {"reason": reason})

    # ---------------------------------------------------------------------- utils
    def _now(self) -> float:
        return time.monotonic() - self._t0

    def _record(self, kind: str, data: Mapping[str, Any]) -> None:
        stage = self._stage_name if self._phase == "running" else None
        self.recorder.request(self._now(), kind, stage, data)

    def _event(self, name: str, data: Mapping[str, Any]) -> None:
        self.recorder.event(self._now(), name, data)
