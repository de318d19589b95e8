"""MJCF for a house layout (a string; no MuJoCo import here).

Names: body ``robot`` (joints and position actuators ``robot_x``, ``robot_y``, ``robot_yaw``;
camera ``eye``); door ``door_<id>`` (hinge joint and actuator ``door_<id>``, equality
``lock_<id>``, indicator geoms ``doorlamp_<id>_<k>``); furniture and container carcasses
``furn_<id>``; container lids ``lid_<id>`` and items ``item_<id>`` are mocap bodies.

Geom groups: 0 walls and furniture, 1 doors, 2 lids, 3 items, 4 what the camera draws
(textured floors and the visual twins of ``_dress.py``), 5 robot. Groups 0-3 hold the
primitives that decide collisions and rays; the camera draws group 4 only. Collisions: only
the robot collides, with walls, furniture and doors (contype/conaffinity 1/2 vs 2/0). Items
and lids are kinematic (mocap) and never collide.
"""

from __future__ import annotations

import math
from xml.sax.saxutils import quoteattr

from ._catalogue import RGBA
from ._dress import Dressing
from ._layout import CARCASS, DOOR_HEIGHT, WALL_HEIGHT, Door, Furniture, HouseLayout, Item

ROBOT_RADIUS = 0.25
EYE_HEIGHT = 1.2
SCAN_HEIGHT = 0.3
HAND = (0.38, 0.0, 0.9)
"""Held-item position in the robot frame."""
TIMESTEP = 0.01
HIDDEN_Z = -5.0
"""Height at which removed items are parked (below the floor, out of every ray)."""

_STATIC = 'contype="2" conaffinity="0"'
_NONE = 'contype="0" conaffinity="0"'
_WOOD = "0.55 0.4 0.26 1"
_CARCASS_RGBA = "0.75 0.72 0.66 1"
_LID_RGBA = "0.35 0.45 0.62 1"
LAMP_RGBA = {False: "0.2 0.75 0.3 1", True: "0.95 0.1 0.1 1"}
"""Door indicator colour, by ``locked``."""


def _f(*values: float) -> str:
    return " ".join(f"{v:.5g}" for v in values)


def yaw_quat(yaw: float) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) of a rotation about z."""
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def _quat_mul(a: tuple[float, ...], b: tuple[float, ...]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def lid_pose(f: Furniture, is_open: bool) -> tuple[tuple[float, float, float], tuple[float, ...]]:
    """World position and quaternion of a container's lid, open or closed."""
    w, d, h = f.size
    if f.opening == "top":
        if is_open:
            local, q = (
                (0.0, -d / 2 + CARCASS / 2, h + d / 2),
                (math.cos(math.pi / 4), math.sin(math.pi / 4), 0.0, 0.0),
            )
        else:
            local, q = (0.0, 0.0, h + CARCASS / 2), (1.0, 0.0, 0.0, 0.0)
    elif is_open:
        local, q = (-w / 2, d / 2 + w / 2, h / 2), yaw_quat(math.pi / 2)
    else:
        local, q = (0.0, d / 2 - CARCASS / 2, h / 2), (1.0, 0.0, 0.0, 0.0)
    c, s = math.cos(f.yaw), math.sin(f.yaw)
    pos = (f.pos[0] + c * local[0] - s * local[1], f.pos[1] + s * local[0] + c * local[1], local[2])
    return pos, _quat_mul(yaw_quat(f.yaw), q)


def _lid_size(f: Furniture) -> tuple[float, float, float]:
    w, d, h = f.size
    if f.opening == "top":
        return (w / 2, d / 2, CARCASS / 2)
    return (w / 2, CARCASS / 2, h / 2)


def _furniture_geoms(f: Furniture) -> list[str]:
    w, d, h = f.size
    t = CARCASS
    name = f"furn_{f.id}"
    if f.kind == "furniture":
        return [
            f'<geom name="{name}_0" type="box" size="{_f(w / 2, d / 2, h / 2)}" '
            f'pos="0 0 {h / 2:.4g}" rgba="{_WOOD}" group="0" {_STATIC}/>'
        ]
    panels = [
        ((0, 0, t / 2), (w / 2, d / 2, t / 2)),
        ((0, -d / 2 + t / 2, h / 2), (w / 2, t / 2, h / 2)),
        ((-w / 2 + t / 2, 0, h / 2), (t / 2, d / 2, h / 2)),
        ((w / 2 - t / 2, 0, h / 2), (t / 2, d / 2, h / 2)),
    ]
    if f.opening == "front":
        panels.append(((0, 0, h - t / 2), (w / 2, d / 2, t / 2)))
    else:
        panels.append(((0, d / 2 - t / 2, h / 2), (w / 2, t / 2, h / 2)))
    return [
        f'<geom name="{name}_{k}" type="box" size="{_f(*half)}" pos="{_f(*pos)}" '
        f'rgba="{_CARCASS_RGBA}" group="0" {_STATIC}/>'
        for k, (pos, half) in enumerate(panels)
    ]


