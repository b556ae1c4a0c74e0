"""The untuned corpus (benchmarks/bench_corpus.py): six scan-like shapes made here from numpy,
nobody tuned the weathering to: a head, a standing draped figure, a relief panel, a column with
a capital, a cornice with a drip edge and brackets, a gargoyle.

    python sample_blends/corpus_generator.py [--shapes head ...] [--check]

``SHAPES[name](seed)`` -> (vertices (V, 3) float64 in millimetres, triangles (F, 3) int32): a
closed, outward-oriented triangle mesh, Z up, standing on z = 0 (the gargoyle's wall block
too), its front towards -Y, 20k-80k triangles, no UVs. Each is one of two constructions, both
closed by construction:

- a **lathe** (``lathe``): a profile curve (r, z) from a bottom pole to a top pole swept round an
  axis, each ring's radius times a cross-section factor g(z, phi) > 0 plus sculpted relief
  D(z, phi) (eye sockets, folds, flutes, a mouth): the head, the figure, the column and the
  gargoyle (whose axis leans out of its wall);
- an **extrusion** (``extrusion``) along X of a closed profile (y, z) whose points move with x
  (the cornice's brackets, the relief's raised figures), its two ends closed by ear clipping.

Over each lies a little surface noise (``scan_generator._fourier_noise``, RMS 0.2 mm) along
the vertex normals, from the shape's fixed seed. Sizes are real: a 300 mm head, a 1.74 m
figure, a 1 x 0.7 m panel, a 3 m column, a 2.4 m run of cornice, a 0.9 m gargoyle; the metre
version is the same mesh scaled by ``scan_generator.UNITS["m"]``. A shape takes well under a
second. ``--check`` verifies each with ``scan_generator.check_mesh``; none has two triangles that
cross (``scan_generator.self_intersections``, checked 2026-12-02).
"""

import argparse
import math
import pathlib
import sys
import time

import numpy as np

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))  # its sibling, however it is loaded
import scan_generator  # noqa: E402
from scan_generator import _bell as bell  # noqa: E402
from scan_generator import _smoothstep as smoothstep  # noqa: E402

# --- constructions --------------------------------------------------------------------------------


def _resample(polyline, count, smoothing=0.0):
    """``count`` points equally spaced along ``polyline`` (n, 2), its corners first rounded by a
    running mean over ``smoothing`` mm (ends kept)."""
    polyline = np.asarray(polyline, float)
    segments = np.linalg.norm(np.diff(polyline, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(segments)])
    dense_s = np.linspace(0.0, s[-1], max(2000, 4 * count))
    dense = np.stack([np.interp(dense_s, s, polyline[:, k]) for k in range(2)], axis=1)
    width = int(round(smoothing / (dense_s[1] - dense_s[0])))
    if width > 1:
        kernel = np.ones(width) / width
        padded = np.pad(dense, ((width, width), (0, 0)), mode="edge")
        smooth = np.stack([np.convolve(padded[:, k], kernel, mode="same")[width:-width] for k in range(2)], 1)
        dense = np.concatenate([dense[:1], smooth[1:-1], dense[-1:]])
    steps = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    dense_s = np.concatenate([[0.0], np.cumsum(steps)])
    target = np.linspace(0.0, dense_s[-1], count)
    return np.stack([np.interp(target, dense_s, dense[:, k]) for k in range(2)], axis=1)


