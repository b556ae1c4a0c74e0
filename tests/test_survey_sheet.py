"""The condition-map drawings (docs/survey.md, "The drawings"): the SVG parses and its legend lists
exactly the patterns drawn, with their areas; the views are drawn at the print scale, each face in
the view that faces it (colours read back from the PNG), nearer surfaces over farther ones; the
hatch lines lie 2 mm apart on paper at 1:50; the north arrow follows north; a scan-sized mesh
gives an SVG of bounded size; bad input fails in one line and leaves no file."""

import dataclasses
import os
import re
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from porous_weathering.survey import sheet

SVG = "{http://www.w3.org/2000/svg}"
PATTERNS = (
    ("black crust", (0.15, 0.15, 0.15), "cross"),
    ("soiling", (0.70, 0.58, 0.40), "-"),
    ("efflorescence", (0.95, 0.95, 0.95), "dots"),
    ("moist area", (0.30, 0.45, 0.85), "vertical"),
    ("algae", (0.30, 0.62, 0.25), "lines"),
    ("lichen", (0.85, 0.75, 0.15), "\\\\"),
)  # hatch codes by name and in letters
#: The faces of a box as quads of its corners (corner i at x = i >> 2, y = (i >> 1) & 1, z = i & 1),
#: counter-clockwise seen from outside.
QUADS = {
    "west": (0, 1, 3, 2),
    "east": (4, 6, 7, 5),
    "south": (0, 4, 5, 1),
    "north": (2, 3, 7, 6),
    "bottom": (0, 2, 6, 4),
    "top": (1, 5, 7, 3),
}


def box(size, offset=(0.0, 0.0, 0.0), faces=QUADS):
    """Triangles (2 per face) of an axis-aligned box, and the face each belongs to."""
    corners = np.array([[(i >> 2) & 1, (i >> 1) & 1, i & 1] for i in range(8)], float) * size + offset
    triangles, names = [], []
    for name in faces:
        a, b, c, d = QUADS[name]
        triangles += [corners[[a, b, c]], corners[[a, c, d]]]
        names += [name, name]
    return np.array(triangles), names


def split_north_face(triangles, names):
    """The box with its north face (y = max) cut at mid-width into a west and an east half."""
    keep = [i for i, name in enumerate(names) if name != "north"]
    (x0, y, z0), (x1, _, z1) = triangles[names.index("north")].min(axis=0), triangles[names.index("north")].max(axis=0)
    halves, half_names = [], []
    for name, (left, right) in (("north-west", (x0, (x0 + x1) / 2)), ("north-east", ((x0 + x1) / 2, x1))):
        a, b, c, d = [left, y, z0], [left, y, z1], [right, y, z1], [right, y, z0]  # faces +y
        halves += [[a, b, c], [a, c, d]]
        half_names += [name, name]
    return np.concatenate([triangles[keep], np.array(halves)]), [names[i] for i in keep] + half_names


def data_for(triangles, names, pattern_of, **changes):
    index = np.array([pattern_of.get(name, -1) for name in names])
    areas = tuple(
        float(sum(0.5 * np.linalg.norm(np.cross(t[1] - t[0], t[2] - t[0])) for t, i in zip(triangles, index) if i == k))
        for k in range(len(PATTERNS))
    )
    fields = dict(
        object_name="Test box",
        environment="urban",
        years=25.0,
        t=0.42,
        date="2026-12-03",
        triangles_m=triangles,
        pattern_index=index,
        patterns=PATTERNS,
        areas_m2=areas,
    )
    return sheet.SheetData(**(fields | changes))


def write(tmp_path, data, name="sheet"):
    svg, png = tmp_path / f"{name}.svg", tmp_path / f"{name}.png"
    sheet.write_sheets(data, svg, png)
    return ET.parse(svg).getroot(), svg, png


def groups(root, prefix):
    """{id: element} of the SVG's groups whose id starts with ``prefix``."""
    return {g.get("id"): g for g in root.iter(f"{SVG}g") if g.get("id", "").startswith(prefix)}


def text_of(group):
    return "".join(group.itertext()).strip()


def mm_per_unit(root):
    return sheet.SHEET_MM[0] / float(root.get("viewBox").split()[2])


