"""Waypoint-replay baseline for Track 2 (AWDA-style): the demonstration's hand path, replayed
in the frame of the object it was relative to.

Uses only ``simhost.agent`` (``RemoteEnv``, ``OutputFiles``), ``schemas`` (the packet's
``DemoManifest``), numpy and the standard library.

Parsing cuts the demonstration at its grasp and release annotations. Before a grasp the hand
moves relative to the part it grasps (the part nearest the hand at the grasp); while holding,
relative to where the part goes (of the parts that stay put, the one nearest the hand at the
release); after the last release, relative to that same place. Each segment's waypoints are
the demonstration's control targets (rebuilt from its actions) expressed in that part's pose
at the segment's start; during execution they are mapped through the same part's pose
observed when the segment starts (the mean of its fresh measurements so far: poses are
noisy), and followed with the demonstration's grip commands. Nothing else adapts: no goal
is read, no symmetry is known. A failed attempt is replayed again at the demonstration's pace
from the reference poses measured anew (the instance moved a little between attempts; a
slower replay would not fit the attempt's step budget, twice the feasibility expert's
steps). The task model says only what the packet's manifest says: the family
and its stages.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from schemas import DemoManifest, TaskModel
from simhost.agent import OutputFiles, RemoteEnv

INPUT = Path(os.environ.get("EAGC_INPUT", "/input"))
DPOS, DYAW, WMAX = 0.015, 0.15, 0.09
SCALE = np.array([DPOS, DPOS, DPOS, DYAW])
LEAD = np.array([0.02, 0.02, 0.02, 0.3])
LO = np.array([-0.30, -0.30, 0.003, -3.2])
HI = np.array([0.30, 0.30, 0.30, 3.2])


def wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def yaw_of(q: np.ndarray) -> float:
    w, x, y, z = (float(v) for v in q)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def pose(row: np.ndarray) -> np.ndarray:
    """x, y, z, yaw of a parts row."""
    return np.array([*row[1:4], yaw_of(row[4:8])], dtype=float)


def read_packet(folder: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    manifest = DemoManifest.model_validate_json((folder / "manifest.json").read_text())
    manifest = manifest.model_dump()
    with np.load(folder / "trajectory.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return manifest, arrays


def control_targets(arrays: dict[str, np.ndarray]) -> np.ndarray:
    """The demonstration's hand targets after each action (the bench's update rule)."""
    hand = arrays["obs_proprio"][:, :4].astype(float)
    t = hand[0].copy()
    out = []
    for k, a in enumerate(arrays["actions"].astype(float)):
        t = np.clip(np.clip(t + a[:4] * SCALE, hand[k] - LEAD, hand[k] + LEAD), LO, HI)
        out.append(t.copy())
    return np.asarray(out)


def segments(manifest: dict[str, Any], arrays: dict[str, np.ndarray]) -> list[tuple[int, int, int]]:
    """(first action, end action, reference row) for each stretch of the demonstration."""
    parts = arrays["obs_parts"]
    tcp = arrays["obs_proprio"][:, :3]
    n = len(arrays["actions"])
    rows = [i for i in range(parts.shape[1]) if parts[0, i, 0] > 0.5]
    marks = sorted((e["step"], e["event"]) for e in manifest["events"]
                   if e["event"] in ("grasped", "released"))

    def nearest(k: int, among: list[int], xy_only: bool = False) -> int:
        d = [np.linalg.norm((parts[k, i, 1:4] - tcp[k])[: 2 if xy_only else 3]) for i in among]
        return among[int(np.argmin(d))]

    out: list[tuple[int, int, int]] = []
    start, ref = 0, None
    for step, event in marks:
        k = min(step, n)
        if event == "grasped" and k > start:
            out.append((start, k, nearest(k, rows)))
            start = k
        elif event == "released" and k > start:
            moved = np.linalg.norm(parts[k, :, 1:4] - parts[start, :, 1:4], axis=1)
            still = [i for i in rows if moved[i] < 0.01] or rows
            ref = nearest(k, still, xy_only=True)
            out.append((start, k, ref))
            start = k
    if start < n:
        out.append((start, n, ref if ref is not None else nearest(n, rows)))
    return out


class Replay:
    """Follows the transformed waypoints, mirroring the hand's control target."""

    def __init__(self, manifest: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        self.parts0 = arrays["obs_parts"]
        self.targets = control_targets(arrays)
        self.grips = arrays["actions"][:, 4].astype(float)
        self.segments = segments(manifest, arrays)

    def plan(self, obs: dict[str, Any], stretch: int) -> Any:
        target = np.asarray(obs["proprio"][:4], dtype=float)
        seen: dict[int, list[np.ndarray]] = {}
        for first, end, ref in self.segments:
            src = pose(self.parts0[first, ref])
            rows = np.asarray(obs["parts"], dtype=float)
            seen.setdefault(ref, []).append(pose(rows[ref]))
            live = np.mean(seen[ref][-10:], axis=0)
            dyaw = wrap(live[3] - src[3])
            c, s = math.cos(dyaw), math.sin(dyaw)
            for k in range(first, end):
                p = self.targets[k]
                d = p[:2] - src[:2]
                wp = np.array([live[0] + c * d[0] - s * d[1], live[1] + s * d[0] + c * d[1],
                               p[2] + live[2] - src[2], p[3] + dyaw])
                for _ in range(stretch):
                    for _ in range(20):  # catch up after a jump between frames
                        hand = np.asarray(obs["proprio"][:4], dtype=float)
                        step = np.clip(wp - target, -SCALE, SCALE)
                        step[3] = float(np.clip(wrap(wp[3] - target[3]), -DYAW, DYAW))
                        a = np.append(step / SCALE, self.grips[k])
                        target = np.clip(np.clip(target + step, hand - LEAD, hand + LEAD), LO, HI)
                        obs = yield a
                        row = np.asarray(obs["parts"], dtype=float)[ref]
                        if row[9] <= 0.2:  # a fresh measurement of the reference part
                            seen[ref].append(pose(row))
                        if np.all(np.abs(wp - target) < 1e-4):
                            break
        for _ in range(10):  # as the demonstration ends: let go and back off upwards
            obs = yield np.array([0.0, 0.0, 0.5, 0.0, self.grips[-1]])


def main() -> int:
    files = OutputFiles()
    steps = 0

    def record(event: str, stage: str, **data: Any) -> None:
        files.log(step=steps, stage=stage, event=event, data=data)

    with RemoteEnv() as env:
        env.hello(agent="eagc-track2-waypoint/2")
        ts = env.reset()
        replay: Replay | None = None
        attempt, plan = 0, None
        while not ts.episode_over:
            if ts.stage in ("demonstration", "parsing"):
                if replay is None:
                    msg = ts.message("demonstration")
                    folder = INPUT / (msg.data.get("folder", "demo") if msg else "demo")
                    manifest, arrays = read_packet(folder)
                    replay = Replay(manifest, arrays)
                    record("plan", ts.stage, segments=replay.segments)
                    files.write(TaskModel(step=steps, family=manifest["family"],
                                          stages=manifest["stage_names"]))
                ts = env.end_stage()
                continue
            assert replay is not None
            if ts.observation.get("attempt", 0) != attempt:
                attempt = int(ts.observation["attempt"])
                plan = replay.plan(ts.observation, stretch=1)
                action = next(plan)
                record("attempt", ts.stage, attempt=attempt)
            else:
                try:
                    action = plan.send(ts.observation)
                except StopIteration:
                    action = None
            steps += 1
            if action is None:  # the replay is through and the task is not done
                ts = env.step({"end_attempt": 1})
            else:
                ts = env.step({"motion": np.asarray(action, dtype=np.float32)})
            for m in ts.messages:
                if m.type == "attempt_result":
                    record("attempt", ts.stage, **m.data)
        record("note", ts.stage, end=ts.end_reason)
    files.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
