"""Condition-map drawings (docs/survey.md, "The drawings"): for one age, orthographic views of the
object with the survey's patterns coloured and hatched, a legend with each pattern's name and
area, a scale bar, a north arrow, a title block and the forecast table, on one A3 landscape sheet
written as SVG (vector) and PNG.

Each view is rasterised with a depth buffer at the print resolution (``PIXEL_MM`` on paper), so a
scan of millions of triangles costs what the paper holds, not what the mesh holds. The regions of
each pattern are then traced as vector outlines (contourpy, which matplotlib draws its filled
contours with), filled with the pattern's colour, and hatched with lines at a spacing fixed in
paper millimetres, clipped to the region.

Hatch codes are names (``HATCH_NAMES``: "lines", "cross", "dots", ...) or matplotlib's letters:
``/`` ``\\`` ``-`` ``|`` are line families at 45°, 135°, 0° and 90°, ``x`` is ``/`` and ``\\``,
``+`` is ``-`` and ``|``, ``.`` is dots; a letter repeated n times draws its lines n times closer
(``HATCH_SPACING_MM / n``); ``""`` is no hatch.

matplotlib is imported when a sheet is drawn, not with this module: the survey's areas and tables
work in a Blender without it (docs/survey.md says how to add it).
"""

import dataclasses
import math
import os
from collections.abc import Iterator

import numpy as np

from ..common.atomic import move_into_place_together, temporary_file

#: A3 landscape, in millimetres.
SHEET_MM = (420.0, 297.0)
MARGIN_MM = 10.0
#: The column on the right: legend, forecast, north arrow, scale bar, title block.
PANEL_MM = 115.0
GAP_MM = 8.0
#: Room above each view for its name (and, however narrow the view, beside it).
LABEL_MM = 6.0
LABEL_WIDTH_MM = 32.0
#: The side of a raster cell on paper: what a view is resolved to before its regions are traced.
PIXEL_MM = 0.25
#: The mapping unit: each square of MAPPING_CELLS × MAPPING_CELLS raster cells (1 mm on paper) is
#: drawn in its most frequent pattern; the object's outline keeps the raster's resolution.
MAPPING_CELLS = 4
#: Hatch line spacing on paper (2 mm at the print scale, as condition maps print them at 1:50).
HATCH_SPACING_MM = 2.0
HATCH_LINE_MM = 0.13
OUTLINE_MM = 0.35
#: The elevation's own lines (docs/survey.md): where the surface seen steps back or forward by more
#: than this many cells' width between neighbouring cells (a reveal, a moulding's face, a plinth),
#: drawn this thick, so that a white (unchanged) area still shows where it is on the building.
EDGE_STEP_CELLS = 4.0
EDGE_MM = 0.18
PNG_DPI = 150
#: The scales a sheet steps through when the views do not fit at the one asked for.
STANDARD_SCALES = (1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000, 20000, 50000)
#: Elevations: where the viewer stands, in degrees clockwise from north. "plan" looks down.
ELEVATIONS = {"north": 0.0, "east": 90.0, "south": 180.0, "west": 270.0}
VIEWS = (*ELEVATIONS, "plan")
#: The print scale a sheet is drawn at unless the views do not fit (1:50, as condition maps are).
PRINT_SCALE = 50
HATCH_ANGLES = {"/": (45.0,), "\\": (135.0,), "-": (0.0,), "|": (90.0,), "x": (45.0, 135.0), "+": (0.0, 90.0)}
HATCH_DOTS = "."
#: Hatch codes by name, as the patterns give them: "solid" is the colour alone.
HATCH_NAMES = {
    "none": "",
    "solid": "",
    "lines": "/",
    "back lines": "\\",
    "horizontal": "-",
    "vertical": "|",
    "cross": "x",
    "grid": "+",
    "dots": ".",
}
#: Raster cells that no triangle covers; -1 is the object with no pattern.
BACKGROUND = -2
#: Candidate (triangle, cell) pairs tested at once: bounds the rasteriser's memory (~200 bytes each).
_CHUNK = 1 << 19
_PT_PER_MM = 72.0 / 25.4
#: matplotlib settings for a sheet: text kept as text in the SVG (searchable, small), and ids that
#: do not change from one run to the next.
STYLE = {"svg.fonttype": "none", "svg.hashsalt": "porous-weathering", "font.size": 8}


@dataclasses.dataclass(frozen=True)
class SheetData:
    """What one sheet draws: one object at one age (the survey fills it in)."""

    object_name: str
    environment: str
    years: float | None
    t: float
    date: str
    triangles_m: np.ndarray | None  # (n, 3, 3) world coordinates in metres (x, y, z; z up); None with a Frame
    pattern_index: np.ndarray  # (n,) int: index into patterns, -1 none
    patterns: tuple[tuple[str, tuple[float, float, float], str], ...]  # (name, sRGB colour, hatch code)
    areas_m2: tuple[float, ...]  # per pattern
    north: tuple[float, float] = (0.0, 1.0)  # unit vector in world xy pointing north
    scale: int = PRINT_SCALE  # print scale 1:scale
    views: tuple[str, ...] = tuple(ELEVATIONS)
    forecast: tuple[
        tuple[str, str, float | None, float | None], ...
    ] = ()  # (face, pattern, first-shows year, threshold year)


