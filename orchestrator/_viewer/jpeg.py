"""A baseline JPEG encoder in numpy, for the viewer's camera thumbnails.

A textured scene's RGB frame at 192x144 is 30-40 kB as PNG and 4-8 kB as JPEG at quality
80, so a page within its byte budget keeps five to eight times as many frames (the
scrubber's resolution). Every browser decodes baseline JPEG; nothing here is needed
anywhere else, and no image library is added for it.

``encode_jpeg(img, quality)``: JFIF, YCbCr with 4:2:0 chroma, the quantisation tables of
the JPEG standard's Annex K scaled by ``quality`` as the IJG library does, and Huffman
tables made for the picture itself (optimal code lengths limited to 16 bits, as the
standard's Annex K.2 procedure gives). Labels (segmentation) and depth stay PNG: lossless.
"""

from __future__ import annotations

import heapq
import struct

import numpy as np

_LUMA_Q = np.array([
    16, 11, 10, 16, 24, 40, 51, 61, 12, 12, 14, 19, 26, 58, 60, 55,
    14, 13, 16, 24, 40, 57, 69, 56, 14, 17, 22, 29, 51, 87, 80, 62,
    18, 22, 37, 56, 68, 109, 103, 77, 24, 35, 55, 64, 81, 104, 113, 92,
    49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99,
], np.float64).reshape(8, 8)
_CHROMA_Q = np.full((8, 8), 99.0)
_CHROMA_Q[:4, :4] = np.array([17, 18, 24, 47, 18, 21, 26, 66, 24, 26, 56, 99, 47, 66, 99, 99],
                             np.float64).reshape(4, 4)


def _zigzag() -> np.ndarray:
    """Row-major indices of an 8x8 block in the JPEG zig-zag order."""
    order = sorted(((r, c) for r in range(8) for c in range(8)),
                   key=lambda rc: (rc[0] + rc[1], rc[0] if (rc[0] + rc[1]) % 2 else rc[1]))
    return np.array([r * 8 + c for r, c in order])


_ZIGZAG = _zigzag()
_DCT = np.array([[(np.sqrt(0.5) if k == 0 else 1.0) * 0.5 * np.cos((2 * n + 1) * k * np.pi / 16)
                  for n in range(8)] for k in range(8)])


def _scaled(table: np.ndarray, quality: int) -> np.ndarray:
    q = max(1, min(100, quality))
    scale = 5000 / q if q < 50 else 200 - 2 * q
    return np.clip(np.floor((table * scale + 50) / 100), 1, 255)


