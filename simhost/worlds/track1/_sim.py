"""The MuJoCo side of a house: model, data, guarded controls, rays and rendering.

Every control goes through :meth:`HouseSim.set_ctrl`, which refuses non-finite values and
clips to the actuator's range, so NaN/Inf never reach ``data.ctrl``.
"""

from __future__ import annotations

import math
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # headless by default; only effective before mujoco loads

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from ._dress import VISUAL_GROUP  # noqa: E402
from ._layout import Door, Furniture, HouseLayout  # noqa: E402
from ._mjcf import (  # noqa: E402
    EYE_HEIGHT,
    HAND,
    HIDDEN_Z,
    LAMP_RGBA,
    SCAN_HEIGHT,
    build_mjcf,
    lid_pose,
    yaw_quat,
)
from ._world import WorldState  # noqa: E402

STATE_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION
_RAY_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)
"""Line of sight: walls and furniture, doors, container lids (items never occlude)."""
_SCAN_GROUPS = np.array([1, 1, 0, 0, 0, 0], dtype=np.uint8)
"""Range scan: what the base can collide with (walls and furniture, doors)."""
_DRAWN_GROUPS = tuple(int(g == VISUAL_GROUP) for g in range(mujoco.mjNGROUP))
"""The camera draws the textured floors and visual twins only, never a primitive."""
_GREY = np.array((0.3, 0.3, 0.3, 1.0), dtype=np.float32)
_CULL_SCALE, _CULL_MARGIN = 1.01, 0.01
"""A geom is culled only when its bounding sphere, grown by 1 % and 1 cm, is out of view."""


def _rgba(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()], dtype=np.float32)


EYE_NEAR = 0.05
"""The camera's near plane (metres): what is closer to the eye is not drawn."""


