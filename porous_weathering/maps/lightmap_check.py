"""The lightmap check: whether a UV map can hold a bake at a resolution (docs/maps.md, "The
lightmap").

A UV map can hold a bake at a resolution when ``check_uvs`` passes it: every corner lies in
[0, 1]; no texel centre lies on two triangles; the texels each UV island touches lie at least
``padding`` texels from those of every other island; and at most 0.1% of the triangles get
under 1% of their fair (area-proportional) share of the map's texels.

It also says which points of a mesh make its surface (``surface_points``), from which the
object's size, the run-off's grid and the unwrap's placing are measured.

Pure numpy, and no import of this package: the unwrap's child process (``lightmap_child``)
loads this file by its path.
"""

from dataclasses import dataclass

import numpy as np

#: Texels between UV islands (and packed between new charts) at and above PADDING_FULL_FROM.
PADDING = 4
#: Below this resolution islands need only 2 texels between them (a few charts could not fit).
PADDING_FULL_FROM = 256
#: A triangle is starved below this fraction of its area-proportional share of texels...
STARVED_SHARE = 0.01
#: ... and a map may starve at most this fraction of its triangles.
STARVED_MAX = 0.001
#: A texel centre this close to an edge (in texels² of the edge function) lies on it.
ON_EDGE = 1e-6
#: Candidate texels rasterised at once (bounds the check's memory).
RASTER_BLOCK = 1 << 22


def padding_for(resolution: int) -> int:
    """The texels a lightmap keeps between its UV islands at ``resolution``."""
    return PADDING if resolution >= PADDING_FULL_FROM else 2


def triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """Areas of triangles (T, 3, 2 or 3)."""
    u, v = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    if triangles.shape[-1] == 2:
        return 0.5 * np.abs(_cross(u, v))
    return 0.5 * np.linalg.norm(np.cross(u, v), axis=1)


def surface_points(positions: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The points of ``positions`` (V, 3) that the ``triangles`` (T, 3) of non-zero area use, as
    float64 (n, 3): the surface, without loose vertices, the ends of loose edges or collapsed
    faces (a scan's stray point far away must not change the object's size)."""
    positions = np.asarray(positions, dtype=np.float64)
    triangles = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    solid = triangle_areas(positions[triangles]) > 0
    used = np.zeros(len(positions), dtype=bool)
    used[triangles[solid].ravel()] = True  # in index order, as np.unique gives them, without its sort
    return positions[used]


def _cross(u, v):
    return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]


@dataclass(frozen=True)
class LightmapReport:
    """What ``check_uvs`` found in a UV map at ``resolution``² with ``padding`` texels between
    islands: triangles with a corner outside [0, 1] (``outside``), texel centres inside two or
    more triangles (``overlapping``), texels of an island within ``padding`` texels of another
    island's (``crowded``), triangles under 1% of their fair share of texels (``starved``, of
    ``triangles`` that have an area), texels whose centre a triangle covers (``covered``) and
    UV ``islands``."""

    resolution: int
    padding: int
    triangles: int
    outside: int
    overlapping: int
    crowded: int
    starved: int
    covered: int
    islands: int

    @property
    def utilisation(self) -> float:
        """The fraction of the image's texels that the bake fills (their centre on a triangle)."""
        return self.covered / self.resolution**2

    @property
    def ok(self) -> bool:
        return not self.problems()

    def problems(self) -> list[str]:
        """Why the map cannot hold a bake, one phrase per reason (empty when it can)."""
        size = f"at {self.resolution}²"
        found = []
        if self.outside:
            found.append(f"{self.outside} triangles leave [0, 1]")
        if self.overlapping:
            found.append(f"{self.overlapping} texels lie on two triangles {size}")
        if self.crowded:
            found.append(f"{self.crowded} texels lie within {self.padding} texels of another island {size}")
        if self.starved > STARVED_MAX * self.triangles:
            found.append(
                f"{self.starved} of {self.triangles} triangles get under {STARVED_SHARE:.0%} of their "
                f"fair share of texels {size}"
            )
        return found


def check_uvs(
    triangle_uvs: np.ndarray, areas: np.ndarray, resolution: int, padding: int | None = None
) -> LightmapReport:
    """Check per-triangle UVs ``triangle_uvs`` (T, 3, 2) of triangles of 3D ``areas`` (T,) as a
    bake target of ``resolution``² texels (see the module docstring)."""
    return inspect_uvs(triangle_uvs, areas, resolution, padding_for(resolution) if padding is None else padding)[0]