def _item_geom(item: Item) -> str:
    rgba = _f(*RGBA[item.colour])
    if item.shape == "sphere":
        size = _f(item.size[0])
    elif item.shape == "cylinder":
        size = _f(item.size[0], item.size[1])
    else:
        size = _f(*item.size)
    return (
        f'<geom name="item_{item.id}_0" type="{item.shape}" size="{size}" rgba="{rgba}" '
        f'group="3" {_NONE}/>'
    )


def build_mjcf(layout: HouseLayout, *, offscreen: tuple[int, int] = (640, 480)) -> str:
    """The MJCF document of a house in its initial state."""
    width, height = layout.extent
    dress = Dressing()
    lines = [
        f"<mujoco model={quoteattr(f'eagc_house_{layout.seed}')}>",
        '<compiler angle="radian" autolimits="true"/>',
        f'<option timestep="{TIMESTEP}" integrator="implicitfast">',
        '<flag autoreset="disable"/>',
        "</option>",
        "<visual>",
        '<quality shadowsize="0" offsamples="0"/>',
        f'<global offwidth="{max(offscreen[0], 64)}" offheight="{max(offscreen[1], 64)}"/>',
        '<headlight ambient="0.38 0.38 0.38" diffuse="0.4 0.4 0.4" specular="0 0 0"/>',
        '<map znear="0.02" zfar="60"/>',
        "</visual>",
    ]
    body = [
        "<worldbody>",
        # light from above and aslant, so that faces of different slopes shade differently
        f'<light name="sun" directional="true" castshadow="false" '
        f'pos="{_f(width / 2, height / 2, 10)}" dir="0.35 0.5 -0.8" diffuse="0.45 0.45 0.42"/>',
        # one render cell: the plane's grid only costs time (its pixels are the same)
        f'<geom name="floor" type="plane" '
        f'size="{_f(width / 2 + 2, height / 2 + 2, max(width, height) + 4)}" '
        f'pos="{_f(width / 2, height / 2, -0.002)}" rgba="0.5 0.5 0.5 1" group="4" {_NONE}/>',
    ]
    for room in layout.rooms:
        x0, y0, x1, y1 = room.bounds
        body.append(
            f'<geom name="floor_{room.id}" type="box" '
            f'size="{_f((x1 - x0) / 2, (y1 - y0) / 2, 0.001)}" '
            f'pos="{_f((x0 + x1) / 2, (y0 + y1) / 2, 0)}" '
            f'material="{dress.floor(room.type)}" group="4" {_NONE}/>'
        )
    for k, wall in enumerate(layout.walls):
        body.append(
            f'<geom name="wall_{k}" type="box" size="{_f(*wall.half, WALL_HEIGHT / 2)}" '
            f'pos="{_f(*wall.centre, WALL_HEIGHT / 2)}" rgba="0.92 0.91 0.88 1" '
            f'group="0" {_STATIC}/>'
        )
        body.append(dress.wall(f"wallvis_{k}", wall.centre, wall.half, (0.0, WALL_HEIGHT)))
    for door in layout.doors:
        body.extend(_door_body(door, dress))
    for f in layout.furniture:
        body.append(
            f'<body name="furn_{f.id}" pos="{_f(*f.pos, 0)}" quat="{_f(*yaw_quat(f.yaw))}">'
        )
        body.extend(_furniture_geoms(f))
        body.extend(dress.furniture(f))
        body.append("</body>")
        if f.kind == "container":
            pos, quat = lid_pose(f, f.initial_state == "open")
            body.append(
                f'<body name="lid_{f.id}" mocap="true" pos="{_f(*pos)}" quat="{_f(*quat)}">'
            )
            body.append(
                f'<geom name="lid_{f.id}_0" type="box" size="{_f(*_lid_size(f))}" '
                f'rgba="{_LID_RGBA}" group="2" {_NONE}/>'
            )
            body.extend(dress.lid(f))
            body.append("</body>")
    for item in layout.items:
        rec = layout.entity(item.receptacle)
        assert isinstance(rec, Furniture)
        pos = layout.item_position(item, item.receptacle, item.slot)
        body.append(
            f'<body name="item_{item.id}" mocap="true" pos="{_f(*pos)}" '
            f'quat="{_f(*yaw_quat(rec.yaw))}">'
        )
        body.append(_item_geom(item))
        body.extend(dress.item(item))
        body.append("</body>")
    body.extend(_robot_body())
    body.append("</worldbody>")
    lines.extend(dress.assets())
    lines.extend(body)
    lines.append("<actuator>")
    lim = max(width, height) + 2
    for axis in ("x", "y"):
        lines.append(
            f'<position name="robot_{axis}" joint="robot_{axis}" kp="10000" kv="900" '
            f'ctrlrange="{_f(-2, lim)}" forcerange="-600 600"/>'
        )
    lines.append(
        '<position name="robot_yaw" joint="robot_yaw" kp="1000" kv="55" '
        'ctrlrange="-7 7" forcerange="-300 300"/>'
    )
    for door in layout.doors:
        lines.append(
            f'<position name="door_{door.id}" joint="door_{door.id}" kp="600" kv="90" '
            'ctrlrange="-1.7 1.7" forcerange="-400 400"/>'
        )
    lines.append("</actuator>")
    if layout.doors:
        lines.append("<equality>")
        for door in layout.doors:
            active = "true" if door.initial_state == "locked" else "false"
            lines.append(
                f'<joint name="lock_{door.id}" joint1="door_{door.id}" '
                f'polycoef="0 1 0 0 0" active="{active}"/>'
            )
        lines.append("</equality>")
    lines.append("</mujoco>")
    return "\n".join(lines)


