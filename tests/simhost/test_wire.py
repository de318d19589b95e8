"""The v1 wire format: round trips of every message kind, alignment, and hostile buffers.

A hostile buffer may only ever give a ``WireError`` (or, when it happens to be a valid
message, that message): any other exception would become an internal error in the host.
"""

from __future__ import annotations

import json
import struct
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from schemas import (
    ActionResult,
    Answer,
    EndStage,
    ErrorReply,
    FieldSpec,
    Hello,
    HelloReply,
    HostMessage,
    ObservationReply,
    Reset,
    StageInfo,
    Step,
)
from simhost._wire import (
    MAGIC,
    WireError,
    decode_observation,
    decode_reply,
    decode_request,
    encode,
)

DTYPES = ("float32", "float64", "int32", "int64", "uint8", "uint16", "bool")
FRAME = struct.Struct("<4sI")


def tensors_of_every_dtype() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    out: dict[str, np.ndarray] = {}
    for i, dt in enumerate(DTYPES):
        shape = [(), (0,), (3,), (2, 3, 5), (1, 7)][i % 5]
        out[f"t_{dt}"] = (rng.random(shape) * 100).astype(dt)
    out["image"] = rng.integers(0, 255, (4, 6, 3), dtype=np.uint8)
    out["odd"] = np.arange(5, dtype=np.uint8)  # 5 bytes: the next tensor needs padding
    out["transposed"] = np.arange(12, dtype=np.float64).reshape(3, 4).T  # not contiguous
    out["empty2d"] = np.zeros((0, 4), np.int32)
    return out


def specs() -> tuple[FieldSpec, ...]:
    return (
        FieldSpec(name="rgb", dtype="uint8", shape=(4, 6, 3), low=0, high=255, tensor=True),
        FieldSpec(name="mode", dtype="int32", choices=("walk", "grasp")),
        FieldSpec(name="note", dtype="str"),
    )


REQUESTS: dict[str, Any] = {
    "hello": Hello(seq=0, agent="team/1.0"),
    "reset": Reset(seq=1),
    "step": Step(seq=2, action={"velocity": [0.5, -1.0], "mode": "grasp", "nested": {"a": [1]}}),
    "answer": Answer(seq=3, answers={"q1": "kitchen", "q2": [1, 2]}),
    "end_stage": EndStage(seq=4, payload={"plan": [{"do": "open", "what": "door_1"}]}),
}
REPLIES: dict[str, Any] = {
    "hello": HelloReply(
        seq=1, episode="ab12cd34", track="sanity", observation_spec=specs(),
        action_spec=specs()[1:], stages=(StageInfo(name="explore", budget_s=60.0, max_steps=5),),
        max_request_bytes=1 << 20, startup_budget_s=120.0,
    ),
    "observation": ObservationReply(
        seq=5, stage="reach", stage_index=1, time_left_s=12.5, steps_left=3,
        observation={"text": "hi", "count": 2}, action=ActionResult(applied=True, ok=False,
                                                                    reason="blocked"),
        messages=(HostMessage(type="instruction", data={"text": "go"}),),
        episode_over=True, end_reason="completed",
    ),
    "error": ErrorReply(seq=9, code="stale", message="request seq 3, expected 9", fatal=False),
}


def same_tensors(got: dict[str, np.ndarray], sent: dict[str, np.ndarray]) -> None:
    assert list(got) == list(sent)
    for name, a in sent.items():
        b = got[name]
        assert (b.dtype, b.shape) == (a.dtype, a.shape), name
        assert np.array_equal(b, a), name


def without_tensors(msg: Any) -> dict[str, Any]:
    return msg.model_dump(mode="json", exclude={"tensors"})


# ------------------------------------------------------------------------ round trips
@pytest.mark.parametrize("with_tensors", [False, True], ids=["plain", "tensors"])
@pytest.mark.parametrize("kind", REQUESTS)
def test_request_round_trip(kind, with_tensors):
    sent = tensors_of_every_dtype() if with_tensors else {}
    msg, tensors = decode_request(encode(REQUESTS[kind], sent))
    assert type(msg) is type(REQUESTS[kind])
    assert without_tensors(msg) == without_tensors(REQUESTS[kind])
    assert [m.name for m in msg.tensors] == list(sent)
    same_tensors(tensors, sent)