def _quads(index):
    """Two triangles per quad of the (rows, columns) vertex ``index`` grid, columns wrapping."""
    a, b = index[:-1], np.roll(index[:-1], -1, axis=1)
    c, d = np.roll(index[1:], -1, axis=1), index[1:]
    a, b, c, d = (x.ravel() for x in (a, b, c, d))
    return np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def lathe(profile, around, rings, shape, relief, *, axis=None, smoothing=4.0):
    """The closed surface of ``profile`` (r, z) swept round Z: ``rings`` rings of ``around``
    points between its two poles (r = 0 at both ends). A ring point at angle phi (from +X, the
    front -Y at phi = -pi/2) and height z lies at radius r * shape(z, phi) + relief(z, phi, r).
    ``axis`` (a function of the (V, 3) points) places the lathe elsewhere (the gargoyle)."""
    curve = _resample(profile, rings + 2, smoothing)
    r0, z0 = curve[1:-1, 0], curve[1:-1, 1]
    phi = np.linspace(-np.pi, np.pi, around, endpoint=False)
    z, p = np.broadcast_arrays(z0[:, None], phi[None, :])
    r = r0[:, None] * shape(z, p) + relief(z, p, np.broadcast_to(r0[:, None], z.shape))
    rings_xyz = np.stack([r * np.cos(p), r * np.sin(p), z], axis=-1).reshape(-1, 3)
    vertices = np.concatenate([[[0.0, 0.0, curve[0, 1]]], rings_xyz, [[0.0, 0.0, curve[-1, 1]]]])
    index = 1 + np.arange(rings * around).reshape(rings, around)
    j = np.arange(around)
    top = len(vertices) - 1
    triangles = np.concatenate(
        [
            np.stack([np.zeros(around, int), index[0, (j + 1) % around], index[0, j]], 1),
            _quads(index),
            np.stack([np.full(around, top), index[-1, j], index[-1, (j + 1) % around]], 1),
        ]
    )
    if axis is not None:
        vertices = axis(vertices)
    return vertices, triangles


def _ear_clip(polygon):
    """Triangles (indices) of a simple polygon (n, 2), counter-clockwise."""
    remaining = list(range(len(polygon)))
    triangles = []
    while len(remaining) > 3:
        n = len(remaining)
        for k in range(n):
            previous, corner, following = remaining[k - 1], remaining[k], remaining[(k + 1) % n]
            a, b, c = polygon[previous], polygon[corner], polygon[following]
            turn = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            if turn <= 1e-6 * np.linalg.norm(b - a) * np.linalg.norm(c - b):
                continue  # reflex or flat corner
            others = polygon[[m for m in remaining if m not in (previous, corner, following)]]
            v0, v1, v2 = c - a, b - a, others - a
            d00, d01, d11 = v0 @ v0, v0 @ v1, v1 @ v1
            d20, d21 = v2 @ v0, v2 @ v1
            denom = d00 * d11 - d01 * d01
            u = (d11 * d20 - d01 * d21) / denom
            v = (d00 * d21 - d01 * d20) / denom
            if not np.any((u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)):
                triangles.append((previous, corner, following))
                del remaining[k]
                break
        else:
            raise ValueError("ear clipping found no ear: the profile is not a simple polygon")
    triangles.append(tuple(remaining))
    return np.array(triangles)


def extrusion(xs, profile_at):
    """The closed solid swept along X: ``profile_at(x)`` -> (n, 2) closed profile (y, z) at each
    of ``xs`` (n fixed, the same polygon topology all along), both ends closed."""
    rings = np.stack([profile_at(x) for x in xs])
    if _signed_area(rings[0]) < 0:  # counter-clockwise in (y, z): the end at the last x faces +X
        rings = rings[:, ::-1]
    count = rings.shape[1]
    vertices = np.concatenate([np.concatenate([np.full((count, 1), x), ring], axis=1) for x, ring in zip(xs, rings)])
    index = np.arange(len(xs) * count).reshape(len(xs), count)
    cap0, cap1 = _ear_clip(rings[0]), _ear_clip(rings[-1])
    triangles = np.concatenate([_quads(index), cap0[:, ::-1], cap1 + index[-1, 0]])
    return vertices, triangles


def _signed_area(polygon):
    y, z = polygon[:, 0], polygon[:, 1]
    return 0.5 * np.sum(y * np.roll(z, -1) - np.roll(y, -1) * z)


