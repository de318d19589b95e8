"""What a task family provides, and the motion primitives its scripted expert is built from.

A family turns :class:`InstanceParams` into MJCF bodies, reads the simulation into the
observation's ``parts`` rows and ``goal`` vector, classifies the true key stage, and states
the ground truth of the instance. Its expert is a generator of actions that reads privileged
state (exact part poses, the hand's control target) through the environment it drives.

Ground-truth vocabulary shared by all families (``task_truth``):

- ``stages``: ordered key-stage names; ``info["stage"]`` is one of them, or ``"done"``.
- ``state_variables``: ``{"name", "type", "part"?}`` with type in
  ``pose | position | angle | fraction | length | bool``.
- ``constraints``: ``{"name", "value"}`` — geometric or physical facts of the instance.
- ``preconditions``: ``{stage: [predicate, ...]}`` — what must hold to enter the stage.
- ``success``: ``[{"variable", "op", "value"}]`` with op in ``>= | <= | == | within``; all of
  them must hold at once.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ._bench import DPOS_MAX, DYAW_MAX, WIDTH_MAX, WORKSPACE_HI, WORKSPACE_LO, Scene, wrap
from ._params import InstanceParams

if TYPE_CHECKING:
    from ._env import BenchEnv
    from ._sim import Sim

PART_FIELDS = ("present", "x", "y", "z", "qw", "qx", "qy", "qz", "joint")
GOAL_NAMES = ("stated", "g1", "g2", "g3")
GOAL_SIZE = len(GOAL_NAMES)
Action = np.ndarray
Plan = Iterator[Action]


@dataclass
class Evaluation:
    """The task's reading of the current state."""

    stage: str
    frac: float = 0.0
    success: bool = False
    flags: dict[str, bool] = field(default_factory=dict)
    """Predicates named ``"<event>:<part>"``; a rising edge is an annotation ``event``, and the
    falling edge of ``grasped:<part>`` is ``released``."""


class FamilyTask(ABC):
    """One instance of a task family inside one MuJoCo model."""

    family: ClassVar[str]
    part_names: ClassVar[tuple[str, ...]]
    max_steps: ClassVar[int]

    def __init__(self, params: InstanceParams) -> None:
        self.p = params
        self.sim: Sim | None = None

    # -- building ------------------------------------------------------------------------------
    @abstractmethod
    def scene(self) -> Scene:
        """The MJCF bodies (and assets, contact excludes) of this instance."""

    def bind(self, sim: Sim) -> None:
        """Resolve names to ids once the model is compiled."""
        self.sim = sim

    def reset(self, sim: Sim) -> None:
        """Set the initial joint values of articulated parts (before ``mj_forward``)."""
        return None

    @property
    def s(self) -> Sim:
        assert self.sim is not None, "task is not bound to a simulation"
        return self.sim

    # -- reading -------------------------------------------------------------------------------
    @abstractmethod
    def stages(self) -> tuple[str, ...]:
        """Ordered key stages of this instance."""

    @abstractmethod
    def parts(self) -> np.ndarray:
        """``(len(part_names), len(PART_FIELDS))`` rows; padding rows are zero."""

    def goal(self) -> np.ndarray:
        """``[stated, g1, g2, g3]``: public goal parameters, zeros when the task states none."""
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
    def truth(self) -> dict[str, Any]:
        """Stages, state variables, constraints, preconditions and success criteria."""

    @abstractmethod
    def plan(self, env: BenchEnv) -> Plan:
        """The scripted expert: yields one action per step, reading privileged state."""

    # -- helpers -------------------------------------------------------------------------------
    def row(self, body: int, joint: float = 0.0) -> np.ndarray:
        s = self.s
        return np.array([1.0, *s.pos(body), *s.quat(body), joint])

    def pad(self, rows: list[np.ndarray]) -> np.ndarray:
        out = np.zeros((len(self.part_names), len(PART_FIELDS)))
        for i, r in enumerate(rows):
            out[i] = r
        return out


