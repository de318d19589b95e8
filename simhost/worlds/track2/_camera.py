"""``BenchCameras``: RGB and depth of the bench's cameras, each from a single render pass.

``mujoco.Renderer`` renders RGB and depth in two passes (depth in a second pass with
segment colouring). One ``mjr_render`` followed by one ``mjr_readPixels`` of both buffers
gives the same RGB and the same depth buffer; depth is converted to metres exactly as
``mujoco.Renderer`` does (same float32/float64 steps), so the images are bit-identical.
Every camera renders through one GL context and one scene into an offscreen buffer of the
image's size (``build_mjcf`` sets ``offwidth``/``offheight``): the picture does not depend on
the buffer's size, only on the viewport.
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np


class _OwnedContext(mujoco.GLContext):  # type: ignore[misc,name-defined]
    """A GL context freed only by :meth:`BenchCameras.close` (after its MjrContext)."""

    def __del__(self) -> None:
        pass


class BenchCameras:
    """Renders named cameras of a model at ``(height, width)``.

    Args:
      model: the compiled model (its offscreen buffer at least ``height`` x ``width``).
      height, width: image size in pixels.
      cameras: the cameras' names; the first is the default of every call.
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int,
                 cameras: Sequence[str] = ("overview",)) -> None:
        g = model.vis.global_
        if width > g.offwidth or height > g.offheight:
            raise ValueError(f"image {height}x{width} exceeds the model's offscreen buffer "
                             f"{g.offheight}x{g.offwidth}")
        self.model = model
        self.height, self.width = height, width
        self.names = tuple(cameras)
        self._gl = _OwnedContext(width, height)
        self._gl.make_current()
        self._con = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self._con)
        self._con.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self.scene = mujoco.MjvScene(model, maxgeom=10000)
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = 0
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = 0
        self.option = mujoco.MjvOption()
        self._cams = {}
        for name in self.names:
            cam = mujoco.MjvCamera()
            cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
            cam.fixedcamid = int(model.camera(name).id)
            self._cams[name] = cam
        self._pert = mujoco.MjvPerturb()
        self._rect = mujoco.MjrRect(0, 0, width, height)
        extent = model.stat.extent
        zfar = np.float32(model.vis.map.zfar * extent)
        znear = np.float32(model.vis.map.znear * extent)
        c_coef = -(zfar + znear) / (zfar - znear)
        d_coef = -(np.float32(2) * zfar * znear) / (zfar - znear)
        self._c = np.float32(-0.5) * c_coef - np.float32(0.5)
        self._d = np.float32(-0.5) * d_coef

    def _draw(self, data: mujoco.MjData, camera: str | None) -> None:
        self._gl.make_current()
        cam = self._cams[camera or self.names[0]]
        mujoco.mjv_updateScene(self.model, data, self.option, self._pert, cam,
                               mujoco.mjtCatBit.mjCAT_ALL.value, self.scene)
        mujoco.mjr_render(self._rect, self.scene, self._con)

    def rgbd(self, data: mujoco.MjData, depth: bool = True,
             camera: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """RGB (H, W, 3) uint8 and, with ``depth``, depth (H, W) float32 in metres."""
        self._draw(data, camera)
        rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
        if not depth:
            mujoco.mjr_readPixels(rgb, None, self._rect, self._con)
            return np.flipud(rgb).copy(), np.zeros(0, dtype=np.float32)
        raw = np.empty((self.height, self.width), dtype=np.float32)
        mujoco.mjr_readPixels(rgb, raw, self._rect, self._con)
        metres = (self._d / (raw.astype(np.float64) + self._c)).astype(np.float32)
        return np.flipud(rgb).copy(), np.flipud(metres).copy()

    def segmentation(self, data: mujoco.MjData, camera: str | None = None) -> np.ndarray:
        """(H, W) geom id per pixel (-1: no geom), as ``mujoco.Renderer``'s segmentation."""
        flags = self.scene.flags
        saved = flags.copy()
        flags[mujoco.mjtRndFlag.mjRND_SEGMENT] = 1
        flags[mujoco.mjtRndFlag.mjRND_IDCOLOR] = 1
        try:
            self._draw(data, camera)
            rgb = np.empty((self.height, self.width, 3), dtype=np.uint8)
            mujoco.mjr_readPixels(rgb, None, self._rect, self._con)
        finally:
            np.copyto(flags, saved)
        img = rgb.astype(np.uint32)
        segimage = img[:, :, 0] + img[:, :, 1] * (2**8) + img[:, :, 2] * (2**16)
        n = self.scene.ngeom
        lut = np.full(n + 1, -1, dtype=np.int32)
        for g in self.scene.geoms[:n]:
            if g.segid != -1 and g.objtype == int(mujoco.mjtObj.mjOBJ_GEOM):
                lut[g.segid + 1] = g.objid
        return np.flipud(lut[np.clip(segimage, 0, n)]).copy()

    def close(self) -> None:
        """Free the GL resources (the cameras cannot render afterwards)."""
        if self._gl is not None:
            self._gl.make_current()
            self._con.free()
            self._gl.free()
            self._gl = None  # type: ignore[assignment]

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001  at interpreter exit EGL may already be gone
            self._gl = None  # type: ignore[assignment]
