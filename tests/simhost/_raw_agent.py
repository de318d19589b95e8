"""A bare Zenoh client of one episode, the way a broken or hand-written client talks: it
publishes whatever bytes it is given and decodes the one reply (shared by protocol tests)."""

from __future__ import annotations

import json
import queue
import struct
import time
from typing import Any

import numpy as np
import zenoh

from schemas import Hello, HelloReply, ObservationReply, Reset
from simhost._transport import agent_config, keys
from simhost._wire import MAGIC, decode_reply, encode

GO = {"velocity": [0.3, -0.2]}


def frame(header: bytes | str | dict[str, Any], block: bytes = b"", *, hlen: int | None = None
          ) -> bytes:
    """A v1 buffer around any header (not validated), padded the way the encoder pads."""
    if isinstance(header, dict):
        header = json.dumps(header)
    if isinstance(header, str):
        header = header.encode()
    header += b" " * ((-(8 + len(header))) % 8)
    return struct.pack("<4sI", MAGIC, len(header) if hlen is None else hlen) + header + block


class RawAgent:
    """A bare Zenoh client of one episode: publishes bytes, returns the decoded reply."""

    timeout_s = 10.0

    def __init__(self, endpoint: str, episode: str) -> None:
        k = keys(episode)
        conf = agent_config(endpoint)
        # open() otherwise sometimes waits 0.5 s for scouting; matching is awaited below.
        conf.insert_json5("scouting/delay", "0")
        self.session = zenoh.open(conf)
        self.token = self.session.liveliness().declare_token(k.alive)
        self.replies: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self.sub = self.session.declare_subscriber(
            k.rep, lambda s: self.replies.put(s.payload.to_bytes())
        )
        self.pub = self.session.declare_publisher(
            k.req, congestion_control=zenoh.CongestionControl.BLOCK
        )
        deadline = time.monotonic() + 5.0
        while not self.pub.matching_status.matching:  # the host's subscriber is known here
            assert time.monotonic() < deadline, "the host's request subscriber never showed up"
            time.sleep(0.005)
        self.seq = 0

    def send(self, buf: bytes) -> Any:
        self.pub.put(buf)
        reply, _ = decode_reply(self.replies.get(timeout=self.timeout_s))
        self.seq = reply.seq
        return reply

    def call(self, model: type, tensors: dict[str, np.ndarray] | None = None, **fields: Any
             ) -> Any:
        return self.send(encode(model(seq=self.seq, **fields), tensors))

    def start(self) -> ObservationReply:
        assert isinstance(self.call(Hello, agent="raw/1"), HelloReply)
        reply = self.call(Reset)
        assert isinstance(reply, ObservationReply) and reply.stage == "explore"
        return reply

    def close(self) -> None:
        if not self.session.is_closed():
            self.session.close()
