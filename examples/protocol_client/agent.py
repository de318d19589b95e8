"""A sanity agent written from ``schemas/PROTOCOL.md`` alone: no eagc import.

It needs only the Zenoh binding, numpy and the standard library (``json``, ``struct``),
which is what a team writing its own client (in Python or, the same way, in any language
with a Zenoh binding) has. It is the proof that the page is enough: CI plays a whole
sanity episode with it against a real host, and the episode must complete with no
protocol error. Its strategy is the sanity baseline's: sweep the arena until the target is
in range, write it to ``world_model.json``, end the stage, drive onto it, and when the
target jumps (the controlled exception) log ``exception_detected``, update the model and
drive to the new place.

    EAGC_ENDPOINT=... EAGC_EPISODE=... EAGC_OUTPUT=... python agent.py
"""

from __future__ import annotations

import json
import os
import struct
import sys
import time
from typing import Any

import numpy as np
import zenoh

# ------------------------------------------------------------------- §3: the byte layout
MAGIC = b"EGC1"
FRAME = struct.Struct("<4sI")  # magic, header length H (u32 little-endian)
DTYPES = {"float32": "<f4", "float64": "<f8", "int32": "<i4", "int64": "<i8",
          "uint8": "u1", "uint16": "<u2", "bool": "?"}
NAMES = {np.dtype(v).newbyteorder("<"): k for k, v in DTYPES.items()}


def pad8(n: int) -> int:
    return (-n) % 8


def encode(header: dict[str, Any], tensors: dict[str, np.ndarray]) -> bytes:
    """Header JSON padded with spaces to 8 + H ≡ 0 (mod 8), then each tensor's little-endian
    row-major bytes at the next multiple of 8, each followed by zero padding."""
    metas, blocks, offset = [], [], 0
    for name, array in tensors.items():
        dtype = NAMES[array.dtype.newbyteorder("<")]  # KeyError: not a v1 dtype
        data = np.ascontiguousarray(array, dtype=np.dtype(DTYPES[dtype])).tobytes()
        metas.append({"name": name, "dtype": dtype, "shape": list(array.shape),
                      "offset": offset, "nbytes": len(data)})
        blocks.append(data + bytes(pad8(len(data))))
        offset += len(data) + pad8(len(data))
    text = json.dumps({**header, "tensors": metas}).encode()
    text += b" " * pad8(FRAME.size + len(text))
    return FRAME.pack(MAGIC, len(text)) + text + b"".join(blocks)


def decode(buf: bytes) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The header and the tensors of a reply, checking the exact layout of §3."""
    magic, hlen = FRAME.unpack_from(buf)
    if magic != MAGIC or (FRAME.size + hlen) % 8 or FRAME.size + hlen > len(buf):
        raise ValueError("not a v1 message")
    header = json.loads(buf[FRAME.size : FRAME.size + hlen])
    block = memoryview(buf)[FRAME.size + hlen :]
    tensors, expected = {}, 0
    for m in header.get("tensors", []):
        dtype = np.dtype(DTYPES[m["dtype"]])
        count = int(np.prod(m["shape"], dtype=np.int64))
        if m["offset"] != expected or m["nbytes"] != count * dtype.itemsize:
            raise ValueError(f"tensor {m['name']!r} is not where the layout puts it")
        arr = np.frombuffer(block, dtype=dtype, count=count, offset=m["offset"])
        tensors[m["name"]] = arr.reshape(m["shape"])
        expected = m["offset"] + m["nbytes"] + pad8(m["nbytes"])
    if expected != len(block):
        raise ValueError("the tensor block's length does not match its tensors")
    return header, tensors


# ------------------------------------------------------------- §2: the session and keys
class HostGone(Exception):
    """The host's liveliness token went: the episode is over."""


