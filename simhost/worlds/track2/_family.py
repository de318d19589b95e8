"""What a task family provides, and the motion primitives its scripted expert is built from.

A family turns :class:`InstanceParams` (and the split's :class:`BenchConfig`) into MJCF
bodies, reads the simulation into the observation's ``parts`` rows (true poses: the
observation channel adds the noise) and the ``goal`` vector, classifies the true key stage,
and states the ground truth of the instance (:class:`TaskTruth`). Its expert is a generator
of actions that reads part poses through an :class:`Eye`: the true state (the privileged
oracle, the demonstrations) or the observations (the feasibility check, which sees what an
agent sees). Both know the instance's parameters.

Ground-truth vocabulary shared by all families (``task_truth``):

- ``stages``: ordered key-stage names; ``info["stage"]`` is one of them, or ``"done"``.
- ``state_variables``: ``{"name", "type", "part"?}`` with type in
  ``pose | position | angle | fraction | length | bool``.
- ``constraints``: ``{"name", "value"}`` — geometric or physical facts of the instance.
- ``preconditions``: ``{stage: [predicate, ...]}`` — what must hold to enter the stage.
- ``success``: ``[{"variable", "op", "value"}]`` with op in ``>= | <= | == | within``; all of
  them must hold at once. Goals are stated relative to the start of the attempt where the
  demonstration defines them (a turn, not an absolute angle).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import numpy as np

from ._bench import (
    DPOS_MAX,
    DYAW_MAX,
    WIDTH_MAX,
    WORKSPACE_HI,
    WORKSPACE_LO,
    Scene,
    wrap,
)
from ._config import BenchConfig
from ._params import InstanceParams
from ._truth import TaskTruth, TruthConstraint, TruthCriterion, TruthVariable

if TYPE_CHECKING:
    from ._sim import Sim

GOAL_NAMES = ("stated", "g1", "g2", "g3")
GOAL_SIZE = len(GOAL_NAMES)
Action = np.ndarray
Plan = Iterator[Action]


class Bench(Protocol):
    """What a family task uses of the bench it is bound to (``BenchEnv``)."""

    sim: Sim

    @property
    def control_target(self) -> np.ndarray:
        """The hand's current control target (x, y, z, yaw)."""
        ...


class Eye(Protocol):
    """Where the expert reads part poses: the true state or an estimate from observations."""

    def pos(self, body: int) -> np.ndarray: ...
    def quat(self, body: int) -> np.ndarray: ...
    def yaw(self, body: int) -> float: ...
    def point(self, body: int, local: tuple[float, float, float]) -> np.ndarray: ...
    def tilt(self, body: int) -> float: ...
    def site(self, site: int) -> np.ndarray: ...


@dataclass
class Evaluation:
    """The task's reading of the current state."""

    stage: str
    frac: float = 0.0
    success: bool = False
    flags: dict[str, bool] = field(default_factory=dict)
    """Predicates named ``"<event>:<part>"``; a rising edge is an annotation ``event``, and the
    falling edge of ``grasped:<part>`` is ``released``."""
    value: float | None = None
    """The magnitude the goal is about (fraction opened, angle turned, depth), if any."""