@pytest.mark.parametrize("with_tensors", [False, True], ids=["plain", "tensors"])
@pytest.mark.parametrize("kind", REPLIES)
def test_reply_round_trip(kind, with_tensors):
    sent = tensors_of_every_dtype() if with_tensors else {}
    buf = encode(REPLIES[kind], sent)
    msg, tensors = decode_reply(buf)
    assert type(msg) is type(REPLIES[kind])
    assert without_tensors(msg) == without_tensors(REPLIES[kind])
    same_tensors(tensors, sent)
    fast = decode_observation(buf)  # the agent's fast path agrees with the validated one
    if kind != "observation":
        assert fast is None
    else:
        assert fast is not None
        doc, fast_tensors = fast
        assert {k: v for k, v in doc.items() if k != "tensors"} == without_tensors(msg)
        same_tensors(fast_tensors, sent)


def test_plain_dict_messages_encode_like_models():
    model = Step(seq=3, action={"velocity": [0.25, 0.5]})
    sent = {"rgb": np.ones((2, 2, 3), np.uint8)}
    as_dict = {"kind": "step", "seq": 3, "action": {"velocity": [0.25, 0.5]}}
    a, ta = decode_request(encode(model, sent))
    b, tb = decode_request(encode(as_dict, sent))
    assert a == b
    same_tensors(ta, tb)


def test_layout_is_aligned():
    sent = tensors_of_every_dtype()
    buf = encode(REQUESTS["step"], sent)
    magic, hlen = FRAME.unpack_from(buf)
    assert magic == MAGIC and (FRAME.size + hlen) % 8 == 0
    header = json.loads(buf[FRAME.size : FRAME.size + hlen])
    end = 0
    for meta in header["tensors"]:  # each exactly where the previous one's padding ends
        assert meta["offset"] == end
        end = meta["offset"] + meta["nbytes"]
        end += (-end) % 8
    assert len(buf) == FRAME.size + hlen + end  # every tensor padded, the last one too
    _, tensors = decode_request(buf)
    assert all(t.flags.aligned and t.flags.c_contiguous for t in tensors.values())


@pytest.mark.parametrize(
    "array",
    [np.zeros(2, np.float16), np.zeros(2, np.complex64), np.array(["a"]),
     np.array([{}], dtype=object)],
    ids=["float16", "complex64", "str", "object"],
)
def test_encoding_a_dtype_outside_v1_is_refused(array):
    with pytest.raises(WireError, match="'x'"):
        encode(Step(seq=0), {"x": array})


def test_big_endian_arrays_travel_little_endian():
    sent = np.arange(6, dtype=">f4").reshape(2, 3)
    buf = encode(Step(seq=0), {"x": sent})
    _, tensors = decode_request(buf)
    assert tensors["x"].dtype.str == "<f4" and np.array_equal(tensors["x"], sent)
    assert buf[-24:-20] == struct.pack("<f", 0.0) and buf[-20:-16] == struct.pack("<f", 1.0)


def test_size_limit():
    buf = encode(Step(seq=0, action={"v": [1.0]}), {"x": np.zeros(64, np.uint8)})
    decode_request(buf, max_bytes=len(buf))
    with pytest.raises(WireError) as e:
        decode_request(buf, max_bytes=len(buf) - 1)
    assert e.value.code == "oversized"


# ----------------------------------------------------------------------- hostile input
DECODERS: dict[str, Callable[[bytes], Any]] = {
    "request": decode_request,
    "reply": decode_reply,
    "observation": decode_observation,
}


def decode_or_wire_error(decode: Callable[[bytes], Any], buf: bytes) -> Any:
    """The decoded message, or None on a WireError; any other exception fails the test."""
    try:
        return decode(buf)
    except WireError as e:
        assert e.code in ("malformed", "oversized") and str(e)
        return None


def frame(header: bytes | str | dict[str, Any], block: bytes = b"", hlen: int | None = None
          ) -> bytes:
    if isinstance(header, dict):
        header = json.dumps(header)
    if isinstance(header, str):
        header = header.encode()
    header += b" " * ((-(8 + len(header))) % 8)
    return FRAME.pack(MAGIC, len(header) if hlen is None else hlen) + header + block


def valid_buffers() -> dict[str, bytes]:
    sent = {"a": np.arange(3, dtype=np.uint8), "b": np.ones((2, 2), np.float32)}
    return {
        "request": encode(REQUESTS["step"], sent),
        "reply": encode(REPLIES["hello"]),
        "observation": encode(REPLIES["observation"], sent),
    }


