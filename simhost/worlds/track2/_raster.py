"""Raster drawing and PNG decoding with numpy and zlib only (no matplotlib).

Encoding is ``simhost.host._png.encode_png``.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

_SIG = b"\x89PNG\r\n\x1a\n"


def decode_png(data: bytes) -> np.ndarray:
    """Decode a PNG written by :func:`encode_png` (8-bit grey or RGB, no interlace)."""
    if not data.startswith(_SIG):
        raise ValueError("not a PNG file")
    pos, idat, head = len(_SIG), b"", None
    while pos < len(data):
        (n,) = struct.unpack_from(">I", data, pos)
        tag = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + n]
        pos += 12 + n
        if tag == b"IHDR":
            head = struct.unpack(">IIBBBBB", body)
        elif tag == b"IDAT":
            idat += body
    if head is None:
        raise ValueError("PNG without IHDR")
    w, h, depth, colour, _, _, interlace = head
    if depth != 8 or colour not in (0, 2) or interlace:
        raise ValueError("only 8-bit grey/RGB non-interlaced PNGs are supported")
    ch = 3 if colour == 2 else 1
    raw = np.frombuffer(zlib.decompress(idat), dtype=np.uint8).reshape(h, 1 + w * ch)
    if not raw[:, 0].any():  # every row unfiltered (what encode_png writes): no work
        img = raw[:, 1:].copy()
        return img.reshape(h, w, 3) if ch == 3 else img
    out = np.zeros((h, w * ch), dtype=np.int32)
    prev = np.zeros(w * ch, dtype=np.int32)
    for y in range(h):
        f, line = raw[y, 0], raw[y, 1:].astype(np.int32)
        cur = np.zeros_like(line)
        for x in range(w * ch):
            a = cur[x - ch] if x >= ch else 0
            b = prev[x]
            c = prev[x - ch] if x >= ch else 0
            if f == 0:
                pred = 0
            elif f == 1:
                pred = a
            elif f == 2:
                pred = b
            elif f == 3:
                pred = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (line[x] + pred) & 0xFF
        out[y] = prev = cur
    img = out.astype(np.uint8)
    return img.reshape(h, w, 3) if ch == 3 else img


class Canvas:
    """An RGB raster with lines, discs and rectangles (anti-aliasing: none)."""

    def __init__(self, height: int, width: int, background: tuple[int, int, int]) -> None:
        self.img = np.empty((height, width, 3), dtype=np.uint8)
        self.img[:] = background

    @property
    def shape(self) -> tuple[int, int]:
        return self.img.shape[0], self.img.shape[1]

    def rect(self, y0: int, x0: int, y1: int, x1: int, colour: tuple[int, int, int]) -> None:
        h, w = self.shape
        y0, y1 = max(0, min(y0, y1)), min(h, max(y0, y1))
        x0, x1 = max(0, min(x0, x1)), min(w, max(x0, x1))
        self.img[y0:y1, x0:x1] = colour

    def disc(self, y: float, x: float, r: float, colour: tuple[int, int, int]) -> None:
        h, w = self.shape
        yy, xx = np.ogrid[:h, :w]
        self.img[(yy - y) ** 2 + (xx - x) ** 2 <= r * r] = colour

    def polyline(
        self, ys: np.ndarray, xs: np.ndarray, colour: tuple[int, int, int], thick: int = 1
    ) -> None:
        h, w = self.shape
        for k in range(len(ys) - 1):
            n = int(max(abs(ys[k + 1] - ys[k]), abs(xs[k + 1] - xs[k]), 1)) + 1
            py = np.linspace(ys[k], ys[k + 1], n)
            px = np.linspace(xs[k], xs[k + 1], n)
            for dy in range(-(thick // 2), thick - thick // 2):
                for dx in range(-(thick // 2), thick - thick // 2):
                    iy = np.clip(np.round(py).astype(int) + dy, 0, h - 1)
                    ix = np.clip(np.round(px).astype(int) + dx, 0, w - 1)
                    self.img[iy, ix] = colour

    def blit(self, y: int, x: int, image: np.ndarray) -> None:
        h, w = image.shape[:2]
        self.img[y : y + h, x : x + w] = image[: self.shape[0] - y, : self.shape[1] - x]

    def text(self, y: int, x: int, s: str, colour: tuple[int, int, int], scale: int = 2) -> None:
        """Draw ``s`` (A-Z, 0-9, space, a few signs) in a 3x5 pixel font."""
        for i, ch in enumerate(s.upper()):
            rows = _FONT.get(ch, _FONT["?"])
            for r, bits in enumerate(rows):
                for c in range(3):
                    if bits >> (2 - c) & 1:
                        yy, xx = y + r * scale, x + (i * 4 + c) * scale
                        self.rect(yy, xx, yy + scale, xx + scale, colour)


_FONT: dict[str, tuple[int, ...]] = {
    "A": (2, 5, 7, 5, 5), "B": (6, 5, 6, 5, 6), "C": (3, 4, 4, 4, 3), "D": (6, 5, 5, 5, 6),
    "E": (7, 4, 6, 4, 7), "F": (7, 4, 6, 4, 4), "G": (3, 4, 5, 5, 3), "H": (5, 5, 7, 5, 5),
    "I": (7, 2, 2, 2, 7), "J": (1, 1, 1, 5, 2), "K": (5, 5, 6, 5, 5), "L": (4, 4, 4, 4, 7),
    "M": (5, 7, 7, 5, 5), "N": (6, 5, 5, 5, 5), "O": (2, 5, 5, 5, 2), "P": (6, 5, 6, 4, 4),
    "Q": (2, 5, 5, 6, 3), "R": (6, 5, 6, 5, 5), "S": (3, 4, 2, 1, 6), "T": (7, 2, 2, 2, 2),
    "U": (5, 5, 5, 5, 7), "V": (5, 5, 5, 5, 2), "W": (5, 5, 7, 7, 5), "X": (5, 5, 2, 5, 5),
    "Y": (5, 5, 2, 2, 2), "Z": (7, 1, 2, 4, 7), "0": (7, 5, 5, 5, 7), "1": (2, 6, 2, 2, 7),
    "2": (6, 1, 2, 4, 7), "3": (6, 1, 2, 1, 6), "4": (5, 5, 7, 1, 1), "5": (7, 4, 6, 1, 6),
    "6": (3, 4, 7, 5, 7), "7": (7, 1, 2, 2, 2), "8": (7, 5, 7, 5, 7), "9": (7, 5, 7, 1, 6),
    " ": (0, 0, 0, 0, 0), "-": (0, 0, 7, 0, 0), "_": (0, 0, 0, 0, 7), ".": (0, 0, 0, 0, 2),
    ":": (0, 2, 0, 2, 0), "/": (1, 1, 2, 4, 4), "%": (5, 1, 2, 4, 5), "?": (6, 1, 2, 0, 2),
    "(": (1, 2, 2, 2, 1), ")": (4, 2, 2, 2, 4), "=": (0, 7, 0, 7, 0), "+": (0, 2, 7, 2, 0),
}