def path_points(element):
    """The vertices of every path under ``element``, (k, 2) in SVG units (y down), by path."""
    paths = []
    for path in element.iter(f"{SVG}path"):
        numbers = [float(n) for n in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", path.get("d"))]
        paths.append(np.array(numbers).reshape(-1, 2))
    return paths


def extent_mm(root, group_id):
    """(x0, y0, x1, y1) in paper mm (y down) of the paths of a group."""
    points = np.concatenate(path_points(groups(root, group_id)[group_id])) * mm_per_unit(root)
    return (*points.min(axis=0), *points.max(axis=0))


def colour_at(png, root, x_mm, y_mm):
    """The median colour of a 7 × 7 pixel window of the PNG at a point given in paper mm (y down)."""
    import matplotlib.image

    image = matplotlib.image.imread(png)[..., :3]
    column = int(round(x_mm / sheet.SHEET_MM[0] * image.shape[1]))
    row = int(round(y_mm / sheet.SHEET_MM[1] * image.shape[0]))
    return np.median(image[row - 3 : row + 4, column - 3 : column + 4].reshape(-1, 3), axis=0)


@pytest.fixture(scope="module")
def box_sheet(tmp_path_factory):
    """A 4 × 3 × 2.5 m box: black crust on the north face's west half, algae on its east half,
    soiling east, efflorescence south, nothing west, moist area on top (seen in no elevation),
    lichen nowhere (area 0)."""
    triangles, names = split_north_face(*box((4.0, 3.0, 2.5)))
    pattern_of = {"north-west": 0, "north-east": 4, "east": 1, "south": 2, "top": 3}
    forecast = (("north", "algae", 3.0, 12.5), ("south", "soiling", 8.0, None))
    data = data_for(triangles, names, pattern_of, forecast=forecast)
    root, svg, png = write(tmp_path_factory.mktemp("box"), data)
    return data, root, svg, png


def test_the_svg_parses_and_its_legend_lists_exactly_the_patterns_drawn(box_sheet):
    data, root, _, _ = box_sheet
    drawn = {int(name.rsplit("-", 1)[1]) for name in groups(root, "region-")}
    assert drawn == {0, 1, 2, 4}  # not moist area (top only), not lichen (none)
    names = {int(i.rsplit("-", 1)[1]): text_of(g) for i, g in groups(root, "legend-name-").items()}
    assert names == {k: PATTERNS[k][0] for k in drawn}
    areas = {int(i.rsplit("-", 1)[1]): text_of(g) for i, g in groups(root, "legend-area-").items()}
    assert set(areas) == drawn
    for k, text in areas.items():
        value = float(text.removesuffix(" m²").replace(",", ""))
        assert value == pytest.approx(data.areas_m2[k], rel=5e-3), (PATTERNS[k][0], text)
    # 5 m² (north halves), 7.5 m² (east), 10 m² (south): independent of the code's sums
    assert [areas[k] for k in (0, 4, 1, 2)] == ["5 m²", "5 m²", "7.5 m²", "10 m²"]
    assert text_of(groups(root, "legend-unseen")["legend-unseen"]) == "Not seen in these views: moist area (12 m²)"


def test_the_title_block_and_the_forecast_say_what_was_asked(box_sheet):
    _, root, _, _ = box_sheet
    title = {i: text_of(g) for i, g in groups(root, "title-").items()}
    assert title == {
        "title-object": "Test box",
        "title-environment": "urban",
        "title-age": "25 years (t = 0.42)",
        "title-date": "2026-12-03",
        "title-scale": "1:50 on A3",
    }
    texts = [text_of(t) for t in root.iter(f"{SVG}text")]
    for row in (["north", "algae", "3", "12.5"], ["south", "soiling", "8", "—"]):
        start = texts.index(row[0])
        assert texts[start : start + 4] == row


def test_the_views_are_drawn_at_the_print_scale(box_sheet):
    _, root, _, _ = box_sheet
    for view, (width_m, height_m) in {
        "north": (4.0, 2.5),
        "east": (3.0, 2.5),
        "south": (4.0, 2.5),
        "west": (3.0, 2.5),
    }.items():
        x0, y0, x1, y1 = extent_mm(root, f"outline-{view}")
        assert (x1 - x0, y1 - y0) == pytest.approx((width_m * 1000 / 50, height_m * 1000 / 50), abs=0.3)


def test_each_face_is_drawn_in_the_view_that_faces_it(box_sheet):
    _, root, _, png = box_sheet
    expected = {"east": PATTERNS[1][1], "south": PATTERNS[2][1], "west": (1.0, 1.0, 1.0)}
    for view, colour in expected.items():
        x0, y0, x1, y1 = extent_mm(root, f"outline-{view}")
        centre = colour_at(png, root, (x0 + x1) / 2, (y0 + y1) / 2)
        assert centre == pytest.approx(colour, abs=0.02), view
    # Seen from the north (looking south), west is on the right: black crust right, algae left
    x0, y0, x1, y1 = extent_mm(root, "outline-north")
    assert colour_at(png, root, x0 + (x1 - x0) / 4, (y0 + y1) / 2) == pytest.approx(PATTERNS[4][1], abs=0.02)
    assert colour_at(png, root, x1 - (x1 - x0) / 4, (y0 + y1) / 2) == pytest.approx(PATTERNS[0][1], abs=0.02)


def test_north_names_the_views(tmp_path):
    """With north along world +x, the "north" view shows the face whose normal is +x."""
    triangles, names = box((4.0, 3.0, 2.5))
    data = data_for(triangles, names, {"east": 1, "west": 2}, north=(1.0, 0.0), views=("north", "south"))
    root, _, png = write(tmp_path, data)
    for view, pattern in (("north", 1), ("south", 2)):
        x0, y0, x1, y1 = extent_mm(root, f"outline-{view}")
        assert x1 - x0 == pytest.approx(3000 / 50, abs=0.3)  # the 3 m side
        assert colour_at(png, root, (x0 + x1) / 2, (y0 + y1) / 2) == pytest.approx(PATTERNS[pattern][1], abs=0.02)


@pytest.mark.parametrize("chunk", [sheet._CHUNK, 1000], ids=["one batch", "batches of 1000 cells"])
def test_nearer_surfaces_are_drawn_over_farther_ones(tmp_path, monkeypatch, chunk):
    """A small slab in front of the north face of a big one: from the north its colour shows at the
    centre and the big one's around it, whatever the order of the triangles, in one batch of
    candidate cells or several."""
    monkeypatch.setattr(sheet, "_CHUNK", chunk)
    big, big_names = box((4.0, 1.0, 4.0))
    small, small_names = box((1.0, 1.0, 1.0), offset=(1.5, 2.0, 1.5))
    triangles = np.concatenate([small, big])  # the nearer first, then again last
    names = [f"small {n}" for n in small_names] + [f"big {n}" for n in big_names]
    for order in (slice(None), slice(None, None, -1)):
        data = data_for(triangles[order], names[order], {"small north": 1, "big north": 4}, views=("north",))
        root, _, png = write(tmp_path, data)
        x0, y0, x1, y1 = extent_mm(root, "outline-north")
        # the small one's pattern comes first: the big one's region, drawn after it, has a hole there
        assert colour_at(png, root, (x0 + x1) / 2, (y0 + y1) / 2) == pytest.approx(PATTERNS[1][1], abs=0.02)
        assert colour_at(png, root, x0 + 5, y0 + 5) == pytest.approx(PATTERNS[4][1], abs=0.02)


def test_the_views_draw_where_the_surface_steps_forward_and_a_flat_face_gets_no_line(tmp_path, box_sheet):
    """A 1 m cube standing 1 m proud of a slab's north face: the north view draws the square where
    the surface steps forward, 20 mm a side at 1:50, about its centre; the box's flat faces none."""
    big, big_names = box((4.0, 1.0, 4.0))
    small, small_names = box((1.0, 1.0, 1.0), offset=(1.5, 2.0, 1.5))
    data = data_for(np.concatenate([big, small]), big_names + small_names, {}, views=("north",))
    root, _, _ = write(tmp_path, data)
    x0, y0, x1, y1 = extent_mm(root, "edges-north")
    assert (x1 - x0, y1 - y0) == pytest.approx((20.0, 20.0), abs=0.3)
    ox0, oy0, ox1, oy1 = extent_mm(root, "outline-north")
    assert ((x0 + x1) / 2, (y0 + y1) / 2) == pytest.approx(((ox0 + ox1) / 2, (oy0 + oy1) / 2), abs=0.3)
    assert groups(box_sheet[1], "edges-") == {}


def test_hatch_lines_are_2_mm_apart_on_paper_at_1_to_50(box_sheet):
    _, root, _, _ = box_sheet
    hatches = groups(root, "hatch-")
    assert "hatch-south-2" not in hatches and "hatch-south-2-dots" in hatches  # efflorescence: dots only
    for group_id, families in (("hatch-east-1", 1), ("hatch-north-4", 1), ("hatch-north-0", 2)):
        offsets = {}  # direction: distances of the lines from the origin, across them
        for start, end in path_points(hatches[group_id]):
            direction = (end - start) / np.linalg.norm(end - start)
            direction *= np.sign(direction[0] or direction[1])
            offsets.setdefault(tuple(np.round(direction, 3)), []).append(
                direction[0] * start[1] - direction[1] * start[0]
            )
        assert len(offsets) == families, group_id
        for family in offsets.values():
            gaps_mm = np.diff(np.sort(family)) * mm_per_unit(root)
            assert len(gaps_mm) > 10
            assert gaps_mm == pytest.approx(2.0, abs=1e-3)
    box = (0.0, 0.0, 20.0, 20.0)
    for name, letters in (("lines", "/"), ("cross", "x"), ("grid", "+"), ("solid", ""), ("none", "")):
        assert np.array_equal(sheet.hatch_lines(name, box), sheet.hatch_lines(letters, box)), name
    assert np.array_equal(sheet.hatch_dots("dots", box), sheet.hatch_dots(".", box)) and len(sheet.hatch_dots(".", box))
    lichen = sheet.hatch_lines("\\\\", (0.0, 0.0, 20.0, 20.0))  # a letter twice: lines twice as close
    offsets = (lichen[:, 0, 0] + lichen[:, 0, 1]) / np.sqrt(2)  # across the lines at 135°
    assert np.diff(np.sort(offsets)) == pytest.approx(1.0)


@pytest.mark.parametrize("north", [(0.0, 1.0), (1.0, 0.0), (-0.6, 0.8), (0.0, -2.0)])
def test_the_north_arrow_follows_north(tmp_path, north):
    triangles, names = box((4.0, 3.0, 2.5))
    root, _, _ = write(tmp_path, data_for(triangles, names, {"north": 0}, north=north, views=("plan",)))
    (tail, tip), *_ = path_points(groups(root, "north-arrow")["north-arrow"])
    direction = (tip - tail) * [1, -1]  # SVG's y runs down
    assert direction / np.linalg.norm(direction) == pytest.approx(np.array(north) / np.linalg.norm(north), abs=1e-4)


def test_the_scale_steps_to_the_next_standard_one_when_the_views_do_not_fit(tmp_path):
    triangles, names = box((30.0, 2.0, 6.0))  # 600 mm long at 1:50, 300 mm at 1:100
    root, _, _ = write(tmp_path, data_for(triangles, names, {"south": 1}, views=("north", "south")))
    assert text_of(groups(root, "title-scale")["title-scale"]) == "1:200 on A3 (the views do not fit A3 at 1:50)"
    x0, _, x1, _ = extent_mm(root, "outline-south")
    assert x1 - x0 == pytest.approx(30000 / 200, abs=0.3)


@pytest.mark.slow
def test_a_scan_sized_mesh_gives_a_bounded_svg(tmp_path):
    """200k triangles of a 10 × 6 m wall, each with a random pattern: noise finer than the mapping
    unit. Traced cell by cell it gave 52 MB of SVG; generalised to the mapping unit it stays under
    16 MB, which no finer mesh can exceed (the paper's cells bound it)."""
    columns, rows = 250, 200
    x, z = np.meshgrid(np.linspace(0, 10, columns + 1), np.linspace(0, 6, rows + 1), indexing="ij")
    grid = np.stack([x, np.zeros_like(x), z], axis=-1)  # faces -y: the south elevation
    a, b, c, d = grid[:-1, :-1], grid[1:, :-1], grid[1:, 1:], grid[:-1, 1:]
    triangles = np.concatenate([np.stack([a, b, c], -2), np.stack([a, c, d], -2)]).reshape(-1, 3, 3)
    assert len(triangles) == 100_000
    triangles = np.concatenate([triangles, triangles[:, ::-1] + [0, 0.5, 0]])  # the north face too
    index = np.random.default_rng(1).integers(-1, 4, len(triangles))
    data = dataclasses.replace(data_for(triangles[:1], ["south"], {}), triangles_m=triangles, pattern_index=index)
    root, svg, _ = write(tmp_path, data)
    assert {int(i.rsplit("-", 1)[1]) for i in groups(root, "region-")} == {0, 1, 2, 3}
    assert os.path.getsize(svg) < 16e6


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(pattern_index=np.full(12, 6)), "pattern_index must be -1 (none) or below 6"),
        (dict(pattern_index=np.zeros(11, int)), "pattern_index must be 12 integers"),
        (dict(areas_m2=(1.0,)), "areas_m2 must be 6 finite areas"),
        (dict(views=("north", "up")), "views must be some of north, east, south, west, plan"),
        (dict(north=(0.0, 0.0)), "north must be a non-zero vector"),
        (dict(scale=0), "scale must be a whole number ≥ 1"),
        (dict(patterns=(*PATTERNS[:5], ("lichen", (1, 1, 1), "#"))), "hatch code '#' is neither one of none, solid"),
        (dict(patterns=(*PATTERNS[:5], ("lichen", (1, 1, 1), "stripes"))), "hatch code 'stripes' is neither"),
        (dict(triangles_m=np.zeros((12, 3))), "triangles_m must be (n, 3, 3)"),
        (dict(years=float("nan")), "the age must be a finite t and years ≥ 0 or None"),
        (dict(forecast=(("north", "algae", 3.0, float("inf")),)), "forecast rows must be"),
    ],
)
def test_bad_input_fails_in_one_line_and_writes_nothing(tmp_path, change, message):
    triangles, names = box((4.0, 3.0, 2.5))
    data = dataclasses.replace(data_for(triangles, names, {"north": 0}), **change)
    with pytest.raises(ValueError, match=re.escape(message)) as raised:
        write(tmp_path, data)
    assert "\n" not in str(raised.value)
    assert os.listdir(tmp_path) == []