def truth_doc(
    task: FamilyTask,
    variables: list[dict[str, Any]],
    constraints: dict[str, Any],
    preconditions: dict[str, list[str]],
    success: list[dict[str, Any]],
) -> dict[str, Any]:
    """Assemble the ground-truth document in its fixed shape."""
    return {
        "version": "eagc-truth/v1",
        "family": task.family,
        "stages": list(task.stages()),
        "state_variables": variables,
        "constraints": [{"name": k, "value": v} for k, v in constraints.items()],
        "preconditions": preconditions,
        "success": success,
        "goal": dict(task.p.goal),
    }


def var(name: str, kind: str, part: str | None = None) -> dict[str, Any]:
    return {"name": name, "type": kind, **({"part": part} if part else {})}


def crit(variable: str, op: str, value: Any) -> dict[str, Any]:
    return {"variable": variable, "op": op, "value": value}


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
    env: BenchEnv,
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
    env: BenchEnv, top: np.ndarray, yaw: float, open_w: float, depth: float, lift_z: float
) -> Plan:
    """Come down over a part whose top centre is ``top``, close ``depth`` below it, lift."""
    yield from move(env, np.array([top[0], top[1], top[2] + 0.04]), yaw, open_w, tol=0.004)
    yield from move(env, np.array([top[0], top[1], top[2] - depth]), yaw, open_w, speed=0.6)
    yield from grip(env, 0.0, 6)
    ee = env.sim.ee()
    yield from move(env, np.array([ee[0], ee[1], lift_z]), yaw, 0.0, tol=0.004)


def servo(
    env: BenchEnv,
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


def hold(env: BenchEnv, steps: int, width: float) -> Plan:
    """Keep the hand still (target where it is) and command ``width``."""
    for _ in range(steps):
        yield action(np.zeros(3), 0.0, width)


def grip(env: BenchEnv, width: float = 0.0, steps: int = 6) -> Plan:
    """Close (or open) the fingers and wait for them to settle."""
    yield from hold(env, steps, width)


def idle(env: BenchEnv, width: float | None = None) -> Plan:
    """Hold forever: what the expert does once its plan is through."""
    w = env.sim.width() if width is None else width
    while True:
        yield action(np.zeros(3), 0.0, w)


def radial(n: int, r: float, t: float, height: float, z0: float = 0.0) -> list[str]:
    """``n`` wall boxes of thickness ``t`` around a regular n-gon of inradius ``r``."""
    half_len = (r + t) * math.tan(math.pi / n) + 0.001
    out = []
    for k in range(n):
        ang = 2 * math.pi * k / n
        cx, cy = (r + t / 2) * math.cos(ang), (r + t / 2) * math.sin(ang)
        out.append(
            f'<geom class="fixture" type="box" pos="{cx:.5f} {cy:.5f} {z0 + height / 2:.5f}" '
            f'size="{t / 2:.5f} {half_len:.5f} {height / 2:.5f}" '
            f'euler="0 0 {ang:.6f}"/>'
        )
    return out


def box_walls(ia: float, ib: float, t: float, height: float, z0: float = 0.0) -> list[str]:
    """Four wall boxes around a rectangle of inner half-sizes ``ia`` x ``ib``."""
    zc, hz = z0 + height / 2, height / 2
    return [
        f'<geom class="fixture" type="box" pos="{sx * (ia + t / 2):.5f} 0 {zc:.5f}" '
        f'size="{t / 2:.5f} {ib + t:.5f} {hz:.5f}"/>'
        for sx in (-1, 1)
    ] + [
        f'<geom class="fixture" type="box" pos="0 {sy * (ib + t / 2):.5f} {zc:.5f}" '
        f'size="{ia:.5f} {t / 2:.5f} {hz:.5f}"/>'
        for sy in (-1, 1)
    ]