@dataclasses.dataclass(frozen=True)
class Frame:
    """The views of a sheet as its geometry alone, the same at every age: the scale they are drawn
    at, each view's lower-left corner on paper (mm), and each view rasterised (``ViewFrame``).
    ``count``: the triangles it was made of (a sheet's ``pattern_index`` has one per triangle);
    ``north`` and ``asked``: the north and the scale it was made for (a sheet's own)."""

    scale: int
    corners: tuple[tuple[float, float], ...]
    views: tuple["ViewFrame", ...]
    count: int
    north: tuple[float, float]
    asked: int


@dataclasses.dataclass(frozen=True)
class ViewFrame:
    """One view rasterised: ``nearest[row, column]`` the triangle seen in that cell (-1 where none
    is), row 0 at the bottom, one empty cell of margin around the object; ``steps`` as ``View``'s."""

    name: str
    nearest: np.ndarray
    steps: tuple[np.ndarray, np.ndarray]

    def labelled(self, pattern_index: np.ndarray) -> "View":
        """The view with each cell given its triangle's pattern."""
        found = self.nearest >= 0
        labels = np.full(self.nearest.shape, BACKGROUND, np.int32)
        labels[found] = np.asarray(pattern_index)[self.nearest[found]]
        return View(self.name, labels, self.steps)


@dataclasses.dataclass(frozen=True)
class View:
    """One view rasterised at the sheet's scale (``PIXEL_MM`` cells on paper, one empty cell of
    margin around the object): ``labels[row, column]`` is the pattern index seen in that cell,
    ``BACKGROUND`` where no triangle is; row 0 at the bottom. ``steps``: the cell boundaries where
    the surface seen steps back or forward (``EDGE_STEP_CELLS``), as (vertical, horizontal) masks."""

    name: str
    labels: np.ndarray
    steps: tuple[np.ndarray, np.ndarray] = (np.zeros((0, 0), bool), np.zeros((0, 0), bool))


def write_sheets(
    data: SheetData, svg_path: str | os.PathLike, png_path: str | os.PathLike, frame: Frame | None = None
) -> None:
    """Draw the condition map of ``data`` on an A3 sheet and write it as ``svg_path`` and
    ``png_path``, both whole or neither. ``frame``: the views' geometry made once for several
    sheets of the same triangles (``make_frame`` of ``data``'s triangles, north, views and scale),
    else made here. Bad input raises ValueError (FileNotFoundError for a missing folder,
    ImportError without matplotlib) in one line, before any work."""
    svg_path, png_path = os.fspath(svg_path), os.fspath(png_path)
    check(data, svg_path, png_path, frame)
    if frame is None:
        frame = make_frame(data.triangles_m, data.north, data.views, data.scale)
    views = [view.labelled(data.pattern_index) for view in frame.views]
    import matplotlib

    with (
        matplotlib.rc_context(STYLE),  # read when saving too (the SVG's text as text)
        temporary_file(os.path.dirname(os.path.abspath(svg_path)), ".svg") as svg_temporary,
        temporary_file(os.path.dirname(os.path.abspath(png_path)), ".png") as png_temporary,
    ):
        figure = draw(data, views, frame.scale, frame.corners)
        figure.savefig(svg_temporary, format="svg", metadata={"Date": None})
        figure.savefig(png_temporary, format="png", dpi=PNG_DPI)
        move_into_place_together([(svg_temporary, svg_path), (png_temporary, png_path)])


