"""Blender's Voronoi texture (2D, F1 and F2, Euclidean, randomness 1: the node's defaults) and White Noise
texture (1D, its Color) as Cycles computes them, in numpy and in single precision as the shader
works, so that a point's nearest seed is the render's (docs/model.md §10.1: the survey's lichens)
and a cell's draws are the render's (§8.8: the rivulets). The Voronoi's cells are hashed by a hash
Blender changed in 5.0: ``LOOKUP3`` (up to 4.5: Bob Jenkins' lookup3 of the bits of the cell's
float coordinates) or ``PCG`` (from 5.0: the PCG hash of its integer coordinates, Jarzynski &
Olano 2020); the White Noise by lookup3 in both; all as Cycles' ``util/hash.h`` writes them. No bpy."""

import numpy as np

LOOKUP3 = "lookup3"
PCG = "pcg"

#: lookup3's starting value for a hash of n words: 0xdeadbeef + (n << 2) + 13.
_START = {n: 0xDEADBEEF + (n << 2) + 13 for n in (1, 2, 3)}
_PCG_MULTIPLIER, _PCG_INCREMENT = np.int32(1664525), np.int32(1013904223)


def _rotate(x: np.ndarray, k: int) -> np.ndarray:
    return (x << np.uint32(k)) | (x >> np.uint32(32 - k))


def _final(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """lookup3's ``final`` mix of three uint32 words: its c."""
    c = (c ^ b) - _rotate(b, 14)
    a = (a ^ c) - _rotate(c, 11)
    b = (b ^ a) - _rotate(a, 25)
    c = (c ^ b) - _rotate(b, 16)
    a = (a ^ c) - _rotate(c, 4)
    b = (b ^ a) - _rotate(a, 14)
    return (c ^ b) - _rotate(b, 24)


def lookup3(*words: np.ndarray) -> np.ndarray:
    """Cycles' ``hash_float_to_float`` / ``hash_float2_to_float`` / ``hash_float3_to_float``:
    lookup3 of the one to three words' float32 bits, as a float32 in [0, 1]."""
    bits = [np.ascontiguousarray(word, dtype=np.float32).view(np.uint32) for word in words]
    a = np.full(bits[0].shape, _START[len(bits)], dtype=np.uint32)
    b, c = a.copy(), a.copy()
    a = a + bits[0]
    if len(bits) >= 2:
        b = b + bits[1]
    if len(bits) == 3:
        c = c + bits[2]
    return _final(a, b, c).astype(np.float32) * np.float32(2.0**-32)


def _pcg2d(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cycles' ``hash_pcg2d_i`` (int32, wrapping; its shift is arithmetic)."""
    x, y = x * _PCG_MULTIPLIER + _PCG_INCREMENT, y * _PCG_MULTIPLIER + _PCG_INCREMENT
    x = x + y * _PCG_MULTIPLIER
    y = y + x * _PCG_MULTIPLIER
    x, y = x ^ (x >> 16), y ^ (y >> 16)
    x = x + y * _PCG_MULTIPLIER
    y = y + x * _PCG_MULTIPLIER
    return x & 0x7FFFFFFF, y & 0x7FFFFFFF


def _pcg3d(x: np.ndarray, y: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cycles' ``hash_pcg3d_i`` (int32, wrapping; its shift is arithmetic)."""
    x, y, z = (w * _PCG_MULTIPLIER + _PCG_INCREMENT for w in (x, y, z))
    x = x + y * z
    y = y + z * x
    z = z + x * y
    x, y, z = x ^ (x >> 16), y ^ (y >> 16), z ^ (z >> 16)
    x = x + y * z
    y = y + z * x
    z = z + x * y
    return x & 0x7FFFFFFF, y & 0x7FFFFFFF, z & 0x7FFFFFFF


def _to_unit(h: np.ndarray) -> np.ndarray:
    return h.astype(np.float32) * np.float32(2.0**-31)


def cell_hash(
    cx: np.ndarray, cy: np.ndarray, kind: str
) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """(seed x, seed y in the cell, the cell's two values: the Color's red and blue) of cells (cx, cy)."""
    if kind == LOOKUP3:  # hash_float2_to_float3: its red is the seed's x (and its green the seed's y)
        own = lookup3(cx, cy)
        return own, lookup3(cx, cy, np.ones_like(cx)), (own, lookup3(cx, cy, np.full_like(cx, 2.0)))
    if kind == PCG:
        ix, iy = cx.astype(np.int32), cy.astype(np.int32)
        sx, sy = _pcg2d(ix, iy)
        red, _, blue = _pcg3d(ix, iy, np.zeros_like(ix))
        return _to_unit(sx), _to_unit(sy), (_to_unit(red), _to_unit(blue))
    raise ValueError(f"the Voronoi hash is {LOOKUP3!r} or {PCG!r}, not {kind!r}")


def voronoi_f1_f2(x: np.ndarray, y: np.ndarray, scale: np.ndarray | float, kind: str) -> tuple[np.ndarray, ...]:
    """(F1's Distance, Color's red and blue, F2's Distance, Color's red and blue) of the Voronoi
    texture node (2D) at ``(x, y) * scale``, its cells hashed by ``kind`` (LOOKUP3 or PCG): the
    distances in cells to the nearest and the second nearest seed and each seed's own two values in
    [0, 1], as Cycles' ``voronoi_f1`` and ``voronoi_f2`` find them."""
    with np.errstate(over="ignore"):
        coord = [np.asarray(axis, dtype=np.float32) * np.asarray(scale, dtype=np.float32) for axis in (x, y)]
        cell = [np.floor(axis) for axis in coord]
        local = [axis - corner for axis, corner in zip(coord, cell)]
        first, second = (np.full(coord[0].shape, np.inf, dtype=np.float32) for _ in range(2))
        first_values, second_values = ([np.zeros(coord[0].shape, dtype=np.float32)] * 2 for _ in range(2))
        for j in (-1, 0, 1):  # Cycles' order: a tie keeps the first seed found
            for i in (-1, 0, 1):
                sx, sy, own = cell_hash(cell[0] + np.float32(i), cell[1] + np.float32(j), kind)
                dx, dy = np.float32(i) + sx - local[0], np.float32(j) + sy - local[1]
                distance = np.sqrt(dx * dx + dy * dy)
                nearest, next_nearest = distance < first, (distance >= first) & (distance < second)
                second = np.where(nearest, first, np.where(next_nearest, distance, second))
                second_values = [
                    np.where(nearest, old, np.where(next_nearest, new, kept))
                    for old, new, kept in zip(first_values, own, second_values)
                ]
                first = np.where(nearest, distance, first)
                first_values = [np.where(nearest, new, kept) for new, kept in zip(own, first_values)]
    return first, *first_values, second, *second_values


def white_noise_colour(w: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The Color of the White Noise texture node in 1D at ``w``, Cycles' ``hash_float_to_float3``:
    three float32 draws in [0, 1], lookup3 of w's float32 bits, then of (w, 1) and (w, 2)."""
    w = np.asarray(w, dtype=np.float32)
    return lookup3(w), lookup3(w, np.ones_like(w)), lookup3(w, np.full_like(w, 2.0))
