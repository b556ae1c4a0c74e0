"""Scan-like meshes made here, not downloaded: a limestone bust as a photogrammetry scan gives it.

    python sample_blends/scan_generator.py [--triangles 200000] [--unit mm|m|normalised]
                                           [--seed 0] [--out FILE.blend] [--preview FILE.png]
                                           [--material limestone|grey] [--check] [--obj FILE.obj]

``bust_mesh(triangles, seed=...)`` is pure numpy: a closed, manifold, outward-oriented triangle
mesh of about ``triangles`` faces, in millimetres, Z up, 500 mm tall, standing on z = 0, with no
UVs. It is a bust on a plinth: draped chest and shoulders, a neck, a head with deep eye sockets,
ear-like hollows behind raised rims, a nose, a mouth, a chin that overhangs the neck, curled hair,
and a hat whose drooping brim projects 70-90 mm beyond the head, so that the face, the eyes and
the ears under it are sheltered from rain. Over that lies medium sculpted detail (curls, drapery
folds, fluted crown, a recessed panel on the plinth) and two noise fields:
erosion (wavelengths 20-80 mm, RMS 0.15 mm) and scan noise (1.2-4 mm, RMS 0.1 mm), fixed by
``seed``.

How it stays free of self-intersections. The surface is a lathe: a closed 2D profile curve in
(r, z) (a polyline with filleted corners, ``PROFILE``; it goes out and back at the brim, so the
brim overhangs) swept around the Z axis, sampled at rings spaced along its arc length and at
equal angles. Poles close the bottom and the top. Everything else is laid over it by maps that
keep a simple curve simple in every half-plane of constant angle phi:
  - the cross-section shape: r -> r * g(z, phi) with g > 0 (a rounded square plinth, an oval
    chest, an off-centre oval head). For fixed (z, phi) this is an increasing map of r, so it is
    a diffeomorphism of the half-plane;
  - the sculpted features: r -> r * g + D(z, phi) * w(r), where w only lets D act on the head's
    own radii (not on the brim at the same height), and |D * w'| < g wherever D < 0;
  - a turn of the head about Z (a twist, a diffeomorphism of space);
  - noise of at most ~1 mm along the normal of the plain lathe (a direction field that turns
    no faster than the profile's fillets), whose size times slope stays well below 1, so it
    cannot fold the surface, even in a narrow groove; the thinnest part, the brim's edge, is 7 mm.
``check_mesh`` verifies closure, manifoldness, orientation and triangle areas with numpy;
``self_intersections`` (bpy's mathutils) verifies that no two triangles cross.

Triangles: about 2 * N * M for M rings of N points; the rings are spaced so that the quads are
about square (denser where the profile bends, sparser on the hidden bottom face), each quad is
cut along its shorter diagonal, and near the poles, where the rings get short, their point count
halves from ring to ring (three triangles per coarse segment), so no pole fan has slivers. The
count comes out within 1% of the request (0.2% from 50k up); 2M triangles take ~2 s.

Units: ``UNITS`` gives the factor from millimetres for "mm", "m" and "normalised" (the nominal
bounding-box diagonal of the bust becomes 1, within 0.2%); ``scaled(vertices, unit)`` applies it.
The same seed gives the same faces on every numpy; vertices agree within 1e-4 mm.

``add_to_scene`` builds the Blender mesh with foreach_set (no from_pydata: 2M faces in seconds),
smooth shaded, with no UV map. ``build_scene`` makes the sample scene (bust, plinth ground, sun,
camera from the front and slightly below, sky), with the conventions of build_samples.py.
``--obj`` writes the bust alone as a scanner exports one (``write_obj``: an OBJ, Z up, without
normals), to take through an import as a user does (docs/scans.md).
"""

import argparse
import functools
import math
import pathlib
import sys
import time

import numpy as np

HERE = pathlib.Path(__file__).resolve().parent

# --- the profile -------------------------------------------------------------------------

#: The lathe profile, bottom pole to top pole: (lateral radius r, height z, fillet radius), mm.
#: r is the half-width along X; the cross-section shape g(z, phi) makes the depth along Y.
PROFILE = (
    (0.0, 0.0, 0.0),  # bottom pole
    (112.0, 0.0, 2.0),  # plinth: bottom edge
    (112.0, 50.0, 2.0),  # plinth: top edge
    (102.0, 54.0, 1.5),  # weathered top of the plinth
    (100.0, 62.0, 2.0),
    (82.0, 70.0, 4.0),  # the socle's cove
    (78.0, 84.0, 4.0),
    (92.0, 96.0, 6.0),  # the chest flares out of the socle
    (130.0, 130.0, 30.0),
    (146.0, 180.0, 25.0),  # shoulders
    (142.0, 208.0, 14.0),
    (106.0, 228.0, 14.0),
    (60.0, 242.0, 10.0),  # base of the neck
    (48.0, 256.0, 10.0),
    (48.0, 274.0, 3.0),  # the neck meets the underside of the jaw
    (57.0, 282.0, 4.0),  # jaw and chin overhang the neck
    (62.0, 294.0, 10.0),
    (72.0, 320.0, 20.0),  # the face widens from the jaw to the temples
    (80.0, 352.0, 25.0),
    (80.0, 386.0, 14.0),
    (77.0, 418.0, 3.0),  # top of the forehead, under the brim
    (155.0, 409.0, 4.0),  # the brim's underside droops outwards
    (166.0, 410.0, 3.5),  # brim edge
    (164.0, 417.0, 3.0),
    (94.0, 436.0, 5.0),  # the brim's top rises to the crown (rain runs off it)
    (84.0, 446.0, 4.0),  # crown
    (84.0, 470.0, 12.0),
    (58.0, 494.0, 15.0),
    (0.0, 500.0, 0.0),  # top pole
)

