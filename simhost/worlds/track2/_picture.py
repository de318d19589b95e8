"""``render_attempt_vs_demo``: one PNG comparing an attempt with the demonstration.

A title line (track, seed, split, outcome, as the caller gives it) heads the picture. Two
panels plot the end-effector path seen from above (x right, y up) and from the side
(x right, z up), the demonstration in blue and the attempt in orange; a disc marks each
start, a square each end, and small black dots on the demonstration mark where its key
stages begin; a legend says so, and a scale bar in each panel gives 5 cm. When frames are
given, pairs of frames (demonstration left, attempt right) sampled evenly along both runs
follow below.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from simhost.host._png import encode_png

from ._packet import DemoPacket, read_demo_packet
from ._raster import Canvas, decode_png

DEMO_RGB = (40, 90, 200)
ATTEMPT_RGB = (235, 120, 20)
INK = (30, 30, 30)
PAPER = (250, 250, 247)


def resize_rgb(img: np.ndarray, width: int) -> np.ndarray:
    """``img`` (RGB, or one channel, made RGB) scaled to ``width`` pixels by nearest
    neighbour, its aspect kept."""
    h, w = img.shape[:2]
    height = max(1, round(h * width / w))
    ys = np.minimum((np.arange(height) * h / height).astype(int), h - 1)
    xs = np.minimum((np.arange(width) * w / width).astype(int), w - 1)
    out = img[ys][:, xs]
    return out if out.ndim == 3 else np.repeat(out[..., None], 3, axis=2)


#: The old private name, still imported by ``plugins/track2/_picture.py`` (on the allow-list
#: of ``tests/test_public_surface.py``) until it imports ``simhost.worlds.track2.resize_rgb``.
_resize = resize_rgb


def render_attempt_vs_demo(
    demo: DemoPacket | str | Path | np.ndarray,
    attempt: np.ndarray,
    *,
    attempt_frames: Sequence[np.ndarray] | None = None,
    demo_frames: Sequence[np.ndarray] | None = None,
    path: str | Path | None = None,
    panel: int = 320,
    pairs: int = 4,
    title: str = "",
) -> bytes:
    """Draw the attempt's end-effector path against the demonstration's; return PNG bytes.

    Args:
      demo: a packet (or its folder) or an ``(N, >=3)`` array of TCP positions.
      attempt: ``(M, >=3)`` TCP positions of the attempt (e.g. ``obs["proprio"]`` rows).
      attempt_frames, demo_frames: optional RGB frames; a packet's own frames are used for
        the demonstration when ``demo_frames`` is omitted.
      path: also write the PNG there.
      panel: side of each plot panel in pixels.
      pairs: how many frame pairs to show.
      title: the heading (e.g. ``TRACK2 SEED 12 STANDARD ATTEMPT 2 OF 3 FAILED``).
    """
    stage_starts: list[int] = []
    if isinstance(demo, str | Path):
        demo = read_demo_packet(demo)
    if isinstance(demo, DemoPacket):
        if demo_frames is None:
            demo_frames = [decode_png(p.read_bytes()) for p in demo.frame_paths()]
        stage_starts = [ks.start for ks in demo.manifest.key_stages]
        demo_xyz = np.asarray(demo.arrays["obs_proprio"], dtype=float)[:, :3]
    else:
        demo_xyz = np.asarray(demo, dtype=float)[:, :3]
    att_xyz = np.asarray(attempt, dtype=float)[:, :3]
    for name, arr in (("demo", demo_xyz), ("attempt", att_xyz)):
        if arr.ndim != 2 or arr.shape[0] == 0 or not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} path must be a non-empty finite (N, >=3) array")
    both = np.vstack([demo_xyz, att_xyz])
    lo, hi = both.min(axis=0), both.max(axis=0)
    span = float(max(np.max(hi - lo), 0.05)) * 1.15
    centre = (lo + hi) / 2
    head, margin = 58, 12
    width = 2 * panel + 3 * margin
    strip: list[np.ndarray] = []
    if attempt_frames and demo_frames:
        half = (width - 3 * margin) // 2
        for i in range(pairs):
            a = demo_frames[round(i * (len(demo_frames) - 1) / max(pairs - 1, 1))]
            b = attempt_frames[round(i * (len(attempt_frames) - 1) / max(pairs - 1, 1))]
            strip.append(np.hstack([resize_rgb(a, half), np.full((resize_rgb(a, half).shape[0],
                                    margin, 3), 255, np.uint8), resize_rgb(b, half)]))
    height = head + panel + 2 * margin + sum(s.shape[0] + margin for s in strip)
    c = Canvas(height, width, PAPER)
    c.text(6, margin, title or "TRACK2 ATTEMPT VS DEMONSTRATION", INK)
    y = 26
    c.rect(y, margin, y + 10, margin + 10, DEMO_RGB)
    c.text(y, margin + 16, "DEMO", INK)
    c.rect(y, margin + 70, y + 10, margin + 80, ATTEMPT_RGB)
    c.text(y, margin + 86, "ATTEMPT", INK)
    c.disc(y + 5, margin + 180, 4, INK)
    c.text(y, margin + 190, "START", INK)
    c.rect(y + 1, margin + 250, y + 10, margin + 259, INK)
    c.text(y, margin + 265, "END", INK)
    c.disc(y + 5, margin + 315, 2.5, INK)
    c.text(y, margin + 324, "KEY STAGE STARTS", INK)
    for k, (axis, label) in enumerate(((1, "TOP X-Y"), (2, "SIDE X-Z"))):
        x0, y0 = margin + k * (panel + margin), head + margin
        c.rect(y0, x0, y0 + panel, x0 + panel, (255, 255, 255))
        c.text(y0 + 4, x0 + 4, label, (120, 120, 120))

        def to_px(
            p: np.ndarray, axis: int = axis, x0: int = x0, y0: int = y0
        ) -> tuple[np.ndarray, np.ndarray]:
            u = (p[:, 0] - centre[0]) / span + 0.5
            v = (p[:, axis] - centre[axis]) / span + 0.5
            return y0 + (1 - v) * (panel - 1), x0 + u * (panel - 1)

        for xyz, colour in ((demo_xyz, DEMO_RGB), (att_xyz, ATTEMPT_RGB)):
            ys, xs = to_px(xyz)
            c.polyline(ys, xs, colour, thick=2)
            c.disc(ys[0], xs[0], 4, colour)
            c.rect(int(ys[-1]) - 4, int(xs[-1]) - 4, int(ys[-1]) + 5, int(xs[-1]) + 5, colour)
        ys, xs = to_px(demo_xyz)
        for s in stage_starts[1:]:
            if s < len(ys):
                c.disc(ys[s], xs[s], 2.5, INK)
        bar = int(round(0.05 / span * (panel - 1)))  # 5 cm
        by, bx = y0 + panel - 12, x0 + 8
        c.rect(by, bx, by + 3, bx + bar, INK)
        c.text(by - 14, bx, "5 CM", INK)
    y = head + panel + 2 * margin
    for s in strip:
        c.blit(y, margin, s)
        y += s.shape[0] + margin
    png = encode_png(c.img)
    if path is not None:
        Path(path).write_bytes(png)
    return png
