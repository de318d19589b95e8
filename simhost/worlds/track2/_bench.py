"""The bench every family shares: table, gripper, cameras, and a view of the simulation.

The gripper is joint-driven: a hand on three world-aligned slides (x, y, z) and a yaw hinge,
position-servoed with capped forces, and two fingers on slides along the hand's y axis. Its
origin is the tool centre point (TCP), level with the fingertips. The table top is at z = 0,
x points away from the robot's side of the table; the hand reaches x, y in [-0.3, 0.3] and
z in [0.003, 0.3] m, yaw in [-3.2, 3.2] rad, and starts at ``HOME``. Fingers squeeze with at
most ``GRIP_FORCE`` each. Three fixed cameras (``CAMERAS``): two look down at the table from
opposite sides, 60 degrees below the horizon, low enough to see under the gripper at
``HOME`` (the ``overview`` camera from the robot's side frames the near half of the bench,
the ``front`` camera from across the table the far half), and the ``top`` camera looks
straight down into the region of the tool-use family's press wells (``TOP_POS``,
``TOP_FOVY``). Physics: 2 ms implicit-fast steps, elliptic friction cones, auto-reset
disabled.
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
CAMERAS = ("overview", "front", "top")
"""The bench's cameras, every image 4:3 (W:H). ``overview`` and ``front`` are
``CAMERA_FOVY`` degrees high, 60 degrees below the horizon, and each frames its band of the
table, every point of it from the table top to 8 cm above, at the official image size:
``overview`` at (-0.38, 0, 0.46) m looking along +x, x in [-0.24, 0.06] m (the pegs, the
assembly's loose parts, the tools); ``front`` at (0.555, 0, 0.51) m looking along -x,
x in [0.06, 0.46] m (holes, trays, handles, housings, wells, the puck); both
y in [-0.19, 0.19] m. A ray from either to a part under the gripper at ``HOME`` passes below
the fingertips. ``top`` looks straight down (image up = +x, image right = -y) at
``TOP_POS``, ``TOP_FOVY`` degrees high: it shows the buttons at the bottom of the press
wells, which no slanted view sees past the well's walls."""
CAMERA_FOVY = 40.0

WELLS_REGION = ((0.08, 0.18), (-0.10, 0.10))
"""(x, y) ranges (m) of a press well's centre over the instance distribution: the tool-use
family places it at (0.08 + 0.10 u, -0.10 + 0.20 v), ``target_u`` and ``target_v`` in
[0, 1] on every split."""
WELL_IN = 0.011
"""Inner half-width of a press well (m)."""
BUTTON_HALF = 0.008
"""Half-width of a press button's square face (m)."""
BUTTON_TOP = 0.016
"""Height of a press button's face above the table at rest (m)."""
WELL_RIM_MAX = 0.085
"""Height of the deepest well's rim above the table (the top of ``well_depth``'s range)."""
JITTER_MAX = 0.01
"""Largest per-reset offset of a fixture along an axis (m): ``JITTER_CLIP`` (2.5) standard
deviations of the largest ``attempt_jitter_m`` of the splits (0.004, ``challenge``)."""


def _top_camera() -> tuple[tuple[float, float, float], float]:
    """The ``top`` camera's position and vertical field of view (degrees), by rule.

    Framing: the region a button's face can take (``WELLS_REGION`` widened on every side by
    ``JITTER_MAX`` and ``BUTTON_HALF``) fills the image's width (y) or height (x), 4:3, in the
    plane of the button faces, centred. Height: a line of sight to the near edge of a button
    whose centre is farthest from the camera along an image axis passes inside the rim of
    the deepest well, so every button shows its whole face: the rim, ``WELL_RIM_MAX -
    BUTTON_TOP`` above the face, may lean in by no more than the gap between the button and
    the wall (``WELL_IN - BUTTON_HALF``).
    """
    (x0, x1), (y0, y1) = WELLS_REGION
    grow = JITTER_MAX + BUTTON_HALF
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    half_y = max((y1 - y0) / 2 + grow, ((x1 - x0) / 2 + grow) * 4 / 3)  # image width
    far = max((x1 - x0) / 2, (y1 - y0) / 2) + JITTER_MAX - BUTTON_HALF  # near edge, off-axis
    height = (WELL_RIM_MAX - BUTTON_TOP) * far / (WELL_IN - BUTTON_HALF)
    fovy = 2 * math.degrees(math.atan(half_y * 3 / 4 / height))
    return (round(cx, 4), round(cy, 4), round(BUTTON_TOP + height, 4)), round(fovy, 4)


TOP_POS, TOP_FOVY = _top_camera()
"""The ``top`` camera's position (m) and vertical field of view (degrees): ``_top_camera``'s
rule, about 2.35 m above the button faces and 4.3 degrees high: a narrow view from far up,
so that a line of sight to any button leans about 3 degrees from vertical at most."""


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
    <camera name="top" pos="{' '.join(f'{v:g}' for v in TOP_POS)}" xyaxes="0 -1 0 1 0 0"
      fovy="{TOP_FOVY:g}"/>
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
