"""The bench every family shares: table, gripper, cameras, and a view of the simulation.

The gripper is joint-driven: a hand on three world-aligned slides (x, y, z) and a yaw hinge,
position-servoed with capped forces, and two fingers on slides along the hand's y axis. Its
origin is the tool centre point (TCP), level with the fingertips. The table top is at z = 0,
x points away from the robot's side of the table; the hand reaches x, y in [-0.3, 0.3] and
z in [0.003, 0.3] m, yaw in [-3.2, 3.2] rad, and starts at ``HOME``. Fingers squeeze with at
most ``GRIP_FORCE`` each. Two fixed cameras (``CAMERAS``) look down at the table from opposite
sides, 60 degrees below the horizon, low enough to see under the gripper at ``HOME``: the
``overview`` camera from the robot's side frames the near half of the bench, the ``front``
camera from across the table the far half. Physics: 2 ms implicit-fast steps, elliptic
friction cones, auto-reset disabled.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from simhost.worlds.assets import ASSET_DIR

CONTROL_HZ = 20
PHYSICS_DT = 0.002
SUBSTEPS = 25  # 25 x 2 ms = one 50 ms control step
DPOS_MAX = 0.015  # m per control step at |action| = 1
DYAW_MAX = 0.15  # rad per control step at |action| = 1
WIDTH_MAX = 0.09  # m, finger opening at gripper command +1
LEAD_POS = 0.02  # the position target stays within this of the hand (bounds pushing force)
LEAD_YAW = 0.3
WORKSPACE_LO = np.array([-0.30, -0.30, 0.003, -3.2])
WORKSPACE_HI = np.array([0.30, 0.30, 0.30, 3.2])
HOME = np.array([-0.05, 0.0, 0.18, 0.0])
FINGER_HALF = (0.01, 0.006, 0.03)  # finger box half-sizes (x, y, z)
PALM_BOTTOM = 0.058  # palm underside above the TCP
GRIP_FORCE = 20.0  # N, cap of each finger's servo force

ACTION_NAMES = ("dx", "dy", "dz", "dyaw", "grip")
PROPRIO_NAMES = ("x", "y", "z", "yaw", "width", "contact_left", "contact_right")
FORCE_NAMES = ("left", "right", "palm", "fx", "fy", "fz")
PART_FIELDS = ("present", "x", "y", "z", "qw", "qx", "qy", "qz", "joint", "age")
HAND_JOINTS = ("hand_x", "hand_y", "hand_z", "hand_yaw")

VISUAL_GROUP = 2
"""Geom group of the visual-only geoms (meshes that show a part as what it is): rendered by
default, never in contact (``contype=0 conaffinity=0``), massless (``density=0``), and no
ray sees them (``RAY_GROUPS``)."""
HIDDEN_GROUP = 3
"""Geom group of collision geoms a visual geom shows instead: in contact, not rendered."""
RAY_GROUPS = np.array([1, 1, 0, 1, 1, 1], dtype=np.uint8)
"""``mj_ray``'s geom group mask: every group but ``VISUAL_GROUP``."""
CAMERAS = ("overview", "front")
"""The bench's cameras, both ``CAMERA_FOVY`` degrees high, their image 4:3 (W:H), 60 degrees below
the horizon. Each frames its band of the table, every point of it from the table top to 8 cm
above, at the official image size: ``overview`` at (-0.38, 0, 0.46) m looking along +x,
x in [-0.24, 0.06] m (the pegs, the assembly's loose parts, the tools); ``front`` at
(0.555, 0, 0.51) m looking along -x, x in [0.06, 0.46] m (holes, trays, handles, housings,
wells, the puck); both y in [-0.19, 0.19] m. A ray from either to a part under the gripper at
``HOME`` passes below the fingertips."""
CAMERA_FOVY = 40.0


def image_key(channel: str, camera: str) -> str:
    """The observation key of a camera's image ``channel`` (``rgb``, ``depth``,
    ``segmentation``): the channel itself for ``overview``, ``rgb_front`` and so on for the
    others."""
    return channel if camera == CAMERAS[0] else f"{channel}_{camera}"

METAL = "0.85 0.86 0.88 1"
DARK = "0.25 0.25 0.27 1"