def cannot_draw() -> str | None:
    """Why sheets cannot be drawn in this Python (the line to show), or None when they can: a
    survey asks before any work, to skip the drawings or refuse."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return "the condition-map drawings need matplotlib, which this Python lacks (docs/survey.md, 'The drawings')"
    return None


def make_frame(triangles_m: np.ndarray, north: tuple[float, float], views: tuple[str, ...], scale: int) -> Frame:
    """The ``Frame`` of the triangles (n, 3, 3), world metres, z up, seen in ``views`` at 1:``scale``
    or the next standard scale at which they fit the sheet."""
    check_triangles(triangles_m)
    projections = [project(triangles_m, north, name) for name in views]
    fitted, corners = fit_scale([hi - lo for *_, lo, hi in projections], scale)
    cell_m = PIXEL_MM * fitted / 1000.0
    rasters = tuple(rasterise(name, uv, depth, index, lo, hi, cell_m) for name, uv, depth, index, lo, hi in projections)
    return Frame(fitted, tuple(corners), rasters, len(triangles_m), tuple(map(float, north)), scale)


def check_triangles(triangles_m: np.ndarray) -> None:
    triangles = np.asarray(triangles_m)
    if triangles.ndim != 3 or triangles.shape[1:] != (3, 3) or len(triangles) == 0:
        raise ValueError(f"triangles_m must be (n, 3, 3) with n > 0, not {triangles.shape}")
    if not np.isfinite(triangles).all():
        raise ValueError("triangles_m holds a NaN or infinite coordinate")


def check(data: SheetData, svg_path: str, png_path: str, frame: Frame | None = None) -> None:
    """Raise on the first thing wrong with the input, in one line."""
    missing = cannot_draw()
    if missing:
        raise ImportError(missing)
    if frame is None:
        check_triangles(data.triangles_m)
        count = len(data.triangles_m)
    elif tuple(view.name for view in frame.views) != tuple(data.views):
        raise ValueError(f"the frame has the views {[view.name for view in frame.views]}, the sheet {list(data.views)}")
    elif (frame.north, frame.asked) != (tuple(map(float, data.north)), data.scale):
        raise ValueError(
            f"the frame was made for north {frame.north} at 1:{frame.asked}, the sheet asks north "
            f"{tuple(data.north)} at 1:{data.scale}"
        )
    else:
        count = frame.count
    index = np.asarray(data.pattern_index)
    if index.shape != (count,) or not np.issubdtype(index.dtype, np.integer):
        raise ValueError(f"pattern_index must be {count} integers, one per triangle, not {index.dtype} {index.shape}")
    if len(index) and (index.min() < -1 or index.max() >= len(data.patterns)):
        raise ValueError(f"pattern_index must be -1 (none) or below {len(data.patterns)} (the patterns)")
    for name, colour, hatch in data.patterns:
        if len(colour) != 3 or not all(0.0 <= channel <= 1.0 for channel in colour):
            raise ValueError(f"pattern {name!r}: its colour must be three sRGB values in 0-1, not {colour}")
        if set(hatch_letters(hatch)) - set(HATCH_ANGLES) - set(HATCH_DOTS):
            raise ValueError(
                f"pattern {name!r}: hatch code {hatch!r} is neither one of {', '.join(HATCH_NAMES)} "
                "nor letters of / \\ - | x + ."
            )
    if len(data.areas_m2) != len(data.patterns) or not all(math.isfinite(a) and a >= 0 for a in data.areas_m2):
        raise ValueError(f"areas_m2 must be {len(data.patterns)} finite areas ≥ 0, one per pattern")
    if not all(math.isfinite(c) for c in data.north) or math.hypot(*data.north) < 1e-9:
        raise ValueError(f"north must be a non-zero vector in world xy, not {data.north}")
    if not isinstance(data.scale, int) or data.scale < 1:
        raise ValueError(f"scale must be a whole number ≥ 1 (the sheet is drawn at 1:scale), not {data.scale!r}")
    if not data.views or len(set(data.views)) != len(data.views) or set(data.views) - set(VIEWS):
        raise ValueError(f"views must be some of {', '.join(VIEWS)}, each once, not {data.views}")
    if not math.isfinite(data.t) or (data.years is not None and not (math.isfinite(data.years) and data.years >= 0)):
        raise ValueError(f"the age must be a finite t and years ≥ 0 or None, not t = {data.t}, years = {data.years}")
    years = [year for row in data.forecast if len(row) == 4 for year in row[2:]]
    if any(len(row) != 4 for row in data.forecast) or not all(y is None or math.isfinite(y) for y in years):
        raise ValueError(
            "forecast rows must be (face, pattern, first-shows year, threshold year), a year finite or None"
        )
    for path in (svg_path, png_path):
        folder = os.path.dirname(os.path.abspath(path))
        if not os.path.isdir(folder):
            raise FileNotFoundError(f"no folder {folder} to write {os.path.basename(path)} in")


def unit(north: tuple[float, float]) -> np.ndarray:
    return np.asarray(north, float) / math.hypot(*north)


def view_axes(north: tuple[float, float], name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(toward the viewer, right, up) of a view, unit vectors in world coordinates. An elevation is
    seen from the side it names, looking horizontally at the object ("north": the side facing
    north, seen from the north); the plan is seen from above with world x to the right and y up,
    as the key plan with the north arrow is drawn."""
    if name == "plan":
        return np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])
    nx, ny = unit(north)
    angle = math.radians(ELEVATIONS[name])
    toward = math.cos(angle) * np.array([nx, ny, 0.0]) + math.sin(angle) * np.array([ny, -nx, 0.0])
    return toward, np.array([-toward[1], toward[0], 0.0]), np.array([0.0, 0.0, 1.0])


