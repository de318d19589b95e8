"""What the robot could perceive: visibility, exact detections and reach.

Visible means: within the sensing range (horizontal distance from the robot), within the
field of view (the bearing of the entity's centre within half of it from straight ahead; 360
degrees is all-round), and in line of sight from the robot's eye (``mj_ray`` against walls,
doors, furniture and lids; items never occlude). So a robot sees into its room and through
open doorways, never through walls or closed doors. An item inside a container is visible
when the container is open, the robot is on its opening side and the opening is in line of
sight. Held and removed items are never detected. What the detector then reports (misses,
noise, confusion) is ``_perception``'s business.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from ._layout import Door, Furniture, HouseLayout, Item
from ._mjcf import ROBOT_RADIUS
from ._sim import HouseSim
from ._world import WorldState


@dataclass(frozen=True)
class Detection:
    """One visible entity, as the agent sees it."""

    id: int
    kind: str
    category: str
    colour: str
    rel_pos: tuple[float, float]
    """Position in the robot frame: x ahead, y to the left (metres)."""
    state: str
    distance: float

    def to_dict(self) -> dict[str, Any]:
        """The JSON-friendly form sent in ``info["detections"]``."""
        return {
            "id": self.id,
            "kind": self.kind,
            "category": self.category,
            "colour": self.colour,
            "rel_pos": [round(self.rel_pos[0], 4), round(self.rel_pos[1], 4)],
            "state": self.state,
        }


def _points(
    layout: HouseLayout,
    world: WorldState,
    sim: HouseSim,
    entity: Door | Furniture | Item,
    robot: tuple[float, float, float],
) -> tuple[tuple[float, float], list[tuple[float, float, float]], int]:
    """Reference xy, line-of-sight points and the instance a ray may hit, or no points."""
    if isinstance(entity, Door):
        cx, cy = entity.centre
        return (cx, cy), [(cx, cy, 1.0), sim.door_panel_centre(entity)], entity.id
    if isinstance(entity, Furniture):
        w, d, h = entity.size
        fx, fy = entity.front
        top = (entity.pos[0], entity.pos[1], h - 0.02)
        face = (entity.pos[0] + fx * (d / 2 - 0.02), entity.pos[1] + fy * (d / 2 - 0.02), h / 2)
        return entity.pos, [top, face], entity.id
    if entity.id == world.held or entity.id in world.removed:
        return (0.0, 0.0), [], entity.id
    rec_id, slot = world.places[entity.id]
    rec = layout.entity(rec_id)
    assert isinstance(rec, Furniture)
    x, y, z = layout.item_position(entity, rec_id, slot)
    if rec.kind == "container":
        if world.containers[rec_id] != "open":
            return (x, y), [], entity.id
        if rec.opening == "front":
            fx, fy = rec.front
            if (robot[0] - rec.pos[0]) * fx + (robot[1] - rec.pos[1]) * fy < rec.size[1] / 2:
                return (x, y), [], entity.id
        return (x, y), [rec.opening_point], rec_id
    return (x, y), [(x, y, z), (x, y, z + entity.half_height - 0.005)], entity.id


def detect(
    layout: HouseLayout,
    world: WorldState,
    sim: HouseSim,
    sensing_range: float,
    field_of_view: float = 360.0,
    *,
    reveal: bool = True,
    item_range: float | None = None,
) -> list[Detection]:
    """Every visible entity with its exact attributes, nearest first (ties by id).

    ``reveal``: whether locked doors and unavailable containers show it (else they show
    the state they seem to be in). ``item_range``: a shorter range for objects and tools.
    """
    robot = sim.robot_pose()
    rx, ry, yaw = robot
    c, s = math.cos(yaw), math.sin(yaw)
    half_fov = math.radians(field_of_view) / 2
    out = []
    for entity in (*layout.doors, *layout.furniture, *layout.items):
        (ex, ey), points, instance = _points(layout, world, sim, entity, robot)
        if not points:
            continue
        dist = math.hypot(ex - rx, ey - ry)
        if dist > (item_range if item_range and isinstance(entity, Item) else sensing_range):
            continue
        dx, dy = ex - rx, ey - ry
        if half_fov < math.pi and dist > 1e-6:
            bearing = math.atan2(-s * dx + c * dy, c * dx + s * dy)
            if abs(bearing) > half_fov:
                continue
        if not any(sim.line_of_sight(p, instance) for p in points):
            continue
        kind = "door" if isinstance(entity, Door) else entity.kind
        out.append(
            Detection(
                id=entity.id,
                kind=kind,
                category="door" if isinstance(entity, Door) else entity.category,
                colour=entity.colour if isinstance(entity, Item) else "none",
                rel_pos=(c * dx + s * dy, -s * dx + c * dy),
                state=world.visible_state(layout, entity.id, reveal=reveal),
                distance=dist,
            )
        )
    out.sort(key=lambda det: (round(det.distance, 6), det.id))
    return out


def footprint_distance(f: Furniture, x: float, y: float) -> float:
    """Distance from a point to a furniture footprint (0 inside)."""
    x0, y0, x1, y1 = f.footprint
    return math.hypot(max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1))


def robot_blocks(door: Door, x: float, y: float, margin: float = 0.03) -> bool:
    """True when a robot at (x, y) is in the way of the door's swing."""
    reach = ROBOT_RADIUS + margin
    return door.swing_distance(x, y) < reach or door.panel_distance(x, y) < reach
