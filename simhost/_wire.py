"""The v1 wire format: one buffer = a small frame, a JSON header, then raw tensors.

    offset 0   magic b"EGC1"
    offset 4   u32 little-endian H: the header's length in bytes, padding included
    offset 8   the header: UTF-8 JSON, then spaces so that 8 + H is a multiple of 8
    offset 8+H the tensor block: each tensor's bytes (row-major, little-endian) in the order
               the header lists them, the first at block offset 0 and each next one at the
               next multiple of 8; zero bytes pad every tensor, the last one included, to a
               multiple of 8. The buffer ends with the last tensor's padding.

So the whole layout follows from the header: a decoder checks that every ``offset`` is
exactly where the previous tensor's padding ends and that the buffer ends exactly there,
and refuses anything else (overlapping, misaligned or out-of-order tensors, trailing or
missing bytes, a header length that is not padded). ``schemas/PROTOCOL.md`` is the
specification; this module implements it. Never pickle, never a JSON list of pixels.
Decoding checks every length and offset before it touches the bytes, so a hostile buffer
yields a ``WireError`` with a code and a message naming the problem, never a crash.
Imports only numpy and pydantic (it runs inside team containers).
"""

from __future__ import annotations

import math
import struct
from collections.abc import Mapping
from typing import Any

import numpy as np
import pydantic_core
from pydantic import BaseModel, TypeAdapter, ValidationError

from schemas import Reply, Request
from simhost._errors import SimHostError

MAGIC = b"EGC1"
_FRAME = struct.Struct("<4sI")
_ALIGN = 8
_ID_MAX = 2**53 - 1
_ID_HEADER_MAX = 1 << 16  # the longest header read just to echo a refused request's id

_REQUEST = TypeAdapter(Request)
_REPLY = TypeAdapter(Reply)
_DTYPES = {
    name: np.dtype(name).newbyteorder("<")
    for name in ("float32", "float64", "int32", "int64", "uint8", "uint16", "bool")
}
_NAMES = {dt: name for name, dt in _DTYPES.items()}
_ZEROS = [b"\0" * n for n in range(_ALIGN)]


class WireError(SimHostError, ValueError):
    """Raised when a buffer is not a valid v1 message; ``code`` is the protocol error code."""

    def __init__(self, code: str, message: str) -> None:
        super().__init__(message)
        self.code = code


def _plain(o: Any) -> Any:
    """numpy values a track may leave in JSON observation data."""
    if isinstance(o, np.ndarray | np.generic):
        return o.tolist()
    raise TypeError(f"{type(o).__name__} is not JSON serialisable")


def _dumps(doc: dict[str, Any]) -> bytes:
    # pydantic-core's serialiser: 5x faster than json.dumps on a step's header.
    return pydantic_core.to_json(doc, inf_nan_mode="constants", fallback=_plain)


def _pad(n: int) -> int:
    return (-n) % _ALIGN


def encode(
    message: BaseModel | dict[str, Any], tensors: Mapping[str, np.ndarray] | None = None
) -> bytes:
    """Serialise a message (a model, or on hot paths the equivalent plain dict) and tensors.

    Tensor metadata is written as plain JSON: on a 64-byte observation, building validated
    ``TensorMeta`` models cost more than the rest of the step.
    """
    metas: list[dict[str, Any]] = []
    blobs: list[bytes | memoryview] = []
    offset = 0
    if tensors:
        for name, arr in tensors.items():
            dtype = _NAMES.get(arr.dtype)
            if dtype is None:
                little = arr.dtype.newbyteorder("<")
                dtype = _NAMES.get(little)
                if dtype is None:
                    raise WireError("malformed",
                                    f"tensor {name!r}: dtype {arr.dtype} is not in protocol v1")
                arr = arr.astype(little)
            a = arr if arr.flags.c_contiguous else np.ascontiguousarray(arr)
            nbytes = a.nbytes
            metas.append({"name": name, "dtype": dtype, "shape": a.shape, "offset": offset,
                          "nbytes": nbytes})
            blobs.append(memoryview(a).cast("B") if nbytes else b"")
            pad = (-nbytes) % _ALIGN
            if pad:
                blobs.append(_ZEROS[pad])
            offset += nbytes + pad
    if isinstance(message, dict):
        header = _dumps(dict(message, tensors=metas))
    elif metas:
        doc = message.model_dump(mode="json")
        doc["tensors"] = metas
        header = _dumps(doc)
    else:
        header = message.model_dump_json().encode()
    header += b" " * _pad(_FRAME.size + len(header))
    return b"".join([_FRAME.pack(MAGIC, len(header)), header, *blobs])


def _split(buf: bytes, max_bytes: int | None) -> tuple[bytes, memoryview]:
    n = len(buf)
    if max_bytes is not None and n > max_bytes:
        raise WireError("oversized", f"message of {n} bytes exceeds {max_bytes}")
    if n < _FRAME.size:
        raise WireError("malformed", f"message of {n} bytes is shorter than the 8-byte frame")
    magic, hlen = _FRAME.unpack_from(buf)
    if magic != MAGIC:
        raise WireError("malformed", f"bad magic {magic!r}: not an eagc/v1 message")
    end = _FRAME.size + hlen
    if end > n:
        raise WireError("malformed", f"header length {hlen} runs past the end of the "
                        f"{n}-byte message")
    if end % _ALIGN:
        raise WireError("malformed", f"header length {hlen}: 8 + header length must be a "
                        f"multiple of 8 (pad the JSON with {_pad(end)} more space(s))")
    return buf[_FRAME.size : end], memoryview(buf)[end:]