def project(
    triangles_m: np.ndarray, north: tuple[float, float], name: str
) -> tuple[str, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The triangles that face the view's viewer: (name, view coordinates (m, 3, 2) in metres,
    depth (m, 3) away from the viewer, their index among ``triangles_m`` (m,), lower and upper
    corner of the view)."""
    triangles = np.asarray(triangles_m, float)
    toward, right, up = view_axes(north, name)
    # the normal's component toward the viewer, (e1 x e2) . toward = e1 . (e2 x toward), without
    # the normals themselves (the drawings' triangles are one per sample point: millions)
    e1, e2 = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    across = np.stack(
        [
            e2[:, 1] * toward[2] - e2[:, 2] * toward[1],
            e2[:, 2] * toward[0] - e2[:, 0] * toward[2],
            e2[:, 0] * toward[1] - e2[:, 1] * toward[0],
        ],
        axis=-1,
    )
    facing = np.einsum("ij,ij->i", e1, across) > 0.0  # triangles facing away are culled
    seen = triangles[facing]
    uv = np.stack([seen @ right, seen @ up], axis=-1)
    if len(seen):
        lo, hi = uv.reshape(-1, 2).min(axis=0), uv.reshape(-1, 2).max(axis=0)
    else:
        lo = hi = np.zeros(2)
    return name, uv, -(seen @ toward), np.flatnonzero(facing), lo, hi


def fit_scale(extents_m: list[np.ndarray], asked: int) -> tuple[int, list[tuple[float, float]]]:
    """The scale the views are drawn at, the one asked for or the next standard one at which they
    fit the sheet, and the lower-left corner on paper (mm) of each view."""
    area = (SHEET_MM[0] - 2 * MARGIN_MM - PANEL_MM - GAP_MM, SHEET_MM[1] - 2 * MARGIN_MM)
    for scale in [asked, *(s for s in STANDARD_SCALES if s > asked)]:
        corners = arrange([extent * 1000.0 / scale for extent in extents_m], area)
        if corners is not None:
            return scale, corners
    raise ValueError(f"the views do not fit an A3 sheet even at 1:{STANDARD_SCALES[-1]}: is the object in metres?")


def arrange(sizes_mm: list[np.ndarray], area: tuple[float, float]) -> list[tuple[float, float]] | None:
    """Lay the views out in a grid (each with its name above it) in ``area``: of the column counts
    that fit, the one that leaves the most room. None if none fits."""
    best = None
    count = len(sizes_mm)
    cells_mm = [(max(size[0], LABEL_WIDTH_MM), size[1]) for size in sizes_mm]  # room for each view's name
    for columns in range(1, count + 1):
        rows = math.ceil(count / columns)
        cells = [divmod(index, columns) for index in range(count)]
        widths = [
            max((s[0] for s, (_, c) in zip(cells_mm, cells) if c == column), default=0.0) for column in range(columns)
        ]
        heights = [max(s[1] for s, (r, _) in zip(sizes_mm, cells) if r == row) + LABEL_MM for row in range(rows)]
        width = sum(widths) + GAP_MM * (columns - 1)
        height = sum(heights) + GAP_MM * (rows - 1)
        fill = max(width / area[0], height / area[1])
        if fill <= 1.0 and (best is None or fill < best[0]):
            left = MARGIN_MM + (area[0] - width) / 2
            top = MARGIN_MM + area[1] - (area[1] - height) / 2
            corners = []
            for size, (row, column) in zip(sizes_mm, cells):
                x = left + sum(widths[:column]) + GAP_MM * column + (widths[column] - size[0]) / 2
                y = top - sum(heights[: row + 1]) - GAP_MM * row + (heights[row] - LABEL_MM - size[1]) / 2
                corners.append((x, y))
            best = (fill, corners)
    return None if best is None else best[1]


def rasterise(
    name: str, uv: np.ndarray, depth: np.ndarray, index: np.ndarray, lo: np.ndarray, hi: np.ndarray, cell_m: float
) -> ViewFrame:
    """The triangle (its ``index``) seen in each cell of a grid of side ``cell_m`` over the view
    (one empty cell of margin around it): of the triangles covering the cell's centre, the nearest."""
    columns, rows = (np.ceil((hi - lo) / cell_m).astype(int) + 2).tolist()
    origin = lo - cell_m
    nearest = np.full(rows * columns, np.inf)
    seen = np.full(rows * columns, -1, np.int64)
    corners = (uv - origin) / cell_m  # in cells
    first = np.clip(np.ceil(corners.min(axis=1) - 0.5), 0, None).astype(np.int64)  # first cell centre inside
    last = np.minimum(np.floor(corners.max(axis=1) - 0.5), [columns - 1, rows - 1]).astype(np.int64)
    span = np.maximum(last - first + 1, 0)
    counts = span[:, 0] * span[:, 1]
    for start, stop in chunks(counts):
        count = counts[start:stop]
        triangle = np.repeat(np.arange(start, stop), count)
        offset = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        column = first[triangle, 0] + offset % span[triangle, 0]
        row = first[triangle, 1] + offset // span[triangle, 0]
        a, b, c = (corners[triangle, k] for k in range(3))
        p = np.stack([column + 0.5, row + 0.5], axis=-1)
        ab, ac, ap = b - a, c - a, p - a
        area = ab[:, 0] * ac[:, 1] - ab[:, 1] * ac[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):  # edge-on triangles cover no cell
            s = (ap[:, 0] * ac[:, 1] - ap[:, 1] * ac[:, 0]) / area
            t = (ab[:, 0] * ap[:, 1] - ab[:, 1] * ap[:, 0]) / area
            tolerance = 1e-9
            inside = (s >= -tolerance) & (t >= -tolerance) & (s + t <= 1 + tolerance) & (np.abs(area) > 1e-12)
        d, s, t = depth[triangle[inside]], s[inside], t[inside]  # edge-on triangles' s and t are not numbers
        z = d[:, 0] + s * (d[:, 1] - d[:, 0]) + t * (d[:, 2] - d[:, 0])
        cell = (row * columns + column)[inside]
        if not len(cell):
            continue
        order = np.lexsort((z, cell))
        cell, z, triangle = cell[order], z[order], triangle[inside][order]
        nearest_here = np.r_[True, cell[1:] != cell[:-1]]
        cell, z, triangle = cell[nearest_here], z[nearest_here], triangle[nearest_here]
        nearer = z < nearest[cell]
        nearest[cell[nearer]] = z[nearer]
        seen[cell[nearer]] = index[triangle[nearer]]
    return ViewFrame(name, seen.reshape(rows, columns), steps(nearest.reshape(rows, columns), EDGE_STEP_CELLS * cell_m))


