"""Low-poly meshes made in code, for the categories no asset package has.

A build-time tool: ``reproduce.py`` runs it to write ``meshes/*.obj``; nothing imports it at
run time. Plain numpy (no trimesh): closed, outward-facing triangle meshes from a few
primitives (boxes, prisms, surfaces of revolution, tubes along a path, slabs), written as OBJ
with five decimals so that the bytes are the same on every machine.

Frames: furniture and containers stand on z = 0, centred in x (width) and y (depth), front
towards +y, sized as the catalogue's default (``simhost/worlds/track1/_catalogue.py``); an item is
centred on its origin with the extent of the catalogue's primitive; a container's front or
top panel (the Track 1 "lid") is centred on its origin. The Track 2 parts are unit sized
(scale them per instance).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

Point = tuple[float, float, float]


@dataclass(frozen=True)
class Mesh:
    """Triangles ``faces`` (indices into ``vertices``), counter-clockwise seen from outside."""

    vertices: np.ndarray
    faces: np.ndarray

    def __add__(self, other: Mesh) -> Mesh:
        return Mesh(
            np.vstack([self.vertices, other.vertices]),
            np.vstack([self.faces, other.faces + len(self.vertices)]),
        )

    def moved(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Mesh:
        return Mesh(self.vertices + np.array([x, y, z]), self.faces)

    def scaled(self, x: float, y: float, z: float) -> Mesh:
        return _oriented(Mesh(self.vertices * np.array([x, y, z]), self.faces))

    def turned(self, axis: str, degrees: float) -> Mesh:
        """Rotated about the x, y or z axis through the origin (right hand)."""
        c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
        i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
        v = self.vertices.copy()
        v[:, i] = c * self.vertices[:, i] - s * self.vertices[:, j]
        v[:, j] = s * self.vertices[:, i] + c * self.vertices[:, j]
        return Mesh(v, self.faces)


def _oriented(mesh: Mesh) -> Mesh:
    """The mesh with its faces flipped when its signed volume is negative (inside out)."""
    v = mesh.vertices[mesh.faces]
    volume = np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum()
    return mesh if volume >= 0 else Mesh(mesh.vertices, mesh.faces[:, ::-1].copy())


def join(parts: Sequence[Mesh]) -> Mesh:
    out = parts[0]
    for part in parts[1:]:
        out = out + part
    return out


# -- primitives ------------------------------------------------------------------------------------
def box(lo: Point, hi: Point) -> Mesh:
    """An axis-aligned box between corners ``lo`` and ``hi``."""
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], float)
    f = np.array(
        [
            [0, 2, 1],
            [1, 2, 3],
            [4, 5, 6],
            [5, 7, 6],
            [0, 1, 4],
            [1, 5, 4],
            [2, 6, 3],
            [3, 6, 7],
            [0, 4, 2],
            [2, 4, 6],
            [1, 3, 5],
            [3, 7, 5],
        ]
    )
    return _oriented(Mesh(v, f))


def prism(polygon: Sequence[tuple[float, float]], z0: float, z1: float) -> Mesh:
    """A convex polygon in the xy plane extruded from ``z0`` to ``z1``."""
    n = len(polygon)
    p = np.array(polygon, float)
    v = np.vstack([np.c_[p, np.full(n, z0)], np.c_[p, np.full(n, z1)]])
    faces = [[0, k + 1, k] for k in range(1, n - 1)] + [
        [n, n + k, n + k + 1] for k in range(1, n - 1)
    ]
    for k in range(n):
        a, b = k, (k + 1) % n
        faces += [[a, b, n + b], [a, n + b, n + a]]
    return _oriented(Mesh(v, np.array(faces)))


def rounded_rect(w: float, d: float, r: float, steps: int = 3) -> list[tuple[float, float]]:
    """A w x d rectangle centred on the origin with corners rounded to radius ``r``."""
    out = []
    for cx, cy, a0 in (
        (w / 2 - r, d / 2 - r, 0),
        (-w / 2 + r, d / 2 - r, 90),
        (-w / 2 + r, -d / 2 + r, 180),
        (w / 2 - r, -d / 2 + r, 270),
    ):
        for k in range(steps + 1):
            a = math.radians(a0 + 90 * k / steps)
            out.append((cx + r * math.cos(a), cy + r * math.sin(a)))
    return out


def slab(lo: Point, hi: Point, r: float) -> Mesh:
    """A box with its vertical edges rounded (a cushion, a mattress, a sponge)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    return prism(rounded_rect(x1 - x0, y1 - y0, r), z0, z1).moved((x0 + x1) / 2, (y0 + y1) / 2)


