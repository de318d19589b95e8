"""Parsing one demonstration into phases: what was grasped, how it moved, relative to what.

Nothing here knows a task family: the packet's annotations (``grasped``, ``released``,
``lifted``) cut the demonstration into grasp phases, and the observations (the ``parts``
rows, the exact proprioception) say, per phase,

- which row the hand held: the annotation's part if a row has that name, else the row that
  moved and lay nearest the hand when it closed; rows that moved rigidly with it are
  *linked* to it (a tool's tip);
- how the hand held it: the hand's pose in the part's frame when the fingers closed, and
  how far the fingers were open before;
- what kind of phase it was: ``carry`` (the part was lifted and let go elsewhere: place it
  relative to the row it ended up nearest), ``drive`` (it was not lifted: a mechanism
  moved along with the hand; the phase's hand path and the part's displacement, both in the
  part's frame before the grasp), ``tool`` (lifted and held to the end: its working point
  was moved along a path relative to the row it acted on, and another part may have moved
  as a result).

Poses are ``[x, y, z, yaw]``; a row's pose at rest is the mean of its fresh measurements
(noisy, biased, late: averaging removes the noise, not the bias, which is the same for the
agent's own observations and cancels in relative poses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from perception import rot2, wrap, yaw_of

from schemas import DemoManifest

MOVED_M = 0.006  # a row that moved more than this (or 0.08 rad) during a phase moved
LIFTED_M = 0.012  # a held part raised this far above where it rested was lifted
YAW_M = 0.1  # m per rad when a displacement mixes a slide and a turn


def relative(pose: Any, frame: Any) -> np.ndarray:
    """``pose`` (x, y, z, yaw) expressed in ``frame``."""
    d = rot2(-frame[3], np.asarray(pose[:2]) - np.asarray(frame[:2]))
    return np.array([d[0], d[1], pose[2] - frame[2], wrap(pose[3] - frame[3])])


def compose(frame: Any, rel: Any) -> np.ndarray:
    """The world pose of ``rel`` given in ``frame``."""
    xy = np.asarray(frame[:2]) + rot2(frame[3], rel[:2])
    return np.array([xy[0], xy[1], frame[2] + rel[2], frame[3] + rel[3]])


@dataclass
class Phase:
    """One grasp of the demonstration, and what it did."""

    kind: str  # carry | drive | tool
    held: int
    grasp: np.ndarray  # the hand in the held part's frame when the fingers closed
    open_width: float
    held_width: float  # how far apart the fingers were while they held it
    start: int  # observation index of the grasp
    end: int  # of the release (the last observation if held to the end)
    ref: int | None = None  # carry: the row it was placed against; drive: the nearest
    # row that stayed put; tool: the row the tip ended nearest
    goal: np.ndarray | None = None  # carry, drive: the held part in ref's frame at rest after
    carry_z: float = 0.1
    path: list[np.ndarray] = field(default_factory=list)  # drive: hand in the part's frame
    # tool: the tip in ref's (translated) frame, with the hand's yaw
    displacement: np.ndarray | None = None  # drive: the part's motion in its own frame
    tip: int | None = None
    moved: int | None = None  # tool: a part the tool moved
    moved_ref: int | None = None  # the row that part ended against
    moved_goal: np.ndarray | None = None  # its offset from moved_ref at the end
    moved_dir: np.ndarray | None = None  # the direction it was moved in (xy, unit)
    start_rel: np.ndarray | None = None  # drive: the held part in ref's frame before
    anchor: int | None = None  # tool: the row its path is relative to (translated frame)
    stage: str = ""  # the key stage its action happened in


@dataclass
class DemoParse:
    """The demonstration as phases, plus what the perception needs to know of the rows."""

    family: str
    rows: list[str]
    phases: list[Phase]
    movable: set[int]
    links: dict[int, int]
    reach: dict[int, float]
    steps: int


class _Rows:
    """The demonstration's part rows: fresh measurements and poses at rest."""

    def __init__(self, parts: np.ndarray) -> None:
        self.parts = parts
        t, n = parts.shape[:2]
        age = parts[:, :, 9]
        fresh = np.zeros((t, n), dtype=bool)
        fresh[0] = True
        fresh[1:] = (age[1:] < age[:-1] - 1e-6) | (age[1:] <= 1e-6)
        self.fresh = fresh & (parts[:, :, 0] > 0.5)

    def present(self, i: int) -> bool:
        return bool(self.parts[0, i, 0] > 0.5)

    def pose(self, i: int, k: int) -> np.ndarray:
        r = self.parts[k, i]
        return np.array([r[1], r[2], r[3], yaw_of(r[4:8])])

    def mean(self, i: int, k0: int, k1: int) -> np.ndarray:
        """The mean pose of row ``i`` over its fresh measurements in ``[k0, k1)``."""
        k0, k1 = max(0, k0), min(len(self.parts), max(k1, k0 + 1))
        ks = [k for k in range(k0, k1) if self.fresh[k, i]] or [min(k1, len(self.parts)) - 1]
        poses = np.array([self.pose(i, k) for k in ks])
        yaw = math.atan2(float(np.mean(np.sin(poses[:, 3]))), float(np.mean(np.cos(poses[:, 3]))))
        return np.array([*poses[:, :3].mean(axis=0), yaw])