def steps(depth: np.ndarray, least: float) -> tuple[np.ndarray, np.ndarray]:
    """(between columns (rows, columns - 1), between rows (rows - 1, columns)): where the depth
    seen changes by more than ``least`` from one cell to the next, both cells on the object (the
    object's own outline is drawn apart)."""
    with np.errstate(invalid="ignore"):  # inf - inf off the object
        across = np.abs(np.diff(depth, axis=1)) > least
        up = np.abs(np.diff(depth, axis=0)) > least
    on = np.isfinite(depth)
    return across & on[:, 1:] & on[:, :-1], up & on[1:] & on[:-1]


def step_lines(view: View, x0: float, y0: float, cell_mm: float) -> np.ndarray:
    """The segments (k, 2, 2) in paper mm along ``view.steps``, each straight run as one."""
    segments = []
    for mask, vertical in ((view.steps[0], True), (view.steps[1], False)):
        runs = mask.T if vertical else mask  # along the run's direction: its last axis
        padded = np.pad(runs, ((0, 0), (1, 1)))
        line, start = np.nonzero(padded[:, 1:] & ~padded[:, :-1])
        _, stop = np.nonzero(~padded[:, 1:] & padded[:, :-1])
        at = line + 1.0  # the boundary after the line's cell (the cells' row or column)
        ends = np.stack([start, stop], axis=-1).astype(float)
        if vertical:
            xy = np.stack([np.stack([at, at], -1), ends], axis=-1)
        else:
            xy = np.stack([ends, np.stack([at, at], -1)], axis=-1)
        segments.append(xy * cell_mm + (x0, y0))
    return np.concatenate(segments) if segments else np.zeros((0, 2, 2))


