"""Camera frames for the page: PNGs from the MCAP log, made into small thumbnails.

The recorder writes PNGs without filters (``simhost.host._png``) and depth as raw float32; a
page carries thumbnails at most ``THUMB_WIDTH`` pixels wide (a wider frame is scaled down
to exactly that width, whatever the camera's resolution: 96x72 stays as it is, 256x192
shows at 192x144, 640x480 too), PNG with the "up" filter, as ``data:`` URIs, within a byte
budget: frames are thinned evenly until they fit, so a page stays under 2 MB at any
resolution. RGB goes as JPEG (Pillow's encoder) where that is smaller (a textured frame at
192x144 is a tenth of its PNG), so a textured episode keeps about as many frames as a flat-shaded
one; depth (grey, smooth) and segmentation (labels: exact) stay PNG.
"""

from __future__ import annotations

import base64
import struct
import zlib
from dataclasses import dataclass

import numpy as np

#: Widest thumbnail on a page, in pixels.
THUMB_WIDTH = 192
#: Most frames on one page (the recorder keeps at most 120 by step, plus the timed ones).
MAX_FRAMES = 120
#: Bytes of encoded thumbnails one page may carry (base64 adds a third).
FRAME_BUDGET = 1_100_000
#: JPEG quality of the RGB thumbnails (where a JPEG is smaller than the PNG).
JPEG_QUALITY = 80


@dataclass(frozen=True)
class Frame:
    """One logged camera frame at ``step``: pictures as H×W×3 uint8 (None: not logged)."""

    step: int
    rgb: np.ndarray | None = None
    depth: np.ndarray | None = None
    segmentation: np.ndarray | None = None