def lathe(profile: Sequence[tuple[float, float]], segments: int = 16) -> Mesh:
    """A surface of revolution about z of the (radius, z) ``profile``, which starts and ends on
    the axis (radius 0), so that the solid is closed; a profile that climbs the outside and
    comes back down the inside makes a hollow vessel."""
    if profile[0][0] != 0 or profile[-1][0] != 0:
        raise ValueError("a lathe profile starts and ends on the axis")
    verts: list[list[float]] = []
    rings: list[list[int]] = []
    for r, z in profile:
        if r == 0:
            verts.append([0.0, 0.0, z])
            rings.append([len(verts) - 1] * segments)
        else:
            start = len(verts)
            for j in range(segments):
                a = 2 * math.pi * j / segments
                verts.append([r * math.cos(a), r * math.sin(a), z])
            rings.append(list(range(start, start + segments)))
    faces = []
    for lower, upper in zip(rings, rings[1:], strict=False):
        for j in range(segments):
            k = (j + 1) % segments
            for tri in ((lower[j], lower[k], upper[k]), (lower[j], upper[k], upper[j])):
                if len(set(tri)) == 3:
                    faces.append(tri)
    return _oriented(Mesh(np.array(verts), np.array(faces)))


def ellipsoid(rx: float, ry: float, rz: float, segments: int = 12) -> Mesh:
    rows = max(segments // 2, 3)
    profile = [
        (math.sin(math.pi * i / rows), -math.cos(math.pi * i / rows)) for i in range(rows + 1)
    ]
    profile = [(0.0 if i in (0, rows) else r, z) for i, (r, z) in enumerate(profile)]
    return lathe(profile, segments).scaled(rx, ry, rz)


def tube(path: Sequence[Point], radius: float | Sequence[float], segments: int = 8) -> Mesh:
    """A capped tube of ``radius`` (one, or one per point) along a polyline."""
    p = np.array(path, float)
    radii = np.broadcast_to(np.asarray(radius, float), (len(p),))
    tangents = np.gradient(p, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1)[:, None]
    helper = np.array([0.0, 0.0, 1.0]) if abs(tangents[0, 2]) < 0.9 else np.array([1.0, 0, 0])
    normal = np.cross(tangents[0], helper)
    normal /= np.linalg.norm(normal)
    verts: list[np.ndarray] = []
    for i, t in enumerate(tangents):
        normal = normal - t * (normal @ t)  # parallel transport of the frame
        normal /= np.linalg.norm(normal)
        binormal = np.cross(t, normal)
        for j in range(segments):
            a = 2 * math.pi * j / segments
            verts.append(p[i] + radii[i] * (math.cos(a) * normal + math.sin(a) * binormal))
    n = len(p)
    verts += [p[0], p[-1]]
    first, last = n * segments, n * segments + 1
    faces = []
    for i in range(n - 1):
        for j in range(segments):
            k = (j + 1) % segments
            a, b = i * segments + j, i * segments + k
            faces += [[a, b, b + segments], [a, b + segments, a + segments]]
    for j in range(segments):
        k = (j + 1) % segments
        faces += [[first, k, j], [last, (n - 1) * segments + j, (n - 1) * segments + k]]
    return _oriented(Mesh(np.array(verts), np.array(faces)))


def arc(
    centre: Point, radius: float, a0: float, a1: float, plane: str = "xz", steps: int = 8
) -> list[Point]:
    """Points on a circular arc in the ``xz``, ``yz`` or ``xy`` plane, angles in degrees."""
    out = []
    for k in range(steps + 1):
        a = math.radians(a0 + (a1 - a0) * k / steps)
        u, w = radius * math.cos(a), radius * math.sin(a)
        dx, dy, dz = {"xz": (u, 0, w), "yz": (0, u, w), "xy": (u, w, 0)}[plane]
        out.append((centre[0] + dx, centre[1] + dy, centre[2] + dz))
    return out


def wavy_slab(
    w: float, d: float, thickness: float, z: float, amplitude: float, cells: int = 10
) -> Mesh:
    """A thin w x d sheet centred at height ``z``, rippled by ``amplitude`` (cloth)."""
    xs, ys = np.linspace(-w / 2, w / 2, cells + 1), np.linspace(-d / 2, d / 2, cells + 1)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    h = z + amplitude * np.sin(2.5 * math.pi * gx / w) * np.cos(1.5 * math.pi * gy / d)
    top = np.c_[gx.ravel(), gy.ravel(), (h + thickness / 2).ravel()]
    bottom = np.c_[gx.ravel(), gy.ravel(), (h - thickness / 2).ravel()]
    n, m = cells + 1, (cells + 1) ** 2
    faces = []
    for i in range(cells):
        for j in range(cells):
            a, b, c, e = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            faces += [[a, b, c], [a, c, e], [m + a, m + c, m + b], [m + a, m + e, m + c]]
    border = (
        [i * n for i in range(n)]
        + [cells * n + j for j in range(1, n)]
        + [i * n + cells for i in range(cells - 1, -1, -1)]
        + [j for j in range(cells - 1, 0, -1)]
    )
    for a, b in zip(border, border[1:] + border[:1], strict=True):
        faces += [[a, m + a, m + b], [a, m + b, b]]
    return _oriented(Mesh(np.vstack([top, bottom]), np.array(faces)))


# -- Track 1: objects and tools (centred, the catalogue primitive's extent) ----------------------
def apple() -> Mesh:
    body = lathe(
        [
            (0, -0.034),
            (0.016, -0.039),
            (0.031, -0.031),
            (0.039, -0.014),
            (0.040, 0.004),
            (0.037, 0.022),
            (0.027, 0.035),
            (0.012, 0.038),
            (0, 0.031),
        ],
        16,
    )
    stem = tube([(0, 0, 0.028), (0.002, 0, 0.040), (0.006, 0, 0.047)], 0.0025, 6)
    return body + stem


def plate() -> Mesh:
    return lathe(
        [
            (0, -0.008),
            (0.055, -0.008),
            (0.06, -0.01),
            (0.066, -0.008),
            (0.092, 0.005),
            (0.1, 0.01),
            (0.097, 0.01),
            (0.088, 0.006),
            (0.06, -0.004),
            (0, -0.004),
        ],
        24,
    )


def bowl() -> Mesh:
    return lathe(
        [
            (0, -0.03),
            (0.032, -0.03),
            (0.036, -0.026),
            (0.055, -0.012),
            (0.066, 0.008),
            (0.07, 0.03),
            (0.064, 0.03),
            (0.06, 0.012),
            (0.047, -0.008),
            (0.025, -0.02),
            (0, -0.022),
        ],
        20,
    )


def jug() -> Mesh:
    body = lathe(
        [
            (0, -0.1),
            (0.044, -0.1),
            (0.05, -0.092),
            (0.05, -0.03),
            (0.043, 0.035),
            (0.036, 0.07),
            (0.039, 0.094),
            (0.042, 0.1),
            (0.037, 0.1),
            (0.034, 0.072),
            (0.038, 0.035),
            (0.045, -0.03),
            (0.045, -0.088),
            (0, -0.094),
        ],
        16,
    )
    handle = tube(arc((-0.045, 0, 0.0), 0.05, 100, 260, "xz", 8), 0.007, 8)
    spout = tube([(0.03, 0, 0.085), (0.045, 0, 0.095), (0.056, 0, 0.1)], [0.014, 0.011, 0.008], 8)
    return body + handle + spout


def watering_can() -> Mesh:
    body = lathe(
        [
            (0, -0.09),
            (0.064, -0.09),
            (0.07, -0.082),
            (0.07, 0.02),
            (0.062, 0.04),
            (0.03, 0.05),
            (0.03, 0.058),
            (0, 0.058),
        ],
        16,
    )
    spout = tube([(0.05, 0, -0.05), (0.085, 0, 0.0), (0.115, 0, 0.045)], 0.008, 8)
    rose = lathe([(0, -0.004), (0.02, -0.004), (0.02, 0.004), (0, 0.012)], 12)
    rose = rose.turned("y", 35).moved(0.12, 0, 0.052)
    handle = tube(
        [
            (-0.066, 0, -0.01),
            (-0.09, 0, 0.02),
            (-0.085, 0, 0.065),
            (-0.05, 0, 0.08),
            (-0.01, 0, 0.06),
        ],
        0.008,
        8,
    )
    return body + spout + rose + handle


def book_cover() -> Mesh:
    return join(
        [
            box((-0.1, -0.07, -0.02), (0.1, 0.07, -0.016)),
            box((-0.1, -0.07, 0.016), (0.1, 0.07, 0.02)),
            box((-0.1, -0.07, -0.016), (-0.095, 0.07, 0.016)),
        ]
    )


def book_pages() -> Mesh:
    return box((-0.095, -0.067, -0.016), (0.097, 0.067, 0.016))


def towel() -> Mesh:
    layers = [
        slab((-0.115, -0.09, z0), (0.1, 0.09, z0 + 0.011), 0.006) for z0 in (-0.02, -0.008, 0.004)
    ]
    fold = tube([(0.1, -0.09, -0.002), (0.1, 0.09, -0.002)], 0.017, 10)
    return join(layers) + fold


def cloth() -> Mesh:
    return wavy_slab(0.2, 0.2, 0.004, -0.005, 0.004)


def sponge_foam() -> Mesh:
    return slab((-0.05, -0.035, -0.02), (0.05, 0.035, 0.008), 0.008)


def sponge_scourer() -> Mesh:
    return slab((-0.05, -0.035, 0.008), (0.05, 0.035, 0.02), 0.008)


def knife_blade() -> Mesh:
    return prism(
        [(-0.012, -0.011), (0.06, -0.011), (0.085, -0.005), (0.1, 0.009), (-0.012, 0.011)],
        -0.01,
        -0.007,
    )


def knife_handle() -> Mesh:
    return (
        tube(
            [(-0.1, 0, -0.004), (-0.055, 0, -0.004), (-0.012, 0, -0.004)], [0.008, 0.009, 0.008], 10
        )
        .scaled(1, 1, 0.7)
        .moved(0, 0, -0.0012)
    )


def scissors_blades() -> Mesh:
    a = prism([(0.0, -0.006), (0.075, 0.0), (0.0, 0.006)], -0.008, -0.006).turned("z", 6)
    b = prism([(0.0, -0.006), (0.075, 0.0), (0.0, 0.006)], -0.006, -0.004).turned("z", -6)
    return a.moved(0, -0.003) + b.moved(0, 0.003) + tube([(0, 0, -0.009), (0, 0, -0.002)], 0.004, 8)


def scissors_handles() -> Mesh:
    out = []
    for s in (-1, 1):
        ring = tube(arc((-0.05, s * 0.016, -0.006), 0.014, 0, 360, "xy", 12), 0.004, 6)
        shank = tube([(-0.036, s * 0.012, -0.006), (0.0, s * 0.004, -0.006)], 0.004, 6)
        out += [ring, shank]
    return join(out)


def plant_pot() -> Mesh:
    return lathe(
        [
            (0, -0.12),
            (0.045, -0.12),
            (0.058, -0.045),
            (0.066, -0.042),
            (0.066, -0.03),
            (0.058, -0.03),
            (0.054, -0.04),
            (0, -0.04),
        ],
        16,
    )


def plant_leaves() -> Mesh:
    leaves = [ellipsoid(0.008, 0.008, 0.012, 8).moved(0, 0, -0.035)]  # soil mound
    for k in range(7):
        tilt = 40 + 12 * (k % 3)
        leaf = ellipsoid(0.045, 0.014, 0.003, 10).moved(0.045, 0, 0).turned("y", -tilt)
        leaves.append(leaf.turned("z", k * 360 / 7 + 11 * (k % 2)).moved(0, 0, -0.035))
    leaves.append(ellipsoid(0.012, 0.004, 0.05, 8).moved(0, 0, 0.015))
    return join(leaves)


# -- Track 1: furniture and containers (on z = 0, front +y) --------------------------------------
def bed_frame() -> Mesh:
    legs = [
        box((x - 0.03, y - 0.03, 0), (x + 0.03, y + 0.03, 0.1))
        for x in (-0.66, 0.66)
        for y in (-0.91, 0.91)
    ]
    return join(
        legs
        + [box((-0.7, -0.95, 0.1), (0.7, 0.95, 0.26)), box((-0.7, -0.95, 0.1), (0.7, -0.89, 0.95))]
    )


def bed_mattress() -> Mesh:
    return slab((-0.67, -0.89, 0.26), (0.67, 0.93, 0.44), 0.05)


def bed_pillows() -> Mesh:
    return join([ellipsoid(0.27, 0.14, 0.06, 14).moved(x, -0.72, 0.48) for x in (-0.32, 0.32)])


def bed_blanket() -> Mesh:
    return slab((-0.69, -0.45, 0.42), (0.69, 0.95, 0.47), 0.03)


def sofa_body() -> Mesh:
    legs = [
        box((x - 0.03, y - 0.03, 0), (x + 0.03, y + 0.03, 0.08))
        for x in (-0.85, 0.85)
        for y in (-0.35, 0.35)
    ]
    return join(
        legs
        + [
            slab((-0.9, -0.4, 0.08), (0.9, 0.4, 0.24), 0.03),
            slab((-0.9, -0.4, 0.24), (0.9, -0.22, 0.8), 0.05),
            slab((-0.9, -0.4, 0.24), (-0.74, 0.4, 0.58), 0.05),
            slab((0.74, -0.4, 0.24), (0.9, 0.4, 0.58), 0.05),
        ]
    )


def sofa_cushions() -> Mesh:
    seats = [
        slab((x0 + 0.005, -0.22, 0.24), (x0 + 0.49, 0.4, 0.42), 0.04)
        for x0 in (-0.74, -0.245, 0.25)
    ]
    backs = [
        slab((x0 + 0.005, -0.22, 0.42), (x0 + 0.49, -0.08, 0.74), 0.04)
        for x0 in (-0.74, -0.245, 0.25)
    ]
    return join(seats + backs)


def fridge_body() -> Mesh:
    return join(
        [
            box((-0.33, -0.33, 0), (0.33, 0.3, 0.05)),
            slab((-0.35, -0.35, 0.05), (0.35, 0.32, 1.8), 0.03),
        ]
    )


def fridge_doors() -> Mesh:
    """The fridge's front (its Track 1 lid: 0.7 x 0.03 x 1.8, centred): two doors."""
    return join(
        [
            slab((-0.345, -0.015, -0.84), (0.345, 0.015, 0.34), 0.02),
            slab((-0.345, -0.015, 0.36), (0.345, 0.015, 0.895), 0.02),
        ]
    )


def bin_body() -> Mesh:
    return lathe(
        [
            (0, 0),
            (0.18, 0),
            (0.2, 0.02),
            (0.215, 0.47),
            (0.22, 0.5),
            (0.205, 0.5),
            (0.2, 0.47),
            (0.186, 0.03),
            (0, 0.03),
        ],
        20,
    )


def bin_lid() -> Mesh:
    """The bin's top (its Track 1 lid: 0.45 x 0.45 x 0.03, centred): a domed lid and a grip."""
    dome = lathe(
        [(0, -0.015), (0.225, -0.015), (0.225, 0.0), (0.17, 0.025), (0.09, 0.037), (0, 0.04)], 20
    )
    grip = tube([(-0.05, 0, 0.03), (-0.04, 0, 0.06), (0.04, 0, 0.06), (0.05, 0, 0.03)], 0.01, 8)
    return dome + grip


def drawer_fronts() -> Mesh:
    """A chest's front (its Track 1 lid: 0.7 x 0.03 x 0.7, centred): three drawer fronts."""
    return join(
        [
            slab((-0.345, -0.015, z0), (0.345, 0.015, z0 + 0.222), 0.01)
            for z0 in (-0.345, -0.111, 0.123)
        ]
    )


def door_leaf() -> Mesh:
    """A panelled door leaf (1.0 m wide door: 0.96 x 0.05 x 1.98, centred)."""
    panels = [
        slab((x0, -0.031, z0), (x0 + 0.33, 0.031, z0 + h), 0.02)
        for x0 in (-0.38, 0.05)
        for z0, h in ((-0.86, 0.8), (0.06, 0.8))
    ]
    return join([box((-0.48, -0.025, -0.99), (0.48, 0.025, 0.99))] + panels)


# -- Track 2: parts (unit size: scale per instance) -----------------------------------------------
def peg_square() -> Mesh:
    """A square peg 1 x 1 x 1 (centred) with a chamfered bottom edge."""
    return join(
        [
            box((-0.5, -0.5, -0.42), (0.5, 0.5, 0.5)),
            prism(rounded_rect(0.84, 0.84, 0.001, 1), -0.5, -0.42),
        ]
    )


def peg_round() -> Mesh:
    """A round peg, diameter 1, height 1 (centred), chamfered at the bottom."""
    return lathe([(0, -0.5), (0.42, -0.5), (0.5, -0.42), (0.5, 0.5), (0, 0.5)], 24)


def peg_hex() -> Mesh:
    """A hexagonal peg 1 across flats, height 1 (centred), chamfered at the bottom."""
    r = 0.5 / math.cos(math.pi / 6)
    hexagon = [
        (r * math.cos(math.pi / 6 + k * math.pi / 3), r * math.sin(math.pi / 6 + k * math.pi / 3))
        for k in range(6)
    ]
    return join(
        [prism(hexagon, -0.42, 0.5), prism([(0.84 * x, 0.84 * y) for x, y in hexagon], -0.5, -0.42)]
    )


def hex_nut() -> Mesh:
    """A hex nut 1 across flats, 0.9 high (centred), with a hexagonal bore 0.55 across."""
    r = 0.5 / math.cos(math.pi / 6)
    parts = []
    for k in range(6):
        a0, a1 = math.pi / 6 + k * math.pi / 3, math.pi / 6 + (k + 1) * math.pi / 3
        outer = [(r * math.cos(a0), r * math.sin(a0)), (r * math.cos(a1), r * math.sin(a1))]
        inner = [
            (0.275 * math.cos(a1), 0.275 * math.sin(a1)),
            (0.275 * math.cos(a0), 0.275 * math.sin(a0)),
        ]
        parts.append(prism(outer + inner, -0.45, 0.45))
    return join(parts)


def bolt() -> Mesh:
    """A threaded bolt, diameter 1 at the thread crests, 1 high (bottom at z = 0)."""
    profile = [(0.0, 0.0), (0.5, 0.0)]
    for k in range(12):
        z = 0.02 + k / 12 * 0.95
        profile += [(0.5, z), (0.42, z + 0.04)]
    profile += [(0.42, 1.0), (0.0, 1.0)]
    return lathe(profile, 16)


GENERATED: dict[str, Callable[[], Mesh]] = {
    "apple": apple,
    "plate": plate,
    "bowl": bowl,
    "jug": jug,
    "watering_can": watering_can,
    "book_cover": book_cover,
    "book_pages": book_pages,
    "towel": towel,
    "cloth": cloth,
    "sponge_foam": sponge_foam,
    "sponge_scourer": sponge_scourer,
    "knife_blade": knife_blade,
    "knife_handle": knife_handle,
    "scissors_blades": scissors_blades,
    "scissors_handles": scissors_handles,
    "plant_pot": plant_pot,
    "plant_leaves": plant_leaves,
    "bed_frame": bed_frame,
    "bed_mattress": bed_mattress,
    "bed_pillows": bed_pillows,
    "bed_blanket": bed_blanket,
    "sofa_body": sofa_body,
    "sofa_cushions": sofa_cushions,
    "fridge_body": fridge_body,
    "fridge_doors": fridge_doors,
    "bin_body": bin_body,
    "bin_lid": bin_lid,
    "drawer_fronts": drawer_fronts,
    "door_leaf": door_leaf,
    "peg_square": peg_square,
    "peg_round": peg_round,
    "peg_hex": peg_hex,
    "hex_nut": hex_nut,
    "bolt": bolt,
}
"""Every generated mesh, by the name of its file (``meshes/<name>.obj``)."""


def _num(x: float) -> str:
    s = f"{x:.5f}"
    return "0.00000" if s == "-0.00000" else s


def obj_text(name: str, mesh: Mesh) -> str:
    """The OBJ file of ``mesh``: a comment naming its generator, vertices, 1-based faces."""
    lines = [f"# {name}: generated by simhost/worlds/assets/_meshgen.py (eagc, Apache-2.0)"]
    lines += [f"v {_num(x)} {_num(y)} {_num(z)}" for x, y, z in mesh.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces]
    return "\n".join(lines) + "\n"
