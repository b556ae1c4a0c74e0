"""Build node_groups/porous_weathering_assets.blend, the extension's asset library: never edit it by hand.

    python node_groups/build_assets.py [--out DIR]     (the bpy module; commit with the 4.5 line,
                                                        the oldest we support, so every line reads it)

Every node group in ASSETS (the porous BRDF and the soiling, wet-surface and efflorescence
groups, each in the three light modes) is built by the package's own builders into an empty
file, marked as an asset with a catalog, a description and a rendered preview (weathering
groups fully weathered), and saved beside its blender_assets.cats.txt. The same code gives the same
groups: tests/test_assets.py rebuilds
the file and compares it with the committed one.
"""

import argparse
import pathlib
import sys
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field

import bpy

HERE = pathlib.Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from porous_weathering.blender import compat, render
from porous_weathering.core import modes as weathering_modes  # noqa: E402
from porous_weathering.samples import studio  # noqa: E402
from porous_weathering.shading import nodes

FILENAME = "porous_weathering_assets.blend"
CATALOGS_FILENAME = "blender_assets.cats.txt"
AUTHOR = "Porous Weathering"
#: Catalog UUIDs derive from their paths, so they never change between builds.
CATALOG_NAMESPACE = uuid.UUID("6f0d8a52-2d8e-4d55-9d8c-0f4b3c7e5a10")
PREVIEW_SIZE = 64
#: The preview sun and camera: lit from the upper left, as the Blender material previews are.
PREVIEW_SUN = (-0.5, 0.5, 0.7)


@dataclass(frozen=True)
class Asset:
    build: Callable[[], "bpy.types.NodeTree"]
    catalog: str  #: the catalog path, "/"-separated
    description: str
    #: Group inputs (model.WEATHERING_INPUTS names) set for the preview only, so that it shows
    #: the weathered look rather than the new stone of the defaults (time = 0).
    preview_inputs: dict = field(default_factory=dict)


LIGHTS = {
    nodes.SUN: "lit by a key sun: wire its direction to Light Direction",
    nodes.POINT: "lit by a key point, spot or area light: wire its position to Light Position",
    nodes.AMBIENT: "for environment lighting: pore shadowing averaged over the sky",
}
#: Every node group of the library: the porous BRDF, then each registered weathering mode (its
#: catalog, summary and fully weathered preview come from its record in modes/), in each light mode.
ASSETS = tuple(
    Asset(
        lambda light=light: nodes.porous_group(light),
        "Porous Weathering/Porous BRDF",
        f"Porous BRDF (Merillou et al. 2000) {text}",
    )
    for light, text in LIGHTS.items()
) + tuple(
    Asset(
        lambda mode=mode.name, light=light: nodes.weathered_group((mode,), light),
        f"Porous Weathering/{mode.catalog}",
        f"{mode.asset_summary}, on the porous BRDF, {text}; Time ages it from new (0) to weathered (1)",
        mode.preview,
    )
    for mode in map(weathering_modes.get, weathering_modes.names())
    for light, text in LIGHTS.items()
)


def catalog_id(path):
    return str(uuid.uuid5(CATALOG_NAMESPACE, path))


def catalog_paths():
    """Every catalog the assets use, with its parents, sorted."""
    paths = set()
    for asset in ASSETS:
        parts = asset.catalog.split("/")
        paths.update("/".join(parts[:i]) for i in range(1, len(parts) + 1))
    return sorted(paths)


def write_catalogs(path):
    lines = ["# Asset catalogs of the Porous Weathering node groups, written by build_assets.py.", "VERSION 1", ""]
    lines += [f"{catalog_id(p)}:{p}:{p.replace('/', '-')}" for p in catalog_paths()]
    path.write_text("\n".join(lines) + "\n")


def render_preview(group, inputs):
    """A small Cycles render of a sphere shaded by ``group`` (its first shader output), with the
    weathering ``inputs`` set."""
    scene = bpy.context.scene
    shader_outputs = [
        s
        for s in group.interface.items_tree
        if s.item_type == "SOCKET" and s.in_out == "OUTPUT" and s.socket_type == "NodeSocketShader"
    ]
    if not shader_outputs:
        return None
    material = compat.new_material("Preview")
    tree = material.node_tree
    tree.nodes.clear()
    node = tree.nodes.new("ShaderNodeGroup")
    node.node_tree = group
    for name, value in (("Light Direction", PREVIEW_SUN), ("Light Position", tuple(10 * c for c in PREVIEW_SUN))):
        if name in node.inputs:
            node.inputs[name].default_value = value
    for name, value in inputs.items():
        node.inputs[weathering_modes.inputs()[name].socket].default_value = value
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(node.outputs[shader_outputs[0].name], output.inputs["Surface"])
    sphere = studio.add_sphere(scene, segments=32, rings=16)
    studio.assign(sphere, material)
    render.use_cycles(scene, size=PREVIEW_SIZE, samples=16, bounces=1, pixel_filter=1.5)
    try:
        return render.render_array(scene)
    finally:
        bpy.data.objects.remove(sphere)
        bpy.data.materials.remove(material)


def set_preview(group, pixels):
    preview = group.preview_ensure()
    preview.image_size = pixels.shape[1], pixels.shape[0]
    # Blender stores images bottom row first; the sphere sits on a transparent background.
    preview.image_pixels_float[:] = pixels[::-1].clip(0.0, 1.0).ravel().tolist()


def preview_scene(scene):
    """Camera, key sun and a dim grey world for the preview renders."""
    studio.add_ortho_camera(scene, scale=2.1)
    studio.add_sun(scene, towards=PREVIEW_SUN, strength=3.0)
    scene.world = bpy.data.worlds.new("Preview World")
    scene.world.color = (0.25, 0.25, 0.25)


def build(out_dir=HERE):
    """Write the asset .blend and its catalogs into ``out_dir``; returns the .blend path."""
    out_dir = pathlib.Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backup beside the library
    scene = bpy.context.scene
    preview_scene(scene)
    for asset in ASSETS:
        group = asset.build()
        group.asset_mark()
        group.asset_data.catalog_id = catalog_id(asset.catalog)
        group.asset_data.description = asset.description
        group.asset_data.author = AUTHOR
        pixels = render_preview(group, asset.preview_inputs)
        if pixels is not None:
            set_preview(group, pixels)
    # Only the node groups stay in the file.
    for collection in (
        bpy.data.objects,
        bpy.data.cameras,
        bpy.data.lights,
        bpy.data.meshes,
        bpy.data.worlds,
        bpy.data.images,
    ):
        for item in list(collection):
            collection.remove(item)
    write_catalogs(out_dir / CATALOGS_FILENAME)
    path = out_dir / FILENAME
    bpy.ops.wm.save_as_mainfile(filepath=str(path), compress=True, relative_remap=False)
    return path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=pathlib.Path, default=HERE, help="output folder (default: node_groups/)")
    print(f"wrote {build(parser.parse_args().out)}")