def _tensors(metas: Any, block: memoryview) -> dict[str, np.ndarray]:
    """Views of the tensors, after checking the block's exact layout.

    ``metas`` are TensorMeta models or their plain dicts. A buffer that breaks the layout
    anywhere raises, so its tensors (views, nothing copied) are never used.
    """
    size = len(block)
    out: dict[str, np.ndarray] = {}
    expected = 0
    for m in metas:
        if type(m) is not dict:
            if not hasattr(m, "__dict__"):
                raise WireError("malformed", f"tensor metadata {m!r} is not an object")
            m = m.__dict__
        name, shape, offset, nbytes = m["name"], tuple(m["shape"]), m["offset"], m["nbytes"]
        dtype = _DTYPES.get(m["dtype"])
        if dtype is None:
            raise WireError("malformed", f"tensor {name!r}: dtype {m['dtype']!r} not in v1")
        if name in out:
            raise WireError("malformed", f"tensor {name!r} appears twice")
        count = math.prod(shape)
        if nbytes != count * dtype.itemsize:
            raise WireError("malformed", f"tensor {name!r}: nbytes is {nbytes}, shape "
                            f"{list(shape)} of {m['dtype']} needs {count * dtype.itemsize}")
        if offset != expected:
            how = "is misaligned" if offset % _ALIGN else (
                "overlaps the previous tensor" if offset < expected else "leaves a gap")
            raise WireError("malformed", f"tensor {name!r} at offset {offset} {how}: expected "
                            f"offset {expected} (tensors follow each other in header order, "
                            "each at the next multiple of 8)")
        end = offset + nbytes
        expected = end + (-end) % _ALIGN
        if expected > size:
            raise WireError("malformed", f"message ends {expected - size} byte(s) early: "
                            f"tensor {name!r} and its padding need bytes {offset}..{expected} "
                            f"of a {size}-byte tensor block")
        if expected != end and block[end:expected] != _ZEROS[expected - end]:
            raise WireError("malformed", f"tensor {name!r}: the padding after it is not zero "
                            "bytes")
        try:  # e.g. shape (0, 2**70): no bytes, but no such array either
            arr = np.frombuffer(block, dtype=dtype, count=count, offset=offset)
            out[name] = arr.reshape(shape) if len(shape) != 1 else arr
        except (ValueError, OverflowError) as e:
            raise WireError("malformed", f"tensor {name!r}: shape {list(shape)}: {e}") from None
    if expected != size:
        raise WireError("malformed", f"{size - expected} trailing byte(s) after the last "
                        f"tensor (the tensor block must be exactly {expected} bytes)")
    return out


def decode_request(
    buf: bytes, *, max_bytes: int | None = None
) -> tuple[Any, dict[str, np.ndarray]]:
    """Parse an agent's request. Raises WireError (malformed / oversized)."""
    header, block = _split(buf, max_bytes)
    try:
        msg = _REQUEST.validate_json(header)
    except ValidationError as e:
        first = e.errors(include_url=False)[0]
        loc = ".".join(str(p) for p in first["loc"]) or "(header)"
        raise WireError("malformed", f"{loc}: {first['msg']}") from None
    return msg, _tensors(msg.tensors, block)


def request_id(buf: bytes) -> int | None:
    """The ``id`` of a request that was refused, when its header can be read at all (so
    that even the error reply to a malformed request names the request it answers)."""
    if len(buf) < _FRAME.size:
        return None
    magic, hlen = _FRAME.unpack_from(buf)
    if magic != MAGIC or hlen > _ID_HEADER_MAX or _FRAME.size + hlen > len(buf):
        return None
    try:
        doc = pydantic_core.from_json(buf[_FRAME.size : _FRAME.size + hlen])
    except (ValueError, RecursionError):
        return None
    rid = doc.get("id") if isinstance(doc, dict) else None
    if type(rid) is int and 0 <= rid <= _ID_MAX:
        return rid
    return None


def decode_observation(buf: bytes) -> tuple[dict[str, Any], dict[str, np.ndarray]] | None:
    """Fast path for the agent: an observation reply as a plain dict, or None for other kinds.

    The host is trusted from the agent's side, so the header is parsed without validation;
    the layout of the tensors is still checked before any byte is read.
    """
    header, block = _split(buf, None)
    try:
        doc = pydantic_core.from_json(header)
    except (ValueError, RecursionError) as e:
        raise WireError("malformed", f"reply header is not JSON: {e}") from None
    if not isinstance(doc, dict) or doc.get("kind") != "observation":
        return None
    try:
        return doc, _tensors(doc.get("tensors", ()), block)
    except (KeyError, TypeError) as e:
        raise WireError("malformed", f"bad tensor metadata in reply: {e}") from None


def decode_reply(buf: bytes) -> tuple[Any, dict[str, np.ndarray]]:
    """Parse a host's reply (fully validated)."""
    header, block = _split(buf, None)
    try:
        msg = _REPLY.validate_json(header)
    except ValidationError as e:
        raise WireError("malformed", f"reply does not match protocol v1: {e}") from None
    return msg, _tensors(msg.tensors, block)