def generalise(labels: np.ndarray, patterns: int) -> np.ndarray:
    """``labels`` with each square of ``MAPPING_CELLS`` cells of the object given the pattern (or
    none, -1) most of its covered cells have: what is smaller than the mapping unit cannot be drawn
    at the scale, and noise at the raster's resolution would fill the SVG with tiny outlines."""
    rows, columns = labels.shape
    size = MAPPING_CELLS
    padded = np.full((-(-rows // size) * size, -(-columns // size) * size), BACKGROUND, labels.dtype)
    padded[:rows, :columns] = labels
    blocks = padded.reshape(padded.shape[0] // size, size, padded.shape[1] // size, size)
    counts = np.stack([(blocks == value).sum(axis=(1, 3)) for value in range(-1, patterns)])
    most = (np.argmax(counts, axis=0) - 1).astype(labels.dtype)
    spread = np.repeat(np.repeat(most, size, axis=0), size, axis=1)[:rows, :columns]
    return np.where(close(labels != BACKGROUND, size // 2), spread, BACKGROUND)


def close(mask: np.ndarray, steps: int) -> np.ndarray:
    """``mask`` closed by a square of 2 ``steps`` + 1 cells: pinholes (triangles culled as facing
    away, gaps between them) filled, straight edges and corners kept."""
    grown = mask
    for _ in range(steps):
        grown = neighbourhood(grown, np.logical_or)
    for _ in range(steps):
        grown = neighbourhood(grown, np.logical_and)
    return grown | mask


def neighbourhood(mask: np.ndarray, combine) -> np.ndarray:
    """``combine`` over each cell's 3 × 3 neighbourhood (cells outside the grid are outside the mask)."""
    padded = np.pad(mask, 1)
    out = mask.copy()
    for dy in range(3):
        for dx in range(3):
            out = combine(out, padded[dy : dy + mask.shape[0], dx : dx + mask.shape[1]])
    return out


def chunks(counts: np.ndarray) -> Iterator[tuple[int, int]]:
    """(start, stop) runs of triangles with at most ``_CHUNK`` candidate cells (at least one triangle)."""
    ends = np.cumsum(counts)
    start = 0
    while start < len(counts):
        done = ends[start] - counts[start]
        stop = max(int(np.searchsorted(ends, done + _CHUNK, side="right")), start + 1)
        yield start, stop
        start = stop


def trace(inside: np.ndarray, x0: float, y0: float, cell_mm: float):
    """The outline of the cells where ``inside`` holds, as a matplotlib Path in paper mm (cell
    (0, 0)'s lower-left corner at x0, y0), holes included."""
    import contourpy
    from matplotlib.path import Path

    rows, columns = inside.shape
    x = x0 + (np.arange(columns) + 0.5) * cell_mm
    y = y0 + (np.arange(rows) + 0.5) * cell_mm
    generator = contourpy.contour_generator(x, y, inside.astype(np.float64), fill_type="OuterCode")
    points, codes = generator.filled(0.5, 1.5)
    if not points:
        return None
    points, codes = np.concatenate(points), np.concatenate(codes)
    # The cells' outlines run along rows and columns: of a straight run only its ends are kept
    before, after = points[1:-1] - points[:-2], points[2:] - points[1:-1]
    straight = np.abs(before[:, 0] * after[:, 1] - before[:, 1] * after[:, 0]) < 1e-9 * cell_mm**2
    inner = (codes[1:-1] == Path.LINETO) & (codes[2:] != Path.MOVETO)
    keep = np.r_[True, ~(straight & inner), True]
    return Path(points[keep], codes[keep])


def hatch_letters(code: str) -> str:
    """A hatch code as matplotlib's letters."""
    return HATCH_NAMES.get(code, code)


def hatch_lines(code: str, box: tuple[float, float, float, float]) -> np.ndarray:
    """The segments (k, 2, 2) in paper mm of ``code``'s line families over ``box`` (x0, y0, x1,
    y1). Lines sit at whole multiples of their spacing from the sheet's corner, so a pattern's
    hatch runs on from one view to the next and into its legend swatch."""
    corners = np.array([[box[0], box[1]], [box[2], box[1]], [box[0], box[3]], [box[2], box[3]]])
    code, segments = hatch_letters(code), []
    for letter, angles in HATCH_ANGLES.items():
        spacing = HATCH_SPACING_MM / code.count(letter) if letter in code else None
        for angle in angles if spacing else ():
            along = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle))])
            across = np.array([-along[1], along[0]])
            offsets = corners @ across
            ends = corners @ along
            for k in range(math.ceil(offsets.min() / spacing), math.floor(offsets.max() / spacing) + 1):
                base = k * spacing * across
                segments.append([base + ends.min() * along, base + ends.max() * along])
    return np.array(segments).reshape(-1, 2, 2)


def hatch_dots(code: str, box: tuple[float, float, float, float]) -> np.ndarray:
    """The dots (k, 2) in paper mm of ``code`` over ``box``: a staggered grid at the hatch spacing."""
    count = sum(hatch_letters(code).count(letter) for letter in HATCH_DOTS)
    if not count:
        return np.zeros((0, 2))
    spacing = HATCH_SPACING_MM / count
    rows = np.arange(math.floor(box[1] / spacing), math.ceil(box[3] / spacing) + 1)
    columns = np.arange(math.floor(box[0] / spacing), math.ceil(box[2] / spacing) + 1)
    x, y = np.meshgrid(columns * spacing, rows * spacing)
    x = x + (rows[:, None] % 2) * spacing / 2
    return np.stack([x.ravel(), y.ravel()], axis=-1)


def draw(data: SheetData, views: list[View], scale: int, corners: list[tuple[float, float]]):
    """The sheet as a matplotlib Figure whose data coordinates are paper millimetres (drawn in
    ``STYLE``). The parts a
    reader (or a test) looks up carry ids in the SVG: ``region-<view>-<pattern>``,
    ``hatch-<view>-<pattern>``, ``outline-<view>``, ``edges-<view>``, ``legend-name-<pattern>``,
    ``legend-area-<pattern>``, ``north-arrow``, ``scale-bar``."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    figure = Figure(figsize=(SHEET_MM[0] / 25.4, SHEET_MM[1] / 25.4))
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_xlim(0.0, SHEET_MM[0])
    axes.set_ylim(0.0, SHEET_MM[1])
    axes.set_axis_off()
    frame = Rectangle((5.0, 5.0), SHEET_MM[0] - 10, SHEET_MM[1] - 10, fill=False, lw=0.5 * _PT_PER_MM)
    axes.add_patch(frame)
    drawn = set()
    for view, corner in zip(views, corners):
        drawn |= draw_view(axes, data, view, corner)
    panel = SHEET_MM[0] - MARGIN_MM - PANEL_MM
    below = draw_legend(axes, data, drawn, panel, SHEET_MM[1] - MARGIN_MM)
    draw_forecast(axes, data.forecast, panel, below - 6.0, 98.0)
    draw_north_arrow(axes, data.north, (panel + 14.0, 74.0))
    draw_scale_bar(axes, scale, (panel + 34.0, 70.0))
    draw_title_block(axes, data, scale, panel)
    return figure


def draw_view(axes, data: SheetData, view: View, corner: tuple[float, float]) -> set[int]:
    """Draw one view with its lower-left corner at ``corner`` (paper mm); the patterns drawn."""
    from matplotlib.collections import LineCollection
    from matplotlib.patches import PathPatch

    x0, y0 = corner[0] - PIXEL_MM, corner[1] - PIXEL_MM  # the margin cell
    rows, columns = view.labels.shape
    top = y0 + rows * PIXEL_MM
    title = "Plan" if view.name == "plan" else f"{view.name.capitalize()} elevation"
    axes.text(x0 + columns * PIXEL_MM / 2, top + 1.5, title, ha="center", va="bottom", fontsize=9, weight="bold")
    drawn = set()
    labels = generalise(view.labels, len(data.patterns))
    for index in np.unique(labels[labels >= 0]).tolist():
        path = trace(labels == index, x0, y0, PIXEL_MM)
        if path is None:
            continue
        name, colour, code = data.patterns[index]
        region = PathPatch(path, facecolor=colour, edgecolor="none", gid=f"region-{view.name}-{index}")
        axes.add_artist(region)
        draw_hatch(axes, code, colour, path.get_extents().extents, region, f"hatch-{view.name}-{index}")
        drawn.add(index)
    edges = step_lines(view, x0, y0, PIXEL_MM)
    if len(edges):
        axes.add_collection(
            LineCollection(edges, colors="black", linewidths=EDGE_MM * _PT_PER_MM, gid=f"edges-{view.name}")
        )
    outline = trace(labels != BACKGROUND, x0, y0, PIXEL_MM)
    if outline is not None:
        axes.add_artist(PathPatch(outline, fill=False, lw=OUTLINE_MM * _PT_PER_MM, gid=f"outline-{view.name}"))
    else:
        axes.text(x0, y0, "(nothing faces this way)", fontsize=7, style="italic")
    return drawn


def draw_hatch(axes, code: str, colour, box, clip, gid: str) -> None:
    """The hatch of ``code`` over ``box``, clipped to the patch ``clip``, in a darker shade of the
    pattern's colour (a lighter one on a dark colour, so that it shows on a black-and-white copy)."""
    from matplotlib.collections import LineCollection

    dark = 0.2126 * colour[0] + 0.7152 * colour[1] + 0.0722 * colour[2] < 0.3
    ink = tuple(channel + 0.45 * (1.0 - channel) if dark else 0.45 * channel for channel in colour)
    segments = hatch_lines(code, box)
    if len(segments):
        lines = LineCollection(segments, colors=[ink], linewidths=HATCH_LINE_MM * _PT_PER_MM, gid=gid)
        axes.add_collection(lines)
        lines.set_clip_path(clip)
    dots = hatch_dots(code, box)
    if len(dots):
        markers = axes.scatter(
            dots[:, 0], dots[:, 1], s=(0.4 * _PT_PER_MM) ** 2, c=[ink], marker="o", lw=0, gid=f"{gid}-dots"
        )
        markers.set_clip_path(clip)


def draw_legend(axes, data: SheetData, drawn: set[int], x: float, top: float) -> float:
    """The legend: a swatch, the glossary's name and the area of each pattern drawn, in the
    patterns' order, and a line for the patterns with an area that no view shows. Returns the y
    of its bottom."""
    from matplotlib.patches import Rectangle

    axes.text(x, top, "Legend", fontsize=10, weight="bold", va="top")
    y = top - 8.0
    for index in sorted(drawn):
        name, colour, code = data.patterns[index]
        swatch = Rectangle((x, y - 5.0), 14.0, 6.0, facecolor=colour, edgecolor="black", lw=0.2 * _PT_PER_MM)
        axes.add_patch(swatch)
        draw_hatch(axes, code, colour, (x, y - 5.0, x + 14.0, y + 1.0), swatch, f"legend-hatch-{index}")
        axes.text(x + 17.0, y - 2.0, name, va="center", fontsize=9, gid=f"legend-name-{index}")
        area = format_area(data.areas_m2[index])
        axes.text(x + PANEL_MM, y - 2.0, area, va="center", ha="right", fontsize=9, gid=f"legend-area-{index}")
        y -= 8.0
    unseen = [i for i, area in enumerate(data.areas_m2) if area > 0 and i not in drawn]
    if unseen:
        names = ", ".join(f"{data.patterns[i][0]} ({format_area(data.areas_m2[i])})" for i in unseen)
        axes.text(x, y, f"Not seen in these views: {names}", fontsize=7, va="top", wrap=True, gid="legend-unseen")
        y -= 8.0
    axes.text(
        x,
        y,
        f"Areas: true surface areas on the whole object. Hatch lines {HATCH_SPACING_MM:g} mm apart on paper.",
        fontsize=6.5,
        va="top",
        style="italic",
    )
    return y - 4.0


def format_area(area_m2: float) -> str:
    """An area in m² to the digits a survey reads: three significant ones, none below 0.001 m²."""
    if area_m2 >= 100:
        return f"{area_m2:,.0f} m²"
    if area_m2 >= 0.01:
        return f"{area_m2:.3g} m²"
    return f"{area_m2:.3f} m²"


def format_year(year: float | None) -> str:
    """A forecast year to a tenth; "—" for none within the forecast."""
    return "—" if year is None else f"{round(year, 1):g}"


def draw_forecast(axes, forecast, x: float, top: float, bottom: float) -> None:
    """The forecast table (face, pattern, year it first shows, year it crosses the cleaning
    threshold), as many rows as fit between ``top`` and ``bottom``."""
    if not forecast:
        return
    axes.text(x, top, "Forecast (years)", fontsize=10, weight="bold", va="top")
    columns = (x, x + 28.0, x + 85.0, x + PANEL_MM)
    aligns = ("left", "left", "right", "right")
    y = top - 7.0
    for text, column, align in zip(("face", "pattern", "first shows", "cleaning threshold"), columns, aligns):
        axes.text(column, y, text, fontsize=7, weight="bold", ha=align, va="top")
    rows = int((y - 4.0 - bottom) // 4.0)
    shown = forecast if len(forecast) <= rows else forecast[: rows - 1]
    for face, pattern, shows, cleaning in shown:
        y -= 4.0
        for text, column, align in zip((face, pattern, format_year(shows), format_year(cleaning)), columns, aligns):
            axes.text(column, y, text, fontsize=7, ha=align, va="top")
    if len(shown) < len(forecast):
        axes.text(x, y - 4.0, f"… {len(forecast) - len(shown)} more rows in the survey's tables", fontsize=7, va="top")
    axes.text(
        x,
        y - (8.0 if len(shown) < len(forecast) else 4.0),
        "—: not within the forecast",
        fontsize=6.5,
        style="italic",
        va="top",
    )


def draw_north_arrow(axes, north: tuple[float, float], centre: tuple[float, float]) -> None:
    """A north arrow in plan (world x to the right, y up), pointing along ``north``."""
    from matplotlib.patches import Circle, Polygon

    direction = unit(north)
    across = np.array([-direction[1], direction[0]])
    c = np.asarray(centre)
    radius = 11.0
    axes.add_patch(Circle(centre, radius, fill=False, lw=0.25 * _PT_PER_MM))
    tip, tail = c + radius * direction, c - radius * direction
    axes.plot(*np.stack([tail, tip]).T, color="black", lw=0.35 * _PT_PER_MM, gid="north-arrow")
    axes.add_patch(
        Polygon([tip, tip - 5 * direction + 2.2 * across, tip - 5 * direction - 2.2 * across], color="black")
    )
    label = c + (radius + 3.5) * direction
    axes.text(*label, "N", ha="center", va="center", fontsize=10, weight="bold")


def scale_bar_length(scale: int, longest_mm: float = 75.0) -> float:
    """The longest of 1, 2, 5 × 10^k metres that is at most ``longest_mm`` on paper."""
    best = None
    for power in range(-3, 6):
        for lead in (1, 2, 5):
            metres = lead * 10.0**power
            if metres * 1000.0 / scale <= longest_mm:
                best = metres
    return best


def draw_scale_bar(axes, scale: int, corner: tuple[float, float]) -> None:
    """A scale bar in metres: alternate black and white parts, the length at its end."""
    from matplotlib.patches import Rectangle

    metres = scale_bar_length(scale)
    parts = 4 if f"{metres:e}".startswith("2") else 5
    length_mm = metres * 1000.0 / scale
    x, y = corner
    for part in range(parts):
        axes.add_patch(
            Rectangle(
                (x + part * length_mm / parts, y),
                length_mm / parts,
                2.0,
                facecolor="black" if part % 2 == 0 else "white",
                edgecolor="black",
                lw=0.2 * _PT_PER_MM,
                gid="scale-bar" if part == 0 else None,
            )
        )
    axes.text(x, y + 3.0, "0", ha="center", fontsize=7)
    axes.text(x + length_mm, y + 3.0, f"{metres:g} m", ha="center", fontsize=7, gid="scale-bar-length")
    axes.text(x, y - 4.0, f"Scale 1:{scale} on A3", fontsize=8, va="top")


def draw_title_block(axes, data: SheetData, scale: int, x: float) -> None:
    """Object, site environment, age (years and t), date and scale, in a box at the bottom right."""
    from matplotlib.patches import Rectangle

    bottom, height = MARGIN_MM, 50.0
    axes.add_patch(Rectangle((x, bottom), PANEL_MM, height, fill=False, lw=0.35 * _PT_PER_MM))
    age = f"t = {data.t:.3g}" if data.years is None else f"{data.years:g} years (t = {data.t:.3g})"
    stepped = "" if scale == data.scale else f" (the views do not fit A3 at 1:{data.scale})"
    rows = [
        ("Condition map", data.object_name),
        ("Environment", data.environment),
        ("Age", age),
        ("Date", data.date),
        ("Scale", f"1:{scale} on A3{stepped}"),
    ]
    y = bottom + height - 4.0
    axes.text(x + 3.0, y, rows[0][1], fontsize=12, weight="bold", va="top", gid="title-object")
    axes.text(x + PANEL_MM - 3.0, y, rows[0][0], fontsize=8, ha="right", va="top", style="italic")
    for label, value in rows[1:]:
        y -= 8.0
        axes.text(x + 3.0, y - 2.0, label, fontsize=7, va="top", color="0.35")
        axes.text(x + 28.0, y - 2.0, value, fontsize=8.5, va="top", gid=f"title-{label.lower()}")
    axes.text(
        x + 3.0,
        bottom + 2.0,
        "Patterns named after the ICOMOS-ISCS glossary (docs/survey.md)",
        fontsize=6.5,
        style="italic",
    )
