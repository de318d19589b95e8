"""The v1 wire format: one buffer = a small frame, a JSON header, then raw tensors.

    magic b"EGC1" | u32 little-endian header length | header JSON (space-padded to 8 bytes)
    | tensor block: each tensor's bytes, row-major, at the 8-byte-aligned offset its
      ``TensorMeta`` gives

Never pickle, never a JSON list of pixels. Decoding checks every length and offset before it
touches the bytes, so a hostile buffer yields a ``WireError`` with a code, never a crash.
Imports only numpy and pydantic (it runs inside team containers).
"""

from __future__ import annotations

import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import BaseModel, TypeAdapter, ValidationError

from schemas._protocol import Reply, Request, TensorMeta

MAGIC = b"EGC1"
_FRAME = struct.Struct("<4sI")
_ALIGN = 8

_REQUEST = TypeAdapter(Request)
_REPLY = TypeAdapter(Reply)


class WireError(ValueError):
    """Raised when a buffer is not a valid v1 message; ``code`` is the protocol error code."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


def _pad(n: int) -> int:
    return (-n) % _ALIGN


def encode(message: BaseModel, tensors: Mapping[str, np.ndarray] | None = None) -> bytes:
    """Serialise a message model and its tensors into one buffer."""
    metas: list[TensorMeta] = []
    blobs: list[bytes | memoryview] = []
    offset = 0
    for name, arr in (tensors or {}).items():
        a = np.ascontiguousarray(arr)
        nbytes = a.nbytes
        metas.append(
            TensorMeta(name=name, dtype=a.dtype.name, shape=a.shape, offset=offset, nbytes=nbytes)
        )
        blobs.append(memoryview(a).cast("B") if nbytes else b"")
        pad = _pad(nbytes)
        if pad:
            blobs.append(b"\0" * pad)
        offset += nbytes + pad
    if metas:
        message = message.model_copy(update={"tensors": tuple(metas)})
    header = message.model_dump_json(exclude_defaults=False).encode()
    header += b" " * _pad(_FRAME.size + len(header))
    return b"".join([_FRAME.pack(MAGIC, len(header)), header, *blobs])


def _split(buf: bytes, max_bytes: int | None) -> tuple[bytes, memoryview]:
    if max_bytes is not None and len(buf) > max_bytes:
        raise WireError("oversized", f"message of {len(buf)} bytes exceeds {max_bytes}")
    if len(buf) < _FRAME.size:
        raise WireError("malformed", f"message of {len(buf)} bytes is shorter than the frame")
    magic, hlen = _FRAME.unpack_from(buf)
    if magic != MAGIC:
        raise WireError("malformed", f"bad magic {magic!r}: not an eagc/v1 message")
    if hlen > len(buf) - _FRAME.size:
        raise WireError("malformed", f"header length {hlen} runs past the end of the message")
    view = memoryview(buf)
    return bytes(view[_FRAME.size : _FRAME.size + hlen]), view[_FRAME.size + hlen :]


def _tensors(metas: tuple[TensorMeta, ...], block: memoryview) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for m in metas:
        dtype = np.dtype(m.dtype)
        expected = int(np.prod(m.shape, dtype=np.int64)) * dtype.itemsize
        if m.nbytes != expected:
            raise WireError("malformed", f"tensor {m.name!r}: {m.nbytes} bytes, shape needs {expected}")
        if m.offset + m.nbytes > len(block):
            raise WireError("malformed", f"tensor {m.name!r} runs past the end of the message")
        if m.name in out:
            raise WireError("malformed", f"tensor {m.name!r} appears twice")
        arr = np.frombuffer(block, dtype=dtype, count=expected // dtype.itemsize, offset=m.offset)
        out[m.name] = arr.reshape(m.shape)
    return out


def decode_request(buf: bytes, *, max_bytes: int | None = None) -> tuple[Any, dict[str, np.ndarray]]:
    """Parse an agent's request. Raises WireError (malformed / oversized)."""
    header, block = _split(buf, max_bytes)
    try:
        msg = _REQUEST.validate_json(header)
    except ValidationError as e:
        first = e.errors(include_url=False)[0]
        loc = ".".join(str(p) for p in first["loc"]) or "(header)"
        raise WireError("malformed", f"{loc}: {first['msg']}") from None
    return msg, _tensors(msg.tensors, block)


def decode_reply(buf: bytes) -> tuple[Any, dict[str, np.ndarray]]:
    """Parse a host's reply."""
    header, block = _split(buf, None)
    try:
        msg = _REPLY.validate_json(header)
    except ValidationError as e:
        raise WireError("malformed", f"reply does not match protocol v1: {e}") from None
    return msg, _tensors(msg.tensors, block)
