"""One MCAP file per episode, for organizers only (it holds the hidden scenario).

Channels (JSON unless said otherwise):

- ``/eagc/scenario``   the hidden scenario and episode metadata (once)
- ``/eagc/request``    every request the episode applied, in order: kind, stage, and the
                       checked action / answers / end-of-stage payload (replay input)
- ``/eagc/reply``      every reply header (observation JSON, stage, messages)
- ``/eagc/event``      stages, exceptions, protocol errors, agent lifecycle
- ``/eagc/state_hash`` a hash of the simulator state after every step
- ``/eagc/state``      the full simulator state every N steps (raw bytes, for replay)
- ``/eagc/file``       the agent's ``/output`` files snapshotted at stage ends (raw bytes)
- ``/eagc/score``      the score card (once, at the end)
- ``/camera/<name>``   RGB observations as ``foxglove.CompressedImage`` (PNG), at a low rate
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

from simhost._episode import Observation
from simhost._host import EpisodeRecorder
from simhost._png import encode_png

_OBJECT = json.dumps({"type": "object"}).encode()
_COMPRESSED_IMAGE = json.dumps(
    {
        "type": "object",
        "properties": {
            "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"},
                                                           "nsec": {"type": "integer"}}},
            "frame_id": {"type": "string"},
            "data": {"type": "string", "contentEncoding": "base64"},
            "format": {"type": "string"},
        },
    }
).encode()


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


class McapRecorder(EpisodeRecorder):
    """Writes an episode's MCAP log. Thread-safe; ``close()`` finishes the file."""

    def __init__(self, path: Path | str, *, image_every: int = 10) -> None:
        self.path = Path(path)
        self._file = self.path.open("wb")
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile="eagc", library="eagc")
        self._lock = threading.Lock()
        self._channels: dict[str, int] = {}
        self._wall0 = time.time_ns()
        self._image_every = image_every
        self._replies = 0
        json_schema = self._writer.register_schema("eagc.json", "jsonschema", _OBJECT)
        image_schema = self._writer.register_schema(
            "foxglove.CompressedImage", "jsonschema", _COMPRESSED_IMAGE
        )
        self._schemas = {"json": json_schema, "image": image_schema, "raw": 0}
        self.closed = False

    def now(self) -> float:
        """Seconds since the log started (the time base of every message)."""
        return (time.time_ns() - self._wall0) / 1e9

    def _channel(self, topic: str, kind: str) -> int:
        if topic not in self._channels:
            encoding = {"json": "json", "image": "json", "raw": "application/octet-stream"}[kind]
            self._channels[topic] = self._writer.register_channel(
                topic, encoding, self._schemas[kind]
            )
        return self._channels[topic]

    def _write(self, topic: str, t: float, data: bytes, kind: str = "json") -> None:
        with self._lock:
            if self.closed:
                return
            ns = self._wall0 + int(t * 1e9)
            self._writer.add_message(self._channel(topic, kind), ns, data, ns)

    def write_json(self, topic: str, t: float, obj: Any) -> None:
        self._write(topic, t, json.dumps(obj, default=_default).encode())

    def write_raw(self, topic: str, t: float, data: bytes) -> None:
        self._write(topic, t, data, "raw")

    # EpisodeRecorder
    def request(self, t: float, kind: str, stage: str | None, data: Mapping[str, Any]) -> None:
        self.write_json("/eagc/request", t, {"kind": kind, "stage": stage, **data})

    def reply(self, t: float, reply: Any, obs: Observation | None) -> None:
        if not isinstance(reply, dict):
            reply = reply.model_dump(mode="json", exclude={"tensors"})
        self.write_json("/eagc/reply", t, reply)
        if obs is None:
            return
        self._replies += 1
        small = {k: v for k, v in obs.tensors.items() if v.size <= 256}
        if small:
            self.write_json("/eagc/observation", t, small)
        if self._replies % self._image_every == 1:
            for name, arr in obs.tensors.items():
                if arr.dtype == np.uint8 and arr.ndim == 3 and arr.shape[2] in (3, 4):
                    sec, nsec = divmod(self._wall0 + int(t * 1e9), 1_000_000_000)
                    self.write_json(
                        f"/camera/{name}",
                        t,
                        {
                            "timestamp": {"sec": sec, "nsec": nsec},
                            "frame_id": name,
                            "format": "png",
                            "data": base64.b64encode(encode_png(arr, level=1)).decode(),
                        },
                    )

    def event(self, t: float, name: str, data: Mapping[str, Any]) -> None:
        self.write_json("/eagc/event", t, {"event": name, **data})

    def state(self, t: float, step: int, state_hash: str, state: bytes | None) -> None:
        self.write_json("/eagc/state_hash", t, {"step": step, "hash": state_hash})
        if state:
            self.write_raw("/eagc/state", t, state)

    def close(self) -> None:
        with self._lock:
            if self.closed:
                return
            self.closed = True
            self._writer.finish()
            self._file.close()