def _door_body(door: Door, dress: Dressing) -> list[str]:
    w = door.width
    half = (w / 2 - 0.02, 0.025, DOOR_HEIGHT / 2 - 0.01)
    x, y = door.hinge
    lintel_c = (x + math.cos(door.yaw) * w / 2, y + math.sin(door.yaw) * w / 2)
    lintel_half = (w / 2, 0.05) if abs(math.sin(door.yaw)) < 0.5 else (0.05, w / 2)
    return [
        f'<geom name="lintel_{door.id}" type="box" '
        f'size="{_f(*lintel_half, (WALL_HEIGHT - DOOR_HEIGHT) / 2)}" '
        f'pos="{_f(*lintel_c, (WALL_HEIGHT + DOOR_HEIGHT) / 2)}" rgba="0.92 0.91 0.88 1" '
        f'group="0" {_STATIC}/>',
        dress.wall(f"lintelvis_{door.id}", lintel_c, lintel_half, (DOOR_HEIGHT, WALL_HEIGHT)),
        f'<body name="door_{door.id}" pos="{_f(x, y, 0)}" quat="{_f(*yaw_quat(door.yaw))}">',
        f'<joint name="door_{door.id}" type="hinge" axis="0 0 1" damping="5" armature="0.2" '
        'range="-1.65 1.65"/>',
        f'<geom name="door_{door.id}_0" type="box" size="{_f(*half)}" '
        f'pos="{_f(w / 2, 0, DOOR_HEIGHT / 2 + 0.01)}" rgba="0.62 0.45 0.3 1" mass="8" '
        f'group="1" {_STATIC}/>',
        f'<geom name="doorlamp_{door.id}" type="box" size="0.05 0.035 0.05" '
        f'pos="{_f(w - 0.15, 0, 1.1)}" rgba="{LAMP_RGBA[False]}" group="1" mass="0.01" {_NONE}/>',
        *dress.door(door),
        "</body>",
    ]


def _robot_body() -> list[str]:
    r = ROBOT_RADIUS
    return [
        '<body name="robot" pos="0 0 0">',
        '<joint name="robot_x" type="slide" axis="1 0 0" armature="1"/>',
        '<joint name="robot_y" type="slide" axis="0 1 0" armature="1"/>',
        '<joint name="robot_yaw" type="hinge" axis="0 0 1" armature="0.1"/>',
        f'<geom name="robot_base" type="cylinder" size="{_f(r, 0.25)}" pos="0 0 0.3" mass="20" '
        'rgba="0.2 0.25 0.7 1" group="5" contype="1" conaffinity="2"/>',
        '<geom name="robot_mast" type="box" size="0.04 0.04 0.35" pos="0 0 0.9" mass="1" '
        f'rgba="0.3 0.3 0.35 1" group="5" {_NONE}/>',
        f'<geom name="robot_head" type="box" size="0.08 0.12 0.06" pos="0.05 0 {EYE_HEIGHT:.3g}" '
        f'mass="0.5" rgba="0.9 0.9 0.95 1" group="5" {_NONE}/>',
        f'<geom name="robot_nose" type="box" size="0.06 0.05 0.03" pos="0.2 0 0.5" mass="0.1" '
        f'rgba="0.95 0.95 0.95 1" group="5" {_NONE}/>',
        f'<camera name="eye" pos="0.14 0 {EYE_HEIGHT:.3g}" '
        'xyaxes="0 -1 0 0.4226 0 0.9063" fovy="75"/>',
        "</body>",
    ]