@pytest.mark.parametrize("which", DECODERS)
def test_random_bytes(which):
    decode = DECODERS[which]
    rng = np.random.default_rng(1)
    for n in range(1500):
        size = int(rng.integers(0, 200))
        body = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
        # A third are pure noise; the rest pass the frame check and reach the parser.
        if n % 3:
            hlen = int(rng.integers(0, size + 8))
            body = FRAME.pack(MAGIC, hlen) + body
        assert decode_or_wire_error(decode, body) is None


@pytest.mark.parametrize("which", DECODERS)
def test_every_truncation(which):
    decode = DECODERS[which]
    buf = valid_buffers()[which]
    decode(buf)
    for n in range(len(buf)):  # the length is exact: no truncation decodes
        assert decode_or_wire_error(decode, buf[:n]) is None, n


@pytest.mark.parametrize("which", DECODERS)
def test_every_byte_mutated(which):
    decode = DECODERS[which]
    buf = valid_buffers()[which]
    rng = np.random.default_rng(2)
    for i in range(len(buf)):
        for value in (0, 0xFF, int(rng.integers(0, 256)), ord("9"), ord("-"), ord("[")):
            mutated = bytearray(buf)
            mutated[i] = value
            decode_or_wire_error(decode, bytes(mutated))


def _meta(**kw: Any) -> dict[str, Any]:
    return {"name": "x", "dtype": "uint8", "shape": [8], "offset": 0, "nbytes": 8, **kw}


# The value of the header's "tensors" field.
HOSTILE_TENSORS: dict[str, Any] = {
    "negative offset": [_meta(offset=-8)],
    "huge offset": [_meta(offset=2**63)],
    "offset past the end": [_meta(offset=8)],
    "nbytes too small": [_meta(nbytes=4)],
    "nbytes huge": [_meta(nbytes=2**70)],
    "negative dimension": [_meta(shape=[-8], nbytes=-8)],
    "float dimension": [_meta(shape=[8.5])],
    "string dimension": [_meta(shape=["8"])],
    "shape not a list": [_meta(shape=8)],
    "nine dimensions": [_meta(shape=[1] * 8 + [8])],
    "product overflows int64": [_meta(shape=[2**62, 4], nbytes=0)],
    "empty with a huge dimension": [_meta(shape=[0, 2**70], nbytes=0)],
    "empty with dimension 2**63": [_meta(shape=[0, 2**63], nbytes=0)],
    "dtype outside v1": [_meta(dtype="float16", nbytes=16)],
    "dtype object": [_meta(dtype="object")],
    "dtype not a string": [_meta(dtype=["uint8"])],
    "no name": [{k: v for k, v in _meta().items() if k != "name"}],
    "name empty": [_meta(name="")],
    "same name twice": [_meta(), _meta()],
    "meta not an object": [8],
    "tensors not a list": {"x": 1},
}

# (decoder, case) pairs that still fail: the decoder raises something else than WireError.


def _hostile_cases() -> list[Any]:
    out = []
    for which in DECODERS:
        for case in HOSTILE_TENSORS:
            out.append(pytest.param(which, case, id=f"{which}-{case}"))
    return out


@pytest.mark.parametrize(("which", "case"), _hostile_cases())
def test_hostile_tensor_metadata(which, case):
    header = {
        "request": {"kind": "step", "seq": 0, "action": {}},
        "reply": REPLIES["error"].model_dump(mode="json"),
        "observation": REPLIES["observation"].model_dump(mode="json"),
    }[which]
    header["tensors"] = HOSTILE_TENSORS[case]
    got = decode_or_wire_error(DECODERS[which], frame(header, bytes(8)))
    # The agent's fast path trusts the host's header beyond sizes and offsets; pydantic's lax
    # mode may read "8" as 8. Everything else must be refused.
    if which != "observation" and case != "string dimension":
        assert got is None


HOSTILE_HEADERS: dict[str, bytes] = {
    "header length past the end": frame(b"{}", hlen=1 << 31),
    "not UTF-8": frame(b'{"kind": "step", "seq": 0, "x": "\xff\xfe"}'),
    "not JSON": frame(b"\x00\x01\x02"),
    "JSON array": frame(b"[]"),
    "JSON null": frame(b"null"),
    "deep nesting": frame(b'{"kind": "step", "seq": 0, "action": {"a": ' + b"[" * 100_000
                          + b"]" * 100_000 + b"}}"),
    "huge seq": frame(b'{"kind": "step", "seq": 1' + b"0" * 5000 + b"}"),
    "huge float": frame(b'{"kind": "step", "seq": 0, "action": {"v": 1e999999}}'),
    "unknown kind": frame({"kind": "x", "seq": 0}),
    "kind not a string": frame({"kind": 1, "seq": 0}),
}


