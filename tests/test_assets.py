"""The committed node-group asset library: assets in catalogs, and what build_assets.py builds."""

import pathlib

import bpy

import numpy as np
import pytest

from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.shading import assets, nodes
from scripts import OLDEST_LINE, load_script

NODE_GROUPS = pathlib.Path(__file__).resolve().parent.parent / "node_groups"

build_assets = load_script("node_groups/build_assets.py")


def catalogs(path):
    """{catalog UUID: catalog path} of a blender_assets.cats.txt."""
    rows = [line.split(":") for line in path.read_text().splitlines() if line and not line.startswith(("#", "VERSION"))]
    return {row[0]: row[1] for row in rows}


def asset_groups(blend, describe=None):
    """{name: summary} of the node-group assets in ``blend``, appended and then removed again;
    ``describe(group)`` gives the summary (default: what a rebuild on any line must keep)."""
    with bpy.data.libraries.load(str(blend), assets_only=True) as (source, target):
        target.node_groups = list(source.node_groups)
    summary = {}
    for group in target.node_groups:
        summary[group.name] = (
            describe(group)
            if describe
            else dict(
                nodes=len(group.nodes),
                links=len(group.links),
                sockets=[(item.in_out, item.name) for item in group.interface.items_tree if item.item_type == "SOCKET"],
                catalog=group.asset_data.catalog_id,
                description=group.asset_data.description,
                preview=tuple(group.preview.image_size) if group.preview else (0, 0),
            )
        )
        bpy.data.node_groups.remove(group)
    return summary


def test_committed_groups_are_assets_in_catalogs_with_previews():
    groups = asset_groups(NODE_GROUPS / build_assets.FILENAME)
    known = catalogs(NODE_GROUPS / build_assets.CATALOGS_FILENAME)
    assert len(groups) == len(build_assets.ASSETS) >= 3
    for name, group in groups.items():
        assert known.get(group["catalog"], "").startswith("Porous Weathering/"), name
        assert group["description"], name
        assert group["preview"] == (build_assets.PREVIEW_SIZE,) * 2, name


def preview_pixels(group):
    return np.array(group.preview.image_pixels_float[:]).reshape(-1, 4)


def test_weathering_modes_are_assets_in_every_light_mode_with_weathered_previews():
    blend = NODE_GROUPS / build_assets.FILENAME
    groups, previews = asset_groups(blend), asset_groups(blend, preview_pixels)
    known = catalogs(NODE_GROUPS / build_assets.CATALOGS_FILENAME)
    for light in nodes.LIGHT_MODES:
        clean = previews[nodes.porous_group_name(light)]
        sphere = clean[:, 3] > 0.5
        for mode in model.MODES:
            name = nodes.weathered_group_name((mode,), light)
            assert known[groups[name]["catalog"]] == f"Porous Weathering/{weathering_modes.get(mode).catalog}"
            # every input of the mode is a socket of its asset (its clock too: Time, or Biological Years)
            assert {("INPUT", item.socket) for item in weathering_modes.get(mode).inputs} <= set(
                groups[name]["sockets"]
            )
            # the previews are fully weathered: soot and deposit darken, salt whitens, water
            # darkens the diffuse and adds a mirror lobe
            change = (previews[name] - clean)[sphere, :3]
            assert np.abs(change).mean() > 0.01, name
            assert {model.SOILING: change.mean() < -0.02, model.EFFLORESCENCE: change.mean() > 0.02}.get(mode, True), (
                name
            )


def test_committed_file_is_saved_by_the_oldest_line():
    bpy.ops.wm.open_mainfile(filepath=str(NODE_GROUPS / build_assets.FILENAME))
    assert bpy.data.version[:2] == OLDEST_LINE, "rebuild it with the bpy module of the oldest line"


def test_committed_file_is_what_the_script_builds(tmp_path):
    rebuilt = build_assets.build(tmp_path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert asset_groups(NODE_GROUPS / build_assets.FILENAME) == asset_groups(rebuilt), (
        "node_groups/ is stale: run python node_groups/build_assets.py"
    )
    assert (tmp_path / build_assets.CATALOGS_FILENAME).read_text() == (
        NODE_GROUPS / build_assets.CATALOGS_FILENAME
    ).read_text()


@pytest.fixture
def no_library():
    assets.unregister()
    yield
    assets.unregister()


def test_asset_library_registers_once_and_unregisters(no_library):
    libraries = bpy.context.preferences.filepaths.asset_libraries
    before = len(libraries)
    assets.register()
    assets.register()  # enabling twice (e.g. a reload) must not add a second entry
    ours = [library for library in libraries if library.name == assets.LIBRARY_NAME]
    assert len(ours) == 1 and len(libraries) == before + 1
    assert pathlib.Path(ours[0].path) == NODE_GROUPS
    assets.unregister()
    assert len(libraries) == before