class FamilyTask(ABC):
    """One instance of a task family inside one MuJoCo model."""

    family: ClassVar[str]
    part_names: ClassVar[tuple[str, ...]]
    max_steps: ClassVar[int]

    def __init__(self, params: InstanceParams, config: BenchConfig | None = None) -> None:
        self.p = params
        self.config = config or BenchConfig()
        self.tol = self.config.tolerances
        self.sim: Sim | None = None
        self.eye: Eye | None = None

    # -- building ------------------------------------------------------------------------------
    @abstractmethod
    def scene(self) -> Scene:
        """The MJCF bodies (and assets, contact excludes) of this instance."""

    def bind(self, sim: Sim) -> None:
        """Resolve names to ids once the model is compiled."""
        self.sim = sim

    def reset(self, sim: Sim, jitter: float) -> None:
        """Set the initial joint values of articulated parts (before ``mj_forward``).

        ``jitter`` is a standard normal draw for this reset; a family with an articulated
        part offsets its start by ``jitter * attempt_jitter_rad`` (or a matching fraction).
        """
        return None

    def jitter_groups(self) -> tuple[tuple[str, ...], ...]:
        """Bodies moved together by the per-reset jitter (each group one offset)."""
        return tuple((name,) for name in self.part_names)

    @property
    def s(self) -> Sim:
        assert self.sim is not None, "task is not bound to a simulation"
        return self.sim

    @property
    def e(self) -> Eye:
        """The expert's eye (the true state unless an observed eye was attached)."""
        return self.eye if self.eye is not None else self.s

    # -- reading -------------------------------------------------------------------------------
    @abstractmethod
    def stages(self) -> tuple[str, ...]:
        """Ordered key stages of this instance."""

    @abstractmethod
    def parts(self) -> np.ndarray:
        """``(len(part_names), 9)`` true rows ``present, x..qz, joint``; padding rows are zero."""

    def row_refs(self) -> tuple[tuple[str, int] | None, ...]:
        """What each ``parts`` row shows: ``("body", id)``, ``("site", id)`` or ``None``."""
        return tuple(("body", self.s.bid(n)) for n in self.part_names)

    def symmetry(self) -> tuple[float, ...]:
        """Per ``parts`` row, the yaw period under which the part looks the same (rad)."""
        return (2 * math.pi,) * len(self.part_names)

    def yaw_priors(self) -> dict[int, float]:
        """Per ``parts`` row, the nominal yaw the instance's parameters give (rad): the
        feasibility expert unwraps a symmetric part's first measurement near it."""
        return {}

    def row_links(self) -> dict[int, int]:
        """Rows rigidly attached to another row (a tool's tip to its handle)."""
        return {}

    def held_rows(self) -> set[int]:
        """Rows of parts the gripper can carry or drive (loose or articulated parts)."""
        loose = set(self.loose_parts().values())
        return {i for i, ref in enumerate(self.row_refs())
                if ref is not None and ref[0] == "body" and ref[1] in loose}

    def row_reach(self) -> dict[int, float]:
        """Rows whose frame lies farther than 5 cm from where the gripper holds them: how far
        (m). The feasibility expert takes such a part as held within that distance."""
        return {}

    def goal(self) -> np.ndarray:
        """``[stated, g1, g2, g3]``: the goal parameters, zeros when the task states none."""
        return np.zeros(GOAL_SIZE)

    @abstractmethod
    def evaluate(self) -> Evaluation:
        """Stage, within-stage fraction, success and event predicates of the current state."""

    def loose_parts(self) -> dict[str, int]:
        """Free parts the gripper may drop, by annotation name (body ids)."""
        return {}

    def progress(self, ev: Evaluation) -> float:
        """Progress in [0, 1]: ``(stage index + fraction) / number of stages``, 1 on success."""
        if ev.success:
            return 1.0
        st = self.stages()
        k = st.index(ev.stage) if ev.stage in st else 0
        return float(min(0.999, (k + min(max(ev.frac, 0.0), 0.999)) / len(st)))

    @abstractmethod
    def truth(self) -> TaskTruth:
        """Stages, state variables, constraints, preconditions and success criteria."""

    @abstractmethod
    def plan(self, env: Bench) -> Plan:
        """The scripted expert: yields one action per step, reading poses through ``self.e``."""

    # -- helpers -------------------------------------------------------------------------------
    def row(self, body: int, joint: float = 0.0) -> np.ndarray:
        s = self.s
        return np.array([1.0, *s.pos(body), *s.quat(body), joint])

    def pad(self, rows: list[np.ndarray]) -> np.ndarray:
        out = np.zeros((len(self.part_names), 9))
        for i, r in enumerate(rows):
            out[i] = r
        return out


def truth_doc(
    task: FamilyTask,
    variables: list[TruthVariable],
    constraints: dict[str, Any],
    preconditions: dict[str, list[str]],
    success: list[TruthCriterion],
    goal: dict[str, Any] | None = None,
) -> TaskTruth:
    """Assemble the ground truth in its fixed shape."""
    return TaskTruth(
        family=task.family,  # type: ignore[arg-type]
        stages=tuple(task.stages()),
        state_variables=tuple(variables),
        constraints=tuple(TruthConstraint(name=k, value=v) for k, v in constraints.items()),
        preconditions={k: tuple(v) for k, v in preconditions.items()},
        success=tuple(success),
        goal=dict(goal or {}),
    )


def var(name: str, kind: str, part: str | None = None) -> TruthVariable:
    return TruthVariable(name=name, type=kind, part=part)  # type: ignore[arg-type]


def crit(variable: str, op: str, value: Any) -> TruthCriterion:
    return TruthCriterion(variable=variable, op=op, value=value)  # type: ignore[arg-type]