class Client:
    """One request in flight at a time; replies matched by request id (§4)."""

    def __init__(self, endpoint: str, episode: str) -> None:
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
        conf.insert_json5("listen/endpoints", "[]")
        conf.insert_json5("scouting/multicast/enabled", "false")
        conf.insert_json5("scouting/gossip/enabled", "false")
        conf.insert_json5("scouting/delay", "0")
        base = f"eagc/v1/{episode}/agent"
        self.session = zenoh.open(conf)
        self.token = self.session.liveliness().declare_token(f"{base}/alive")
        self.replies = self.session.declare_subscriber(f"{base}/rep")
        self.host = self.session.liveliness().declare_subscriber(f"{base}/host_alive",
                                                                 history=True)
        self.requests = self.session.declare_publisher(
            f"{base}/req", congestion_control=zenoh.CongestionControl.BLOCK, express=True)
        self.seq = 0
        self.next_id = 1
        self.host_seen = False

    def _reply(self, rid: int, resend: bytes | None, timeout_s: float = 60.0) -> dict:
        deadline = time.monotonic() + timeout_s
        resend_at = time.monotonic() + 0.5
        while True:
            sample = self.replies.try_recv()
            if sample is not None:
                header, tensors = decode(sample.payload.to_bytes())
                if header.get("id") == rid:  # anything else answers another request
                    header["_tensors"] = tensors
                    return header
                continue
            token = self.host.try_recv()
            if token is not None:
                if token.kind == zenoh.SampleKind.PUT:
                    self.host_seen = True
                elif self.host_seen:
                    raise HostGone("the host's liveliness token went")
            now = time.monotonic()
            if now > deadline:
                raise TimeoutError(f"no reply within {timeout_s} s")
            if resend is not None and now >= resend_at:
                self.requests.put(resend)  # the same hello, same id
                resend_at = now + 0.5
            time.sleep(0.0002)

    def call(self, header: dict[str, Any], tensors: dict[str, np.ndarray] | None = None,
             *, resend: bool = False) -> dict:
        rid = self.next_id
        self.next_id += 1
        buf = encode({**header, "seq": self.seq, "id": rid}, tensors or {})
        self.requests.put(buf)
        reply = self._reply(rid, buf if resend else None)
        self.seq = reply["seq"]
        if reply["kind"] == "error":
            raise RuntimeError(f"host error {reply['code']}: {reply['message']}")
        return reply

    def hello(self, agent: str) -> dict:
        deadline = time.monotonic() + 5.0  # the first hello may be lost: wait for a match
        while not self.requests.matching_status.matching and time.monotonic() < deadline:
            time.sleep(0.001)
        return self.call({"kind": "hello", "protocol": "eagc/v1", "agent": agent},
                         resend=True)

    def close(self) -> None:
        self.session.close()


def observation(reply: dict) -> dict[str, Any]:
    return {**reply.get("observation", {}), **reply["_tensors"]}


# ---------------------------------------------------------------- §1: the output files
class Files:
    def __init__(self, folder: str) -> None:
        self.folder = folder
        self.log_fd = os.open(os.path.join(folder, "episode_log.jsonl"),
                              os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)

    def write_json(self, name: str, doc: dict) -> None:
        tmp = os.path.join(self.folder, f".{name}.tmp")
        with open(tmp, "w") as f:
            json.dump(doc, f)
        os.replace(tmp, os.path.join(self.folder, name))

    def log(self, **record: Any) -> None:
        os.write(self.log_fd, (json.dumps(record) + "\n").encode())


# ------------------------------------------------------------------------ the agent
WAYPOINTS = [(-1.5, -1.5), (1.5, -1.5), (1.5, -0.5), (-1.5, -0.5), (-1.5, 0.5), (1.5, 0.5),
             (1.5, 1.5), (-1.5, 1.5)]


def run(client: Client, files: Files) -> str:
    spec = client.hello("protocol-client/1")
    names = [f["name"] for f in spec["action_spec"]]
    assert names == ["velocity"], names
    reply = client.call({"kind": "reset"})
    target: np.ndarray | None = None
    steps, wp = 0, 0

    def model() -> None:
        objects = [] if target is None else [
            {"id": "target", "category": "target", "position": target.tolist()}]
        files.write_json("world_model.json", {"version": "eagc-world-model/v1", "step": steps,
                                              "rooms": [{"id": "arena"}], "objects": objects})

    while not reply["episode_over"]:
        obs, stage = observation(reply), reply["stage"]
        pos = obs["position"].astype(float)
        moved = False
        if obs["target_visible"][0] > 0.5:
            seen = pos + obs["target_rel"].astype(float)
            moved = target is not None and bool(np.linalg.norm(seen - target) > 0.3)
            target = seen
        elif target is not None and np.linalg.norm(target - pos) < 0.8:
            target, moved = None, True  # the model says "here", but it is not in sight
        if stage == "explore" and target is not None:
            files.log(step=steps, stage=stage, event="model_update",
                      data={"target": target.tolist()})
            model()
            reply = client.call({"kind": "end_stage", "payload": {}})
            continue
        if moved:
            files.log(step=steps, stage=stage, event="exception_detected",
                      exception_type="target_moved")
            model()
        if target is None:
            goal = np.array(WAYPOINTS[wp % len(WAYPOINTS)])
            if np.linalg.norm(goal - pos) < 0.15:
                wp += 1
        else:
            goal = target
        velocity = np.clip((goal - pos) * 3.0, -1.0, 1.0).astype(np.float32)
        steps += 1
        reply = client.call({"kind": "step", "action": {}}, {"velocity": velocity})
    model()
    files.log(step=steps, stage=reply["stage"], event="note",
              data={"end": reply["end_reason"]})
    return str(reply["end_reason"])


def main() -> int:
    client = Client(os.environ["EAGC_ENDPOINT"], os.environ["EAGC_EPISODE"])
    try:
        end = run(client, Files(os.environ.get("EAGC_OUTPUT", "/output")))
    finally:
        client.close()
    print(f"episode over: {end}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