HEIGHT_MM = 500.0
#: The horizontal radius of the face (front of the head), used to measure features in mm.
FACE_RADIUS = 105.0
#: The head turns this far (radians) to its left, as sculpted heads often do.
HEAD_TURN = math.radians(5.0)
#: phi (from +X, counter-clockwise seen from above) of the front: the bust faces -Y, like the
#: other sample scenes.
FRONT = -math.pi / 2


def _fillet_profile(points, step=0.05):
    """The profile as a dense polyline (n, 2) of (r, z), each corner rounded by a circular arc
    of its fillet radius, with at most ``step`` mm between points."""
    pts = np.array([(r, z) for r, z, _ in points], dtype=float)
    radii = np.array([f for _, _, f in points], dtype=float)
    edges = np.diff(pts, axis=0)
    lengths = np.linalg.norm(edges, axis=1)
    directions = edges / lengths[:, None]
    d1, d2 = directions[:-1], directions[1:]
    turns = np.arctan2(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0], (d1 * d2).sum(axis=1))  # signed
    tangents = np.concatenate([[0.0], radii[1:-1] * np.tan(np.abs(turns) / 2), [0.0]])
    if (overlong := np.flatnonzero(tangents[:-1] + tangents[1:] > lengths + 1e-9)).size:
        raise ValueError(f"profile: the fillets at both ends of segment {overlong[0]} do not fit on it")
    pieces = [pts[:1]]
    start = pts[0]
    for k in range(1, len(pts) - 1):
        incoming, turn, radius = d1[k - 1], turns[k - 1], radii[k]
        t1 = pts[k] - incoming * tangents[k]  # where the arc starts (it ends as far past the corner)
        pieces.append(_segment(start, t1, step))
        if tangents[k] > 0:
            left = np.array([-incoming[1], incoming[0]])  # the normal on the side the curve turns to
            centre = t1 + left * radius * np.sign(turn)
            a0 = math.atan2(*(t1 - centre)[::-1])
            count = max(2, int(math.ceil(abs(turn) * radius / step)))
            angles = a0 + np.linspace(0.0, turn, count + 1)[1:]
            pieces.append(centre + radius * np.stack([np.cos(angles), np.sin(angles)], axis=1))
        start = pieces[-1][-1]
    pieces.append(_segment(start, pts[-1], step))
    return np.concatenate(pieces)


def _segment(a, b, step):
    count = max(1, int(math.ceil(np.linalg.norm(b - a) / step)))
    return a + (b - a) * np.linspace(0.0, 1.0, count + 1)[1:, None]


# --- cross-section shapes g(z, phi) ----------------------------------------------------------


