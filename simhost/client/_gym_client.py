"""``GymEnv``: a team container's episode as a ``gymnasium.Env``-shaped object.

A policy written against the offline environment (``gymnasium.make("eagc/House-v0")``:
an observation dict in, an action out) runs unchanged against the sim host::

    from simhost.client import GymEnv, StageRule

    env = GymEnv(stages={"exploration": StageRule(max_steps=400)},
                 on_stage_end=lambda end: {"world_model.json": my_model(end)})
    obs, info = env.reset()
    terminated = truncated = False
    while not (terminated or truncated):
        obs, reward, terminated, truncated, info = env.step(policy(obs))
    env.close()

The spaces come from the ``hello`` reply's specs (``gymnasium.spaces`` when gymnasium is
importable, else the plain descriptions of ``simhost.client._plain_spaces`` with the same
attributes); ``step`` returns reward 0, ``terminated`` once the episode is over and never
``truncated``; the stage, the host's messages and the observation's non-numeric entries are
in ``info``. The client ends stages for the policy (``StageRule``) and calls
``on_stage_end`` at every stage end, writing the files it returns to ``$EAGC_OUTPUT``.
How the observations and actions are converted from and to the wire is in the class
docstring and in docs/contract.md ("A gymnasium-style client").

Imports gymnasium only if it is installed: ``import simhost.client`` never loads this module
(``simhost.client.GymEnv`` does, on first use).
"""

from __future__ import annotations

import difflib
import math
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ValidationError

from schemas import FieldSpec, HelloReply, HostMessage, LogRecord
from simhost._errors import SimHostError
from simhost.client._outputs import LOG_FILE, OutputFileError, OutputFiles
from simhost.client._plain_spaces import PlainBox, PlainDict, PlainDiscrete
from simhost.client._remote import HostLost, RemoteEnv, TimeStep

try:
    import gymnasium
    from gymnasium import spaces as gym_spaces
except ImportError:  # the light install: plain space descriptions
    # None says "not installed"; every use checks it first.
    gymnasium = None  # type: ignore[assignment]
    gym_spaces = None  # type: ignore[assignment]

__all__ = ["OFFLINE_DTYPES", "FileContent", "GymClientError", "GymEnv", "StageEnd", "StageRule"]

OFFLINE_DTYPES: Mapping[str, Mapping[str, str]] = {
    "track1": {"last_action_ok": "int8", "collided": "int8", "det_mask": "int8"},
}
"""Per track, the observation entries whose offline dtype the wire lacks (it has no int8:
the host sends these as uint8) and the dtype ``GymEnv`` gives them back."""

FileContent = bytes | str | BaseModel | Mapping[str, Any] | Sequence[Mapping[str, Any] | BaseModel]
"""What ``on_stage_end`` may return per file name: bytes or text (written as they are), a
schema model or a mapping (``world_model.json`` and ``task_model.json`` are checked against
their schema first), or a sequence of records (JSON lines; each checked as a ``LogRecord``
for ``episode_log.jsonl``). Every file is written whole, to a dot-name, then renamed."""

_EndedBy = Literal["client", "host"]


class GymClientError(SimHostError, RuntimeError):
    """Raised when ``GymEnv`` is used out of the episode's order (a step before reset or
    after the episode ended, a second reset) or given a rule for a stage that does not
    exist."""


@dataclass(frozen=True)
class StageRule:
    """How ``GymEnv`` runs one stage for the policy. After every reply in the stage, the
    client ends it itself (``end_stage``, after calling the hooks) as soon as one of these
    holds; the host's step cap and wall-clock budget are always kept this way.

    Attributes:
        play: Whether the policy plays the stage. None (default): when the stage allows
            motion; a stage not played is ended at once (Track 1's ``planning``).
        max_steps: End it after this many steps of the policy (None: no limit of its own).
        until: End it when ``until(observation, info)`` is true of the latest reply.
        min_time_left_s: End it when less wall-clock time than this is left in the stage
            (the host counts the policy's thinking time too).
    """

    play: bool | None = None
    max_steps: int | None = None
    until: Callable[[Mapping[str, Any], Mapping[str, Any]], bool] | None = None
    min_time_left_s: float = 2.0