def dress(geoms: str | list[str] | tuple[str, ...], material: str,
          rgba: str | None = "1 1 1 1") -> str:
    """The ``<geom>`` elements of ``geoms`` with a material (``rgba``, a tint multiplied onto
    its texture, replaces theirs; ``None`` keeps theirs). Visual attributes only."""
    xml = "".join(geoms) if not isinstance(geoms, str) else geoms
    if rgba is not None:
        xml = re.sub(r' rgba="[^"]*"', "", xml)
        return xml.replace("<geom ", f'<geom material="{material}" rgba="{rgba}" ')
    return xml.replace("<geom ", f'<geom material="{material}" ')


def hide(geoms: str) -> str:
    """Collision geoms moved to ``HIDDEN_GROUP``: a visual geom shows them."""
    return geoms.replace("<geom ", f'<geom group="{HIDDEN_GROUP}" ')


def look(mesh: str, material: str, *, pos: str = "0 0 0", quat: str = "1 0 0 0",
         rgba: str = "1 1 1 1") -> str:
    """A visual-only geom showing the mesh asset ``mesh``."""
    return (f'<geom class="visual" type="mesh" mesh="{mesh}" material="{material}" '
            f'pos="{pos}" quat="{quat}" rgba="{rgba}"/>')


_TEXTURES = (("wood_dark", "wood_dark.png"), ("wood_light", "wood_light.png"),
             ("steel", "steel_brushed.png"), ("brass", "brass.png"))
"""Materials every bench declares (cube textures: meshes have no texture coordinates),
from the asset library (``simhost/worlds/assets/README.md``), plus ``table`` (wood_table.png)."""


@dataclass(frozen=True)
class Scene:
    """A family's contribution to the MJCF document."""

    bodies: str
    assets: str = ""
    contact: str = ""


