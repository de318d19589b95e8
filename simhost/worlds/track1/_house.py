"""The house world: primitives with preconditions, perturbations, ground truth and state.

``House`` is the simulator without the Gymnasium adapter; ``HouseEnv`` wraps one. The
symbolic ``WorldState`` is the authority; the physics follows it (doors driven by their
hinge actuators, lids and items as mocap bodies, the base by its position controllers).
A failed precondition leaves both untouched.
"""

from __future__ import annotations

import hashlib
import math
import struct
from typing import Any

import numpy as np

from ._actions import ActionResult
from ._catalogue import AFFORDANCE_EFFECTS, AFFORDANCES
from ._config import HouseEnvConfig
from ._errors import PerturbationError, StateError
from ._graph import doors_on_path, shortest_room_path
from ._layout import Door, Furniture, HouseLayout, Item
from ._mjcf import ROBOT_RADIUS
from ._perception import drift, perceive
from ._sensors import Detection, detect, footprint_distance, robot_blocks
from ._sim import HouseSim
from ._task import HouseTask, task_blockers, task_satisfied
from ._truth import HouseTruth
from ._world import WorldState, ground_truth

_MAGIC = b"EAGCT1\x00\x00"


class House:
    """One house, simulated: the rules of Track 1's world."""

    def __init__(
        self, layout: HouseLayout, config: HouseEnvConfig | None = None, *, noise_seed: int = 0
    ) -> None:
        self.layout = layout
        self.config = config or HouseEnvConfig()
        self.sim = HouseSim(layout, offscreen=self.config.image_size)
        self.sim.reveal_exceptions = self.config.reveal_exceptions
        self.world = WorldState.initial(layout)
        self._digest = bytes.fromhex(layout.digest())
        self._visible: list[Detection] | None = None
        self._detections: list[Detection] | None = None
        self.reset(noise_seed)

    def reset(self, noise_seed: int | None = None) -> None:
        """Back to the layout's initial state; ``noise_seed`` keys the sensors' draws
        (default: the layout's seed)."""
        self.world = WorldState.initial(self.layout)
        self.world.noise_seed = self.layout.seed if noise_seed is None else int(noise_seed)
        self.world.odometry = self.layout.start
        self.world.sign_room = self.layout.start_room
        self.sim.reset(self.world, self.layout.start)
        self._changed()

    # ----------------------------------------------------------------- perception
    @property
    def robot_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) in the house frame."""
        return self.sim.robot_pose()

    @property
    def robot_room(self) -> int:
        """The room the robot's centre is in."""
        x, y, _ = self.sim.robot_pose()
        return self.layout.room_at(x, y)

    def visible(self) -> list[Detection]:
        """Every entity in view now with its exact attributes, nearest first (cached until
        the world changes). What the robot can act on."""
        if self._visible is None:
            cfg = self.config
            self._visible = detect(self.layout, self.world, self.sim, cfg.sensing_range,
                                   cfg.field_of_view, reveal=cfg.reveal_exceptions,
                                   item_range=cfg.item_range)
        return self._visible

    def detections(self) -> list[Detection]:
        """What the detector reports now: the visible entities after misses, position noise
        and confusion (``_perception``), nearest first."""
        if self._detections is None:
            self._detections = perceive(self.visible(), self.config, self.world.noise_seed,
                                        self.world.steps)
        return self._detections

    @property
    def odometry(self) -> tuple[float, float, float]:
        """The robot's pose as its odometry has it (x, y, yaw)."""
        x, y, yaw = self.world.odometry
        return (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))

    def room_sign(self) -> int:
        """The room the robot knows it is in now: always the current room with
        ``room_sign="always"``; else the room whose sign it read at this step, or -1."""
        if self.config.room_sign == "always":
            return self.robot_room
        return self.world.sign_room if self.world.sign_step == self.world.steps else -1

    def _changed(self) -> None:
        self._visible = None
        self._detections = None

    def in_reach(self, entity_id: int) -> bool:
        """Whether the robot can act on an entity from where it stands."""
        x, y, _ = self.sim.robot_pose()
        e = self.layout.entity(entity_id)
        if isinstance(e, Door):
            return math.hypot(x - e.centre[0], y - e.centre[1]) <= self.config.door_reach
        if isinstance(e, Furniture):
            return footprint_distance(e, x, y) <= self.config.furniture_reach
        if isinstance(e, Item) and e.id in self.world.places:
            ix, iy, _ = self.layout.item_position(e, *self.world.places[e.id])
            return math.hypot(x - ix, y - iy) <= self.config.reach
        return False

    # ----------------------------------------------------------------- primitives
    def execute(
        self,
        primitive: str,
        *,
        forward: float = 0.0,
        turn: float = 0.0,
        target: int = 0,
        tool: int = 0,
    ) -> ActionResult:
        """Run one primitive (arguments already validated and clipped)."""
        if primitive == "move":
            result = self._move(forward, turn)
        elif primitive in ("open", "close"):
            result = self._open_close(primitive, target)
        elif primitive == "pick":
            result = self._pick(target)
        elif primitive == "place":
            result = self._place(target)
        elif primitive == "use":
            result = self._use(tool, target)
        elif primitive in ("noop", "done"):
            self._run(self.config.action_steps if primitive == "noop" else 0)
            result = ActionResult(primitive, True)
        else:
            result = ActionResult(primitive, False, "invalid_action")
        self.world.steps += 1
        room = self.robot_room
        if room != self.world.sign_room:
            self.world.sign_room, self.world.sign_step = room, self.world.steps
        if self.config.odometry_noise == (0.0, 0.0):
            self.world.odometry = self.sim.robot_pose()
        self._changed()
        return result

    def _run(self, steps: int) -> None:
        for _ in range(steps):
            self.sim.step(self.world.held)

    def _target_check(self, primitive: str, target: int) -> ActionResult | None:
        if self.layout.entity(target) is None:
            return ActionResult(primitive, False, "unknown_id")
        if target not in {d.id for d in self.visible()}:
            return ActionResult(primitive, False, "not_visible")
        if not self.in_reach(target):
            return ActionResult(primitive, False, "out_of_reach")
        return None

    def _move(self, forward: float, turn: float) -> ActionResult:
        cfg, sim = self.config, self.sim
        df, dth = forward * cfg.max_forward, turn * cfg.max_turn
        x0, y0, th0 = sim.robot_joints()
        th1 = th0 + dth
        x1, y1 = x0 + df * math.cos(th1), y0 + df * math.sin(th1)
        plan: list[tuple[float, float, float]] = []
        if dth != 0.0:
            n = cfg.turn_steps
            plan += [(x0, y0, th0 + dth * k / n) for k in range(1, n + 1)]
        if df != 0.0:
            n = cfg.forward_steps
            plan += [(x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, th1) for k in range(1, n + 1)]
        plan += [(x1, y1, th1)] * cfg.settle_steps
        last = (x0, y0, th0)
        collided = False
        for aim in plan:
            sim.set_robot_ctrl(*aim)
            if sim.step(self.world.held):
                collided = True
                break
            last = sim.robot_joints()
        if collided:
            sim.set_robot_pose(*last)
            if self.world.held >= 0:
                sim.place_item_mocap(self.world, self.world.held)
        sim.wrap_yaw()
        sim.forward()
        self.world.odometry = drift(self.world.odometry, (x0, y0, th0), sim.robot_pose(),
                                    cfg, self.world.noise_seed, self.world.steps)
        return ActionResult("move", True, "collided" if collided else "", collided)

    def _open_close(self, primitive: str, target: int) -> ActionResult:
        bad = self._target_check(primitive, target)
        if bad:
            return bad
        opening = primitive == "open"
        e = self.layout.entity(target)
        if isinstance(e, Door):
            state = self.world.doors[e.id]
            if state == "locked":
                return ActionResult(primitive, False, "locked")
            if state == ("open" if opening else "closed"):
                return ActionResult(
                    primitive, False, "already_open" if opening else "already_closed"
                )
            x, y, _ = self.sim.robot_pose()
            if robot_blocks(e, x, y):
                return ActionResult(primitive, False, "blocked_by_robot")
            self.sim.set_ctrl(self.sim.door_act[e.id], e.open_angle if opening else 0.0)
            self._run(self.config.door_steps)
            self.world.doors[e.id] = "open" if opening else "closed"
            return ActionResult(primitive, True)
        if isinstance(e, Furniture) and e.kind == "container":
            if e.id in self.world.unavailable:
                return ActionResult(primitive, False, "unavailable")
            if self.world.containers[e.id] == ("open" if opening else "closed"):
                return ActionResult(
                    primitive, False, "already_open" if opening else "already_closed"
                )
            self.world.containers[e.id] = "open" if opening else "closed"
            self.sim.set_lid(e, opening)
            self._run(self.config.action_steps)
            return ActionResult(primitive, True)
        return ActionResult(primitive, False, "not_openable")

    def _pick(self, target: int) -> ActionResult:
        if self.world.held >= 0:
            return ActionResult("pick", False, "hand_full")
        bad = self._target_check("pick", target)
        if bad:
            return bad
        if self.layout.kind_of(target) not in ("object", "tool"):
            return ActionResult("pick", False, "not_pickable")
        if self.world.places[target][0] in self.world.unavailable:
            return ActionResult("pick", False, "unavailable")
        del self.world.places[target]
        self.world.held = target
        self.sim.place_item_mocap(self.world, target)
        self._run(self.config.action_steps)
        return ActionResult("pick", True)

    def _place(self, target: int) -> ActionResult:
        if self.world.held < 0:
            return ActionResult("place", False, "hand_empty")
        bad = self._target_check("place", target)
        if bad:
            return bad
        rec = self.layout.entity(target)
        if not isinstance(rec, Furniture):
            return ActionResult("place", False, "not_a_receptacle")
        if rec.kind == "container":
            state = self.world.container_state(rec.id)
            if state != "open":
                return ActionResult(
                    "place", False, "unavailable" if state == "unavailable" else "container_closed"
                )
        slot = self.world.free_slot(self.layout, rec.id)
        if slot is None:
            return ActionResult("place", False, "receptacle_full")
        item = self.world.held
        self.world.places[item] = (rec.id, slot)
        self.world.held = -1
        self.sim.place_item_mocap(self.world, item)
        self._run(self.config.action_steps)
        return ActionResult("place", True)

    def _use(self, tool: int, target: int) -> ActionResult:
        if self.world.held < 0 or self.world.held != tool:
            return ActionResult("use", False, "tool_not_held")
        held = self.layout.entity(tool)
        if not isinstance(held, Item) or not held.affordances:
            return ActionResult("use", False, "not_a_tool")
        bad = self._target_check("use", target)
        if bad:
            return bad
        condition = self.world.conditions.get(target)
        needed = [a for a in AFFORDANCES if condition in AFFORDANCE_EFFECTS[a]]
        if not needed:
            return ActionResult("use", False, "not_applicable")
        if needed[0] not in held.affordances:
            return ActionResult("use", False, "lacks_affordance")
        after = AFFORDANCE_EFFECTS[needed[0]][1]
        if condition == after:
            return ActionResult("use", False, "no_effect")
        self.world.conditions[target] = after
        self.world.used_by[target] = tool
        self._run(self.config.action_steps)
        return ActionResult("use", True)

    # ----------------------------------------------------------------- perturbations
    def _entity(self, entity_id: int, kinds: tuple[str, ...]) -> Any:
        kind = self.layout.kind_of(entity_id)
        if kind not in kinds:
            ids = [
                e.id
                for e in (*self.layout.doors, *self.layout.furniture, *self.layout.items)
                if self.layout.kind_of(e.id) in kinds
            ]
            raise PerturbationError(
                f"id {entity_id} is a {kind or 'unknown id'}, not a {'/'.join(kinds)}; "
                f"valid ids: {ids}"
            )
        return self.layout.entity(entity_id)

    def lock_door(self, door_id: int) -> dict[str, Any]:
        """Close and lock a door. With ``reveal_exceptions`` its indicator turns red and
        detections show ``locked``; else it looks closed until ``open`` fails."""
        door = self._entity(door_id, ("door",))
        before = self.world.doors[door_id]
        if before == "locked":
            raise PerturbationError(f"door {door_id} is already locked")
        x, y, _ = self.sim.robot_pose()
        if door.panel_distance(x, y) < ROBOT_RADIUS + 0.03:
            raise PerturbationError(
                f"the robot stands in doorway {door_id}; retry after it moves on"
            )
        self.world.doors[door_id] = "locked"
        self.sim.set_door(door, "locked")
        return self._perturbed({"kind": "door_lock", "door": door_id, "previous": before})

    def relocate_object(
        self, object_id: int, room_id: int | None = None, *, receptacle: int | None = None,
        shut: bool = False,
    ) -> dict[str, Any]:
        """Move an object or tool onto a free surface (else an open container) in a room
        (default: the backup room), or into a given receptacle (a container's lid does not
        matter then: the item is put inside, and the container keeps its state unless
        ``shut``: then it is closed after, the item put away out of sight)."""
        self._entity(object_id, ("object", "tool"))
        if object_id == self.world.held or object_id in self.world.removed:
            raise PerturbationError(f"item {object_id} is held or removed; relocate another one")
        previous = self.world.places[object_id]
        if receptacle is not None:
            f = self._entity(receptacle, ("furniture", "container"))
            if receptacle == previous[0] or receptacle in self.world.unavailable:
                raise PerturbationError(
                    f"receptacle {receptacle} is the item's own or unavailable; choose another"
                )
            order = [f]
            room = f.room
        else:
            room = self.layout.backup_room if room_id is None else room_id
            if not 0 <= room < len(self.layout.rooms):
                raise PerturbationError(
                    f"room {room} does not exist (rooms 0..{len(self.layout.rooms) - 1})"
                )
            here = [f for f in self.layout.furniture if f.room == room]
            order = [f for f in here if f.kind == "furniture"]
            order += [
                f for f in here
                if f.kind == "container" and self.world.container_state(f.id) == "open"
            ]
        for f in order:
            if f.id == previous[0]:
                continue
            slot = self.world.free_slot(self.layout, f.id)
            if slot is not None:
                self.world.places[object_id] = (f.id, slot)
                self.sim.place_item_mocap(self.world, object_id)
                shut_now = shut and f.kind == "container" and \
                    self.world.containers[f.id] == "open"
                if shut_now:
                    self.world.containers[f.id] = "closed"
                    self.sim.set_lid(f, False)
                return self._perturbed(
                    {
                        "kind": "object_relocation",
                        "object": object_id,
                        "room": room,
                        "receptacle": f.id,
                        "previous_receptacle": previous[0],
                        "shut": shut_now,
                    }
                )
        where = f"receptacle {receptacle}" if receptacle is not None else f"room {room}"
        raise PerturbationError(f"{where} has no free place for item {object_id}")

    def make_container_unavailable(self, container_id: int) -> dict[str, Any]:
        """Make a container unusable for good: it cannot be opened, closed, placed into or
        taken from. With ``reveal_exceptions`` it is shut and shows ``unavailable``; else it
        stays as it looks and fails when used."""
        f = self._entity(container_id, ("container",))
        if container_id in self.world.unavailable:
            raise PerturbationError(f"container {container_id} is already unavailable")
        previous = self.world.containers[container_id]
        self.world.unavailable.add(container_id)
        if self.config.reveal_exceptions:
            self.world.containers[container_id] = "closed"
            self.sim.set_lid(f, False)
        return self._perturbed(
            {"kind": "container_unavailable", "container": container_id, "previous": previous}
        )

    def remove_tool(self, tool_id: int) -> dict[str, Any]:
        """Take a tool out of the house (it is no longer detected anywhere)."""
        self._entity(tool_id, ("tool",))
        if tool_id in self.world.removed or tool_id == self.world.held:
            raise PerturbationError(f"tool {tool_id} is already removed or in the robot's hand")
        previous = self.world.places.pop(tool_id)
        self.world.removed.add(tool_id)
        self.sim.place_item_mocap(self.world, tool_id)
        return self._perturbed(
            {"kind": "tool_removal", "tool": tool_id, "previous_receptacle": previous[0]}
        )

    def _perturbed(self, event: dict[str, Any]) -> dict[str, Any]:
        self.sim.sync_visuals(self.world)
        self.sim.forward()
        self._changed()
        return event

    def teleport_robot(self, x: float, y: float, yaw: float) -> None:
        """Put the robot somewhere (tests and scenario setup only; never an agent action).

        Raises PerturbationError when the pose collides with the house.
        """
        before = tuple(float(v) for v in self.sim.data.qpos[self.sim.robot_qpos])
        self.sim.set_robot_pose(x, y, yaw)
        self.sim.forward()
        if self.sim.robot_in_contact():
            self.sim.set_robot_pose(*before)
            self.sim.forward()
            raise PerturbationError(f"pose ({x:.2f}, {y:.2f}) collides with the house")
        if self.world.held >= 0:
            self.sim.place_item_mocap(self.world, self.world.held)
            self.sim.forward()
        self.world.odometry = (x, y, yaw)
        self._changed()

    # ----------------------------------------------------------------- truth and paths
    def ground_truth(self) -> HouseTruth:
        """Organizer-only ground truth (see ``HouseTruth``)."""
        return ground_truth(self.layout, self.world, self.sim.robot_pose(), self.sim.hand_pose()[0])

    def shortest_path(
        self, from_room: int, to_room: int, *, avoid_locked: bool = True
    ) -> list[int]:
        """Fewest-doors room path (rooms included), [] when none; closed doors are passable."""
        blocked = [d for d, s in self.world.doors.items() if s == "locked"] if avoid_locked else []
        return shortest_room_path(
            range(len(self.layout.rooms)), self.layout.edges(), from_room, to_room, blocked
        )

    def route_doors(self, rooms: list[int]) -> list[int]:
        """The doors a room path crosses."""
        return doors_on_path(self.layout.edges(), rooms)

    def task_satisfied(self, task: HouseTask) -> bool:
        """Whether a task's goal holds now."""
        return task_satisfied(task, self.layout, self.world, self.robot_room)

    def task_blockers(
        self, task: HouseTask | None = None, rooms: tuple[int, ...] = ()
    ) -> list[str]:
        """Why a task (and rooms) cannot be completed from the robot's room; [] when it can."""
        return task_blockers(task, self.layout, self.world, self.robot_room, rooms)

    # ----------------------------------------------------------------- state
    def get_state(self) -> bytes:
        """Full state: MuJoCo ``mjSTATE_INTEGRATION`` plus the symbolic world, tagged with the
        layout's digest."""
        phys = self.sim.get_physics().astype("<f8").tobytes()
        sym = self.world.to_json()
        return _MAGIC + struct.pack("<II", len(phys), len(sym)) + self._digest + phys + sym

    def set_state(self, raw: bytes) -> None:
        """Restore a state from :meth:`get_state` of the same house."""
        head = len(_MAGIC) + 8 + 32
        if len(raw) < head or raw[: len(_MAGIC)] != _MAGIC:
            raise StateError("not a Track 1 house state (bad header)")
        n_phys, n_sym = struct.unpack("<II", raw[len(_MAGIC) : len(_MAGIC) + 8])
        digest = raw[len(_MAGIC) + 8 : head]
        if digest != self._digest:
            raise StateError(
                f"state belongs to another house (layout {digest.hex()[:12]}, "
                f"this is {self._digest.hex()[:12]}); build the env from that layout"
            )
        if n_phys != 8 * self.sim.state_size() or len(raw) != head + n_phys + n_sym:
            raise StateError("state has the wrong length for this house")
        world = WorldState.from_json(raw[head + n_phys :])
        self.sim.set_physics(np.frombuffer(raw[head : head + n_phys], dtype="<f8").copy())
        self.world = world
        self.sim.sync_visuals(world)
        self._changed()

    def state_hash(self) -> str:
        """sha256 of :meth:`get_state` (hex)."""
        return hashlib.sha256(self.get_state()).hexdigest()