def outward(vertices, triangles):
    """The triangles wound so that the signed volume is positive (normals out)."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:
        triangles = triangles[:, ::-1]
    return np.ascontiguousarray(triangles)


def roughened(vertices, triangles, rng, rms=0.2):
    """Scan-like surface noise (erosion and scan noise, ``rms`` mm) along the vertex normals."""
    a, b, c = (vertices[triangles[:, k]] for k in range(3))
    face_normals = np.cross(b - a, c - a)
    normals = np.zeros_like(vertices)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face_normals)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    noise = scan_generator._fourier_noise(vertices, rng, 32, 3.0, 60.0, rms)
    moved = vertices + normals * noise[:, None]
    moved[:, 2] = np.maximum(moved[:, 2], vertices[:, 2].min())  # it still stands on its base
    return moved


def _finish(vertices, triangles, seed):
    triangles = outward(vertices, triangles)
    vertices = roughened(vertices, triangles, np.random.default_rng(seed))
    return vertices, triangles.astype(np.int32)


def _ellipse(phi, depth):
    """The radius along phi of an ellipse of half-width 1 (X) and half-depth ``depth`` (Y)."""
    return 1.0 / np.sqrt(np.cos(phi) ** 2 + (np.sin(phi) / depth) ** 2)


def _square(phi, power=10.0):
    """A rounded square of half-width 1 (a superellipse)."""
    return (np.abs(np.cos(phi)) ** power + np.abs(np.sin(phi)) ** power) ** (-1.0 / power)


def _blend(bands, base):
    """g(z, phi): ``base`` below the first band, each (low, high, shape) blended in above."""

    def shape(zz, phi):
        g = base(phi) + 0.0 * zz
        for low, high, later in bands:
            t = smoothstep(zz, low, high)
            g = g * (1.0 - t) + later(phi) * t
        return g

    return shape


def _across(phi, radius):
    """mm across the front from its centre line (> 0 towards +X), on a cylinder of ``radius``."""
    return ((phi + np.pi / 2 + np.pi) % (2 * np.pi) - np.pi) * radius


def _face(z, phi, centre, size):
    """A face's relief (mm) about eye height ``centre``, scaled by ``size`` (1: a 300 mm head):
    deep eye sockets with eyeballs, a brow, a nose with its underside, a mouth and a chin."""
    u, dz = _across(phi, 80.0 * size) / size, (z - centre) / size
    d = np.zeros(np.broadcast(z, phi).shape)
    for side in (-1.0, 1.0):
        d -= 15.0 * bell(np.hypot((u - side * 28.0) / 16.0, dz / 11.0))
        d += 6.0 * bell(np.hypot((u - side * 28.0) / 8.0, (dz + 1.0) / 6.0))
    d += 5.0 * np.exp(-np.square((dz - 14.0) / 4.0)) * bell(u / 50.0)
    rise = np.clip((12.0 - dz) / 42.0, 0.0, 1.0)
    nose = np.where(dz > -30.0, 3.0 + 19.0 * rise, 22.0 * smoothstep(dz, -44.0, -31.0)) * (dz < 14.0)
    d += nose * bell(u / (7.0 + 6.0 * rise))
    d -= 3.0 * np.exp(-np.square((dz + 55.0) / 1.5)) * bell(u / 20.0)
    d += 10.0 * bell(np.hypot(u / 22.0, (dz + 76.0) / 12.0))
    return d * size


# --- the shapes (mm) ----------------------------------------------------------------------------------


def head(seed=1):
    """A head on its neck and a round base, 300 mm tall: eye sockets, nose, a chin that
    overhangs the neck, ears in hollows, a mass of hair behind and on top."""
    profile = [(0, 0), (62, 0), (62, 12), (44, 18), (40, 70), (44, 86), (62, 94), (72, 130), (78, 180)]
    profile += [(76, 222), (62, 262), (32, 290), (0, 298)]
    shape = _blend([(90, 120, lambda p: _ellipse(p, 1.18))], lambda p: 1.0 + 0 * p)

    def relief(z, phi, r0):
        on_head = smoothstep(z, 92.0, 110.0) * smoothstep(r0, 50.0, 60.0)
        d = _face(z, phi, 178.0, 1.0)
        side = np.abs((phi + np.pi / 2 + np.pi) % (2 * np.pi) - np.pi)  # 0 at the front, pi at the back
        q = np.hypot((side - np.pi / 2) * 80.0 / 14.0, (z - 168.0) / 26.0)
        d += 9.0 * np.exp(-np.square((q - 0.85) / 0.18)) * (q < 1.5) - 10.0 * bell(q / 0.6)  # ears
        curls = 3.0 * np.sin(phi * 18.0) * np.sin(z / 7.0)
        hair = smoothstep(side, 1.9, 2.2) * smoothstep(z, 130.0, 175.0) + smoothstep(z, 225.0, 245.0)
        d += np.clip(hair, 0.0, 1.0) * (14.0 + curls) * (1.0 - smoothstep(z, 285.0, 297.0))
        return d * on_head

    return _finish(*lathe(profile, 192, 150, shape, relief), seed)


def draped_figure(seed=2):
    """A standing figure in a long robe on a plinth, 1.74 m: deep vertical folds from the hip
    to the hem, swags over the chest, a small head with a face."""
    profile = [(0, 0), (280, 0), (280, 90), (250, 100), (215, 104), (220, 160), (205, 600), (175, 1000)]
    profile += [(205, 1300), (235, 1390), (150, 1450), (58, 1472), (55, 1520), (92, 1560), (98, 1650)]
    profile += [(60, 1715), (0, 1740)]
    shape = _blend(
        [
            (95, 110, lambda p: _ellipse(p, 0.62)),
            (1440, 1470, lambda p: _ellipse(p, 1.0)),
            (1530, 1560, lambda p: _ellipse(p, 1.15)),
        ],
        lambda p: _square(p, 8.0) * 0.85,
    )

    def relief(z, phi, r0):
        wobble = 0.12 * np.sin(z / 210.0) + 0.05 * np.sin(z / 67.0 + 1.0)
        valleys = np.abs(np.sin(6.5 * (phi + wobble)))
        depth = 34.0 * (1.0 - smoothstep(z, 500.0, 1100.0)) + 8.0
        folds = -depth * (1.0 - valleys**0.5) * smoothstep(z, 106.0, 150.0) * (1.0 - smoothstep(z, 1150.0, 1250.0))
        u = _across(phi, 200.0)
        swags = 12.0 * (np.abs(np.sin(np.pi * (z + 0.0012 * u**2) / 70.0)) ** 0.6 - 0.6)
        swags *= smoothstep(z, 1180.0, 1230.0) * (1.0 - smoothstep(z, 1360.0, 1400.0))
        face = _face(z, phi, 1610.0, 0.34) * smoothstep(z, 1535.0, 1555.0)
        return folds + swags + face

    return _finish(*lathe(profile, 224, 160, shape, relief, smoothing=8.0), seed)


def column(seed=3):
    """A fluted column, 3 m: a square plinth, a torus base, a shaft with entasis, a capital whose
    echinus flares under a square abacus that overhangs it."""
    profile = [(0, 0), (470, 0), (470, 230), (400, 250), (410, 300), (360, 345), (310, 380)]
    profile += [(300, 1500), (262, 2480), (262, 2520), (285, 2540), (285, 2565), (258, 2585), (290, 2640)]
    profile += [(370, 2705), (430, 2745), (430, 2760), (455, 2765), (455, 2900), (0, 2900)]
    shape = _blend(
        [(232, 250, lambda p: 1.0 + 0 * p), (2758, 2764, lambda p: _square(p, 12.0))],
        lambda p: _square(p, 12.0),
    )

    def relief(z, phi, r0):
        flutes = -16.0 * np.clip(np.cos(20.0 * phi), 0.0, None) ** 0.7
        return flutes * smoothstep(z, 400.0, 450.0) * (1.0 - smoothstep(z, 2430.0, 2470.0))

    return _finish(*lathe(profile, 200, 180, shape, relief, smoothing=6.0), seed)


def polyline(points, spacing):
    """The open polyline ``points`` with a point every ``spacing`` mm or so (its corners kept),
    without its last point (so that pieces join end to start)."""
    out = []
    for a, b in zip(points[:-1], points[1:]):
        a, b = np.asarray(a, float), np.asarray(b, float)
        count = max(1, int(math.ceil(np.linalg.norm(b - a) / spacing)))
        out.append(a + (b - a) * np.linspace(0.0, 1.0, count, endpoint=False)[:, None])
    return np.concatenate(out)


def cornice(seed=4):
    """A 2.4 m run of cornice on its wall: a bed moulding, a soffit with a drip (a throat behind
    a downward lip), a corona, a top moulding and a sloping top; brackets (corbels) every 0.6 m
    carry the soffit."""
    carried = [(-30, 620), (-60, 640), (-80, 670), (-80, 700), (-340, 700)]
    drip = [(-340, 700), (-370, 700), (-372, 714), (-386, 714), (-390, 700), (-418, 684), (-430, 690), (-430, 850)]
    drip += [(-452, 872), (-462, 905), (-472, 925), (-472, 935), (-455, 942)]
    back = [(-455, 942), (0, 985), (400, 1000), (400, 0), (0, 0)]  # the top, the back and the bottom
    base = polyline([(0, 0), (0, 300)], 20.0)  # the wall face under the brackets
    # from the wall at 300 mm up the face and the bed moulding to the soffit: on a bracket, the
    # same number of points along the corbel's curve, out and up to the soffit
    path = _resample(np.concatenate([polyline([(0, 300), (0, 600), *carried], 10.0), [[-340, 700]]]), 60)
    s = np.linspace(0.0, 1.0, len(path))
    corbel = np.stack([-340.0 * s**1.6, 300.0 + 400.0 * np.sin(np.pi * s / 2)], axis=1)
    rest = np.concatenate([polyline(drip, 12.0)[1:], polyline(back, 80.0)])

    def bracket(x):
        """1 on a bracket (160 mm wide, every 600 mm), 0 between, with 12 mm rounded sides."""
        offset = np.abs(x % 600.0 - 300.0)  # centred at 300, 900, ... mm: none at the ends
        return 1.0 - smoothstep(offset, 74.0, 86.0)

    def profile_at(x):
        b = bracket(x)
        return np.concatenate([base, (1.0 - b) * path + b * corbel, rest])

    xs = np.linspace(0.0, 2400.0, 241)
    return _finish(*extrusion(xs, profile_at), seed)


def relief_panel(seed=5):
    """A 1 x 0.7 m relief panel, 120 mm thick: a frame with a projecting sill round a recessed
    field, on which two standing figures and a tree stand out 30-55 mm."""
    width, height, depth = 1000.0, 700.0, 120.0
    zs = np.linspace(0.0, height, 161)

    def proud(x, z):
        """How far the front stands out of y = 0 towards -Y (mm)."""
        inner = np.minimum(np.minimum(x, width - x), np.minimum(z - 20.0, height - z))
        frame = 50.0 - 30.0 * smoothstep(inner, 55.0, 75.0) - 20.0 * smoothstep(inner, 20.0, 40.0)
        frame += 35.0 * (1.0 - smoothstep(z, 70.0, 80.0))  # the sill projects
        figures = np.zeros_like(x)
        for cx, lean in ((330.0, 0.04), (560.0, -0.05)):
            dx = x - cx - lean * (z - 100.0)
            body = bell(np.hypot(dx / 70.0, (z - 300.0) / 190.0)) ** 0.3
            head = bell(np.hypot(dx / 38.0, (z - 540.0) / 45.0)) ** 0.3
            figures = np.maximum(figures, np.maximum(40.0 * body, 45.0 * head))
        trunk = bell(np.hypot((x - 790.0) / 22.0, (z - 230.0) / 160.0)) ** 0.3 * 30.0
        crown = bell(np.hypot((x - 790.0) / 95.0, (z - 460.0) / 110.0)) ** 0.3 * 55.0
        return np.maximum(frame, np.maximum(figures, np.maximum(trunk, crown)))

    def profile_at(x):
        front = np.stack([-proud(np.full_like(zs, x), zs), zs], axis=1)  # bottom to top
        return np.concatenate([front, [[depth, height], [depth, 0.0]]])

    xs = np.linspace(0.0, width, 181)
    return _finish(*extrusion(xs, profile_at), seed)


def gargoyle(seed=6):
    """A lion-headed gargoyle, 0.9 m out of its wall block and leaning 10 degrees up: a block, a
    neck, a shaggy mane, a brow over deep eye sockets, a snout and an open mouth (a deep slot on
    the underside, the spout)."""
    profile = [(0, 0), (200, 0), (200, 260), (150, 300), (140, 360), (215, 430), (220, 520), (170, 590)]
    profile += [(125, 640), (112, 760), (102, 840), (70, 880), (0, 892)]
    shape = _blend(
        [(270, 320, lambda p: _ellipse(p, 0.9)), (600, 660, lambda p: _ellipse(p, 0.8))], lambda p: _square(p, 10.0)
    )
    up = np.pi / 2  # phi of the top of the head: the lathe's +Y turns to +Z below

    def relief(a, phi, r0):
        top = (phi - up + np.pi) % (2 * np.pi) - np.pi  # 0 on top, +-pi underneath
        mane = (12.0 * np.sin(9.0 * phi) * np.sin(a / 18.0) + 10.0) * bell((a - 470.0) / 90.0)
        brow = 14.0 * bell(np.hypot(top / 0.9, (a - 610.0) / 18.0))
        eyes = sum(-24.0 * bell(np.hypot((top - s * 0.55) / 0.32, (a - 640.0) / 26.0)) for s in (-1.0, 1.0))
        under = np.abs(np.abs(top) - np.pi)
        mouth = -55.0 * bell(under / 0.38) * smoothstep(a, 690.0, 730.0) * (1.0 - smoothstep(a, 870.0, 885.0))
        ears = sum(18.0 * bell(np.hypot((top - s * 0.75) / 0.22, (a - 520.0) / 30.0)) for s in (-1.0, 1.0))
        return (mane + brow + eyes + mouth + ears) * smoothstep(a, 300.0, 330.0)

    lean = math.radians(10.0)

    def axis(points):
        """The lathe's Z (out of the wall) to -Y leaning up, its +Y to the head's top."""
        x, y, a = points[:, 0], points[:, 1], points[:, 2]
        out = np.array([0.0, -math.cos(lean), math.sin(lean)])
        top = np.array([0.0, math.sin(lean), math.cos(lean)])
        placed = x[:, None] * np.array([1.0, 0.0, 0.0]) + y[:, None] * top + a[:, None] * out
        return placed + np.array([0.0, 0.0, 210.0])

    vertices, triangles = lathe(profile, 200, 170, shape, relief, axis=axis)
    vertices[:, 2] -= vertices[:, 2].min()
    return _finish(vertices, triangles, seed)


#: name -> generator(seed) -> (vertices in mm, triangles).
SHAPES = {
    "head": head,
    "draped_figure": draped_figure,
    "relief_panel": relief_panel,
    "column": column,
    "cornice": cornice,
    "gargoyle": gargoyle,
}


def shape_mesh(name, unit="mm"):
    """(vertices in ``unit`` (a key of ``scan_generator.UNITS``), triangles) of the shape."""
    vertices, triangles = SHAPES[name]()
    return scan_generator.scaled(vertices, unit), triangles


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--shapes", nargs="+", choices=SHAPES, default=list(SHAPES))
    parser.add_argument("--check", action="store_true", help="check each mesh (closed, manifold, oriented)")
    args = parser.parse_args(argv)
    for name in args.shapes:
        started = time.perf_counter()
        vertices, triangles = SHAPES[name]()
        line = f"{name}: {len(triangles)} triangles in {time.perf_counter() - started:.2f} s"
        line += f", size {np.ptp(vertices, axis=0).round(0).tolist()} mm"
        if args.check:
            report = scan_generator.check_mesh(vertices, triangles)
            line += f", {report}"
            if not scan_generator.is_closed_manifold(report):
                print(line)
                sys.exit(f"{name}: the mesh is not closed, manifold and outward-oriented")
        print(line)


if __name__ == "__main__":
    main()