def decode_png(data: bytes) -> np.ndarray:
    """Pixels of an 8-bit grey, RGB or RGBA PNG whose rows use no filter or "up" (what
    ``simhost.host._png`` and this module write); ValueError otherwise."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError("not a PNG")
    pos, idat, head = 8, [], b""
    while pos < len(data):
        (n,), tag = struct.unpack(">I", data[pos:pos + 4]), data[pos + 4:pos + 8]
        body = data[pos + 8:pos + 8 + n]
        if tag == b"IHDR":
            head = body
        elif tag == b"IDAT":
            idat.append(body)
        pos += 12 + n
    w, h, depth, colour = struct.unpack(">IIBB", head[:10])
    channels = {0: 1, 2: 3, 6: 4}.get(colour)
    if depth != 8 or channels is None:
        raise ValueError(f"PNG of bit depth {depth}, colour type {colour}: not supported")
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(h, 1 + w * channels)
    rows = raw[:, 1:].copy()
    for y in range(h):
        f = raw[y, 0]
        if f == 2 and y > 0:
            rows[y] = rows[y] + rows[y - 1]  # uint8 wraps: the "up" filter undone
        elif f not in (0, 2):
            raise ValueError(f"PNG row filter {f}: not supported")
    img = rows.reshape(h, w, channels)
    return np.repeat(img, 3, axis=2) if channels == 1 else img[:, :, :3]


def encode_png(img: np.ndarray) -> bytes:
    """A compact PNG of an H×W×3 uint8 picture (every row "up"-filtered, zlib level 9)."""
    h, w, c = img.shape
    rows = np.ascontiguousarray(img, np.uint8).reshape(h, w * c)
    up = rows.copy()
    up[1:] = rows[1:] - rows[:-1]
    raw = np.empty((h, 1 + w * c), np.uint8)
    raw[:, 0] = 2
    raw[:, 1:] = up

    def chunk(tag: bytes, body: bytes) -> bytes:
        return (struct.pack(">I", len(body)) + tag + body
                + struct.pack(">I", zlib.crc32(tag + body)))

    return b"".join([b"\x89PNG\r\n\x1a\n",
                     chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)),
                     chunk(b"IDAT", zlib.compress(raw.tobytes(), 9)), chunk(b"IEND", b"")])


def depth_picture(metres: np.ndarray) -> np.ndarray:
    """Depth as grey, stretched over the frame's range: near light, far dark, black where
    nothing was seen."""
    d = np.asarray(metres, np.float32)
    seen = np.isfinite(d) & (d > 0)
    near, far = (np.percentile(d[seen], [1, 99]) if seen.any() else (0.0, 1.0))
    scaled = np.clip((d - near) / max(float(far - near), 1e-6), 0, 1)
    grey = np.where(seen, 245 - scaled * 205, 0).astype(np.uint8)
    return np.repeat(grey[:, :, None], 3, axis=2)


def thumbnail(img: np.ndarray, *, smooth: bool = True) -> np.ndarray:
    """``img`` scaled down to ``THUMB_WIDTH`` wide when it is wider, keeping its aspect: each
    pixel the mean of the area it covers (an area filter), or the pixel nearest its centre
    where colours are labels, as in segmentation."""
    h, w = img.shape[:2]
    if w <= THUMB_WIDTH:
        return img
    out_h = max(1, round(h * THUMB_WIDTH / w))
    if not smooth:
        return img[_nearest(h, out_h)][:, _nearest(w, THUMB_WIDTH)]
    rows = _area_weights(h, out_h)
    cols = _area_weights(w, THUMB_WIDTH)
    c = img.shape[2] if img.ndim == 3 else 1
    tall = rows @ img.reshape(h, w * c).astype(np.float32)  # (out_h, w * c)
    out = np.matmul(cols, tall.reshape(out_h, w, c))  # (out_h, THUMB_WIDTH, c)
    out = out.reshape(out_h, THUMB_WIDTH, *img.shape[2:])
    return np.clip(out.round(), 0, 255).astype(np.uint8)


def _nearest(n_in: int, n_out: int) -> np.ndarray:
    return np.minimum(((np.arange(n_out) + 0.5) * n_in / n_out).astype(int), n_in - 1)


def _area_weights(n_in: int, n_out: int) -> np.ndarray:
    """(n_out, n_in) weights: output pixel j averages input [j, j+1) * n_in / n_out."""
    scale = n_in / n_out
    lo = np.arange(n_out)[:, None] * scale
    i = np.arange(n_in)[None, :]
    overlap = np.clip(np.minimum(lo + scale, i + 1) - np.maximum(lo, i), 0.0, None)
    return (overlap / scale).astype(np.float32)


def data_uri(data: bytes, mime: str = "image/png") -> str:
    return f"data:{mime};base64," + base64.b64encode(data).decode()


def encode_jpeg(img: np.ndarray, quality: int) -> bytes:
    """A baseline JPEG of an HxWx3 uint8 picture (Pillow)."""
    import io

    from PIL import Image

    out = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(img[:, :, :3], np.uint8), "RGB").save(
        out, format="JPEG", quality=quality)
    return out.getvalue()


def compact_rgb(img: np.ndarray) -> tuple[bytes, str]:
    """The smaller of a PNG and a JPEG (quality ``JPEG_QUALITY``) of an RGB thumbnail, and
    its MIME type: a flat-shaded frame stays PNG, exact; a textured one becomes JPEG."""
    png = encode_png(img)
    jpg = encode_jpeg(img, JPEG_QUALITY)
    return (jpg, "image/jpeg") if len(jpg) < len(png) else (png, "image/png")


def page_frames(frames: list[Frame], budget: int = FRAME_BUDGET) -> list[dict[str, object]]:
    """The frames as the page carries them (``step`` and a ``data:`` URI per picture),
    evenly thinned to ``MAX_FRAMES`` and to ``budget`` encoded bytes; first and last kept."""
    by_step = {f.step: f for f in frames}  # the last frame of a step stands for it
    chosen = [by_step[s] for s in sorted(by_step)]
    while len(chosen) > MAX_FRAMES:
        chosen = chosen[::2] if chosen[-1] is chosen[::2][-1] else [*chosen[::2], chosen[-1]]
    encoded = [_encode(f) for f in chosen]
    while len(encoded) > 2 and sum(n for _, n in encoded) > budget:
        keep = list(range(0, len(encoded), 2))
        if keep[-1] != len(encoded) - 1:
            keep.append(len(encoded) - 1)
        encoded = [encoded[i] for i in keep]
    return [e for e, _ in encoded]


def _encode(f: Frame) -> tuple[dict[str, object], int]:
    out: dict[str, object] = {"step": f.step}
    size = 0
    for name, img, smooth in (("rgb", f.rgb, True), ("depth", f.depth, True),
                              ("segmentation", f.segmentation, False)):
        if img is None:
            continue
        small = thumbnail(img, smooth=smooth)
        data, mime = compact_rgb(small) if name == "rgb" else (encode_png(small), "image/png")
        size += len(data)
        out[name] = data_uri(data, mime)
    return out, size