def _smoothstep(x, low, high):
    t = np.clip((x - low) / (high - low), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _bell(q):
    """(1 - q^2)^2 inside the unit disc, 0 outside: a smooth bump of height 1 and radius 1."""
    return np.square(np.clip(1.0 - q * q, 0.0, None))


def _ellipse(phi, depth, centre=0.0):
    """Distance from the axis along phi to an ellipse of half-width 1 and half-depth ``depth``
    (along Y) centred at (0, centre), divided by its value at phi = 0 (so the lateral radius
    stays the profile's r). Star-shaped about the axis as long as |centre| < depth."""
    c, s = np.cos(phi), np.sin(phi)
    a = c * c + s * s / depth**2
    b = centre * s / depth**2
    rho = (b + np.sqrt(b * b - a * (centre**2 / depth**2 - 1.0))) / a
    return rho / math.sqrt(1.0 - centre**2 / depth**2)


def _superellipse(phi, depth, power):
    return (np.abs(np.cos(phi)) ** power + (np.abs(np.sin(phi)) / depth) ** power) ** (-1.0 / power)


#: The cross-sections from the bottom up: (z where the blend into it starts, ends, shape).
SHAPES = (
    (52.0, 68.0, lambda phi: _ellipse(phi, 0.80)),  # socle
    (88.0, 105.0, lambda phi: _ellipse(phi, 0.55, -0.04)),  # chest and shoulders
    (228.0, 250.0, lambda phi: _ellipse(phi, 1.08, -0.10)),  # neck
    (272.0, 286.0, lambda phi: _ellipse(phi, 1.20, -0.15)),  # head: the face is forward
    (396.0, 408.0, lambda phi: _ellipse(phi, 1.12, -0.08)),  # forehead, brim and crown
)


def _plinth_shape(phi):
    return _superellipse(phi, 0.82, 8.0)


def shape_factor(z, phi):
    """g(z, phi) > 0: the cross-section's radius along phi over its lateral radius."""
    g = _plinth_shape(phi) + 0.0 * z
    for low, high, shape in SHAPES:
        t = _smoothstep(z, low, high)
        g = g * (1.0 - t) + shape(phi) * t
    return g


# --- sculpted features D(z, phi), radial mm -------------------------------------------------


def _wrap(angle):
    return (angle + np.pi) % (2 * np.pi) - np.pi


def _features(z, phi, r0, rng):
    """Radial displacement (mm) of the sculpted features, for base points at height z, angle
    phi and lateral profile radius r0 (all broadcast to one shape)."""
    alpha = _wrap(phi - FRONT)  # 0 at the front, > 0 towards +X
    u = alpha * FACE_RADIUS  # mm across the face
    # w(r): the head's features move the head's radii only, not the neck's or the brim's.
    head = _smoothstep(r0, 62.0, 74.0) * (1.0 - _smoothstep(r0, 100.0, 115.0))
    d = np.zeros(np.broadcast(z, phi, r0).shape)

    # Face: only where the head is (the bands are narrow, so compute on the rows that need it).
    face = (z > 280.0) & (z < 415.0)
    if face.any():
        zf, uf, af = (
            np.broadcast_to(z, d.shape)[face],
            np.broadcast_to(u, d.shape)[face],
            np.broadcast_to(alpha, d.shape)[face],
        )
        df = np.zeros(zf.shape)
        au = np.abs(uf)
        # Nose: a ridge from the brow to the tip (26 mm proud at z = 330), an underside back to
        # the lip, two nostrils.
        rise = np.clip((368.0 - zf) / 38.0, 0.0, 1.0) ** 1.3
        under = _smoothstep(zf, 316.0, 331.0)
        height = np.where(zf >= 330.0, 3.0 + 23.0 * rise, 26.0 * under) * (zf < 370.0)
        width = 8.0 + 7.0 * np.clip((368.0 - zf) / 40.0, 0.0, 1.0)
        df += height * _bell(uf / width)
        df -= 3.0 * _bell(np.hypot((au - 6.0) / 3.5, (zf - 321.5) / 3.0))
        # Eye sockets: deep hollows under the brow, each with an eyeball in it.
        for side in (-1.0, 1.0):
            du = uf - side * 31.0
            df -= 18.0 * _bell(np.hypot(du / 18.0, (zf - 361.0) / 12.0))
            df += 9.0 * _bell(np.hypot(du / 10.0, (zf - 358.5) / 7.5))
        df += 6.0 * np.exp(-np.square((zf - 375.0) / 4.5)) * _bell(uf / 58.0)  # brow ridge
        df += 3.0 * _bell(np.hypot((au - 44.0) / 16.0, (zf - 343.0) / 10.0))  # cheekbones
        # Mouth: a groove between two lips; the chin juts out over the neck.
        lips = _bell(uf / 24.0)
        df += lips * (
            2.5 * np.exp(-np.square((zf - 310.0) / 2.5))
            + 3.0 * np.exp(-np.square((zf - 302.0) / 2.8))
            - 3.5 * np.exp(-np.square((zf - 306.0) / 1.3))
        )
        df += 9.0 * _bell(np.hypot(uf / 24.0, (zf - 291.0) / 12.0))
        # Ears, at the sides: a raised rim around a deep hollow (the concha).
        for side in (-1.0, 1.0):
            ue = (side * af - math.pi / 2) * 80.0  # mm, > 0 towards the back
            q = np.hypot(ue / 16.0, (zf - 350.0) / 30.0)
            back = np.clip(1.0 + 0.6 * ue / 16.0, 0.3, 1.6)
            df += 11.0 * back * np.exp(-np.square((q - 0.82) / 0.15)) * (q < 1.4)
            df += 6.0 * _bell(q) - 13.0 * _bell(q / 0.55)
        # Hair: curls behind the ears and a fringe under the brim, each curl a dome with a
        # spiral groove, one per cell of a staggered grid wrapped around the head.
        hair = (
            _smoothstep(np.abs(af), 1.78, 1.98) * _smoothstep(zf, 296.0, 306.0)
            + _smoothstep(zf, 386.0, 396.0) * (1.0 - _smoothstep(np.abs(af), 1.78, 1.98))
        ) * (1.0 - _smoothstep(zf, 404.0, 412.0))
        df += hair * _curls(af, zf, rng)
        d[face] = df * np.broadcast_to(head, d.shape)[face]  # on the head's radii only

    # Drapery over the chest: round ridges and crisp valleys.
    chest = (z > 95.0) & (z < 235.0)
    if chest.any():
        zc, ac = np.broadcast_to(z, d.shape)[chest], np.broadcast_to(alpha, d.shape)[chest]
        # Swags: fold lines that hang lowest at the front, like a cloak draped over the shoulders.
        t = (zc + 45.0 * np.cos(ac) + 6.0 * np.sin(2.0 * ac + 0.7)) / 24.0
        folds = (np.square(np.sin(np.pi * t)) + 0.01) ** 0.3 - 0.6  # |sin|^0.6 with a rounded valley
        d[chest] += 6.0 * folds * _smoothstep(zc, 100.0, 125.0) * (1.0 - _smoothstep(zc, 200.0, 228.0))

    # Crown: a raised band over the brim and flutes above it.
    crown = (z > 432.0) & (z < 490.0)
    if crown.any():
        zc, ac = np.broadcast_to(z, d.shape)[crown], np.broadcast_to(alpha, d.shape)[crown]
        band = 3.0 * _bell((zc - 443.0) / 4.5)
        flutes = (
            -2.5
            * np.clip(np.cos(36.0 * ac), 0.0, None) ** 4
            * _smoothstep(zc, 450.0, 454.0)
            * (1.0 - _smoothstep(zc, 470.0, 476.0))
        )
        d[crown] += band + flutes

    # A recessed panel on the front of the plinth (for an inscription), 2 mm deep, crisp edges.
    panel = (z > 5.0) & (z < 48.0)
    if panel.any():
        zp, up = np.broadcast_to(z, d.shape)[panel], np.broadcast_to(alpha, d.shape)[panel] * 95.0
        inside = (
            _smoothstep(zp, 12.0, 13.5)
            * (1.0 - _smoothstep(zp, 39.5, 41.0))
            * (1.0 - _smoothstep(np.abs(up), 62.0, 63.5))
        )
        d[panel] -= 2.0 * inside
    return d


def _curls(alpha, z, rng):
    """Curls of hair: domes 16 mm across with a spiral groove, on a staggered grid."""
    pitch = 16.0
    columns = int(round(2 * np.pi * 85.0 / pitch))
    cell = 2 * np.pi / columns
    row = np.floor((z - 290.0) / (pitch * 0.87))
    shift = (row % 2) * 0.5 + rng.uniform(-0.15, 0.15)  # one random twist of the grid per seed
    col = np.floor(alpha / cell - shift)
    du = (alpha - (col + 0.5 + shift) * cell) * 85.0
    dz = z - (290.0 + (row + 0.5) * pitch * 0.87)
    rho = np.hypot(du / (pitch * 0.5), dz / (pitch * 0.43))  # each dome ends inside its cell
    theta = np.arctan2(dz, du)
    turn = np.where(((row * 7 + col * 3) % 2) == 0, 1.0, -1.0)  # curls wind both ways
    spiral = np.cos(2 * np.pi * rho * 2.2 - turn * theta) * _smoothstep(rho, 0.0, 0.35)  # smooth at the centre
    return 4.5 * _bell(rho) * (0.75 + 0.25 * spiral)


# --- noise --------------------------------------------------------------------------------------


def _fourier_noise(points, rng, terms, shortest, longest, rms):
    """A smooth random field over 3D space: a sum of ``terms`` plane waves of random directions,
    wavelengths log-uniform in [shortest, longest] mm and random phases, of RMS ``rms``."""
    directions = rng.normal(size=(terms, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    wavelengths = np.exp(rng.uniform(math.log(shortest), math.log(longest), terms))
    waves = (directions * (2 * np.pi / wavelengths)[:, None]).T.astype(np.float32)
    phases = rng.uniform(0.0, 2 * np.pi, terms).astype(np.float32)
    amplitude = rms * math.sqrt(2.0 / terms)
    out = np.empty(len(points), dtype=np.float64)
    block = 1 << 16
    for start in range(0, len(points), block):
        chunk = points[start : start + block].astype(np.float32)
        out[start : start + block] = np.sin(chunk @ waves + phases).sum(axis=1) * amplitude
    return out


# --- the mesh ------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def _profile_table():
    """The dense profile: arc length s, r, z, the mean circumference of the cross-section, the
    ring-weighted arc length (see below), the head's reference circumference and the unit
    normal of the profile in (r, z)."""
    dense = _fillet_profile(PROFILE)
    step = np.linalg.norm(np.diff(dense, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(step)])
    r, z = dense[:, 0], dense[:, 1]
    phi = np.linspace(-np.pi, np.pi, 64, endpoint=False)
    mean_g = shape_factor(z[:, None], phi[None, :]).mean(axis=1)
    circumference = 2 * np.pi * r * mean_g
    reference = 2 * np.pi * 80.0 * shape_factor(np.array([340.0])[:, None], phi[None, :]).mean()
    # Ring density: square quads (fewer rings where the circumference is large, as on the
    # brim), more where the profile bends (the brim's edge, the jaw), few on the hidden bottom.
    tangent = np.gradient(dense, s, axis=0)
    curvature = np.abs(np.gradient(tangent[:, 0], s) * tangent[:, 1] - np.gradient(tangent[:, 1], s) * tangent[:, 0])
    density = np.clip(np.sqrt(reference / np.maximum(circumference, 1e-3)), 0.6, 1.5) * (
        1.0 + np.clip(3.0 * curvature, 0.0, 1.5)
    )
    density = np.where(z < 0.5, 0.4, np.where(r < 40.0, 1.0, density))
    kernel = np.ones(61) / 61.0  # 3 mm running mean: no jumps in ring spacing
    density = np.convolve(np.pad(density, 30, mode="edge"), kernel, mode="valid")
    weighted = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * step)])
    normal = np.stack([tangent[:, 1], -tangent[:, 0]], axis=1)  # outwards in (r, z)
    return s, r, z, circumference, weighted, reference, normal