def _blocks(plane: np.ndarray) -> np.ndarray:
    """(rows, cols, 8, 8) blocks of a plane whose sides are multiples of 8."""
    h, w = plane.shape
    return plane.reshape(h // 8, 8, w // 8, 8).swapaxes(1, 2)


def _quantised(plane: np.ndarray, table: np.ndarray) -> np.ndarray:
    """(rows, cols, 64) quantised DCT coefficients in zig-zag order."""
    b = _blocks(plane - 128.0)
    coef = _DCT @ b @ _DCT.T
    q = np.round(coef / table).astype(np.int32)
    return q.reshape(*q.shape[:2], 64)[:, :, _ZIGZAG]


def _code_lengths(freq: dict[int, int]) -> dict[int, int]:
    """Huffman code lengths of ``freq``'s symbols, at most 16 bits, with one all-ones code
    left unused (a pseudo-symbol of frequency 1, as in the standard's Annex K.2)."""
    items = dict(freq)
    items[256] = 1
    heap: list[tuple[int, int, list[int]]] = [(f, s, [s]) for s, f in items.items()]
    heapq.heapify(heap)
    length = dict.fromkeys(items, 0)
    tie = 1000
    while len(heap) > 1:
        f1, _, a = heapq.heappop(heap)
        f2, _, b = heapq.heappop(heap)
        for s in a + b:
            length[s] += 1
        tie += 1
        heapq.heappush(heap, (f1 + f2, tie, a + b))
    counts = [0] * 64
    for n in length.values():
        counts[n] += 1
    for n in range(63, 16, -1):  # Annex K.2: move the longest codes up to 16 bits
        while counts[n] > 0:
            j = n - 2
            while counts[j] == 0:
                j -= 1
            counts[n] -= 2
            counts[n - 1] += 1
            counts[j + 1] += 2
            counts[j] -= 1
    n = 16
    while counts[n] == 0:
        n -= 1
    counts[n] -= 1  # the pseudo-symbol's code: the all-ones one, never used
    ordered = sorted((s for s in items if s != 256), key=lambda s: (length[s], s))
    out: dict[int, int] = {}
    k = 0
    for size in range(1, 17):
        for _ in range(counts[size]):
            out[ordered[k]] = size
            k += 1
    return out


def _table(freq: dict[int, int]) -> tuple[bytes, dict[int, tuple[int, int]]]:
    """A DHT body (BITS and HUFFVAL) and each symbol's (code, length), canonical order."""
    lengths = _code_lengths(freq)
    ordered = sorted(lengths, key=lambda s: (lengths[s], s))
    bits = [sum(1 for s in ordered if lengths[s] == n) for n in range(1, 17)]
    codes: dict[int, tuple[int, int]] = {}
    code, size = 0, 1
    for s in ordered:
        while lengths[s] > size:
            code <<= 1
            size += 1
        codes[s] = (code, size)
        code += 1
    return bytes(bits) + bytes(ordered), codes


def _events(q: np.ndarray, comp: np.ndarray) -> tuple[np.ndarray, ...]:
    """The scan's symbols in order, from ``q`` (blocks in scan order, 64 zig-zag
    coefficients each) and each block's component: (table, symbol, extra bits, extra size)
    per symbol. Tables: 0 DC luma, 1 AC luma, 2 DC chroma, 3 AC chroma."""
    n = len(q)
    chroma = (comp > 0).astype(np.int64) * 2
    dc = q[:, 0].astype(np.int64)
    diff = np.empty(n, np.int64)
    for c in (0, 1, 2):  # each component's DC is coded as the change from its last block
        idx = np.flatnonzero(comp == c)
        diff[idx] = np.diff(dc[idx], prepend=0)
    blocks, pos = np.nonzero(q[:, 1:])
    pos = pos + 1
    vals = q[blocks, pos].astype(np.int64)
    first = np.ones(len(blocks), bool)
    first[1:] = blocks[1:] != blocks[:-1]
    prev = np.where(first, 0, np.concatenate([[0], pos[:-1]]))
    run = pos - prev - 1
    zrl = run // 16  # a run of 16 zeros or more: one ZRL symbol (0xF0) per 16
    run = run % 16
    last = np.zeros(n, np.int64)
    last[blocks] = pos  # nonzero() is in order: the last write is the block's last
    eob = np.flatnonzero(last != 63)
    z_blocks = np.repeat(blocks, zrl)
    z_pos = np.repeat(pos, zrl)

    def size_of(v: np.ndarray) -> np.ndarray:
        a = np.abs(v)
        out = np.zeros(len(v), np.int64)
        nz = a > 0
        out[nz] = np.floor(np.log2(a[nz])).astype(np.int64) + 1
        return out

    def extra_of(v: np.ndarray, size: np.ndarray) -> np.ndarray:
        return np.where(v >= 0, v, v + (np.int64(1) << size) - 1)

    dc_size, ac_size = size_of(diff), size_of(vals)
    parts = [  # (block, order key, table, symbol, extra, size)
        (np.arange(n), np.zeros(n), chroma, dc_size, extra_of(diff, dc_size), dc_size),
        (z_blocks, z_pos - 0.5, chroma[z_blocks] + 1, np.full(len(z_blocks), 0xF0),
         np.zeros(len(z_blocks), np.int64), np.zeros(len(z_blocks), np.int64)),
        (blocks, pos.astype(float), chroma[blocks] + 1, run << 4 | ac_size,
         extra_of(vals, ac_size), ac_size),
        (eob, np.full(len(eob), 64.0), chroma[eob] + 1, np.zeros(len(eob), np.int64),
         np.zeros(len(eob), np.int64), np.zeros(len(eob), np.int64)),
    ]
    cols = [np.concatenate([np.asarray(p[k]) for p in parts]) for k in range(6)]
    order = np.lexsort((cols[1], cols[0]))
    return tuple(c[order].astype(np.int64) for c in cols[2:])


def _pack(values: np.ndarray, lengths: np.ndarray) -> bytes:
    """Concatenate each value's low ``length`` bits, most significant first; pad with
    ones to a byte and stuff a zero byte after every 0xFF."""
    total = int(lengths.sum())
    if total == 0:
        return b""
    starts = np.cumsum(lengths) - lengths
    rep_v = np.repeat(values, lengths)
    rep_l = np.repeat(lengths, lengths)
    k = np.arange(total) - np.repeat(starts, lengths)
    bits = ((rep_v >> (rep_l - 1 - k)) & 1).astype(np.uint8)
    bits = np.concatenate([bits, np.ones(-total % 8, np.uint8)])
    return np.packbits(bits).tobytes().replace(b"\xff", b"\xff\x00")


def encode_jpeg(img: np.ndarray, quality: int = 80) -> bytes:
    """A baseline JPEG of an H×W×3 uint8 picture (4:2:0, per-picture Huffman tables)."""
    h, w = img.shape[:2]
    ph, pw = -(-h // 16) * 16, -(-w // 16) * 16
    rgb = np.pad(np.asarray(img, np.float64)[:, :, :3], ((0, ph - h), (0, pw - w), (0, 0)),
                 mode="edge")
    r, g, b = rgb[:, :, 0], rgb[:, :, 1], rgb[:, :, 2]
    y = 0.299 * r + 0.587 * g + 0.114 * b
    cb = 128 - 0.168736 * r - 0.331264 * g + 0.5 * b
    cr = 128 + 0.5 * r - 0.418688 * g - 0.081312 * b

    def half(p: np.ndarray) -> np.ndarray:
        return p.reshape(ph // 2, 2, pw // 2, 2).mean(axis=(1, 3))

    lq, cq = _scaled(_LUMA_Q, quality), _scaled(_CHROMA_Q, quality)
    my, mx = ph // 16, pw // 16
    # scan order: per 16x16 unit, its four luma blocks, then one Cb and one Cr block
    qy = _quantised(y, lq).reshape(my, 2, mx, 2, 64).transpose(0, 2, 1, 3, 4)
    qy = qy.reshape(my * mx, 4, 64)
    qcb = _quantised(half(cb), cq).reshape(my * mx, 1, 64)
    qcr = _quantised(half(cr), cq).reshape(my * mx, 1, 64)
    q = np.concatenate([qy, qcb, qcr], axis=1).reshape(-1, 64)
    comp = np.tile(np.array([0, 0, 0, 0, 1, 2]), my * mx)
    table, symbol, extra, size = _events(q, comp)
    tables = []
    codes = np.zeros((4, 256), np.int64)
    lengths = np.zeros((4, 256), np.int64)
    for t in range(4):
        found, counts = np.unique(symbol[table == t], return_counts=True)
        body, code_of = _table(dict(zip(found.tolist(), counts.tolist(), strict=True)))
        tables.append(body)
        for s, (code, n) in code_of.items():
            codes[t, s], lengths[t, s] = code, n
    values = codes[table, symbol] << size | extra
    scan = _pack(values, lengths[table, symbol] + size)

    def segment(marker: int, body: bytes) -> bytes:
        return struct.pack(">BBH", 0xFF, marker, len(body) + 2) + body

    dqt = (b"\x00" + bytes(lq.reshape(64)[_ZIGZAG].astype(np.uint8))
           + b"\x01" + bytes(cq.reshape(64)[_ZIGZAG].astype(np.uint8)))
    sof = struct.pack(">BHHB", 8, h, w, 3) + bytes([1, 0x22, 0, 2, 0x11, 1, 3, 0x11, 1])
    dht = b"".join(bytes([cls_id]) + tables[k]
                   for k, cls_id in enumerate((0x00, 0x10, 0x01, 0x11)))
    sos = bytes([3, 1, 0x00, 2, 0x11, 3, 0x11, 0, 63, 0])
    return b"".join([
        b"\xff\xd8",
        segment(0xE0, b"JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00"),
        segment(0xDB, dqt), segment(0xC0, sof), segment(0xC4, dht), segment(0xDA, sos),
        scan, b"\xff\xd9",
    ])