def overlapping_texels(triangle_uvs: np.ndarray, resolution: int) -> int:
    """How many texel centres of a ``resolution``² image lie on two or more of the UV triangles
    ``triangle_uvs`` (T, 3, 2). A centre on an edge two triangles share is on one of them."""
    return check_uvs(triangle_uvs, np.ones(len(triangle_uvs)), resolution).overlapping


def inspect_uvs(
    triangle_uvs: np.ndarray, areas: np.ndarray, resolution: int, padding: int
) -> tuple[LightmapReport, np.ndarray]:
    """(LightmapReport, the triangles (T,) bool that overlap another or are starved)."""
    uvs = np.asarray(triangle_uvs, dtype=np.float64)
    areas = np.asarray(areas, dtype=np.float64)
    outside = int(np.count_nonzero(np.any((uvs < 0.0) | (uvs > 1.0), axis=(1, 2))))
    islands, rim = _islands(np.asarray(triangle_uvs, dtype=np.float32))
    uv_areas = triangle_areas(uvs)
    share = uv_areas / max(uv_areas.sum(), 1e-300)
    fair = areas / max(areas.sum(), 1e-300)
    solid = fair > 0
    starved = solid & (share < STARVED_SHARE * fair)
    # Islands come closest at their rims, so only rim triangles' footprints are kept apart (an
    # island inside another's would overlap it); a triangle without an area is never seen, one
    # without a UV area is starved.
    footprint = rim & solid & (share > 0)
    centre, centre_triangle, touched, touched_triangle = rasterise(uvs * resolution, resolution, footprint)
    cover = np.bincount(centre, minlength=resolution * resolution)  # triangles on each texel centre
    crowded = _crowded(touched, islands[touched_triangle], resolution, padding)
    culprits = starved.copy()
    culprits[centre_triangle[cover[centre] > 1]] = True
    report = LightmapReport(
        resolution,
        padding,
        int(np.count_nonzero(solid)),
        outside,
        int(np.count_nonzero(cover > 1)),
        crowded,
        int(np.count_nonzero(starved)),
        int(np.count_nonzero(cover)),
        int(np.unique(islands).size),
    )
    return report, culprits


def _islands(triangle_uvs):
    """(the UV island of every triangle (T,), whether it lies on its island's rim (T,) bool):
    triangles are joined where they share a UV point; a rim triangle has an edge no other
    triangle shares."""
    bits = np.ascontiguousarray(triangle_uvs, dtype=np.float32).view(np.uint32).astype(np.uint64)
    keys = (bits[..., 0] << np.uint64(32)) | bits[..., 1]
    _, points = np.unique(keys.ravel(), return_inverse=True)
    points = points.reshape(-1, 3)
    count = int(points.max()) + 1 if points.size else 0
    first, second = np.concatenate([points[:, :2], points[:, 1:], points[:, ::2]]).T
    edges = np.minimum(first, second) * count + np.maximum(first, second)
    _, index, uses = np.unique(edges, return_inverse=True, return_counts=True)
    rim = (uses[index] == 1).reshape(3, -1).any(axis=0)
    return connected_components(count, first, second)[points[:, 0]], rim


