"""``HouseEnv``: the Gymnasium adapter of a Track 1 house."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ._actions import PRIMITIVES, ActionResult, Pixel, parse_action, parse_pixel_action
from ._catalogue import CATEGORIES, COLOURS, KINDS, MAX_IDS, MAX_ROOMS, ROOM_TYPES, STATES
from ._config import HouseEnvConfig
from ._generate import generate_house
from ._house import House
from ._info import HouseInfo
from ._layout import HouseLayout, HouseParams
from ._splits import HouseSplit, house_split
from ._task import HouseTask
from ._topdown import render_topdown
from ._truth import HouseTruth

_SEED_SPACE = 2**31 - 1
_MAX_DEPTH = 100.0
"""Depth (m) reported where the camera sees nothing within the far plane."""
_TARGETED = frozenset({"open", "close", "pick", "place", "use"})
"""Primitives that act on a ``target``."""


class HouseEnv(gym.Env[dict[str, np.ndarray], dict[str, Any]]):
    """A procedurally generated house with a mobile robot (EAGC Track 1).

    Args:
        layout: a fixed house; if None, ``reset(seed=...)`` generates one from the seed.
        split: ``"dev"``, ``"standard"`` or ``"challenge"`` (or a ``HouseSplit``): the
            houses and the sensing of that split (default: ``dev``'s sensing, and the
            houses of ``params``).
        params: generator parameters when the layout is not fixed (replaces the split's).
        config: sensing, control and rendering options (replaces the split's); keyword
            ``options`` override fields (e.g. ``render_rgbd=True, image_size=(64, 48)``).
        render_mode: None or ``"rgb_array"`` (a top-down picture).

    With ``actions_by="pixel"`` (the ``vision`` split) an action names what it acts on by a
    pixel ``[u, v]`` of the last frame observed (``target_px``; ``tool_px``, absent: the
    held item); the env resolves it through its own segmentation of that frame, kept even
    when the observation leaves it out (``make_pixel_action``).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 4}

    def __init__(
        self,
        layout: HouseLayout | None = None,
        *,
        split: str | HouseSplit | None = None,
        params: HouseParams | None = None,
        config: HouseEnvConfig | None = None,
        render_mode: str | None = None,
        **options: Any,
    ) -> None:
        if render_mode not in (None, "rgb_array"):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        preset = house_split(split) if isinstance(split, str) else split
        base = config or (preset.config if preset is not None else None)
        self.config = HouseEnvConfig.from_overrides(base, options)
        self.params = params or (preset.params if preset is not None else HouseParams())
        self.render_mode = render_mode
        self._fixed = layout
        self.house: House | None = House(layout, self.config) if layout is not None else None
        self.task: HouseTask | None = None
        self._last = ActionResult("reset", True)
        self._frame_ids: np.ndarray | None = None
        self.resolved: tuple[int | None, int | None] = (None, None)
        """Organizer-only: the ``(target, tool)`` ids the last pixel-addressed action named
        (None where it named none or nothing); never part of the observation."""
        self.observation_space = self._observation_space()
        self.action_space = self._action_space()

    def _action_space(self) -> spaces.Dict:
        fields: list[tuple[str, spaces.Space[Any]]] = [
            ("primitive", spaces.Discrete(len(PRIMITIVES))),
            ("move", spaces.Box(-1.0, 1.0, (2,), np.float32)),
        ]
        if self.config.actions_by == "pixel":
            w, h = self.config.image_size
            fields += [("target_px", spaces.MultiDiscrete([w, h])),  # [u, v]
                       ("tool_px", spaces.MultiDiscrete([w, h]))]
        else:
            fields += [("target", spaces.Discrete(MAX_IDS)), ("tool", spaces.Discrete(MAX_IDS))]
        return spaces.Dict(fields)

    def _observation_space(self) -> spaces.Dict:
        cfg, k = self.config, self.config.max_detections
        big = cfg.sensing_range + 1.0 + 6 * (cfg.position_noise[0] + cfg.position_noise[1]
                                             * cfg.sensing_range)

        def ints(lo: int, hi: int, shape: tuple[int, ...], dtype: Any = np.int32) -> spaces.Box:
            return spaces.Box(lo, hi, shape, dtype)

        obs: dict[str, spaces.Space[Any]] = {
            "odometry": spaces.Box(
                np.array([-10.0, -10.0, -math.pi], np.float32),
                np.array([100.0, 100.0, math.pi], np.float32),
                dtype=np.float32,
            ),
            "range_scan": spaces.Box(0.0, cfg.scan_range, (cfg.scan_rays,), np.float32),
            "room": ints(-1, MAX_ROOMS - 1, (1,)),
            "room_type": ints(-1, len(ROOM_TYPES) - 1, (1,)),
            "held": ints(0, 1, (1,)) if cfg.held == "flag" else ints(-1, MAX_IDS - 1, (1,)),
            "last_action_ok": ints(0, 1, (1,), np.int8),
            "collided": ints(0, 1, (1,), np.int8),
        }
        if cfg.detections:
            obs.update({
                "det_mask": ints(0, 1, (k,), np.int8),
                "det_id": ints(-1, MAX_IDS - 1, (k,)),
                "det_kind": ints(-1, len(KINDS) - 1, (k,)),
                "det_category": ints(-1, len(CATEGORIES) - 1, (k,)),
                "det_colour": ints(-1, len(COLOURS) - 1, (k,)),
                "det_state": ints(-1, len(STATES) - 1, (k,)),
                "det_rel_pos": spaces.Box(-big, big, (k, 2), np.float32),
            })
        if cfg.render_rgbd:
            w, h = cfg.image_size
            obs["rgb"] = spaces.Box(0, 255, (h, w, 3), np.uint8)
            obs["depth"] = spaces.Box(0.0, _MAX_DEPTH, (h, w), np.float32)
            if cfg.segmentation:
                obs["segmentation"] = ints(-1, MAX_IDS - 1, (h, w))
        return spaces.Dict(list(obs.items()))

    # ----------------------------------------------------------------- gymnasium API
    @property
    def layout(self) -> HouseLayout:
        """The current house (after the first reset when the layout is not fixed)."""
        return self._house().layout

    def _house(self) -> House:
        if self.house is None:
            raise gym.error.ResetNeeded("call reset() first: the house is chosen by reset's seed")
        return self.house

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode (``reset_typed``, with gymnasium's plain ``info`` dict)."""
        obs, info = self.reset_typed(seed=seed, options=options)
        return obs, info.as_dict()

    def step(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Run one primitive (``step_typed``, with gymnasium's plain ``info`` dict)."""
        obs, reward, terminated, truncated, info = self.step_typed(action)
        return obs, reward, terminated, truncated, info.as_dict()

    def observe(self) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """The observation and info of the current state, without stepping (``observe_typed``
        with gymnasium's plain ``info`` dict)."""
        obs, info = self.observe_typed()
        return obs, info.as_dict()

    def reset_typed(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], HouseInfo]:
        """Start an episode. Without a fixed layout, ``seed`` selects the house (same seed,
        same house); with ``seed=None`` the next house comes from the env's seeded RNG. The
        seed also keys the sensors' noise (same seed and actions, same observations).

        ``options``: ``{"task": HouseTask | dict}`` sets the task of the shaped reward.
        """
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = set(options) - {"task"}
        if unknown:
            raise ValueError(f"unknown reset options {sorted(unknown)}; only 'task' is understood")
        if self._fixed is None:
            house_seed = seed if seed is not None else int(self.np_random.integers(_SEED_SPACE))
            if self.house is not None and self.house.layout.seed == house_seed:
                self.house.reset(house_seed)
            else:
                if self.house is not None:
                    self.house.sim.close()
                self.house = House(generate_house(house_seed, params=self.params), self.config,
                                   noise_seed=house_seed)
        else:
            noise = seed if seed is not None else int(self.np_random.integers(_SEED_SPACE))
            self._house().reset(noise)
        house = self._house()
        task = options.get("task")
        self.task = HouseTask.parse(task, house.layout) if task is not None else None
        if self.task is not None and house.task_satisfied(self.task):
            house.world.task_done = True  # already true at the start: nothing to reward
        self._last = ActionResult("reset", True)
        return self._observation(), self._info()

    def step_typed(self, action: Any) -> tuple[dict[str, np.ndarray], float, bool, bool, HouseInfo]:
        """Run one primitive. A failed precondition changes nothing and says why in
        ``info.action_result``."""
        house = self._house()
        parsed = parse_action(action) if self.config.actions_by == "id" else self._by_pixel(action)
        if isinstance(parsed, ActionResult):
            result = parsed
            house.world.steps += 1
        else:
            primitive, forward, turn, target, tool = parsed
            result = house.execute(primitive, forward=forward, turn=turn, target=target, tool=tool)
        self._last = result
        reward = 0.0
        if self.task is not None:
            if not result.ok:
                reward -= self.config.failure_penalty
            if not house.world.task_done and house.task_satisfied(self.task):
                house.world.task_done = True
                reward += 1.0
        terminated = result.primitive == "done" and result.ok
        return self._observation(), reward, terminated, False, self._info()

    def _by_pixel(self, action: Any) -> tuple[str, float, float, int, int] | ActionResult:
        """A pixel-addressed action with its pixels resolved to the instances under them in
        the last frame (``target_px`` for the targeted primitives, ``tool_px`` for ``use``,
        absent: the held item); a failed ``ActionResult`` when it names nothing."""
        self.resolved = (None, None)
        parsed = parse_pixel_action(action, self.config.image_size)
        if isinstance(parsed, ActionResult):
            return parsed
        primitive, forward, turn, target_px, tool_px = parsed
        if primitive not in _TARGETED:
            return primitive, forward, turn, 0, 0
        if target_px is None:
            return ActionResult(primitive, False, "invalid_action")
        target, tool = self.instance_at(target_px), self._house().world.held
        if primitive == "use" and tool_px is not None:
            tool = self.instance_at(tool_px)
            if tool < 0:
                return ActionResult(primitive, False, "nothing_there")
        if target < 0:
            return ActionResult(primitive, False, "nothing_there")
        self.resolved = (target, tool if primitive == "use" else None)
        return primitive, forward, turn, target, tool

    def instance_at(self, pixel: Pixel) -> int:
        """Organizer-only: the instance id under a pixel ``(u, v)`` of the last frame
        observed (-1: nothing, e.g. a wall, the floor or the robot; also before the first
        frame)."""
        if self._frame_ids is None:
            return -1
        u, v = pixel
        return int(self._frame_ids[v, u])

    def last_segmentation(self) -> np.ndarray | None:
        """Organizer-only: the instance id at each pixel of the last frame observed (-1:
        none), kept whether or not the observation carries it; None without frames."""
        return None if self._frame_ids is None else self._frame_ids.copy()

    def frame_instances(self) -> set[int]:
        """Organizer-only: the instance ids the last frame shows (empty without frames)."""
        if self._frame_ids is None:
            return set()
        return {int(i) for i in np.unique(self._frame_ids) if i >= 0}

    def observe_typed(self) -> tuple[dict[str, np.ndarray], HouseInfo]:
        """The observation and info of the current state, without stepping (e.g. after a
        perturbation); the sensors' draws are those of the current step."""
        return self._observation(), self._info()

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """A top-down picture when ``render_mode="rgb_array"``."""
        if self.render_mode != "rgb_array":
            return None
        return render_topdown(self)

    def close(self) -> None:
        """Release the renderer."""
        if self.house is not None:
            self.house.sim.close()

    # ----------------------------------------------------------------- observations
    def _observation(self) -> dict[str, np.ndarray]:
        house, cfg, k = self._house(), self.config, self.config.max_detections
        x, y, yaw = house.odometry
        room = house.room_sign()
        dets = house.detections()[:k] if cfg.detections else []
        n = len(dets)
        obs: dict[str, np.ndarray] = {
            "odometry": np.array([x, y, yaw], dtype=np.float32),
            "range_scan": house.sim.range_scan(cfg.scan_rays, cfg.scan_range),
            "room": np.array([room], dtype=np.int32),
            "room_type": np.array(
                [ROOM_TYPES.index(house.layout.rooms[room].type) if room >= 0 else -1],
                dtype=np.int32,
            ),
            "held": np.array([house.world.held if cfg.held == "id"
                              else int(house.world.held >= 0)], dtype=np.int32),
            "last_action_ok": np.array([int(self._last.ok)], dtype=np.int8),
            "collided": np.array([int(self._last.collided)], dtype=np.int8),
        }
        if cfg.detections:
            obs.update({
                "det_mask": np.zeros(k, np.int8),
                "det_id": np.full(k, -1, np.int32),
                "det_kind": np.full(k, -1, np.int32),
                "det_category": np.full(k, -1, np.int32),
                "det_colour": np.full(k, -1, np.int32),
                "det_state": np.full(k, -1, np.int32),
                "det_rel_pos": np.zeros((k, 2), np.float32),
            })
        if n:
            obs["det_mask"][:n] = 1
            obs["det_id"][:n] = [d.id for d in dets]
            obs["det_kind"][:n] = [KINDS.index(d.kind) for d in dets]
            obs["det_category"][:n] = [CATEGORIES.index(d.category) for d in dets]
            obs["det_colour"][:n] = [COLOURS.index(d.colour) for d in dets]
            obs["det_state"][:n] = [STATES.index(d.state) for d in dets]
            high = self.observation_space["det_rel_pos"].high[0, 0]
            obs["det_rel_pos"][:n] = np.clip([d.rel_pos for d in dets], -high, high)
        if cfg.render_rgbd:
            w, h = cfg.image_size
            obs["rgb"], depth, segmentation = house.sim.render_rgbd(w, h)
            if cfg.segmentation:
                obs["segmentation"] = segmentation
            obs["depth"] = np.minimum(depth, np.float32(_MAX_DEPTH))  # no hit: the far plane
            self._frame_ids = segmentation
        return obs

    def _info(self) -> HouseInfo:
        house = self._house()
        room = house.room_sign()
        return HouseInfo(
            action_result=self._last,
            detections=tuple(house.detections()) if self.config.detections else (),
            room=room,
            room_type=house.layout.rooms[room].type if room >= 0 else None,
            held=house.world.held if self.config.held == "id" else int(house.world.held >= 0),
            step=house.world.steps,
            sim_warnings=house.sim.warnings(),
            task_satisfied=None if self.task is None else house.task_satisfied(self.task),
        )

    # ----------------------------------------------------------------- organizer API
    def ground_truth(self) -> HouseTruth:
        """Organizer-only ground truth; never send it to the agent."""
        return self._house().ground_truth()

    def lock_door(self, door_id: int) -> dict[str, Any]:
        """Close and lock a door; returns an event dict. Raises PerturbationError."""
        return self._house().lock_door(door_id)

    def relocate_object(
        self, object_id: int, room_id: int | None = None, *, receptacle: int | None = None,
        shut: bool = False,
    ) -> dict[str, Any]:
        """Move an item to a room (default: the backup area) or into a given receptacle
        (``shut``: a container is closed after); returns an event dict."""
        return self._house().relocate_object(object_id, room_id, receptacle=receptacle,
                                             shut=shut)

    def make_container_unavailable(self, container_id: int) -> dict[str, Any]:
        """Make a container unusable for good; returns an event dict."""
        return self._house().make_container_unavailable(container_id)

    def remove_tool(self, tool_id: int) -> dict[str, Any]:
        """Remove a tool from the house; returns an event dict."""
        return self._house().remove_tool(tool_id)

    def shortest_path(
        self, from_room: int, to_room: int, *, avoid_locked: bool = True
    ) -> list[int]:
        """Fewest-doors room path, both ends included; [] when none."""
        return self._house().shortest_path(from_room, to_room, avoid_locked=avoid_locked)

    def has_recoverable_path(
        self, task: HouseTask | dict[str, Any] | None = None, *, rooms: tuple[int, ...] = ()
    ) -> bool:
        """True when, from the robot's room and avoiding locked doors, every listed room is
        reachable and the task (default: the reset task) can still be completed."""
        house = self._house()
        chosen = self.task if task is None else HouseTask.parse(task, house.layout)
        return not house.task_blockers(chosen, tuple(rooms))

    def teleport_robot(self, x: float, y: float, yaw: float) -> None:
        """Place the robot (tests and scenario setup; never an agent action)."""
        self._house().teleport_robot(x, y, yaw)

    def get_state(self) -> bytes:
        """Full state for replay: MuJoCo integration state plus the symbolic world."""
        return self._house().get_state()

    def set_state(self, state: bytes) -> None:
        """Restore :meth:`get_state` output of the same house."""
        self._house().set_state(state)

    def state_hash(self) -> str:
        """sha256 (hex) of the full state."""
        return self._house().state_hash()
