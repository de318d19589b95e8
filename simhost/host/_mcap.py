"""One MCAP file per episode, for organizers only (it holds the hidden scenario).

Channels (JSON unless said otherwise):

- ``/eagc/scenario``   the hidden scenario and episode metadata (once)
- ``/eagc/request``    every request the episode applied, in order: kind, stage, and the
                       checked action / answers / end-of-stage payload (replay input)
- ``/eagc/reply``      every reply header (observation JSON, stage, messages)
- ``/eagc/observation`` the small observation tensors (≤ 256 values) of every reply
- ``/eagc/event``      stages, exceptions, protocol errors, agent lifecycle
- ``/eagc/state_hash`` a hash of the simulator state after every step
- ``/eagc/state``      the full simulator state every N steps (raw bytes, for replay)
- ``/eagc/file``       the agent's ``/output`` files snapshotted at stage ends (raw bytes)
- ``/eagc/score``      the score card (once, at the end)

and, so that Foxglove shows the episode (its own schemas, JSON-encoded):

- ``/camera/rgb``          ``foxglove.CompressedImage`` (PNG) of an observation tensor named
                           ``rgb`` (H×W×3 uint8), at most one every ``image_period_s``,
                           and besides one every k-th step (k from ``image_every_steps``,
                           doubled as the episode grows long: at most ``step_images`` in
                           all), so that a fast agent's whole episode is seen
- ``/camera/depth``        ``foxglove.RawImage`` (``32FC1``, metres) of a tensor ``depth``
- ``/camera/segmentation`` ``foxglove.CompressedImage`` (PNG) of a tensor ``segmentation``,
                           one colour per id, black where it is -1
- ``/tf``                  ``foxglove.FrameTransforms``: the track's poses
                           (``TrackEpisode.poses()``) as frames under ``world``, every step
- ``/trajectory/<frame>``  ``foxglove.PosesInFrame``: each frame's whole path (once, at the
                           end), so that the 3D panel draws the trajectory

A frame's step is that of the last ``/eagc/state_hash`` before it. ``simhost.host._records``
reads every record back as its model; the state hashes, camera images and trajectories are
written from those models (the per-step transforms and the replies, on the host's hot path,
as plain dicts of the same fields).

Cost: images only at a low rate (PNG at zlib level 1), one small transform message per
step, a hash every step and the full state every N steps (the host's ``full_state_every``).
"""

from __future__ import annotations

import base64
import json
import threading
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
from mcap.writer import CompressionType, Writer

from simhost.host._episode import Observation, Pose
from simhost.host._host import EpisodeRecorder
from simhost.host._png import encode_png
from simhost.host._records import (
    CompressedImage,
    PoseJson,
    PosesInFrame,
    Quaternion,
    RawImage,
    StateHash,
    Time,
    Vector3,
)

WORLD_FRAME = "world"
_MAX_TRAJECTORY = 4096  # poses kept per frame for /trajectory (evenly thinned beyond it)

_OBJECT = json.dumps({"type": "object"}).encode()
_TIME = {"type": "object", "properties": {"sec": {"type": "integer"},
                                          "nsec": {"type": "integer"}}}
_VEC3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_POSE = {"type": "object", "properties": {"position": _VEC3, "orientation": _QUAT}}
_TRANSFORM = {
    "type": "object",
    "properties": {"timestamp": _TIME, "parent_frame_id": {"type": "string"},
                   "child_frame_id": {"type": "string"}, "translation": _VEC3,
                   "rotation": _QUAT},
}
# Foxglove's well-known schemas (foxglove/schemas), as JSON Schema; bytes are base64.
FOXGLOVE_SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.CompressedImage": {
        "type": "object",
        "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"},
            "data": {"type": "string", "contentEncoding": "base64"},
            "format": {"type": "string"},
        },
    },
    "foxglove.RawImage": {
        "type": "object",
        "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"},
            "width": {"type": "integer"}, "height": {"type": "integer"},
            "encoding": {"type": "string"}, "step": {"type": "integer"},
            "data": {"type": "string", "contentEncoding": "base64"},
        },
    },
    "foxglove.FrameTransforms": {
        "type": "object",
        "properties": {"transforms": {"type": "array", "items": _TRANSFORM}},
    },
    "foxglove.PosesInFrame": {
        "type": "object",
        "properties": {"timestamp": _TIME, "frame_id": {"type": "string"},
                       "poses": {"type": "array", "items": _POSE}},
    },
}