def test_a_sheet_replaces_the_files_whole_and_leaves_no_temporary_file(tmp_path):
    (tmp_path / "sheet.svg").write_text("old")
    triangles, names = box((4.0, 3.0, 2.5))
    write(tmp_path, data_for(triangles, names, {"north": 0}, views=("north",)))
    assert sorted(os.listdir(tmp_path)) == ["sheet.png", "sheet.svg"]
    assert (tmp_path / "sheet.png").read_bytes().startswith(b"\x89PNG")
    with pytest.raises(FileNotFoundError, match="no folder"):
        sheet.write_sheets(data_for(triangles, names, {}), tmp_path / "missing" / "a.svg", tmp_path / "a.png")


def test_without_matplotlib_a_sheet_fails_in_one_line(tmp_path, monkeypatch):
    assert sheet.cannot_draw() is None
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib raises ImportError
    assert sheet.cannot_draw().startswith("the condition-map drawings need matplotlib")
    triangles, names = box((4.0, 3.0, 2.5))
    with pytest.raises(ImportError, match="^the condition-map drawings need matplotlib, which this Python lacks"):
        write(tmp_path, data_for(triangles, names, {"north": 0}))
    assert os.listdir(tmp_path) == []


def test_one_frame_draws_every_age_as_the_sheet_made_alone_would(tmp_path):
    """The survey makes an object's views once and draws each age's patterns on them: the same
    SVG as a sheet that makes its own views; a frame of other views, another north or another
    scale is refused in one line, before any file."""
    triangles, names = split_north_face(*box((4.0, 3.0, 2.5)))
    frame = sheet.make_frame(triangles, (0.0, 1.0), tuple(sheet.ELEVATIONS), sheet.PRINT_SCALE)
    for age, pattern_of in enumerate(({"north-west": 0, "east": 1}, {"north-east": 2, "top": 4, "south": 3})):
        alone = data_for(triangles, names, pattern_of)
        write(tmp_path, alone, f"alone{age}")
        sheet.write_sheets(
            dataclasses.replace(alone, triangles_m=None),
            tmp_path / f"framed{age}.svg",
            tmp_path / f"framed{age}.png",
            frame,
        )
        assert (tmp_path / f"framed{age}.svg").read_bytes() == (tmp_path / f"alone{age}.svg").read_bytes()
    other = data_for(triangles, names, {}, views=("north", "plan"))
    with pytest.raises(ValueError, match="^the frame has the views"):
        sheet.write_sheets(other, tmp_path / "other.svg", tmp_path / "other.png", frame)
    turned = dataclasses.replace(alone, north=(1.0, 0.0))
    with pytest.raises(ValueError, match=r"^the frame was made for north \(0.0, 1.0\) at 1:50, the sheet asks north"):
        sheet.write_sheets(turned, tmp_path / "turned.svg", tmp_path / "turned.png", frame)
    with pytest.raises(ValueError, match="^the frame was made for .* the sheet asks .* at 1:100$"):
        sheet.write_sheets(dataclasses.replace(alone, scale=100), tmp_path / "s.svg", tmp_path / "s.png", frame)
    assert not {"other.svg", "turned.svg", "s.svg", "turned.png"} & set(os.listdir(tmp_path))