def _rings(around, rings, levels):
    """Rings along the profile: lateral radius r0, height z0 and point count of each. A ring
    has ``around`` points, or half, a quarter... (at most ``levels`` halvings) where its
    circumference is that much shorter than the spacing of the rings (near the poles), so its
    quads stay square; neighbouring rings differ by one halving at most."""
    s, r, z, circumference, weighted, _, normal = _profile_table()
    target = weighted[-1] * np.arange(1, rings + 1) / (rings + 1)
    s_rings = np.interp(target, weighted, s)
    spacing = np.gradient(np.concatenate([[0.0], s_rings, [s[-1]]]))[1:-1]
    length = np.maximum(np.interp(s_rings, s, circumference), 1e-9)
    level = np.clip(np.floor(np.log2(around * spacing / length)), 0, levels).astype(int)
    for i in range(1, rings):  # one halving at a time, from either end
        level[i] = min(level[i], level[i - 1] + 1)
    for i in range(rings - 2, -1, -1):
        level[i] = min(level[i], level[i + 1] + 1)
    normal = np.stack([np.interp(s_rings, s, normal[:, k]) for k in range(2)], axis=1)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return np.interp(s_rings, s, r), np.interp(s_rings, s, z), around >> level, normal


def _face_count(counts):
    pairs = np.minimum(counts[1:], counts[:-1])
    return int(counts[0] + counts[-1] + np.where(counts[1:] == counts[:-1], 2 * pairs, 3 * pairs).sum())