def _moved(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.linalg.norm(a[:3] - b[:3]) > MOVED_M or abs(wrap(b[3] - a[3])) > 0.08)


def _grasps(man: DemoManifest, t: int) -> list[tuple[str, int, int | None]]:
    """``(part, grasped at, released at | None)``; flickers shorter than 5 steps merged."""
    out: list[list[Any]] = []
    for e in sorted(man.events, key=lambda e: e.step):
        if e.event == "grasped":
            if out and out[-1][0] == e.part and out[-1][2] is not None \
                    and e.step - out[-1][2] < 5:
                out[-1][2] = None  # a release and a new grasp in a moment: one grasp
            elif not out or out[-1][2] is not None:
                out.append([e.part, e.step, None])
        elif e.event == "released" and out and out[-1][0] == e.part and out[-1][2] is None:
            out[-1][2] = e.step
    return [(p, g, r) for p, g, r in out if (r if r is not None else t) - g >= 5]


def parse(man: DemoManifest, arrays: dict[str, np.ndarray]) -> DemoParse:
    """Phases of the demonstration (see the module docstring)."""
    parts = np.asarray(arrays["obs_parts"], dtype=float)
    hand = np.asarray(arrays["obs_proprio"], dtype=float)
    t = len(hand) - 1
    rows = list(man.observation_spec["parts"].rows)
    seen = _Rows(parts)
    present = [i for i in range(len(rows)) if seen.present(i)]
    lifted_events = [(e.step, e.part) for e in man.events if e.event == "lifted"]
    phases: list[Phase] = []
    links: dict[int, int] = {}
    reach: dict[int, float] = {}
    for part, g, r in _grasps(man, t):
        end = r if r is not None else t
        before = {i: seen.mean(i, g - 12, g - 1) for i in present}
        after = {i: seen.mean(i, end + 3, end + 16) if r is not None else seen.mean(i, t - 8, t + 1)
                 for i in present}
        moving = [i for i in present if _moved(before[i], after[i])]
        held = rows.index(part) if part in rows else None
        if held is None or held not in present:
            pool = moving or present
            held = min(pool, key=lambda i: float(np.linalg.norm(before[i][:3] - hand[g, :3])))
        linked = [i for i in moving if i != held and abs(
            np.linalg.norm(after[i][:3] - after[held][:3])
            - np.linalg.norm(before[i][:3] - before[held][:3])) < 0.005]
        for i in linked:
            links[i] = held
        dist = float(np.linalg.norm(before[held][:3] - hand[g, :3]))
        if dist > 0.05:
            reach[held] = dist + 0.05
        zs = [seen.pose(held, k)[2] for k in range(g, end + 1) if seen.fresh[k, held]]
        lifted = any(g <= k <= end and p == part for k, p in lifted_events) or (
            bool(zs) and max(zs) - before[held][2] > LIFTED_M)
        grasp = relative(hand[g, :4], before[held])
        open_w = float(np.max(hand[max(0, g - 15):g + 1, 4]))
        held_w = float(np.median(hand[g + 2:min(end, g + 12) + 1, 4])) if end > g + 2 else 0.0
        stage = _stage_at(man, (g + end) // 2)
        if lifted and r is not None:
            static = [i for i in present if i != held and i not in linked
                      and not _moved(before[i], after[i])] or [
                i for i in present if i != held and i not in linked]
            ref = min(static, key=lambda i: float(np.linalg.norm(after[i][:3]
                                                                 - after[held][:3])))
            phases.append(Phase(
                kind="carry", held=held, grasp=grasp, open_width=open_w, held_width=held_w,
                start=g, end=end,
                ref=ref, goal=relative(after[held], after[ref]),
                carry_z=float(np.max(hand[g:end + 1, 2])), stage=stage))
        elif lifted:
            phases.append(_tool_phase(seen, hand, present, held, linked, grasp, open_w, held_w,
                                      g, t, lifted_events, part, before, after, stage))
        else:
            if phases and phases[-1].kind == "drive" and phases[-1].held == held:
                prev = phases[-1]  # a regrasp of the same mechanism: one motion
                first = seen.mean(held, prev.start - 12, prev.start - 1)
                prev.displacement = relative(after[held], first)
                if prev.ref is not None:
                    prev.goal = relative(after[held], after[prev.ref])
                prev.end = end
                continue
            path = [relative(hand[k, :4], before[held]) for k in range(g, end + 1)]
            static = [i for i in present if i != held and i not in linked
                      and not _moved(before[i], after[i])]
            ref = min(static, key=lambda i: float(np.linalg.norm(before[i][:3]
                                                                 - before[held][:3])),
                      default=None)
            phases.append(Phase(
                kind="drive", held=held, grasp=grasp, open_width=open_w, held_width=held_w,
                start=g, end=end,
                path=path, displacement=relative(after[held], before[held]),
                ref=ref, goal=None if ref is None else relative(after[held], after[ref]),
                start_rel=None if ref is None else relative(before[held], before[ref]),
                stage=stage))
    movable = {p.held for p in phases}
    return DemoParse(family=man.family, rows=rows, phases=phases, movable=movable,
                     links=links, reach=reach, steps=t)


def _stage_at(man: DemoManifest, k: int) -> str:
    for ks in man.key_stages:
        if ks.start <= k < ks.end:
            return ks.name
    return man.key_stages[-1].name if man.key_stages else ""


def _tool_phase(seen: _Rows, hand: np.ndarray, present: list[int], held: int,
                linked: list[int], grasp: np.ndarray, open_w: float, held_w: float, g: int,
                t: int,
                lifted_events: list[tuple[int, str]], part: str,
                before: dict[int, np.ndarray], after: dict[int, np.ndarray],
                stage: str) -> Phase:
    """A part lifted and held to the end: the tip's path relative to what it acted on."""
    tip = max(linked, key=lambda i: float(np.linalg.norm(before[i][:3] - before[held][:3])),
              default=held)
    others = [i for i in present if i != held and i not in linked]
    end_tip = seen.mean(tip, t - 6, t + 1)
    ref = min(others, key=lambda i: float(np.linalg.norm(before[i][:3] - end_tip[:3])))
    moved = [i for i in others if np.linalg.norm(after[i][:2] - before[i][:2]) > 0.01]
    lift = next((k for k, p in lifted_events if k >= g and p == part), g)
    anchor = moved[0] if moved else ref  # the path is relative to the part it acted on
    origin = before[anchor]
    path = []
    for k in range(lift, t + 1, 2):
        tip_k = seen.pose(tip, k) if seen.fresh[k, tip] else None
        if tip_k is None:
            continue
        path.append(np.array([*(tip_k[:3] - origin[:3]), hand[k, 3]]))
    phase = Phase(kind="tool", held=held, grasp=grasp, open_width=open_w, held_width=held_w,
                  start=g, end=t,
                  ref=ref, path=path, tip=tip, anchor=anchor,
                  carry_z=float(np.max(hand[g:t + 1, 2])), stage=stage)
    if moved:
        m = moved[0]
        static = [i for i in others if i != m and i not in moved]
        if static:
            mref = min(static, key=lambda i: float(np.linalg.norm(before[i][:2] - after[m][:2])))
            d = after[m][:2] - before[m][:2]
            phase.moved, phase.moved_ref = m, mref
            phase.moved_goal = after[m][:3] - after[mref][:3]
            phase.moved_dir = d / max(float(np.linalg.norm(d)), 1e-9)
    return phase