class HouseSim:
    """MuJoCo model and data of one house, with name lookups and guarded access."""

    def __init__(self, layout: HouseLayout, *, offscreen: tuple[int, int] = (640, 480)) -> None:
        self.layout = layout
        self.model = mujoco.MjModel.from_xml_string(build_mjcf(layout, offscreen=offscreen))
        # MJCF gives the near plane as a share of the model's extent (0.02 is ~0.3 m in a
        # house: an open lid before the eye would go undrawn while the host's line of sight
        # meets it); the eye's is 5 cm whatever the house's size.
        self.model.vis.map.znear = EYE_NEAR / self.model.stat.extent
        self.data = mujoco.MjData(self.model)
        m = self.model
        name = mujoco.mjtObj
        self.robot_body = mujoco.mj_name2id(m, name.mjOBJ_BODY, "robot")
        self.robot_geom = mujoco.mj_name2id(m, name.mjOBJ_GEOM, "robot_base")
        self.robot_qpos = np.array(
            [
                m.jnt_qposadr[mujoco.mj_name2id(m, name.mjOBJ_JOINT, f"robot_{a}")]
                for a in ("x", "y", "yaw")
            ]
        )
        self.robot_dof = np.array(
            [
                m.jnt_dofadr[mujoco.mj_name2id(m, name.mjOBJ_JOINT, f"robot_{a}")]
                for a in ("x", "y", "yaw")
            ]
        )
        self.robot_act = np.array(
            [mujoco.mj_name2id(m, name.mjOBJ_ACTUATOR, f"robot_{a}") for a in ("x", "y", "yaw")]
        )
        self.door_qpos: dict[int, int] = {}
        self.door_dof: dict[int, int] = {}
        self.door_act: dict[int, int] = {}
        self.door_eq: dict[int, int] = {}
        self.door_lamp: dict[int, int] = {}
        for d in layout.doors:
            j = mujoco.mj_name2id(m, name.mjOBJ_JOINT, f"door_{d.id}")
            self.door_qpos[d.id], self.door_dof[d.id] = int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j])
            self.door_act[d.id] = mujoco.mj_name2id(m, name.mjOBJ_ACTUATOR, f"door_{d.id}")
            self.door_eq[d.id] = mujoco.mj_name2id(m, name.mjOBJ_EQUALITY, f"lock_{d.id}")
            self.door_lamp[d.id] = mujoco.mj_name2id(m, name.mjOBJ_GEOM, f"doorlamp_{d.id}")
        self.mocap: dict[int, int] = {}
        for prefix, ids in (
            ("lid", [f.id for f in layout.furniture if f.kind == "container"]),
            ("item", [i.id for i in layout.items]),
        ):
            for eid in ids:
                body = mujoco.mj_name2id(m, name.mjOBJ_BODY, f"{prefix}_{eid}")
                self.mocap[eid] = int(m.body_mocapid[body])
        self.lid_geom = {
            f.id: mujoco.mj_name2id(m, name.mjOBJ_GEOM, f"lid_{f.id}_0")
            for f in layout.furniture
            if f.kind == "container"
        }
        self.door_lamp_drawn = {
            d.id: mujoco.mj_name2id(m, name.mjOBJ_GEOM, f"doorlamp_{d.id}_v") for d in layout.doors
        }
        self.lid_drawn = {fid: np.zeros(0, dtype=np.int32) for fid in self.lid_geom}
        """A container's drawn lid parts (they turn grey as its primitive lid does)."""
        self.geom_instance = np.full(m.ngeom, -1, dtype=np.int32)
        for g in range(m.ngeom):
            gname = mujoco.mj_id2name(m, name.mjOBJ_GEOM, g) or ""
            parts = gname.split("_")
            if parts[0] in ("door", "doorlamp", "furn", "lid", "item") and len(parts) >= 2:
                self.geom_instance[g] = int(parts[1])
                if parts[0] == "lid" and parts[-1].startswith("v"):
                    self.lid_drawn[int(parts[1])] = np.append(self.lid_drawn[int(parts[1])], g)
        self._lid_rgba = {fid: m.geom_rgba[g].copy() for fid, g in self.lid_drawn.items()}
        self.ctrl_lo = m.actuator_ctrlrange[:, 0].copy()
        self.ctrl_hi = m.actuator_ctrlrange[:, 1].copy()
        self._lo: list[float] = self.ctrl_lo.tolist()
        self._hi: list[float] = self.ctrl_hi.tolist()
        """The ranges as Python floats: the clip of every substep's controls, without numpy
        scalars (the same doubles)."""
        qx, qy, qyaw = (int(i) for i in self.robot_qpos)
        self._robot_qpos = (qx, qy, qyaw)
        ax, ay, ayaw = (int(i) for i in self.robot_act)
        self._robot_act = (ax, ay, ayaw)
        self._renderer: mujoco.Renderer | None = None
        self._segment_instance = np.zeros(0, dtype=np.int32)
        self._cull_slot = np.zeros(0, dtype=np.int64)
        self._cull_geom = np.zeros(0, dtype=np.int64)
        self._cull_radius = np.zeros(0)
        self._stepped = False
        """True while ``data`` holds ``mj_step1``'s results for its current state, so that
        the next :meth:`step` may start at ``mj_step2``."""
        self._ray_geom = np.zeros(1, dtype=np.int32)
        self.reveal_exceptions = True
        """Whether a locked door's lamp turns red and an unavailable container's lid grey."""

    # ----------------------------------------------------------------- state sync
    def reset(self, world: WorldState, pose: tuple[float, float, float]) -> None:
        """Reset the data to a symbolic state and a robot pose."""
        mujoco.mj_resetData(self.model, self.data)
        self._stepped = False
        self.set_robot_pose(*pose)
        self.sync(world)

    def sync(self, world: WorldState) -> None:
        """Make doors, lids, items and indicator colours match the symbolic state (teleport)."""
        for door in self.layout.doors:
            self.set_door(door, world.doors[door.id])
        for f in self.layout.furniture:
            if f.kind == "container":
                self.set_lid(f, world.container_state(f.id) == "open")
        for item in self.layout.items:
            self.place_item_mocap(world, item.id)
        self.sync_visuals(world)
        self.forward()

    def sync_visuals(self, world: WorldState) -> None:
        """Model-side colours (not part of the MuJoCo state) from the symbolic state; a
        hidden exception (``reveal_exceptions`` off) changes no colour."""
        show = self.reveal_exceptions
        for door_id, geom in self.door_lamp.items():
            self.model.geom_rgba[geom] = _rgba(LAMP_RGBA[show and world.doors[door_id] == "locked"])
        for door_id, geom in self.door_lamp_drawn.items():
            self.model.geom_rgba[geom] = self.model.geom_rgba[self.door_lamp[door_id]]
        for fid, geom in self.lid_geom.items():
            grey = show and fid in world.unavailable
            self.model.geom_rgba[geom] = (0.3, 0.3, 0.3, 1) if grey else (0.35, 0.45, 0.62, 1)
            drawn = self.lid_drawn[fid]
            self.model.geom_rgba[drawn] = _GREY if grey else self._lid_rgba[fid]

    def set_door(self, door: Door, state: str) -> None:
        """Teleport a door to its state's angle and set its lock."""
        self._stepped = False
        angle = door.open_angle if state == "open" else 0.0
        self.data.qpos[self.door_qpos[door.id]] = angle
        self.data.qvel[self.door_dof[door.id]] = 0.0
        self.set_ctrl(self.door_act[door.id], angle)
        self.data.eq_active[self.door_eq[door.id]] = 1 if state == "locked" else 0

    def set_lid(self, f: Furniture, is_open: bool) -> None:
        """Move a container's lid (mocap) open or closed."""
        self._stepped = False
        pos, quat = lid_pose(f, is_open)
        self.data.mocap_pos[self.mocap[f.id]] = pos
        self.data.mocap_quat[self.mocap[f.id]] = quat

    def place_item_mocap(self, world: WorldState, item_id: int) -> None:
        """Put an item's body where the symbolic state says: slot, hand or hidden."""
        self._stepped = False
        k = self.mocap[item_id]
        if item_id == world.held:
            self.data.mocap_pos[k], self.data.mocap_quat[k] = self.hand_pose()
        elif item_id in world.removed:
            self.data.mocap_pos[k] = (0.0, 0.0, HIDDEN_Z)
        else:
            rec_id, slot = world.places[item_id]
            item = self.layout.entity(item_id)
            rec = self.layout.entity(rec_id)
            assert item is not None and isinstance(rec, Furniture)
            self.data.mocap_pos[k] = self.layout.item_position(item, rec_id, slot)  # type: ignore[arg-type]
            self.data.mocap_quat[k] = yaw_quat(rec.yaw)

    # ----------------------------------------------------------------- robot
    def robot_pose(self) -> tuple[float, float, float]:
        """(x, y, yaw) with yaw wrapped to [-pi, pi]."""
        x, y, yaw = self.robot_joints()
        return (x, y, math.atan2(math.sin(yaw), math.cos(yaw)))

    def robot_joints(self) -> tuple[float, float, float]:
        """(x, y, yaw) of the base's joints as they are (yaw not wrapped)."""
        q, (i, j, k) = self.data.qpos, self._robot_qpos
        return (float(q[i]), float(q[j]), float(q[k]))

    def set_robot_pose(self, x: float, y: float, yaw: float) -> None:
        """Teleport the robot (zero velocity, controllers aimed at the pose)."""
        self._stepped = False
        for k, v in enumerate((x, y, yaw)):
            self.data.qpos[self.robot_qpos[k]] = v
            self.data.qvel[self.robot_dof[k]] = 0.0
        self.set_robot_ctrl(x, y, yaw)

    def set_robot_ctrl(self, x: float, y: float, yaw: float) -> None:
        """Aim the base's position controllers."""
        i, j, k = self._robot_act
        self.set_ctrl(i, x)
        self.set_ctrl(j, y)
        self.set_ctrl(k, yaw)

    def wrap_yaw(self) -> None:
        """Bring the yaw joint back into [-pi, pi] (same physical pose)."""
        q = self.robot_qpos[2]
        yaw = float(self.data.qpos[q])
        if abs(yaw) > math.pi:
            wrapped = math.atan2(math.sin(yaw), math.cos(yaw))
            self._stepped = False
            self.data.qpos[q] = wrapped
            self.set_ctrl(
                int(self.robot_act[2]), float(self.data.ctrl[self.robot_act[2]]) + wrapped - yaw
            )

    def hand_pose(self) -> tuple[tuple[float, float, float], tuple[float, float, float, float]]:
        """World position and orientation of the held-item point."""
        x, y, yaw = self.robot_pose()
        c, s = math.cos(yaw), math.sin(yaw)
        return (x + c * HAND[0] - s * HAND[1], y + s * HAND[0] + c * HAND[1], HAND[2]), yaw_quat(
            yaw
        )

    def set_ctrl(self, actuator: int, value: float) -> None:
        """The only way a control reaches MuJoCo: finite, clipped to the actuator's range."""
        if not math.isfinite(value):
            raise ValueError(f"non-finite control {value!r} for actuator {actuator}")
        self.data.ctrl[actuator] = min(max(value, self._lo[actuator]), self._hi[actuator])

    def robot_in_contact(self) -> bool:
        """True when the robot's base touches a wall, a door or furniture."""
        n = self.data.ncon
        if n == 0:
            return False
        return bool(np.any(self.data.contact.geom[:n] == self.robot_geom))

    def step(self, held: int) -> bool:
        """One physics step, carrying a held item; returns whether the robot is in contact.

        ``mj_step`` split in two: ``mj_step1`` (positions, contacts, velocities) ends a step
        at the new state, where the contact check and every reader between steps need it,
        and the next step starts at ``mj_step2`` instead of computing it again. The same
        arithmetic as ``mj_step`` followed by ``mj_fwdPosition``: states are bit-identical.
        A change to the state outside a step (:meth:`invalidate`) makes the next step
        begin with ``mj_step1``.
        """
        m, d = self.model, self.data
        if not self._stepped:
            mujoco.mj_step1(m, d)
        mujoco.mj_step2(m, d)
        if held >= 0:
            k = self.mocap[held]
            d.mocap_pos[k], d.mocap_quat[k] = self.hand_pose()
        mujoco.mj_step1(m, d)
        self._stepped = True
        return self.robot_in_contact()

    def invalidate(self) -> None:
        """Note a change of ``data`` outside :meth:`step` (a teleport, a lock, a mocap)."""
        self._stepped = False

    def forward(self) -> None:
        """Recompute derived quantities (positions, contacts) after a teleport."""
        mujoco.mj_forward(self.model, self.data)
        self._stepped = True

    # ----------------------------------------------------------------- sensing
    def range_scan(self, n: int, max_range: float) -> np.ndarray:
        """Planar scan at SCAN_HEIGHT from the base, n rays counter-clockwise from ahead."""
        x, y, yaw = self.robot_pose()
        angles = yaw + np.arange(n) * (2 * math.pi / n)
        vec = np.zeros((n, 3))
        vec[:, 0], vec[:, 1] = np.cos(angles), np.sin(angles)
        geomid = np.zeros(n, dtype=np.int32)
        dist = np.zeros(n)
        mujoco.mj_multiRay(
            self.model,
            self.data,
            np.array([x, y, SCAN_HEIGHT]),
            vec.reshape(-1),
            _SCAN_GROUPS,
            1,
            self.robot_body,
            geomid,
            dist,
            None,
            n,
            max_range,
        )
        dist[(dist < 0) | (dist > max_range)] = max_range
        return dist.astype(np.float32)

    def line_of_sight(self, point: tuple[float, float, float], instance: int) -> bool:
        """True when nothing but the entity itself lies between the robot's eye and a point."""
        x, y, _ = self.robot_pose()
        eye = np.array([x, y, EYE_HEIGHT])
        vec = np.asarray(point, dtype=float) - eye
        length = float(np.linalg.norm(vec))
        if length < 1e-6:
            return True
        hit = mujoco.mj_ray(
            self.model,
            self.data,
            eye,
            vec / length,
            _RAY_GROUPS,
            1,
            self.robot_body,
            self._ray_geom,
        )
        if hit < 0 or hit >= length - 0.05:
            return True
        return int(self.geom_instance[self._ray_geom[0]]) == instance

    def door_panel_centre(self, door: Door) -> tuple[float, float, float]:
        """World centre of a door's panel (follows the hinge)."""
        angle = float(self.data.qpos[self.door_qpos[door.id]]) + door.yaw
        x, y = door.hinge
        return (x + math.cos(angle) * door.width / 2, y + math.sin(angle) * door.width / 2, 1.0)

    # ----------------------------------------------------------------- state and rendering
    def get_physics(self) -> np.ndarray:
        """The full integration state (``mjSTATE_INTEGRATION``)."""
        out = np.empty(mujoco.mj_stateSize(self.model, STATE_SPEC))
        mujoco.mj_getState(self.model, self.data, out, STATE_SPEC)
        return out

    def set_physics(self, state: np.ndarray) -> None:
        """Restore an integration state and recompute derived quantities."""
        mujoco.mj_setState(self.model, self.data, state, STATE_SPEC)
        self.forward()

    def state_size(self) -> int:
        """Length of :meth:`get_physics`."""
        return int(mujoco.mj_stateSize(self.model, STATE_SPEC))

    def warnings(self) -> dict[str, int]:
        """MuJoCo warning counters by name (``mjWARN_*`` without the prefix, lower case)."""
        return {
            name.removeprefix("mjWARN_").lower(): int(self.data.warning[int(value)].number)
            for name, value in mujoco.mjtWarning.__members__.items()
            if name != "mjNWARNING"
        }

    def render_rgbd(self, width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """RGB uint8[H,W,3], depth float32[H,W] (metres) and instance ids int32[H,W] (-1: none).

        Two passes of one ``mujoco.Renderer``'s context: the lit scene, read back as RGB and
        depth together, and the segmentation scene; the same pixels and depths as the
        renderer's own ``render()`` in its RGB, depth and segmentation modes. Scene geoms
        whose bounding sphere lies wholly outside the camera's view are not drawn in either
        pass (:meth:`_cull`): they give no pixel, and each costs a draw call per pass.
        """
        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, height, width)
            self._scene_option = mujoco.MjvOption()
            self._scene_option.geomgroup[:] = _DRAWN_GROUPS
            self._rgb = np.empty((height, width, 3), dtype=np.uint8)
            self._zbuf = np.empty((height, width), dtype=np.float32)
            self._seg = np.empty((height, width, 3), dtype=np.uint8)
        r = self._renderer
        r.update_scene(self.data, camera="eye", scene_option=self._scene_option)
        scene, context, rect = r.scene, r._mjr_context, r._rect  # noqa: SLF001
        if r._gl_context:  # noqa: SLF001
            r._gl_context.make_current()  # noqa: SLF001
        geoms = scene.geoms
        culled = self._cull(scene, width / height)
        types = [int(geoms[k].type) for k in culled]
        for k in culled:
            geoms[k].type = mujoco.mjtGeom.mjGEOM_NONE
        flags = scene.flags
        segment, idcolor = mujoco.mjtRndFlag.mjRND_SEGMENT, mujoco.mjtRndFlag.mjRND_IDCOLOR
        saved = (flags[segment], flags[idcolor])
        try:
            mujoco.mjr_render(rect, scene, context)
            mujoco.mjr_readPixels(self._rgb, self._zbuf, rect, context)
            flags[segment] = flags[idcolor] = 1
            mujoco.mjr_render(rect, scene, context)
        finally:
            flags[segment], flags[idcolor] = saved
            for k, kind in zip(culled, types, strict=True):
                geoms[k].type = kind
        mujoco.mjr_readPixels(self._seg, None, rect, context)
        rgb = np.flipud(self._rgb).copy()
        depth = _metric_depth(np.flipud(self._zbuf), self.model)
        seg = self._seg.astype(np.int32)[::-1]
        segid = seg[:, :, 0] | (seg[:, :, 1] << 8) | (seg[:, :, 2] << 16)
        return rgb, depth, np.take(self._segment_table(scene), segid)

    def _segment_table(self, scene: mujoco.MjvScene) -> np.ndarray:
        """Instance id by segmentation colour (scene geom index + 1; 0: background)."""
        self._index_scene(scene)
        return self._segment_instance

    def _index_scene(self, scene: mujoco.MjvScene) -> None:
        """What the scene's geoms are, once per scene layout: the segmentation table, and
        the model geom and bounding radius of each scene geom that may be culled.

        The scene holds the drawn group's geoms in model order whatever the state (colours
        change, never which geoms are drawn), so its layout is known by its length.
        """
        n = scene.ngeom
        if len(self._segment_instance) == n + 1:
            return
        table = np.full(n + 1, -1, dtype=np.int32)
        slots, objids = [], []
        geom, plane = int(mujoco.mjtObj.mjOBJ_GEOM), int(mujoco.mjtGeom.mjGEOM_PLANE)
        for k in range(n):
            g = scene.geoms[k]
            if g.objtype != geom or g.objid < 0:
                continue
            if g.segid >= 0:
                table[g.segid + 1] = self.geom_instance[g.objid]
            if g.type != plane and self.model.geom_rbound[g.objid] > 0:
                slots.append(k)
                objids.append(g.objid)
        self._segment_instance = table
        self._cull_slot = np.array(slots, dtype=np.int64)
        self._cull_geom = np.array(objids, dtype=np.int64)
        self._cull_radius = self.model.geom_rbound[self._cull_geom] * _CULL_SCALE + _CULL_MARGIN

    def _cull(self, scene: mujoco.MjvScene, aspect: float) -> list[int]:
        """Scene geoms whose bounding sphere lies wholly outside the camera's view frustum
        (behind the near plane or beyond a side plane), with a margin; planes are kept.

        The frustum is the scene camera's, as ``mjr_render`` sets it up: top and bottom at
        the near distance, and a half-width of the viewport's aspect times the half-height
        about its centre (or the camera's own width where it has one).
        """
        self._index_scene(scene)
        if len(self._cull_slot) == 0:
            return []
        cam = scene.camera[0]
        pos = np.asarray(cam.pos, dtype=np.float64)
        forward = np.asarray(cam.forward, dtype=np.float64)
        up = np.asarray(cam.up, dtype=np.float64)
        right = np.cross(forward, up)
        near = float(cam.frustum_near)
        bottom, top = float(cam.frustum_bottom), float(cam.frustum_top)
        half = max(0.5 * aspect * (top - bottom), float(cam.frustum_width))
        centre = float(cam.frustum_center)
        rel = self.data.geom_xpos[self._cull_geom] - pos
        x, y, f = rel @ right, rel @ up, rel @ forward
        radius = self._cull_radius
        out = f < near - radius
        for slope, sign, coord in (
            ((centre + half) / near, 1.0, x),
            ((centre - half) / near, -1.0, x),
            (top / near, 1.0, y),
            (bottom / near, -1.0, y),
        ):
            out |= sign * (coord - slope * f) / math.sqrt(1.0 + slope * slope) > radius
        return self._cull_slot[out].tolist()

    def close(self) -> None:
        """Release the renderer, if any."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _metric_depth(zbuf: np.ndarray, model: mujoco.MjModel) -> np.ndarray:
    """Metres from the depth buffer of a perspective camera (``mujoco.Renderer``'s formula)."""
    extent = model.stat.extent
    zfar = np.float32(model.vis.map.zfar * extent)
    znear = np.float32(model.vis.map.znear * extent)
    c_coef = -(zfar + znear) / (zfar - znear)
    d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
    c_coef = np.float32(-0.5) * c_coef - np.float32(0.5)
    d_coef = np.float32(-0.5) * d_coef
    return (d_coef / (zbuf.astype(np.float64) + c_coef)).astype(np.float32)