@dataclass(frozen=True)
class StageEnd:
    """What the stage-end hooks are given (one frozen object: fields can be added).

    Attributes:
        stage: The stage that ends.
        index: Its index in the hello reply's stages.
        steps: The steps the policy took in it.
        ended_by: ``"client"``: ``GymEnv`` is about to end it, so the files the hook returns
            are in the host's snapshot at this stage end. ``"host"``: it has ended already
            (the policy's ``done``, a budget, the track): the files reach the next snapshot
            (the next stage's end, or the one taken when the episode ends).
        reason: Why: ``max_steps``, ``until``, ``step cap`` (one step left), ``time``,
            ``not played``, ``finish`` (``GymEnv.finish``/``close``), or ``host: …``.
        last: True for the episode's last stage: its files are the final ones.
        observation: The latest observation (converted as ``step`` returns it).
        info: The latest info.
        messages: Every host message received since the stage began, in order.
    """

    stage: str
    index: int
    steps: int
    ended_by: _EndedBy
    reason: str
    last: bool
    observation: Mapping[str, Any]
    info: Mapping[str, Any]
    messages: tuple[HostMessage, ...]


def _dtype(spec: FieldSpec, track: str) -> np.dtype[Any] | None:
    """The numpy dtype of a numeric entry (None for ``str`` and ``json``)."""
    if spec.dtype in ("str", "json"):
        return None
    return np.dtype(OFFLINE_DTYPES.get(track, {}).get(spec.name, spec.dtype))


def _box(spec: FieldSpec, dtype: np.dtype[Any]) -> Any:
    shape = tuple(spec.shape)
    low: float
    high: float
    if dtype.kind == "b":
        low, high = 0, 1
    elif dtype.kind in "iu":
        info = np.iinfo(dtype)
        low = info.min if spec.low is None else max(int(info.min), math.ceil(spec.low))
        high = info.max if spec.high is None else min(int(info.max), math.floor(spec.high))
    else:
        low = -np.inf if spec.low is None else spec.low
        high = np.inf if spec.high is None else spec.high
    if gym_spaces is not None:
        return gym_spaces.Box(low, high, shape, dtype)
    return PlainBox(np.full(shape, low, dtype), np.full(shape, high, dtype), shape, dtype)


def _discrete(n: int, start: int) -> Any:
    if gym_spaces is not None:
        return gym_spaces.Discrete(n, start=start)
    return PlainDiscrete(n, start)


def _dict(members: Mapping[str, Any]) -> Any:
    if gym_spaces is not None:
        return gym_spaces.Dict(list(members.items()))  # in the spec's order, not sorted
    return PlainDict(dict(members))


def _action_member(spec: FieldSpec) -> Any | None:
    """A field's space: Discrete for a scalar integer with named choices or finite bounds
    (as the offline env's ``primitive``, ``target``, ``tool``), else a Box."""
    dtype = _dtype(spec, "")
    if dtype is None:
        return None
    if dtype.kind in "iu" and not spec.shape:
        if spec.choices is not None:
            return _discrete(len(spec.choices), 0)
        if spec.low is not None and spec.high is not None:
            low, high = math.ceil(spec.low), math.floor(spec.high)
            return _discrete(high - low + 1, low)
    return _box(spec, dtype)


def _write_atomic(folder: Path, name: str, data: bytes) -> None:
    if not name or "/" in name or name.startswith("."):
        raise OutputFileError(f"{name!r} is not a plain file name")
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / f".{name}.tmp"
    tmp.write_bytes(data)
    os.replace(tmp, folder / name)


class _Base:
    """The base without gymnasium: what a policy may read of a ``gymnasium.Env``."""

    metadata: dict[str, Any] = {"render_modes": []}
    render_mode: str | None = None
    spec: Any = None
    _np_random: np.random.Generator | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> Any:
        """Seeds ``np_random`` when given a seed (``GymEnv.reset`` does the rest)."""
        if seed is not None:
            self._np_random = np.random.default_rng(seed)

    @property
    def np_random(self) -> np.random.Generator:
        """The env's own generator (seed 0 until ``reset(seed=…)``)."""
        if self._np_random is None:
            self._np_random = np.random.default_rng(0)
        return self._np_random

    @property
    def unwrapped(self) -> Any:
        return self


_Env: type = _Base if gymnasium is None else gymnasium.Env