def _layout(triangles):
    """(r0, z0, counts, profile normals) of the rings for about ``triangles`` faces."""
    _, _, _, _, weighted, reference, _ = _profile_table()
    # Square quads on the head: rings / around = weighted length / reference circumference.
    estimate = math.sqrt(triangles / 2 * reference / weighted[-1])
    levels = max(0, int(math.floor(math.log2(max(estimate, 12.0) / 12.0))))  # >= 12 points on a ring
    around = max(12, (1 << levels) * int(round(estimate / (1 << levels))))
    rings = max(3, int(round(triangles / (2 * around))))
    for _ in range(6):
        layout = _rings(around, rings, levels)
        better = max(3, int(round(rings * triangles / _face_count(layout[2]))))
        if better == rings:
            break
        rings = better
    return layout


def _ring_faces(positions, offsets, counts):
    """The faces of the closed mesh: a fan at each pole, two triangles per quad between rings
    of equal counts (cut along the shorter diagonal), three per coarse segment where the count
    halves. Vertex 0 is the bottom pole, the last the top pole; ring i starts at offsets[i]."""
    faces = []
    first, last = counts[0], counts[-1]
    j = np.arange(first)
    faces.append(np.stack([np.zeros(first, np.int64), offsets[0] + (j + 1) % first, offsets[0] + j], axis=1))
    for i in range(len(counts) - 1):
        low, high, n_low, n_high = offsets[i], offsets[i + 1], counts[i], counts[i + 1]
        if n_low == n_high:
            j = np.arange(n_low)
            a, b = low + j, low + (j + 1) % n_low
            c, d = high + (j + 1) % n_low, high + j
            faces.append(_split_quads(positions, a, b, c, d))
        elif n_high * 2 == n_low:  # the ring above is coarser
            j = np.arange(n_high)
            f0, f1, f2 = low + 2 * j, low + 2 * j + 1, low + (2 * j + 2) % n_low
            c0, c1 = high + j, high + (j + 1) % n_high
            faces.append(np.concatenate([np.stack(t, 1) for t in ((f0, f1, c0), (f1, c1, c0), (f1, f2, c1))]))
        else:  # the ring above is finer
            j = np.arange(n_low)
            c0, c1 = low + j, low + (j + 1) % n_low
            f0, f1, f2 = high + 2 * j, high + 2 * j + 1, high + (2 * j + 2) % n_high
            faces.append(np.concatenate([np.stack(t, 1) for t in ((c0, c1, f1), (c1, f2, f1), (c0, f1, f0))]))
    j = np.arange(last)
    top = offsets[-1] + last
    faces.append(np.stack([np.full(last, top, np.int64), offsets[-1] + j, offsets[-1] + (j + 1) % last], axis=1))
    return np.concatenate(faces)