# -- motion primitives -------------------------------------------------------------------------
def width_cmd(width: float) -> float:
    """Gripper command for a finger opening ``width`` (m)."""
    return float(np.clip(2.0 * width / WIDTH_MAX - 1.0, -1.0, 1.0))


def action(dpos: np.ndarray, dyaw: float, width: float) -> Action:
    a = np.zeros(5, dtype=np.float32)
    a[:3] = np.clip(dpos / DPOS_MAX, -1.0, 1.0)
    a[3] = np.clip(dyaw / DYAW_MAX, -1.0, 1.0)
    a[4] = width_cmd(width)
    return a


def nearest_yaw(yaw: float, period: float, near: float = 0.0) -> float:
    """The angle equivalent to ``yaw`` modulo ``period`` that is closest to ``near``."""
    return near + (yaw - near + period / 2) % period - period / 2


def move(
    env: Bench,
    goal: np.ndarray,
    yaw: float,
    width: float,
    *,
    speed: float = 1.0,
    tol: float = 0.002,
    max_steps: int = 80,
) -> Plan:
    """Drive the control target in a straight line to ``goal`` and ``yaw``; stop on arrival.

    Ends when the hand is within ``tol`` of ``goal`` and 0.03 rad of ``yaw``, or after
    ``max_steps`` (a blocked hand).
    """
    goal = np.clip(np.asarray(goal, dtype=float), WORKSPACE_LO[:3], WORKSPACE_HI[:3])
    for _ in range(max_steps):
        target = env.control_target
        d = goal - target[:3]
        n = float(np.linalg.norm(d))
        lim = speed * DPOS_MAX
        if n > lim:
            d = d * (lim / n)
        dyaw = float(np.clip(wrap(yaw - target[3]), -speed * DYAW_MAX, speed * DYAW_MAX))
        yield action(d, dyaw, width)
        ee = env.sim.ee()
        if np.linalg.norm(ee[:3] - goal) < tol and abs(wrap(yaw - ee[3])) < 0.03:
            return


def pick(
    env: Bench, top: np.ndarray, yaw: float, open_w: float, depth: float, lift_z: float
) -> Plan:
    """Come down over a part whose top centre is ``top``, close ``depth`` below it, lift."""
    yield from move(env, np.array([top[0], top[1], top[2] + 0.04]), yaw, open_w, tol=0.004)
    yield from move(env, np.array([top[0], top[1], top[2] - depth]), yaw, open_w, speed=0.6)
    yield from grip(env, 0.0, 6)
    ee = env.sim.ee()
    yield from move(env, np.array([ee[0], ee[1], lift_z]), yaw, 0.0, tol=0.004)


def descend(env: Bench, goal: np.ndarray, yaw: float, width: float, *,
            speed: float = 0.6) -> Plan:
    """Come straight down to ``goal``; stop early when the hand stops going down (3 steps
    with less than 0.5 mm), i.e. something is in the way."""
    stuck = 0
    for _ in range(60):
        before = env.sim.ee()[2]
        yield from move(env, goal, yaw, width, speed=speed, max_steps=1)
        ee = env.sim.ee()
        if np.linalg.norm(ee[:3] - goal) < 0.002:
            return
        stuck = stuck + 1 if ee[2] > before - 0.0005 else 0
        if stuck >= 3:
            return


def reach_down(env: Bench, goal: np.ndarray, yaw: float, width: float, *,
               above: float = 0.05) -> Plan:
    """Come down over ``goal`` to it; when something stops the fingers above it (an edge a
    calibration error put under a finger), lift, shift by 4 then 8 mm along and across the
    hand's fingers and come down again: contact decides where perception cannot."""
    c, s = math.cos(yaw), math.sin(yaw)
    along, across = np.array([c, s, 0.0]), np.array([-s, c, 0.0])
    offsets = [np.zeros(3)] + [k * d for k in (0.004, 0.008) for d in (along, -along, across,
                                                                         -across)]
    for k, off in enumerate(offsets):
        at = np.asarray(goal, dtype=float) + off
        yield from move(env, at + [0.0, 0.0, above if k == 0 else 0.015], yaw, width, tol=0.004)
        yield from descend(env, at, yaw, width)
        if env.sim.ee()[2] < goal[2] + 0.003:
            return


