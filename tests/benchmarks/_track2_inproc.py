"""Run a Track 2 baseline's own code in this process, against the plugin's episode.

``run_inproc(folder, seed=..., split=..., index=...)`` plays one episode of the agent in
``examples/<folder>/agent.py`` with ``simhost.client.RemoteEnv`` replaced by :class:`LocalEnv`,
which drives ``Track2Episode`` exactly as the sim host does: the stage sequence, the
stage's step cap (the smaller of the episode's ``step_budget`` and none other), refusals
counted as invalid actions, the host's messages, the observation's JSON part merged with
its tensors. The demonstration packet goes to ``$EAGC_INPUT/demo`` and the agent's files
to ``$EAGC_OUTPUT``; the final ``task_model.json`` is scored by the plugin's ``score``, the
same scoring path as a campaign. What it leaves out: Zenoh, the container, wall-clock stage
budgets, the MCAP log and stage snapshots (the final files decide). Used by
``bench_track2_fidelity.py --inproc`` for calibration runs (the same agent code and scoring
path; adaptation time reads 0, there is no clock).
"""

from __future__ import annotations

import json
import os
import runpy
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[2]


class LocalEnv:
    """What an agent sees of ``simhost.client.RemoteEnv``, driving one Track 2 episode."""

    episode_ref: Any = None  # set by run_inproc before the agent starts

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        from plugins._registry import load_track

        self.plugin = load_track("track2")
        self.ep = LocalEnv.episode_ref
        self.stages = [s.name for s in self.plugin.stages()]
        self.stage = 0
        self.stage_steps = 0
        self.seq = 0
        self.over = False
        self.end_reason: str | None = None
        self.pending: list[Any] = []
        self.invalid = 0
        self.steps = 0
        self.t0: dict[str, float] = {}

    # context manager, as RemoteEnv
    def __enter__(self) -> LocalEnv:
        return self

    def __exit__(self, *exc: object) -> None:
        return None

    def close(self) -> None:
        return None

    def hello(self, agent: str = "") -> None:
        return None

    def _start(self, index: int) -> None:
        from schemas._protocol import HostMessage

        self.stage, self.stage_steps = index, 0
        name = self.stages[index]
        self.t0[name] = time.monotonic()
        self.pending.append(HostMessage(type="stage_started", data={"stage": name,
                                                                    "index": index}))
        self.pending.extend(self.ep.on_stage_start(name))

    def _cap(self) -> int | None:
        return self.ep.step_budget(self.stages[self.stage])

    def _end(self, ended_by: str) -> None:
        self.ep.on_stage_end(self.stages[self.stage], ended_by=ended_by, payload={})
        if self.stage + 1 < len(self.stages):
            self._start(self.stage + 1)
        else:
            self.over, self.end_reason = True, "completed"

    def _reply(self, out: Any) -> Any:
        from simhost.client import TimeStep

        self.seq += 1
        msgs = tuple(self.pending) + tuple(out.messages if out is not None else ())
        self.pending = []
        obs = self.ep.observe() if out is None else out.observation
        data = {**dict(obs.data), **{k: np.asarray(v) for k, v in obs.tensors.items()}}
        return TimeStep(observation=data, stage=self.stages[self.stage],
                        stage_index=self.stage, time_left_s=60.0, steps_left=None,
                        action=None if out is None else out.action, messages=msgs,
                        episode_over=self.over, end_reason=self.end_reason, seq=self.seq)

    def reset(self) -> Any:
        self.ep.reset()
        self._start(0)
        return self._reply(None)

    def end_stage(self, payload: Any = None) -> Any:
        self._end("agent")
        return self._reply(None)

    def step(self, action: dict[str, Any]) -> Any:
        if self.over:
            raise RuntimeError("episode over")
        act = dict(action)
        if "motion" in act:
            act["motion"] = np.asarray(act["motion"], dtype=np.float32)
        self.steps += 1
        self.stage_steps += 1
        out = self.ep.step(self.stages[self.stage], act)
        if out.action is not None and not out.action.ok:
            self.invalid += 1
        if out.episode_over:
            self.over, self.end_reason = True, out.end_reason
            self.ep.on_stage_end(self.stages[self.stage], ended_by="episode_over", payload={})
        else:
            cap = self._cap()
            if cap is not None and self.stage_steps >= cap:
                self._end("steps")
        return self._reply(out)


def run_inproc(folder: str, *, seed: int, split: str, index: int,
               params: dict[str, Any] | None = None) -> dict[str, Any]:
    """One episode of ``examples/<folder>`` in this process; the ``EpisodeResult`` as JSON."""
    import simhost.client as agent_mod
    from plugins import load_track, score_episode
    from schemas import EpisodeResult, EpisodeStats, EpisodeStatus, TaskModel

    started = time.time()
    plugin = load_track("track2")
    scenario = plugin.make_scenario(seed=seed, split=split,
                                    params={"demo_frames": False, **(params or {})},
                                    index=index)
    ep = plugin.make_episode(scenario)
    with tempfile.TemporaryDirectory(prefix="eagc-t2i-") as tmp:
        inp, out = Path(tmp) / "input", Path(tmp) / "output"
        inp.mkdir()
        out.mkdir()
        plugin.write_inputs(scenario, inp)
        os.environ["EAGC_INPUT"], os.environ["EAGC_OUTPUT"] = str(inp), str(out)
        LocalEnv.episode_ref = ep
        env_holder: dict[str, LocalEnv] = {}

        class _Env(LocalEnv):
            def __init__(self, *a: Any, **k: Any) -> None:
                super().__init__(*a, **k)
                env_holder["env"] = self

        saved = agent_mod.RemoteEnv
        agent_mod.RemoteEnv = _Env  # type: ignore[misc]
        here = ROOT / "examples" / folder
        path = list(sys.path)
        sys.path[:0] = [str(here), str(here.parent / "track2_demoparser")]
        error = None
        try:
            runpy.run_path(str(here / "agent.py"), run_name="__main__")
        except SystemExit:
            pass
        except Exception as exc:  # noqa: BLE001 - the agent's crash is its outcome
            error = f"{type(exc).__name__}: {exc}"
        finally:
            agent_mod.RemoteEnv = saved  # type: ignore[misc]
            sys.path[:] = path
            for name in ("controllers", "perception", "taskmodel", "demoparser", "skills",
                         "policy", "parse", "generic", "trajectory", "mpc", "worldmodel"):
                sys.modules.pop(name, None)
        env = env_holder.get("env")
        outcome = ep.outcome()
        ep.close()
        files: dict[str, Any] = {}
        tm = out / "task_model.json"
        if tm.is_file():
            try:
                files["task_model.json"] = TaskModel.model_validate(json.loads(tm.read_text()))
            except Exception:  # noqa: BLE001 - an invalid file scores as missing
                pass
    steps = env.steps if env else 0
    card = score_episode(
        plugin, scenario, status=EpisodeStatus.COMPLETED, end_reason="completed",
        stages_reached=tuple(env.stages[: env.stage + 1]) if env else (),
        outcome=outcome, files=files, snapshots={}, steps=steps,
        invalid_actions=env.invalid if env else 0, protocol_errors=0)
    result = EpisodeResult(
        episode=f"{folder}-{split}-{seed}", track="track2", split=split, image=folder,
        runtime="in-process", status=EpisodeStatus.COMPLETED, score=card,
        stats=EpisodeStats(steps=steps, wall_s=time.time() - started),
        started_at=started, finished_at=time.time())
    doc = result.model_dump(mode="json")
    doc["outcome"] = outcome.model_dump(mode="json")
    if error:
        doc["error"] = error
    return doc