def connected_components(count: int, first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """The component of each of ``count`` nodes joined by the edges ``first[i]``-``second[i]``,
    as the smallest node of the component (hooking of roots and pointer jumping, vectorised)."""
    label = np.arange(count)
    first, second = np.asarray(first), np.asarray(second)
    while True:
        low, high = label[first], label[second]
        apart = low != high
        if not apart.any():
            return label
        first, second, low, high = first[apart], second[apart], low[apart], high[apart]
        np.minimum.at(label, np.maximum(low, high), np.minimum(low, high))
        while True:  # every node points at its root again
            jumped = label[label]
            if np.array_equal(jumped, label):
                break
            label = jumped


def rasterise(
    points: np.ndarray, resolution: int, footprint: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """For triangles ``points`` (T, 3, 2) in texel units: (texels whose centre lies strictly
    inside a triangle, and that triangle, one entry per pair; texels a triangle where
    ``footprint`` (T,) touches at all, and that triangle). Texels are numbered
    row * resolution + column.

    Triangles go in groups of one bounding-box shape (in texels), so each group is a dense
    (triangles, texels of the box) array of candidates."""
    low = np.clip(np.floor(points.min(axis=1)), 0, resolution - 1)
    extent = (np.clip(np.floor(points.max(axis=1)), 0, resolution - 1) - low + 1).astype(np.int64)
    local = points - low[:, None, :]  # small numbers: the edge functions stay exact enough
    orientation = np.sign(_cross(local[:, 1] - local[:, 0], local[:, 2] - local[:, 0]))
    edges = np.roll(local, -1, axis=1) - local  # (T, 3, 2): a -> b, b -> c, c -> a
    # the edge function orientation * cross(edge, p - start) = along_x * x + along_y * y + offset
    along_x, along_y = -orientation[:, None] * edges[..., 1], orientation[:, None] * edges[..., 0]
    offset = -(along_x * local[..., 0] + along_y * local[..., 1])
    reach = 0.5 * (np.abs(edges[..., 0]) + np.abs(edges[..., 1]))  # of a texel's square, across the edge
    # a centre on an edge two triangles share is theirs once: the triangle the edge faces right
    # (or up) owns it; "on" allows for rounding, as each computes the edge function its own way
    owns = (along_x > 0) | ((along_x == 0) & (along_y > 0))
    origin = (low[:, 1] * resolution + low[:, 0]).astype(np.int64)  # the box's first texel

    shapes, group = np.unique(extent[:, 0] * (resolution + 1) + extent[:, 1], return_inverse=True)
    order = np.argsort(group, kind="stable")
    starts = np.searchsorted(group[order], np.arange(len(shapes) + 1))
    found = {"centre": [], "centre_triangle": [], "touched": [], "touched_triangle": []}
    for shape, first, last in zip(shapes, starts[:-1], starts[1:]):
        width, height = divmod(int(shape), resolution + 1)
        dy, dx = np.divmod(np.arange(width * height), width)
        x, y, step = dx + 0.5, dy + 0.5, dy * resolution + dx
        members = order[first:last]
        for block in np.array_split(members, max(1, members.size * width * height // RASTER_BLOCK)):
            inside = meets = True
            for k in range(3):  # (a degenerate triangle's edge functions are all 0: inside none)
                value = along_x[block, k, None] * x + along_y[block, k, None] * y + offset[block, k, None]
                inside = inside & ((value > ON_EDGE) | ((value >= -ON_EDGE) & owns[block, k, None]))
                meets = meets & (value >= -reach[block, k, None])
            texel = origin[block, None] + step
            meets &= footprint[block, None]
            for mask, where, which in ((inside, "centre", "centre_triangle"), (meets, "touched", "touched_triangle")):
                found[where].append(texel[mask])
                found[which].append(np.broadcast_to(block[:, None], mask.shape)[mask])
    return tuple(np.concatenate(found[name]) if found[name] else np.empty(0, np.int64) for name in found)


def _crowded(texels, islands, resolution, padding):
    """How many touched ``texels`` (of ``islands``) lie within ``padding`` texels (Chebyshev)
    of another island's, or are touched by two islands."""
    label = np.full(resolution * resolution, -1, dtype=np.int32)
    label[texels] = islands
    shared = np.unique(texels[label[texels] != islands])
    label = label.reshape(resolution, resolution)
    empty = label < 0
    highest = _window(label, padding, np.maximum)
    lowest = _window(np.where(empty, np.iinfo(np.int32).max, label), padding, np.minimum)
    near = ~empty & ((highest > label) | (lowest < label))
    near.reshape(-1)[shared] = True
    return int(np.count_nonzero(near))


def _window(image, radius, pick):
    """``pick`` (np.maximum or np.minimum) over the (2 radius + 1)² square around every texel
    (the square cut at the image's border)."""
    result = image.copy()
    for axis in (0, 1):
        source = result.copy()
        for shift in range(1, radius + 1):
            ahead = [slice(None)] * 2
            behind = [slice(None)] * 2
            ahead[axis], behind[axis] = slice(shift, None), slice(None, -shift)
            pick(result[tuple(ahead)], source[tuple(behind)], out=result[tuple(ahead)])
            pick(result[tuple(behind)], source[tuple(ahead)], out=result[tuple(behind)])
    return result