class GymEnv(_Env):
    """The episode as a ``gymnasium.Env``: ``reset()``, ``step(action)``, ``close()``.

    Says hello at construction (the spaces come from the reply), so the spaces are there
    before ``reset``. One container plays one episode: ``reset`` once.

    Observations: the numeric entries of the wire observation (tensors and numeric JSON
    values), as numpy arrays of the spec's dtype, except where the offline env uses a dtype
    the wire lacks (``OFFLINE_DTYPES``: Track 1's ``last_action_ok``, ``collided`` and
    ``det_mask`` come back as int8, as ``gymnasium.make("eagc/House-v0")`` gives them).
    The ``str`` and ``json`` entries (Track 1: ``detections``, ``room_name``,
    ``action_result``) go to ``info`` under their own names.

    Actions: a mapping of the action spec's fields, as the offline env takes it. Float
    fields are clipped to their bounds (the offline env clips ``move`` to [-1, 1]; the host
    would refuse a value out of bounds); NaN or infinity still reaches the host, which
    refuses it (``HostError`` ``invalid_action``). Fields the spec does not name are left
    out (the offline env ignores them; the host would refuse them). With a one-field action
    spec (sanity), the action space is that field's and a bare array is that field.

    ``info``: the non-numeric observation entries, then ``stage``, ``stage_index``,
    ``time_left_s``, ``steps_left``, ``stage_steps`` (the policy's steps in this stage),
    ``action`` (the host's ``ActionResult`` of this step: ``ok``, ``reason``), ``messages``
    (every host message of this call, in order: the stages the client ended in between
    included), ``stages_ended`` (the stages that ended during this call), ``episode_over``,
    ``end_reason`` and ``timestep`` (the latest ``TimeStep``).

    Args:
        remote: The client to drive (default: ``RemoteEnv()`` from ``$EAGC_ENDPOINT`` and
            ``$EAGC_EPISODE``). Closed by ``close()``.
        agent: The name and version sent in hello (when ``remote`` has not said hello).
        stages: A ``StageRule`` per stage name; a stage not named gets ``StageRule()``.
        on_stage_end: Called at every stage end, once per stage: returns the files to write
            to ``output`` (file name → ``FileContent``), or None.
        end_stage_payload: Called when the client ends a stage, after ``on_stage_end``:
            returns the ``end_stage`` payload (Track 1's plan: ``{"plan": …}``), or None.
        output: Where the files go (default ``$EAGC_OUTPUT``, ``/output`` in a container).
    """

    def __init__(
        self,
        remote: RemoteEnv | None = None,
        *,
        agent: str = "",
        stages: Mapping[str, StageRule] | None = None,
        on_stage_end: Callable[[StageEnd], Mapping[str, FileContent] | None] | None = None,
        end_stage_payload: Callable[[StageEnd], Mapping[str, Any] | None] | None = None,
        output: str | os.PathLike[str] | None = None,
    ) -> None:
        self.remote = remote if remote is not None else RemoteEnv()
        self.hello: HelloReply = self.remote.spec or self.remote.hello(agent=agent)
        names = [s.name for s in self.hello.stages]
        for name in stages or {}:
            if name not in names:
                near = difflib.get_close_matches(name, names, n=1)
                hint = f"; did you mean {near[0]!r}?" if near else ""
                raise GymClientError(f"no stage {name!r} in this episode (its stages: "
                                     f"{names}){hint}")
        self._rules = dict(stages or {})
        self._on_stage_end = on_stage_end
        self._payload = end_stage_payload
        self.files = OutputFiles(output)
        track = self.hello.track
        self._obs_dtypes = {s.name: d for s in self.hello.observation_spec
                            if (d := _dtype(s, track)) is not None}
        self._fields = {s.name: s for s in self.hello.action_spec}
        self.observation_space = _dict({
            s.name: _box(s, self._obs_dtypes[s.name]) for s in self.hello.observation_spec
            if s.name in self._obs_dtypes})
        members = {s.name: m for s in self.hello.action_spec
                   if (m := _action_member(s)) is not None}
        self._single = next(iter(members)) if len(self._fields) == 1 and members else None
        self.action_space = members[self._single] if self._single else _dict(members)
        self._ts: TimeStep | None = None
        self._obs: dict[str, Any] = {}
        self._info: dict[str, Any] = {}
        self._stage_steps = 0
        self._stage_messages: list[HostMessage] = []
        self._call_messages: list[HostMessage] = []
        self._call_ended: list[str] = []
        self._ended: set[int] = set()
        self._closed = False

    # ------------------------------------------------------------------ gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """Starts the episode and returns ``(observation, info)``.

        ``seed`` seeds only ``self.np_random`` (the host chooses the episode; the agent
        never sees its seed); ``options`` (the offline env's shaped-reward task) are
        ignored with a warning. Stages not played are ended before it returns.
        """
        super().reset(seed=seed)
        if self._ts is not None:
            raise GymClientError("reset() was called already: one container plays one "
                                 "episode (reset once, then step until terminated)")
        if options:
            warnings.warn(f"GymEnv.reset ignores options {sorted(options)}: the host sets "
                          "the episode", stacklevel=2)
        self._begin_call()
        self._advance(self.remote.reset())
        return self._obs, self._info

    def step(self, action: Any) -> tuple[dict[str, Any], float, bool, bool, dict[str, Any]]:
        """Sends one action; returns ``(observation, 0.0, terminated, False, info)``.

        ``terminated`` is true once the episode is over (whatever ended it:
        ``info["end_reason"]``). If the reply ends the stage for the rules, the client
        ends it (hooks, files, ``end_stage``) and returns the next played stage's first
        observation.
        """
        self._require_running()
        self._begin_call()
        reply = self.remote.step(self._to_wire(action))
        self._stage_steps += 1
        self._advance(reply)
        over = self._ts is not None and self._ts.episode_over
        return self._obs, 0.0, over, False, self._info

    def render(self) -> None:
        """Nothing to render: images, when the track sends them, are in the observation."""
        return None

    def close(self) -> None:
        """Finishes the episode if it is still on (``finish``), then closes the client.
        Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            ts = self._ts
            if ts is not None and not ts.episode_over and self.remote.host_alive:
                try:
                    self.finish()
                except (HostLost, TimeoutError):
                    pass  # the episode is gone: nothing left to finish
        finally:
            self.remote.close()

    def __enter__(self) -> GymEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ beyond gymnasium
    def finish(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """Ends every stage left, as the rules would (hooks, files, ``end_stage``), until
        the episode is over; returns the last ``(observation, info)``."""
        ts = self._require_running()
        self._begin_call()
        while not ts.episode_over:
            self._advance(self._end_stage_now("finish"))
            assert self._ts is not None
            ts = self._ts
        return self._obs, self._info

    def answer(self, answers: Mapping[str, Any]) -> TimeStep:
        """Answers the host's queries (e.g. from ``end_stage_payload`` during Track 1's
        planning, before the client ends it); returns the reply."""
        self._require_running()
        ts = self.remote.answer(answers)
        self._take(ts)
        return ts

    @property
    def stage(self) -> str | None:
        """The current stage (None before reset)."""
        return None if self._ts is None else self._ts.stage

    # ------------------------------------------------------------------ internals
    def _require_running(self) -> TimeStep:
        if self._ts is None:
            raise GymClientError("call reset() first")
        if self._ts.episode_over:
            raise GymClientError(f"the episode is over ({self._ts.end_reason}): exit; one "
                                 "container plays one episode")
        return self._ts

    def _begin_call(self) -> None:
        self._call_messages = []
        self._call_ended = []

    def _to_wire(self, action: Any) -> dict[str, Any]:
        if not isinstance(action, Mapping):
            if self._single is None:
                raise GymClientError(f"an action is a mapping of {sorted(self._fields)}, "
                                     f"not {type(action).__name__}")
            action = {self._single: action}
        out: dict[str, Any] = {}
        for name, value in action.items():
            spec = self._fields.get(name)
            if spec is None:
                continue  # the offline env ignores fields it does not read
            if spec.dtype in ("float32", "float64") and not isinstance(value, str):
                arr = np.asarray(value, dtype=spec.dtype)
                if np.all(np.isfinite(arr)) and (spec.low is not None or spec.high is not None):
                    arr = np.clip(arr, spec.low, spec.high).astype(spec.dtype)
                value = arr
            out[name] = value
        return out

    def _convert(self, observation: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
        obs: dict[str, Any] = {}
        extra: dict[str, Any] = {}
        dtypes = self._obs_dtypes
        for name, value in observation.items():
            dtype = dtypes.get(name)
            if dtype is None:
                extra[name] = value
            elif isinstance(value, np.ndarray) and value.dtype == dtype:
                obs[name] = value
            else:
                obs[name] = np.asarray(value, dtype=dtype)
        return obs, extra

    def _take(self, ts: TimeStep) -> None:
        """Records a reply (observation, info, the stage's messages) and calls the hooks of
        the stages the host ended."""
        old = self._ts
        old_steps, old_messages = self._stage_steps, self._stage_messages
        if old is None or ts.stage_index != old.stage_index:
            self._stage_steps = 0
            self._stage_messages = list(ts.messages)
        else:
            self._stage_messages.extend(ts.messages)
        self._call_messages.extend(ts.messages)
        self._ts = ts
        self._obs, extra = self._convert(ts.observation)
        self._info = {
            **extra,
            "stage": ts.stage,
            "stage_index": ts.stage_index,
            "time_left_s": ts.time_left_s,
            "steps_left": ts.steps_left,
            "stage_steps": self._stage_steps,
            "action": ts.action,
            "messages": tuple(self._call_messages),
            "stages_ended": tuple(self._call_ended),
            "episode_over": ts.episode_over,
            "end_reason": ts.end_reason,
            "timestep": ts,
        }
        if old is None:
            return
        last = ts.stage_index + 1 if ts.episode_over else ts.stage_index
        for index in range(old.stage_index, last):
            if index in self._ended:
                continue
            if index == old.stage_index:
                steps, messages = old_steps, tuple(old_messages)
            elif index == ts.stage_index:
                steps, messages = self._stage_steps, tuple(self._stage_messages)
            else:
                steps, messages = 0, ()
            why = (f"host: {ts.end_reason}" if ts.episode_over and index == ts.stage_index
                   else "host: the stage ended (its budget, or the track)")
            self._stage_end(index, "host", why, steps=steps, messages=messages)

    def _advance(self, ts: TimeStep) -> None:
        """Takes a reply, then ends stages for the rules until a played stage or the end."""
        self._take(ts)
        while not ts.episode_over:
            why = self._why_end(ts)
            if why is None:
                return
            ts = self._end_stage_now(why)
            self._take(ts)

    def _why_end(self, ts: TimeStep) -> str | None:
        rule = self._rules.get(ts.stage) or StageRule()
        play = rule.play
        if play is None:
            play = self.hello.stages[ts.stage_index].allows_motion
        if not play:
            return "not played"
        if rule.max_steps is not None and self._stage_steps >= rule.max_steps:
            return "max_steps"
        if ts.steps_left is not None and ts.steps_left <= 1:
            return "step cap"
        if ts.time_left_s < rule.min_time_left_s:
            return "time"
        if rule.until is not None and rule.until(self._obs, self._info):
            return "until"
        return None

    def _end_stage_now(self, why: str) -> TimeStep:
        """Calls the hooks, writes the files, sends ``end_stage``; returns the reply."""
        ts = self._ts
        assert ts is not None
        event = self._stage_end(ts.stage_index, "client", why, steps=self._stage_steps,
                                messages=tuple(self._stage_messages))
        payload = self._payload(event) if self._payload is not None else None
        return self.remote.end_stage(payload or {})

    def _stage_end(self, index: int, ended_by: _EndedBy, reason: str, *, steps: int,
                   messages: tuple[HostMessage, ...]) -> StageEnd:
        stage = self.hello.stages[index].name
        self._ended.add(index)
        self._call_ended.append(stage)
        self._info["stages_ended"] = tuple(self._call_ended)
        event = StageEnd(stage=stage, index=index, steps=steps, ended_by=ended_by,
                         reason=reason, last=index == len(self.hello.stages) - 1,
                         observation=self._obs, info=self._info, messages=messages)
        if self._on_stage_end is not None:
            for name, content in (self._on_stage_end(event) or {}).items():
                self._write(name, content)
        return event

    def _write(self, name: str, content: FileContent) -> None:
        folder = self.files.folder
        if isinstance(content, bytes):
            _write_atomic(folder, name, content)
        elif isinstance(content, str):
            _write_atomic(folder, name, content.encode())
        elif isinstance(content, BaseModel | Mapping):
            self.files.write(content, name)
        elif isinstance(content, Sequence):
            lines = []
            for i, record in enumerate(content, start=1):
                try:
                    if name == LOG_FILE:
                        record = LogRecord.model_validate(
                            record.model_dump() if isinstance(record, BaseModel) else record)
                    text = (record.model_dump_json(exclude_none=True)
                            if isinstance(record, BaseModel) else _json(record))
                except ValidationError as e:
                    first = e.errors(include_url=False)[0]
                    loc = ".".join(str(p) for p in first["loc"]) or "(record)"
                    raise OutputFileError(f"{name}: line {i}: {loc}: {first['msg']}") from None
                lines.append(text + "\n")
            _write_atomic(folder, name, "".join(lines).encode())
        else:
            raise OutputFileError(f"{name}: cannot write a {type(content).__name__} (bytes, "
                                  "str, a model, a mapping or a sequence of records)")


def _json(value: Any) -> str:
    import json

    return json.dumps(value, separators=(",", ":"), allow_nan=False)
