"""Policies written against the offline environments, and the agent that runs them unchanged
through ``simhost.client.GymEnv`` (``tests/simhost/test_gym_client.py``).

The policies take an observation dict and return an action exactly as
``gymnasium.make("eagc/House-v0")`` and ``gymnasium.make("eagc/Sanity-v0")`` do; they import
numpy only. Run as a script it is a team's agent::

    python _gym_agent.py track1|sanity TRACE.npz|- [plain]

``plain`` makes gymnasium unimportable first (the light install). The hooks write
``world_model.json`` and ``episode_log.jsonl`` at every stage end; the observations, actions
and stage ends the policy saw go to ``TRACE.npz`` for the test to compare with the offline run
(``-``: nowhere); a summary line goes to stdout.
"""

from __future__ import annotations

import json
import sys
from typing import Any

import numpy as np

# Track 1's vocabularies, by index (as the offline env's Discrete and Box entries hold them).
MOVE, PICK = 1, 4
"""Indices into ``PRIMITIVES`` (noop, move, open, close, pick, place, use, done)."""
OBJECT = 3
"""Index into ``KINDS`` (door, furniture, container, object, tool)."""


class HousePolicy:
    """Drives ahead while the way is clear, turns away from walls, picks up an object within
    reach when the hand is empty. Seeded: same observations, same actions."""

    def __init__(self, seed: int = 0) -> None:
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: dict[str, np.ndarray]) -> dict[str, Any]:
        none = np.zeros(2, np.float32)
        if int(obs["held"][0]) < 0:
            rows = obs["det_mask"].astype(bool) & (obs["det_kind"] == OBJECT)
            near = rows & (np.hypot(obs["det_rel_pos"][:, 0], obs["det_rel_pos"][:, 1]) < 0.9)
            if near.any():
                return {"primitive": PICK, "move": none, "target": int(obs["det_id"][near][0]),
                        "tool": 0}
        ahead = float(np.min(obs["range_scan"][[0, 1, -1]]))
        if ahead < 0.9 or int(obs["collided"][0]) == 1:
            move = [0.0, float(self.rng.choice([-1.0, 1.0]))]
        else:
            move = [min(1.0, (ahead - 0.6) / 0.5), float(self.rng.uniform(-0.25, 0.25))]
        return {"primitive": MOVE, "move": np.array(move, np.float32), "target": 0, "tool": 0}


WAYPOINTS = np.array([(-1.5, -1.5), (1.5, -1.5), (1.5, -0.5), (-1.5, -0.5), (-1.5, 0.5),
                      (1.5, 0.5), (1.5, 1.5), (-1.5, 1.5)])