def _header_cases() -> list[Any]:
    return [
        pytest.param(which, case, id=f"{which}-{case}")
        for which in DECODERS
        for case in HOSTILE_HEADERS
    ]


@pytest.mark.parametrize(("which", "case"), _header_cases())
def test_hostile_headers(which, case):
    got = decode_or_wire_error(DECODERS[which], HOSTILE_HEADERS[case])
    if case != "huge float":  # JSON reads it as inf; the action check refuses it later
        assert got is None


# ------------------------------------------------------------------- exact framing
def _layout(*metas: dict[str, Any], block: bytes) -> bytes:
    header = {"kind": "step", "seq": 0, "action": {}, "tensors": list(metas)}
    return frame(header, block)


def _t(name: str, offset: int, n: int = 5) -> dict[str, Any]:
    return {"name": name, "dtype": "uint8", "shape": [n], "offset": offset, "nbytes": n}


# Each breaks exactly one framing rule of PROTOCOL.md; the error must name that problem.
BAD_FRAMING: dict[str, tuple[bytes, str]] = {
    "tensors overlap": (_layout(_t("a", 0, 16), _t("b", 8, 8), block=bytes(24)),
                        "'b' at offset 8 overlaps"),
    "misaligned tensor": (_layout(_t("a", 0), _t("b", 5), block=bytes(16)),
                          "'b' at offset 5 is misaligned"),
    "gap between tensors": (_layout(_t("a", 0), _t("b", 16), block=bytes(24)),
                            "'b' at offset 16 leaves a gap"),
    "first tensor not at 0": (_layout(_t("a", 8), block=bytes(16)), "'a' at offset 8"),
    "tensors out of order": (_layout(_t("b", 8), _t("a", 0), block=bytes(16)),
                             "'b' at offset 8"),
    "trailing bytes": (_layout(_t("a", 0), block=bytes(16)), "8 trailing byte"),
    "trailing bytes, no tensor": (frame({"kind": "reset", "seq": 0}, bytes(8)),
                                  "8 trailing byte"),
    "missing padding of the last tensor": (_layout(_t("a", 0), block=bytes(5)),
                                           "ends 3 byte\\(s\\) early"),
    "missing tensor bytes": (_layout(_t("a", 0, 16), block=bytes(8)),
                             "ends 8 byte\\(s\\) early"),
    "padding not zero": (_layout(_t("a", 0), block=bytes(5) + b"\x01\0\0"),
                         "padding after it is not zero"),
    "header length not padded": (FRAME.pack(MAGIC, 15) + b'{"kind":"reset","seq":0}'[:15]
                                 + bytes(1), "must be a multiple of 8"),
    "nbytes does not match the shape": (
        _layout({**_t("a", 0), "nbytes": 8}, block=bytes(8)), "shape \\[5\\] of uint8 needs 5"),
}


@pytest.mark.parametrize("case", BAD_FRAMING)
@pytest.mark.parametrize("which", ["request", "observation"])
def test_framing_must_be_exact(which, case):
    buf, problem = BAD_FRAMING[case]
    if which == "observation" and case != "header length not padded":
        # The agent's decoder checks the host's replies alike.
        hlen = FRAME.unpack_from(buf)[1]
        header = {**REPLIES["observation"].model_dump(mode="json"),
                  "tensors": json.loads(buf[8 : 8 + hlen]).get("tensors", [])}
        buf = frame(header, buf[8 + hlen :])
    decode = DECODERS[which]
    with pytest.raises(WireError, match=problem) as e:
        decode(buf)
    assert e.value.code == "malformed"


def test_request_id_is_read_from_a_refused_request():
    from simhost._wire import request_id

    good = encode({"kind": "step", "seq": 4, "id": 77, "action": {}})
    assert request_id(good) == 77
    broken = frame({"kind": "step", "seq": 4, "id": 78, "action": {}}, bytes(3))  # trailing
    with pytest.raises(WireError):
        decode_request(broken)
    assert request_id(broken) == 78
    for hostile in (b"", b"EGC1", frame(b"[1]"), frame({"id": -1}), frame({"id": 2**60}),
                    frame({"id": "7"}), frame({"id": 1.5}), frame(b"{"), b"XXXX" + good[4:]):
        assert request_id(hostile) is None