def _default(o: Any) -> Any:
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, bytes):
        return base64.b64encode(o).decode()
    if hasattr(o, "model_dump"):
        return o.model_dump(mode="json")
    return str(o)


def segmentation_colours(ids: np.ndarray) -> np.ndarray:
    """An H×W×3 uint8 picture of an id image: a fixed colour per id, black for -1."""
    ids = np.asarray(ids).astype(np.int64)
    rgb = ((ids[..., None] + 1) * np.array([97, 57, 23]) + np.array([40, 90, 140])) % 200 + 55
    rgb[ids < 0] = 0
    return rgb.astype(np.uint8)


def _pose_json(p: Pose) -> dict[str, Any]:
    """``foxglove.Pose`` as a dict (every step: cheaper than the model)."""
    (x, y, z), (w, qx, qy, qz) = p.position, p.orientation
    return {"position": {"x": x, "y": y, "z": z},
            "orientation": {"x": qx, "y": qy, "z": qz, "w": w}}


def _pose_model(p: Pose) -> PoseJson:
    (x, y, z), (w, qx, qy, qz) = p.position, p.orientation
    return PoseJson(position=Vector3(x=x, y=y, z=z),
                    orientation=Quaternion(x=qx, y=qy, z=qz, w=w))


class McapRecorder(EpisodeRecorder):
    """Writes an episode's MCAP log. Thread-safe; ``close()`` finishes the file.

    Args:
        path: the file to write.
        image_period_s: at most one camera frame per this many seconds of the episode.
        image_every_steps: besides, a frame every this many steps; the spacing doubles
            each time half of what is left of ``step_images`` is used.
        step_images: at most this many frames kept by step in one episode.
    """

    pose_every = 1

    def __init__(self, path: Path | str, *, image_period_s: float = 0.5,
                 image_every_steps: int = 5, step_images: int = 120) -> None:
        self.path = Path(path)
        self._file = self.path.open("wb")
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile="eagc", library="eagc")
        self._lock = threading.Lock()
        self._channels: dict[str, int] = {}
        self._wall0 = time.time_ns()
        self._image_period = image_period_s
        self._last_image: float | None = None
        self._step = 0  # the last step state() saw: replies follow it
        self._step_every = max(1, image_every_steps)
        self._step_images = step_images
        self._step_quota = max(1, step_images // 2)  # frames left at this spacing
        self._last_step_image = -1
        self._trajectories: dict[str, list[Pose]] = {}
        self._last_pose_t = 0.0
        self._schemas = {
            "json": self._writer.register_schema("eagc.json", "jsonschema", _OBJECT),
            "raw": 0,
            **{name: self._writer.register_schema(name, "jsonschema", json.dumps(s).encode())
               for name, s in FOXGLOVE_SCHEMAS.items()},
        }
        self.closed = False

    def now(self) -> float:
        """Seconds since the log started (the time base of every message)."""
        return (time.time_ns() - self._wall0) / 1e9

    def _channel(self, topic: str, schema: str) -> int:
        if topic not in self._channels:
            encoding = "application/octet-stream" if schema == "raw" else "json"
            self._channels[topic] = self._writer.register_channel(
                topic, encoding, self._schemas[schema]
            )
        return self._channels[topic]

    def _write(self, topic: str, t: float, data: bytes, schema: str = "json") -> None:
        with self._lock:
            if self.closed:
                return
            ns = self._wall0 + int(t * 1e9)
            self._writer.add_message(self._channel(topic, schema), ns, data, ns)

    def write_json(self, topic: str, t: float, obj: Any, schema: str = "json") -> None:
        self._write(topic, t, json.dumps(obj, default=_default).encode(), schema)

    def write_raw(self, topic: str, t: float, data: bytes) -> None:
        self._write(topic, t, data, "raw")

    def _stamp(self, t: float) -> dict[str, int]:
        sec, nsec = divmod(self._wall0 + int(t * 1e9), 1_000_000_000)
        return {"sec": sec, "nsec": nsec}

    def _time(self, t: float) -> Time:
        return Time.model_validate(self._stamp(t))

    # EpisodeRecorder
    def request(self, t: float, kind: str, stage: str | None, data: Mapping[str, Any]) -> None:
        self.write_json("/eagc/request", t, {"kind": kind, "stage": stage, **data})

    def reply(self, t: float, reply: Any, obs: Observation | None) -> None:
        if not isinstance(reply, dict):
            reply = reply.model_dump(mode="json", exclude={"tensors"})
        self.write_json("/eagc/reply", t, reply)
        if obs is None:
            return
        small = {k: v for k, v in obs.tensors.items() if v.size <= 256}
        if small:
            self.write_json("/eagc/observation", t, small)
        if not any(k in obs.tensors for k in ("rgb", "depth", "segmentation")):
            return
        by_time = self._last_image is None or t - self._last_image >= self._image_period
        by_step = (self._step_images > 0 and self._step % self._step_every == 0
                   and self._step != self._last_step_image)
        if by_step:
            self._last_step_image = self._step
            self._step_images -= 1
            self._step_quota -= 1
            if self._step_quota == 0:  # a long episode: thinner, still bounded
                self._step_every *= 2
                self._step_quota = max(1, self._step_images // 2)
        if by_time or by_step:
            self._last_image = t
            self._images(t, obs.tensors)

    def _images(self, t: float, tensors: Mapping[str, np.ndarray]) -> None:
        stamp = self._time(t)
        rgb = tensors.get("rgb")
        if rgb is not None and rgb.dtype == np.uint8 and rgb.ndim == 3 and rgb.shape[2] == 3:
            self._png("/camera/rgb", t, stamp, rgb)
        depth = tensors.get("depth")
        if depth is not None and depth.ndim == 2:
            d = np.ascontiguousarray(depth, dtype="<f4")
            self.write_json("/camera/depth", t, RawImage(
                timestamp=stamp, frame_id="camera", width=d.shape[1], height=d.shape[0],
                encoding="32FC1", step=d.shape[1] * 4,
                data=base64.b64encode(d.tobytes()).decode(),
            ), "foxglove.RawImage")
        seg = tensors.get("segmentation")
        if seg is not None and seg.ndim == 2 and seg.dtype.kind in "iu":
            self._png("/camera/segmentation", t, stamp, segmentation_colours(seg))

    def _png(self, topic: str, t: float, stamp: Time, image: np.ndarray) -> None:
        self.write_json(topic, t, CompressedImage(
            timestamp=stamp, frame_id="camera", format="png",
            data=base64.b64encode(encode_png(image, level=1)).decode(),
        ), "foxglove.CompressedImage")

    def event(self, t: float, name: str, data: Mapping[str, Any]) -> None:
        self.write_json("/eagc/event", t, {"event": name, **data})

    def state(self, t: float, step: int, state_hash: str, state: bytes | None) -> None:
        self._step = step
        self.write_json("/eagc/state_hash", t, StateHash(step=step, hash=state_hash))
        if state:
            self.write_raw("/eagc/state", t, state)

    def poses(self, t: float, step: int, poses: Mapping[str, Pose]) -> None:
        if not poses:
            return
        stamp = self._stamp(t)
        transforms = []
        for name, p in poses.items():
            j = _pose_json(p)
            transforms.append({"timestamp": stamp, "parent_frame_id": WORLD_FRAME,
                               "child_frame_id": name, "translation": j["position"],
                               "rotation": j["orientation"]})
            path = self._trajectories.setdefault(name, [])
            path.append(p)
            if len(path) > 2 * _MAX_TRAJECTORY:  # keep every other pose: bounded memory
                del path[1::2]
        self._last_pose_t = t
        self.write_json("/tf", t, {"transforms": transforms}, "foxglove.FrameTransforms")

    def _write_trajectories(self) -> None:
        stamp = self._time(self._last_pose_t)
        for name, path in self._trajectories.items():
            self.write_json(f"/trajectory/{name}", self._last_pose_t, PosesInFrame(
                timestamp=stamp, frame_id=WORLD_FRAME, poses=[_pose_model(p) for p in path],
            ), "foxglove.PosesInFrame")

    def close(self) -> None:
        if not self.closed and self._trajectories:
            self._write_trajectories()
        with self._lock:
            if self.closed:
                return
            self.closed = True
            self._writer.finish()
            self._file.close()