def _split_quads(vertices, a, b, c, d):
    """Two triangles per quad (a, b, c, d), cut along its shorter diagonal."""
    ac = np.einsum("ij,ij->i", vertices[a] - vertices[c], vertices[a] - vertices[c])
    bd = np.einsum("ij,ij->i", vertices[b] - vertices[d], vertices[b] - vertices[d])
    short_ac = ac <= bd
    first = np.where(short_ac[:, None], np.stack([a, b, c], 1), np.stack([a, b, d], 1))
    second = np.where(short_ac[:, None], np.stack([a, c, d], 1), np.stack([b, c, d], 1))
    return np.concatenate([first, second])


def _base_shape(r0, z0, counts, normal, rng):
    """The points of the rings and the poles before noise (the lathe, the cross-section
    shapes, the sculpted features and the turn of the head), and at each the direction the
    noise moves it along: the normal of the plain lathe (the profile's normal turned by phi),
    a field that turns no faster than the profile's fillets, so that noise whose size times
    its slope stays well below 1 cannot fold the surface, however narrow a groove."""
    ring = np.repeat(np.arange(len(counts)), counts)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    phi = -np.pi + 2 * np.pi * (np.arange(len(ring)) - starts[ring]) / counts[ring]
    z, r = z0[ring], r0[ring]
    radius = r * shape_factor(z, phi) + _features(z, phi, r, rng)
    turned = phi + HEAD_TURN * _smoothstep(z, 250.0, 300.0)
    points = np.stack([radius * np.cos(turned), radius * np.sin(turned), z], axis=1)
    directions = np.stack([normal[ring, 0] * np.cos(turned), normal[ring, 0] * np.sin(turned), normal[ring, 1]], axis=1)
    points = np.concatenate([[[0.0, 0.0, 0.0]], points, [[0.0, 0.0, HEIGHT_MM]]])
    directions = np.concatenate([[[0.0, 0.0, -1.0]], directions, [[0.0, 0.0, 1.0]]])
    return points, directions


def bust_mesh(triangles, *, seed=0):
    """A closed bust, ~``triangles`` faces, in mm, Z up, on z = 0: (vertices (V, 3) float64,
    faces (F, 3) int32), faces wound counter-clockwise seen from outside."""
    if triangles < 500:
        raise ValueError("a bust needs at least 500 triangles")
    rng = np.random.default_rng(seed)
    r0, z0, counts, normal = _layout(triangles)
    vertices, directions = _base_shape(r0, z0, counts, normal, rng)
    offsets = 1 + np.concatenate([[0], np.cumsum(counts)[:-1]])
    faces = _ring_faces(vertices, offsets, counts)
    # Erosion and scan noise, along the lathe's normal. The bottom stays a flat cut (the bust
    # stands on z = 0), and the poles' fans keep their shape.
    noise = _fourier_noise(vertices, rng, 40, 20.0, 80.0, 0.15) + _fourier_noise(vertices, rng, 48, 1.2, 4.0, 0.1)
    fade = _smoothstep(np.hypot(vertices[:, 0], vertices[:, 1]), 2.0, 15.0) * _smoothstep(vertices[:, 2], 0.0, 4.0)
    vertices = vertices + directions * (noise * fade)[:, None]
    vertices[:, 2] = np.maximum(vertices[:, 2], 0.0)
    return vertices, faces.astype(np.int32)


# --- units ------------------------------------------------------------------------------------


def _nominal_diagonal():
    r0, z0, counts, normal = _layout(20_000)
    points, _ = _base_shape(r0, z0, np.maximum(counts, 720), normal, np.random.default_rng(0))
    return float(np.linalg.norm(np.ptp(points, axis=0)))


#: The bust's nominal bounding-box diagonal (mm, ~704.7): that of the noise-free shape; a
#: generated bust's is within a millimetre of it.
NOMINAL_DIAGONAL_MM = _nominal_diagonal()

#: The factor from millimetres to each unit of the corpus.
UNITS = {"mm": 1.0, "m": 0.001, "normalised": 1.0 / NOMINAL_DIAGONAL_MM}

#: Blender's scene unit settings for each: (scale_length = metres per Blender unit, length_unit).
#: "normalised" keeps true sizes on display: one Blender unit is the bust's diagonal.
SCENE_UNITS = {
    "mm": (0.001, "MILLIMETERS"),
    "m": (1.0, "METERS"),
    "normalised": (NOMINAL_DIAGONAL_MM / 1000.0, "ADAPTIVE"),
}