def servo(
    env: Bench,
    error: Callable[[], tuple[np.ndarray, float]],
    z: float,
    *,
    tol: float = 0.0006,
    yaw_tol: float = 0.02,
    max_steps: int = 40,
) -> Plan:
    """Move the hand by the measured error (xy, yaw) of a held part until it is within tol."""
    for _ in range(max_steps):
        err, yaw_err = error()
        ee = env.sim.ee()
        still = float(np.linalg.norm(env.sim.ee_vel()[:2])) < 0.003
        if np.linalg.norm(err) < tol and abs(yaw_err) < yaw_tol and still:
            return
        goal = np.array([ee[0] + err[0], ee[1] + err[1], z])
        yield from move(env, goal, ee[3] + yaw_err, 0.0, max_steps=1)


def hold(env: Bench, steps: int, width: float) -> Plan:
    """Keep the hand still (target where it is) and command ``width``."""
    for _ in range(steps):
        yield action(np.zeros(3), 0.0, width)


def grip(env: Bench, width: float = 0.0, steps: int = 6) -> Plan:
    """Close the fingers (or open them gently, 6 mm per step) and wait for them to settle."""
    now = env.sim.width()
    if width > now + 0.006:
        for w in np.arange(now + 0.006, width, 0.006):
            yield action(np.zeros(3), 0.0, float(w))
    yield from hold(env, steps, width)


def idle(env: Bench, width: float | None = None) -> Plan:
    """Hold forever: what the expert does once its plan is through."""
    w = env.sim.width() if width is None else width
    while True:
        yield action(np.zeros(3), 0.0, w)


CHAMFER_T = 0.003  # thickness of a chamfer plate (m)


def _wall(ang: float, inner: float, t: float, half_len: float, height: float, z0: float,
          chamfer: float) -> list[str]:
    """One straight wall whose inner face lies ``inner`` from the centre, in direction
    ``ang``; with ``chamfer`` > 0 its top inner edge is a 45-degree slope ``chamfer`` wide
    that guides a part sliding in."""
    c, s = math.cos(ang), math.sin(ang)
    straight = height - chamfer
    cx, cz = inner + t / 2, z0 + straight / 2
    out = [
        f'<geom class="fixture" type="box" pos="{cx * c:.5f} {cx * s:.5f} {cz:.5f}" '
        f'size="{t / 2:.5f} {half_len:.5f} {straight / 2:.5f}" euler="0 0 {ang:.6f}"/>'
    ]
    if chamfer > 0:
        off = CHAMFER_T / (2 * math.sqrt(2))
        px, pz = inner + chamfer / 2 + off, z0 + height - chamfer / 2 - off
        qz = (math.cos(ang / 2), 0.0, 0.0, math.sin(ang / 2))
        qy = (math.cos(-math.pi / 8), 0.0, math.sin(-math.pi / 8), 0.0)
        w1, x1, y1, z1 = qz
        w2, x2, y2, z2 = qy
        q = (w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
             w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2)
        out.append(
            f'<geom class="fixture" type="box" pos="{px * c:.5f} {px * s:.5f} {pz:.5f}" '
            f'size="{chamfer * math.sqrt(2) / 2:.5f} {half_len:.5f} {CHAMFER_T / 2:.5f}" '
            f'quat="{q[0]:.6f} {q[1]:.6f} {q[2]:.6f} {q[3]:.6f}"/>'
        )
    return out


def radial(n: int, r: float, t: float, height: float, z0: float = 0.0,
           chamfer: float = 0.0) -> list[str]:
    """``n`` wall boxes of thickness ``t`` around a regular n-gon of inradius ``r``."""
    half_len = (r + t) * math.tan(math.pi / n) + 0.001
    out: list[str] = []
    for k in range(n):
        out += _wall(2 * math.pi * k / n, r, t, half_len, height, z0, chamfer)
    return out


def box_walls(ia: float, ib: float, t: float, height: float, z0: float = 0.0,
              chamfer: float = 0.0) -> list[str]:
    """Four wall boxes around a rectangle of inner half-sizes ``ia`` x ``ib``."""
    out: list[str] = []
    for ang, inner, half in ((0.0, ia, ib + t), (math.pi, ia, ib + t),
                             (math.pi / 2, ib, ia), (-math.pi / 2, ib, ia)):
        out += _wall(ang, inner, t, half, height, z0, chamfer)
    return out


def spiral(spacing: float, rings: int) -> list[np.ndarray]:
    """Search offsets on rings of radius ``spacing``, ``2 spacing``, ... (6 k points on ring
    k), nearest first."""
    out = []
    for k in range(1, rings + 1):
        for j in range(6 * k):
            a = 2 * math.pi * j / (6 * k) + 0.5 * k
            out.append(k * spacing * np.array([math.cos(a), math.sin(a)]))
    return out
