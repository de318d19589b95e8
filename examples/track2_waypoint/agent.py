"""Waypoint baseline for Track 2 (AWDA-style): the demonstration's hand path, adapted to the
new instance in the frame of the part it was relative to, followed closed loop, adapted again
between attempts to what the held part did.

Uses only ``simhost.client`` (``RemoteEnv``, ``OutputFiles``), ``schemas`` (the packet's
``DemoManifest``), numpy and the standard library.

Parsing cuts the demonstration at its grasp and release annotations. Before a grasp the hand
moves relative to the part it grasps (the part nearest the hand at the grasp); while holding,
relative to where the part goes (of the parts that stay put, the one nearest the hand at the
release); a part turned in place (a knob: its yaw changed, its position did not) is followed
in its own frame at the grasp, so the turn is the demonstration's from where it was grasped;
a part held to the end (a tool) relative to what it acts on (the part it pushed, or the part
nearest the held ones). Each segment's waypoints are the demonstration's control targets
expressed in that part's pose and mapped through the part's pose observed when the segment
starts: the mean of its fresh measurements since it last moved in the hand (yaws averaged
about the latest, as a symmetric part's reported yaw may fold). After a release the new
segment starts from where the hand is and blends into its frame over its first half (no
sideways jump through a placed part); a waypoint beyond the workspace is not waited out. The
demonstration opens the fingers just enough for its own parts: they open 11 mm wider. A
grasp is turned by half a turn when the demonstration's yaws would leave the hand's range.

Between attempts (the "A"): each hold is compared with the demonstration's, from the held
part's pose measured after the release, in the reference's frame. A part that was held but
did not turn is turned the other way next time; a turn or a slide that fell short (or went
too far) has its waypoints moved by what was missing; a grasp that closed wider than the
demonstration's opens the fingers wider still. A carried part's resting pose after a miss
(on a rim, tilted) is not evidence of where the hand should have been: carries are replayed
from the poses measured anew. The task model says only what the packet's manifest says: the
family and its stages.
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from schemas import DemoManifest, TaskModel
from simhost.client import OutputFiles, RemoteEnv

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
    start, ref, held = 0, None, None
    for step, event in marks:
        k = min(step, n)
        if event == "grasped" and k > start:
            held = nearest(k, rows)
            out.append((start, k, held))
            start = k
        elif event == "released" and k > start:
            moved = np.linalg.norm(parts[k, :, 1:4] - parts[start, :, 1:4], axis=1)
            still = [i for i in rows if moved[i] < 0.01] or rows
            ref = nearest(k, still, xy_only=True)
            out.append((start, k, ref))
            start = k
    if start < n and ref is None and held is not None:  # held to the end (a tool): the
        # path is relative to what it acts on, the part it moved (a puck) or, when nothing
        # moved far, the part nearest to the held ones (a button)
        moved = np.linalg.norm(parts[n, :, 1:4] - parts[start, :, 1:4], axis=1)
        group = [i for i in rows if moved[i] > 0.5 * moved[held]] + [held]
        others = [i for i in rows if i not in group] or rows
        pushed = max(others, key=lambda i: moved[i])
        if moved[pushed] > 0.005:
            ref = pushed
        else:
            ref = min(others, key=lambda i: min(np.linalg.norm(parts[n, i, 1:4] - parts[n, g, 1:4])
                                               for g in group))
    if start < n:
        out.append((start, n, ref if ref is not None else nearest(n, rows)))
    return out


def rel(p: np.ndarray, frame: np.ndarray) -> np.ndarray:
    """Pose ``p`` (x, y, z, yaw) in the frame of pose ``frame``."""
    c, s = math.cos(frame[3]), math.sin(frame[3])
    d = p[:2] - frame[:2]
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], p[2] - frame[2],
                     wrap(p[3] - frame[3])])


def estimate(seen: list[np.ndarray]) -> np.ndarray:
    """A part's pose from its last fresh measurements: positions averaged, yaws averaged
    about the latest one (a symmetric part's reported yaw may fold: those that differ by
    more than 0.2 rad from the latest are left out, not averaged into a yaw in between)."""
    recent = np.asarray(seen[-10:])
    out = recent.mean(axis=0)
    d = np.array([wrap(y - recent[-1, 3]) for y in recent[:, 3]])
    out[3] = wrap(recent[-1, 3] + float(d[np.abs(d) < 0.2].mean()))
    return out


def fresh_pose(parts: np.ndarray, row: int, lo: int, hi: int) -> np.ndarray | None:
    """The last fresh measurement of ``row`` among observations ``lo`` .. ``hi - 1``."""
    for k in range(min(hi, len(parts)) - 1, lo - 1, -1):
        if parts[k, row, 0] > 0.5 and parts[k, row, 9] <= 0.2:
            return pose(parts[k, row])
    return None


class Hold:
    """A stretch of the demonstration with a part in the hand: what it did to the part."""

    def __init__(self, seg: int, held: int, start: np.ndarray, final: np.ndarray) -> None:
        self.seg, self.held = seg, held
        self.start, self.final = start, final  # the part in the reference's frame
        self.motion = final - start
        self.motion[3] = wrap(self.motion[3])
        self.turn = abs(self.motion[3]) > 0.3 and np.linalg.norm(self.motion[:3]) < 0.02
        self.correction = np.zeros(4)  # added to the waypoints, the reference's frame
        self.flipped = False  # the turn mirrored: the part would not follow the demo's
        self.tried: list[str] = []
        self.width = 0.0  # the fingers' opening while the demonstration held the part (m)
        self.carried = False


class Replay:
    """Follows the transformed waypoints, mirroring the hand's control target; between
    attempts it adapts the waypoints of each hold to what the held part did."""

    def __init__(self, manifest: dict[str, Any], arrays: dict[str, np.ndarray]) -> None:
        self.parts0 = arrays["obs_parts"]
        self.targets = control_targets(arrays)
        self.grips = arrays["actions"][:, 4].astype(float)
        self.segments = segments(manifest, arrays)
        grasps = {min(e["step"], len(self.targets)) for e in manifest["events"]
                  if e["event"] == "grasped"}
        self.holds: dict[int, Hold] = {}
        self.approaches = {j for j, seg in enumerate(self.segments) if seg[1] in grasps}
        for j in range(1, len(self.segments)):
            first, end, ref = self.segments[j]
            prev = self.segments[j - 1]
            if prev[1] not in grasps or end >= len(self.targets):
                continue  # not a hold, or never released (its effect is on another part)
            held = prev[2]
            nxt = self.segments[j + 2][0] if j + 2 < len(self.segments) else len(self.parts0)
            frame = pose(self.parts0[first, ref])
            after = fresh_pose(self.parts0, held, end, nxt)
            if after is None:
                continue
            hold = Hold(j, held, rel(pose(self.parts0[first, held]), frame), rel(after, frame))
            if hold.turn and ref != held:  # a part turned in place: its own frame, not the
                # base's, so that the turn is the demonstration's from where it was grasped
                frame = pose(self.parts0[first, held])
                hold = Hold(j, held, rel(pose(self.parts0[first, held]), frame),
                            rel(after, frame))
                for i in range(j, len(self.segments)):
                    if i == j or (i == j + 1 and i not in self.approaches):
                        a, b, r = self.segments[i]
                        self.segments[i] = (a, b, held if r == ref else r)
            hold.width = float(np.median(arrays["obs_proprio"][first:end, 4]))
            rise = self.parts0[first:end, held, 3] - self.parts0[first, held, 3]
            hold.carried = bool(rise.max() > 0.02)  # lifted: a free part, not a mechanism
            self.holds[j] = hold
        self.seen_holds: dict[int, dict[str, Any]] = {}
        self.notes: list[str] = []
        self.widen = 0.25  # grip command units: 0.25 is 11 mm of finger opening

    # ------------------------------------------------------------ adaptation
    def adapt(self) -> list[str]:
        """Moves each hold's waypoints by what its part missed on the last attempt."""
        notes = []
        wider = [got["width"] - self.holds[j].width for j, got in self.seen_holds.items()
                 if got.get("width", 0.0) > 0.005]
        if wider and max(wider) > 0.003:  # the parts are wider than the demonstration's
            self.widen = 0.25 + min(0.5, max(wider) / (WMAX / 2))
            notes.append(f"open wider by {max(wider) * 1000:.0f} mm")
        for j, h in self.holds.items():
            got = self.seen_holds.get(j)
            if not got or got.get("final") is None:
                continue
            start, final, contact = got["start"], got["final"], got["contact"]
            moved = final - start
            moved[3] = wrap(moved[3])
            want = h.start + (-1 if h.flipped else 1) * h.motion
            if h.turn:
                sign = -1.0 if h.flipped else 1.0
                along = moved[3] * sign * math.copysign(1.0, h.motion[3])
                if along < 0.3 * abs(h.motion[3]) and contact > 0.5 and not h.tried:
                    h.flipped = not h.flipped  # held, yet it did not turn: the other way
                    h.correction[:] = 0.0
                    h.tried.append("flip")
                    notes.append(f"hold {j}: turned {moved[3]:+.2f}, flipped")
                    continue
                err = wrap(want[3] - final[3])
                h.correction[3] = float(np.clip(h.correction[3] + err, -1.0, 1.0))
                notes.append(f"hold {j}: turn short by {err:+.2f}")
                continue
            if h.carried:  # where a free part came to rest after a miss (on a rim, tilted)
                continue  # says little about where the hand should have been
            if np.linalg.norm(moved[:3]) < 0.3 * np.linalg.norm(h.motion[:3]):
                notes.append(f"hold {j}: the part did not follow")
                continue  # a missed grasp: its pose says nothing about the waypoints
            err = want - final
            err[3] = wrap(err[3])
            if np.abs(err[:3]).max() > 0.03:  # not a near miss (still held, dropped, pushed)
                notes.append(f"hold {j}: ended far off, not corrected")
                continue
            if abs(err[3]) > 0.2:  # a symmetric part's yaw may fold: not evidence
                err[3] = 0.0
            h.correction[:3] = np.clip(h.correction[:3] + err[:3], -0.03, 0.03)
            h.correction[3] = float(np.clip(h.correction[3] + err[3], -0.3, 0.3))
            notes.append(f"hold {j}: off by {np.round(err, 3).tolist()}")
        return notes

    def adjusted(self) -> np.ndarray:
        """The demonstration's targets with the holds' corrections (demonstration frame)."""
        out = self.targets.copy()
        for j, h in self.holds.items():
            first, end, ref = self.segments[j]
            src = pose(self.parts0[first, ref])
            c, s = math.cos(src[3]), math.sin(src[3])
            cw = h.correction
            delta = np.array([c * cw[0] - s * cw[1], s * cw[0] + c * cw[1], cw[2], cw[3]])
            p0 = self.targets[first].copy()
            span = max(1, end - first)
            for k in range(first, end):
                if h.flipped:
                    out[k, 3] = 2 * p0[3] - self.targets[k, 3]
                out[k] += min(1.0, 2.0 * (k - first + 1) / span) * delta
            tail = out[end - 1] - self.targets[end - 1]
            if j + 1 < len(self.segments):
                a, b, _ = self.segments[j + 1]
                last = j + 1 == len(self.segments) - 1
                for k in range(a, b):
                    out[k] += tail * (1.0 if last else 1.0 - (k - a) / max(1, b - a))
        return out

    # ------------------------------------------------------------ one attempt
    def plan(self, obs: dict[str, Any], stretch: int) -> Any:
        if self.seen_holds:
            self.notes = self.adapt()
        self.seen_holds = {}
        targets = self.adjusted()
        # The demonstration opens the fingers just enough for the source's parts: open a
        # little wider (and by what the last attempt's grasps showed the parts to be wider).
        grips = np.where(self.grips > -0.9, np.minimum(1.0, self.grips + self.widen), self.grips)
        target = np.asarray(obs["proprio"][:4], dtype=float)
        first_rows = np.asarray(obs["parts"], dtype=float)
        # fresh measurements per part, since it last moved in the hand
        seen: dict[int, list[np.ndarray]] = {i: [pose(r)] for i, r in enumerate(first_rows)}
        last: dict[int, tuple[int, np.ndarray]] = {}  # row: (step, fresh pose)
        steps = 0
        watch: list[tuple[int, int, np.ndarray, int]] = []  # hold, row, frame, from step
        turn = 0.0
        released = {j for j in range(len(self.segments)) if j in self.holds
                    or (j - 1 in self.approaches and j + 1 < len(self.segments))}

        def look(o: dict[str, Any]) -> None:
            rows = np.asarray(o["parts"], dtype=float)
            for i in range(len(rows)):
                if rows[i, 0] > 0.5 and rows[i, 9] <= 0.2:
                    last[i] = (steps, pose(rows[i]))
                    seen[i].append(last[i][1])
            for j, row, frame, since in watch:
                if row in last and last[row][0] > since:
                    self.seen_holds[j]["final"] = rel(last[row][1], frame)

        for j, (first, end, ref) in enumerate(self.segments):
            watch = [w for w in watch if w[0] + 2 > j]  # as the demonstration's window
            src = pose(self.parts0[first, ref])
            rows = np.asarray(obs["parts"], dtype=float)
            live = estimate(seen[ref]) if seen[ref] else pose(rows[ref])
            if j in self.approaches:  # the grasp and what follows, within the hand's yaw range
                dyaw = wrap(live[3] - src[3])
                b = self.segments[j + 1][1] if j + 1 < len(self.segments) else end
                yaws = targets[first:b, 3] + dyaw
                turn = 0.0  # a two-finger grasp is the same turned by half a turn
                if yaws.max() > HI[3] - 0.05 and yaws.min() - math.pi > LO[3] + 0.05:
                    turn = -math.pi
                elif yaws.min() < LO[3] + 0.05 and yaws.max() + math.pi < HI[3] - 0.05:
                    turn = math.pi
            hold = self.holds.get(j)
            if hold is not None:
                start = (estimate(seen[hold.held]) if seen[hold.held]
                         else pose(rows[hold.held]))
                seen[hold.held] = []  # it moves with the hand from here
                self.seen_holds[j] = {"start": rel(start, live), "final": None,
                                      "contact": 0.0}
                contacts, widths = 0, []
            jump = np.zeros(4)  # after a release: from where the hand is, not a jump
            fade = max(1.0, 0.5 * (end - first))  # sideways through what it just placed
            for k in range(first, end):
                dyaw = wrap(live[3] - src[3])
                c, s = math.cos(dyaw), math.sin(dyaw)
                p = targets[k]
                d = p[:2] - src[:2]
                wp = np.array([live[0] + c * d[0] - s * d[1], live[1] + s * d[0] + c * d[1],
                               p[2] + live[2] - src[2], p[3] + dyaw + turn])
                if k == first and j - 1 in released:
                    jump = target - wp
                    jump[3] = wrap(jump[3])
                wp = wp + jump * max(0.0, 1.0 - (k - first) / fade)
                for _ in range(stretch):
                    for _ in range(20):  # catch up after a jump between frames
                        hand = np.asarray(obs["proprio"][:4], dtype=float)
                        step = np.clip(wp - target, -SCALE, SCALE)
                        step[3] = float(np.clip(wrap(wp[3] - target[3]), -DYAW, DYAW))
                        a = np.append(step / SCALE, grips[k])
                        was = target
                        target = np.clip(np.clip(target + step, hand - LEAD, hand + LEAD), LO, HI)
                        obs = yield a
                        steps += 1
                        look(obs)
                        if hold is not None:
                            pr = np.asarray(obs["proprio"], dtype=float)
                            contacts += int(pr[5] > 0.5 and pr[6] > 0.5)
                            widths.append(float(pr[4]))
                        if np.all(np.abs(wp - target) < 1e-4):
                            break
                        if np.all(np.abs(target - was) < 1e-4) and (
                                np.any(target <= LO + 1e-6) or np.any(target >= HI - 1e-6)):
                            break  # at the workspace's edge: no waiting it out
            if hold is not None:
                self.seen_holds[j]["contact"] = contacts / max(1, end - first)
                self.seen_holds[j]["width"] = float(np.median(widths)) if widths else 0.0
                watch.append((j, hold.held, live, steps))
                seen[hold.held] = []  # measured anew where it was put
        for _ in range(10):  # as the demonstration ends: let go and back off upwards
            obs = yield np.array([0.0, 0.0, 0.5, 0.0, grips[-1]])
            steps += 1
            look(obs)


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
                record("attempt", ts.stage, attempt=attempt, adapted=replay.notes)
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