def scaled(vertices, unit):
    """``vertices`` (in mm) in ``unit`` (a key of UNITS): the shape scaled about the origin, so
    it still stands on z = 0."""
    try:
        return np.asarray(vertices, dtype=np.float64) * UNITS[unit]
    except KeyError:
        raise ValueError(f"unknown unit {unit!r}: choose one of {', '.join(UNITS)}") from None


# --- checks -----------------------------------------------------------------------------------


def check_mesh(vertices, faces):
    """Facts that make a closed, manifold, outward-oriented mesh, from numpy alone.

    Returns a dict: vertices, faces, edges, edge_uses (min, max: 2, 2 when closed and manifold),
    oriented (every directed edge used once: neighbours wind the same way), euler (2 for a
    sphere), volume (signed; > 0 when the faces point out), min_area, unused_vertices."""
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces, dtype=np.int64)
    n = len(vertices)
    directed = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    undirected = np.sort(directed, axis=1)
    keys, uses = np.unique(undirected[:, 0] * n + undirected[:, 1], return_counts=True)
    directed_unique = len(np.unique(directed[:, 0] * n + directed[:, 1]))
    a, b, c = vertices[faces[:, 0]], vertices[faces[:, 1]], vertices[faces[:, 2]]
    cross = np.cross(b - a, c - a)
    areas = 0.5 * np.linalg.norm(cross, axis=1)
    volume = float(np.einsum("ij,ij->", a, np.cross(b, c)) / 6.0)
    return dict(
        vertices=n,
        faces=len(faces),
        edges=len(keys),
        edge_uses=(int(uses.min()), int(uses.max())),
        oriented=directed_unique == len(directed),
        euler=n - len(keys) + len(faces),
        volume=volume,
        min_area=float(areas.min()),
        unused_vertices=int(n - len(np.unique(faces))),
    )


def is_closed_manifold(report):
    return (
        report["edge_uses"] == (2, 2)
        and report["oriented"]
        and report["euler"] == 2
        and report["volume"] > 0
        and report["min_area"] > 0
        and report["unused_vertices"] == 0
    )


def self_intersections(vertices, faces):
    """Pairs of triangles that cross each other (those that share a vertex are not counted),
    found with mathutils' BVH tree (needs bpy)."""
    from mathutils.bvhtree import BVHTree

    tree = BVHTree.FromPolygons(vertices.tolist(), faces.tolist(), all_triangles=True, epsilon=0.0)
    pairs = np.array(tree.overlap(tree), dtype=np.int64).reshape(-1, 2)
    pairs = pairs[pairs[:, 0] < pairs[:, 1]]
    shared = (faces[pairs[:, 0]][:, :, None] == faces[pairs[:, 1]][:, None, :]).any(axis=(1, 2))
    return pairs[~shared]


# --- Blender ------------------------------------------------------------------------------------