class ArenaPolicy:
    """Sweeps the arena until the target is in sight, then drives onto it (the action is the
    bare velocity array ``eagc/Sanity-v0`` takes)."""

    def __init__(self) -> None:
        self.waypoint = 0

    def __call__(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        pos = obs["position"].astype(float)
        if obs["target_visible"][0] > 0.5:
            goal = pos + obs["target_rel"].astype(float)
        else:
            goal = WAYPOINTS[self.waypoint % len(WAYPOINTS)]
            if np.linalg.norm(goal - pos) < 0.15:
                self.waypoint += 1
        return np.clip((goal - pos) * 3.0, -1.0, 1.0).astype(np.float32)


EXPLORE_STEPS = 24
EXECUTE_STEPS = 12


def _track1(trace: dict[str, Any]) -> None:
    from simhost.client import GymEnv, StageEnd, StageRule

    log: list[dict[str, Any]] = []
    rooms: dict[int, str] = {}
    objects: dict[int, dict[str, Any]] = {}
    steps = [0]

    def remember(obs: dict[str, np.ndarray], info: dict[str, Any]) -> None:
        x, y, yaw = (float(v) for v in obs["odometry"])
        room = int(obs["room"][0])
        if room >= 0:
            rooms[room] = info["room_name"]
        c, s = np.cos(yaw), np.sin(yaw)
        for d in info["detections"]:
            if d["kind"] in ("object", "tool"):
                dx, dy = d["rel_pos"]
                objects[d["id"]] = {"id": d["id"], "category": d["category"],
                                    "position": [x + c * dx - s * dy, y + s * dx + c * dy]}

    def on_stage_end(end: StageEnd) -> dict[str, Any]:
        trace["ends"].append({"stage": end.stage, "ended_by": end.ended_by,
                              "reason": end.reason, "steps": end.steps, "last": end.last,
                              "messages": [m.type for m in end.messages]})
        log.append({"step": steps[0], "stage": end.stage, "event": "stage",
                    "data": {"ended_by": end.ended_by, "reason": end.reason}})
        model = {"version": "eagc-world-model/v1", "step": steps[0],
                 "rooms": [{"id": r, "type": t} for r, t in rooms.items()],
                 "objects": list(objects.values())}
        return {"world_model.json": model, "episode_log.jsonl": log}

    def plan(end: StageEnd) -> dict[str, Any]:
        return {"plan": {"subgoals": [], "route": [], "doors": []}} if end.stage == "planning" \
            else {}

    env = GymEnv(agent="gym-client-test/1", on_stage_end=on_stage_end, end_stage_payload=plan,
                 stages={"exploration": StageRule(max_steps=EXPLORE_STEPS),
                         "execution": StageRule(max_steps=EXECUTE_STEPS)})
    trace["space"] = {"observation": repr(env.observation_space),
                      "action": repr(env.action_space)}
    policy = HousePolicy(seed=0)
    obs, info = env.reset()
    terminated = truncated = False
    while not (terminated or truncated):
        trace["obs"].append(obs)
        trace["stages"].append(info["stage"])
        remember(obs, info)
        action = policy(obs)
        trace["actions"].append(action)
        obs, reward, terminated, truncated, info = env.step(action)
        steps[0] += 1
        trace["rewards"].append(reward)
    trace["end"] = str(info["end_reason"])
    env.close()


def _sanity(trace: dict[str, Any]) -> None:
    from simhost.client import GymEnv, StageEnd, StageRule

    log: list[dict[str, Any]] = []
    target: list[list[float]] = []

    def on_stage_end(end: StageEnd) -> dict[str, Any]:
        trace["ends"].append({"stage": end.stage, "ended_by": end.ended_by,
                              "reason": end.reason, "steps": end.steps, "last": end.last,
                              "messages": [m.type for m in end.messages]})
        log.append({"step": len(trace["actions"]), "stage": end.stage, "event": "stage"})
        objects = [{"id": "target", "category": "target", "position": target[-1]}] \
            if target else []
        return {"world_model.json": {"version": "eagc-world-model/v1",
                                     "rooms": [{"id": "arena"}], "objects": objects},
                "episode_log.jsonl": log}

    def seen(obs: Any, info: Any) -> bool:
        if obs["target_visible"][0] > 0.5:
            target.append((obs["position"] + obs["target_rel"]).astype(float).tolist())
            return True
        return False

    env = GymEnv(agent="gym-client-test/1", on_stage_end=on_stage_end,
                 stages={"explore": StageRule(until=seen)})
    trace["space"] = {"observation": repr(env.observation_space),
                      "action": repr(env.action_space)}
    policy = ArenaPolicy()
    obs, info = env.reset()
    terminated = False
    while not terminated:
        trace["obs"].append(obs)
        trace["stages"].append(info["stage"])
        action = policy(obs)
        trace["actions"].append(action)
        obs, _, terminated, _, info = env.step(action)
    trace["end"] = str(info["end_reason"])
    env.close()


def main(argv: list[str]) -> int:
    track, out = argv[0], argv[1]
    if "plain" in argv[2:]:
        sys.modules["gymnasium"] = None  # type: ignore[assignment]  # as in the agent base
    trace: dict[str, Any] = {"obs": [], "actions": [], "stages": [], "rewards": [], "ends": []}
    (_track1 if track == "track1" else _sanity)(trace)
    import simhost.client._gym_client as client

    arrays = {f"obs/{i}/{k}": v for i, o in enumerate(trace.pop("obs")) for k, v in o.items()}
    arrays.update({f"action/{i}/{k}": np.asarray(v) for i, a in enumerate(trace["actions"])
                   for k, v in (a.items() if isinstance(a, dict) else [("", a)])})
    trace["actions"] = len(trace["actions"])
    trace["gymnasium"] = client.gymnasium is not None
    trace["modules"] = sorted(m for m, v in sys.modules.items() if v is not None and
                              m.split(".")[0] in ("gymnasium", "mujoco", "plugins",
                                                  "orchestrator"))
    if out != "-":
        np.savez(out, trace=np.array(json.dumps(trace)), **arrays)
    print("gym agent:", json.dumps({
        "gymnasium": trace["gymnasium"], "modules": trace["modules"], "end": trace["end"],
        "ends": [[e["stage"], e["ended_by"], e["reason"]] for e in trace["ends"]]}))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