def build_mjcf(scene: Scene, *, surface_friction: float, grip_slip: bool = False,
               image_size: tuple[int, int] = (480, 640)) -> str:
    """The whole MJCF document: options, table, gripper, cameras and the family's bodies.

    With ``grip_slip`` the fingers' contacts take the touched geom's friction (the fingers
    have the lower ``priority``): a grasp on a slippery part can slip.
    """
    lo, hi = WORKSPACE_LO, WORKSPACE_HI
    prio = ' priority="-1"' if grip_slip else ""
    fx, fy, fz = FINGER_HALF
    wmax = WIDTH_MAX / 2 + 0.001
    materials = "".join(
        f'<texture name="{n}" type="cube" file="{f}"/><material name="{n}" texture="{n}"/>'
        for n, f in _TEXTURES)
    return f"""<mujoco model="eagc_bench">
  <compiler angle="radian" autolimits="true" meshdir="{ASSET_DIR / 'meshes'}"
    texturedir="{ASSET_DIR / 'textures'}"/>
  <option timestep="{PHYSICS_DT}" integrator="implicitfast" cone="elliptic" impratio="10">
    <flag autoreset="disable"/>
  </option>
  <visual><quality offsamples="0" shadowsize="0"/>
    <global offwidth="{image_size[1]}" offheight="{image_size[0]}"/></visual>
  <default>
    <geom solref="0.01 1" solimp="0.95 0.99 0.001"/>
    <default class="fixture"><geom friction="{surface_friction:.4f} 0.005 0.0001"
      rgba="0.55 0.57 0.62 1"/></default>
    <default class="visual"><geom contype="0" conaffinity="0" density="0"
      group="{VISUAL_GROUP}"/></default>
  </default>
  <asset>
    <texture name="table" type="2d" file="wood_table.png"/>
    <material name="table" texture="table" texuniform="true" texrepeat="4 4"/>
    {materials}
    {scene.assets}
  </asset>
  <worldbody>
    <light pos="0 0 1.2" dir="0 0 -1" directional="true" castshadow="false"/>
    <camera name="overview" pos="-0.38 0 0.46" xyaxes="0 -1 0 0.866025 0 0.5"
      fovy="{CAMERA_FOVY:g}"/>
    <camera name="front" pos="0.555 0 0.51" xyaxes="0 1 0 -0.866025 0 0.5"
      fovy="{CAMERA_FOVY:g}"/>
    <geom name="table" class="fixture" type="box" pos="0.05 0 -0.02" size="0.5 0.45 0.02"
      material="table" rgba="1 1 1 1"/>
    <body name="hand" gravcomp="1">
      <joint name="hand_x" type="slide" axis="1 0 0" range="{lo[0]} {hi[0]}"
        damping="80" armature="0.3"/>
      <joint name="hand_y" type="slide" axis="0 1 0" range="{lo[1]} {hi[1]}"
        damping="80" armature="0.3"/>
      <joint name="hand_z" type="slide" axis="0 0 1" range="{lo[2]} {hi[2]}"
        damping="80" armature="0.3"/>
      <joint name="hand_yaw" type="hinge" axis="0 0 1" range="{lo[3]} {hi[3]}"
        damping="0.8" armature="0.01"/>
      <geom name="palm" type="box" pos="0 0 {PALM_BOTTOM + 0.012}" size="0.02 0.062 0.012"
        mass="0.6" material="steel" rgba="0.5 0.52 0.56 1" friction="1.0 0.01 0.0001"/>
      <geom class="visual" type="cylinder" pos="0 0 {PALM_BOTTOM + 0.032:.4f}" size="0.03 0.008"
        material="steel" rgba="{DARK}"/>
      <geom class="visual" type="cylinder" pos="0 0 {PALM_BOTTOM + 0.06:.4f}" size="0.022 0.02"
        material="steel" rgba="{METAL}"/>
      <site name="tcp" pos="0 0 0" size="0.004" rgba="1 0 0 1"/>
      <body name="finger_l" gravcomp="1">
        <joint name="finger_l" type="slide" axis="0 1 0" range="0 {wmax}" damping="4"
          armature="0.01"/>
        <geom name="finger_l" type="box" pos="0 {fy} {fz}" size="{fx} {fy} {fz}" mass="0.05"
          condim="4" friction="1.5 0.02 0.0001" material="steel" rgba="{METAL}"{prio}/>
      </body>
      <body name="finger_r" gravcomp="1">
        <joint name="finger_r" type="slide" axis="0 -1 0" range="0 {wmax}" damping="4"
          armature="0.01"/>
        <geom name="finger_r" type="box" pos="0 {-fy} {fz}" size="{fx} {fy} {fz}" mass="0.05"
          condim="4" friction="1.5 0.02 0.0001" material="steel" rgba="{METAL}"{prio}/>
      </body>
    </body>
    {scene.bodies}
  </worldbody>
  <contact>
    <exclude body1="finger_l" body2="finger_r"/>
    {scene.contact}
  </contact>
  <actuator>
    <position name="act_x" joint="hand_x" kp="1500" forcerange="-40 40"
      ctrlrange="{lo[0]} {hi[0]}"/>
    <position name="act_y" joint="hand_y" kp="1500" forcerange="-40 40"
      ctrlrange="{lo[1]} {hi[1]}"/>
    <position name="act_z" joint="hand_z" kp="1500" forcerange="-40 40"
      ctrlrange="{lo[2]} {hi[2]}"/>
    <position name="act_yaw" joint="hand_yaw" kp="10" forcerange="-4 4"
      ctrlrange="{lo[3]} {hi[3]}"/>
    <position name="act_fl" joint="finger_l" kp="1500" forcerange="-{GRIP_FORCE} {GRIP_FORCE}"
      ctrlrange="0 {wmax}"/>
    <position name="act_fr" joint="finger_r" kp="1500" forcerange="-{GRIP_FORCE} {GRIP_FORCE}"
      ctrlrange="0 {wmax}"/>
  </actuator>
</mujoco>"""


def yaw_of(quat: np.ndarray) -> float:
    """Yaw (rotation about world z) of a unit quaternion (w, x, y, z)."""
    w, x, y, z = (float(v) for v in quat)
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def wrap(angle: float) -> float:
    """Angle wrapped into [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def rot2(yaw: float, v: tuple[float, float] | np.ndarray) -> np.ndarray:
    """The 2-D vector ``v`` rotated by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def quat_z(yaw: float) -> str:
    """MJCF ``quat`` attribute for a rotation of ``yaw`` about z."""
    return f"{math.cos(yaw / 2):.6f} 0 0 {math.sin(yaw / 2):.6f}"