def add_to_scene(name, vertices, faces, collection=None):
    """A new smooth-shaded mesh object ``name`` without UV maps, linked to ``collection`` (the
    scene's master collection by default), built with foreach_set."""
    import bpy

    vertices = np.ascontiguousarray(vertices, dtype=np.float32)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(vertices))
    mesh.vertices.foreach_set("co", vertices.ravel())
    mesh.loops.add(faces.size)
    mesh.loops.foreach_set("vertex_index", faces.ravel())
    mesh.polygons.add(len(faces))
    mesh.polygons.foreach_set("loop_start", np.arange(0, faces.size, 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    (collection or bpy.context.scene.collection).objects.link(obj)
    return obj


def _look_at(obj, location, target):
    from mathutils import Vector

    obj.location = location
    obj.rotation_euler = (Vector(target) - Vector(location)).to_track_quat("-Z", "Y").to_euler()


#: Where the scene's camera and sun are, in mm (scaled to the scene's unit): the camera sees the
#: face from the front, a little to the bust's right and below (the brim's underside shows); the
#: sun rakes it from the front left, low enough to light the face under the brim.
CAMERA_MM = dict(location=(-170.0, -1000.0, 160.0), target=(0.0, 0.0, 350.0), lens=75.0)
SUN_TOWARDS = (-0.4, -0.88, 0.25)


def grey_material():
    """A plain grey diffuse material (for previews)."""
    import bpy

    material = bpy.data.materials.new("Grey Diffuse")
    if bpy.app.version < (5, 0, 0):
        material.use_nodes = True
    nodes = material.node_tree.nodes
    nodes.clear()
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
    output = nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(diffuse.outputs[0], output.inputs["Surface"])
    return material


def build_scene(scene, *, triangles=200_000, unit="mm", seed=0, material="limestone"):
    """The bust sample in ``scene``: "Bust" on a concrete "Ground", a "Sun", a "Camera", a sky,
    quick Cycles settings (480 x 480) and the scene's units. ``material``: "limestone" (the
    LIMESTONE preset lit by the sun, as build_samples.py gives every sample) or "grey"."""
    import bpy

    from mathutils import Vector

    factor = UNITS[unit]
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length, scene.unit_settings.length_unit = SCENE_UNITS[unit]
    vertices, faces = bust_mesh(triangles, seed=seed)
    bust = add_to_scene("Bust", scaled(vertices, unit), faces, scene.collection)

    light = bpy.data.lights.new("Sun", "SUN")
    light.energy, light.angle = 4.0, 0.0
    sun = bpy.data.objects.new("Sun", light)
    scene.collection.objects.link(sun)
    sun.rotation_euler = Vector(SUN_TOWARDS).normalized().to_track_quat("Z", "Y").to_euler("XYZ")

    data = bpy.data.cameras.new("Camera")
    data.lens = CAMERA_MM["lens"]
    data.clip_start, data.clip_end = 10.0 * factor, 20_000.0 * factor
    camera = bpy.data.objects.new("Camera", data)
    scene.collection.objects.link(camera)
    _look_at(camera, [v * factor for v in CAMERA_MM["location"]], [v * factor for v in CAMERA_MM["target"]])
    scene.camera = camera

    world = bpy.data.worlds.new("Sky")
    if bpy.app.version < (5, 0, 0):
        world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.42, 0.5, 0.62, 1.0)
    background.inputs["Strength"].default_value = 0.6
    scene.world = world

    half = 1500.0 * factor
    ground = bpy.data.meshes.new("Ground")
    ground.from_pydata([(-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)], [], [(0, 1, 2, 3)])
    ground = bpy.data.objects.new("Ground", ground)
    scene.collection.objects.link(ground)

    if material == "limestone":
        if str(HERE.parent) not in sys.path:
            sys.path.insert(0, str(HERE.parent))
        from porous_weathering.shading.material import make_preset_material

        stone = make_preset_material("LIMESTONE", key_light=sun)
        concrete = make_preset_material("CONCRETE", name="Ground Concrete")
    else:
        stone = concrete = grey_material()
    bust.data.materials.append(stone)
    ground.data.materials.append(concrete)

    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples, scene.cycles.preview_samples, scene.cycles.seed = 32, 8, 0
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 4
    scene.render.resolution_x = scene.render.resolution_y = 480
    scene.render.resolution_percentage = 100
    return bust


def render_preview(scene, path, samples=16, threads=2):
    """A quick denoised Cycles picture of ``scene`` from its camera, written to ``path`` (PNG)."""
    import bpy

    scene.cycles.samples = samples
    scene.cycles.use_denoising = True
    scene.render.threads_mode, scene.render.threads = "FIXED", threads
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True, scene=scene.name)


def write_obj(path, triangles, unit, seed):
    """The bust alone as a scanner exports one: an OBJ at ``path``, Z up (scanners' and GIS
    exports' axis, docs/scans.md), in ``unit``, without normals, UVs or materials."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    vertices, faces = bust_mesh(triangles, seed=seed)
    add_to_scene("Bust", scaled(vertices, unit), faces)
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.obj_export(
        filepath=str(path.resolve()),
        forward_axis="Y",
        up_axis="Z",
        export_normals=False,
        export_uv=False,
        export_materials=False,
    )


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--triangles", type=int, default=200_000)
    parser.add_argument("--unit", choices=UNITS, default="mm")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--material", choices=("limestone", "grey"), default="limestone")
    parser.add_argument("--out", type=pathlib.Path, help="save the scene to this .blend")
    parser.add_argument("--preview", type=pathlib.Path, help="render a 480 x 480 preview (grey material) here")
    parser.add_argument("--check", action="store_true", help="check the mesh (closed, manifold, oriented, areas)")
    parser.add_argument("--obj", type=pathlib.Path, help="write the bust alone as a scan here: OBJ, Z up, in --unit")
    args = parser.parse_args(argv)

    if args.check:
        start = time.perf_counter()
        vertices, faces = bust_mesh(args.triangles, seed=args.seed)
        report = check_mesh(vertices, faces)
        print(f"{len(faces)} triangles in {time.perf_counter() - start:.2f} s: {report}")
        if not is_closed_manifold(report):
            sys.exit("the mesh is not closed, manifold and outward-oriented")
    if not (args.out or args.preview or args.obj):
        return
    import bpy

    if args.obj:
        write_obj(args.obj, args.triangles, args.unit, args.seed)
        print(f"wrote {args.obj}")
        if not (args.out or args.preview):
            return

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0
    scene = bpy.context.scene
    scene.name = "bust"
    material = "grey" if args.preview and not args.out else args.material
    build_scene(scene, triangles=args.triangles, unit=args.unit, seed=args.seed, material=material)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=str(args.out.resolve()), compress=True, relative_remap=False)
        print(f"wrote {args.out}")
    if args.preview:
        if material != "grey":
            grey = grey_material()
            for obj in scene.objects:
                if obj.type == "MESH":
                    obj.data.materials.clear()
                    obj.data.materials.append(grey)
        render_preview(scene, args.preview.resolve())
        print(f"wrote {args.preview}")


if __name__ == "__main__":
    main()
