"""Temporary scenes, the one place the bakes work: a clean-up ledger (``Ledger``) that removes
every datablock, file and folder made for a bake when it closes, success or error; a temporary
scene with the deterministic Cycles set-up every bake (and render) uses; copies of the user's
objects in it, so that the user's scene, meshes, materials and selection are never touched; the
probe materials and light aiming those scenes use; and exact texel bakes (EMIT, one sample a
texel) of what a probe emits on an object's UV map."""

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TypeVar

import bpy

import numpy as np
from mathutils import Matrix, Vector

from ..common import held_output
from ..core.shader_math import Graph
from . import compat, mesh_arrays

#: Object types that have surfaces, materials and therefore something to bake or shade.
GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}

Block = TypeVar("Block", bound=bpy.types.ID)


class Ledger:
    """What a temporary piece of work made (datablocks, files, folders), all removed when the
    ledger closes, on success or error: objects first, then the other datablocks (latest first),
    the scenes, and last the files and folders. A datablock removed meanwhile is skipped; what
    cannot be removed does not stop the rest (the first such error is raised afterwards, unless
    the ledger closes on an error of its own, which then goes on)."""

    def __init__(self) -> None:
        self._blocks: list[bpy.types.ID] = []
        self._paths: list[str] = []

    def add(self, block: Block) -> Block:
        """Record ``block`` (a datablock, returned) for removal."""
        self._blocks.append(block)
        return block

    def add_path(self, path: str | os.PathLike) -> str | os.PathLike:
        """Record the file or folder ``path`` (returned) for removal."""
        self._paths.append(os.fspath(path))
        return path

    def folder(self, prefix: str | None = None, dir: str | None = None) -> str:
        """A new temporary folder (``tempfile.mkdtemp``), recorded for removal."""
        return self.add_path(tempfile.mkdtemp(prefix=prefix, dir=dir))

    def __enter__(self) -> "Ledger":
        return self

    def __exit__(self, kind, error, trace) -> bool:
        try:
            self.close()
        except Exception:
            if error is None:
                raise
        return False

    def close(self) -> None:
        """Remove everything recorded (see the class docstring); the ledger is empty afterwards."""
        live = []
        for block in reversed(self._blocks):
            try:
                kind = block.id_type
            except ReferenceError:  # removed already
                continue
            live.append((0 if kind == "OBJECT" else 2 if kind == "SCENE" else 1, block))
        self._blocks.clear()
        errors = []
        for _, block in sorted(live, key=lambda item: item[0]):
            try:
                _collection(block).remove(block)
            except Exception as error:  # remove the others all the same
                errors.append(error)
        for path in reversed(self._paths):
            try:
                if os.path.isdir(path):
                    shutil.rmtree(path, ignore_errors=True)
                elif os.path.lexists(path):
                    os.remove(path)
            except OSError as error:
                errors.append(error)
        self._paths.clear()
        if errors:
            raise errors[0]


def _collection(block):
    """The ``bpy.data`` collection that holds ``block``: bpy.data.objects for an Object, ..."""
    return getattr(bpy.data, _COLLECTIONS.get(block.id_type, block.id_type.lower() + "s"))


_COLLECTIONS = {"MESH": "meshes", "NODETREE": "node_groups"}


def use_cycles(scene: bpy.types.Scene, *, samples: int = 1, seed: int = 0, bounces: int = 0) -> None:
    """The deterministic Cycles set-up of every bake and render: CPU, a fixed seed, no
    denoising, no adaptive sampling, ``samples`` samples (a pixel's or texel's) and at most
    ``bounces`` bounces (0: direct light only)."""
    scene.render.engine = "CYCLES"
    cycles = scene.cycles
    cycles.device = "CPU"
    cycles.samples = samples
    cycles.seed = seed
    cycles.use_denoising = False
    cycles.use_adaptive_sampling = False
    cycles.max_bounces = bounces


def temporary_scene(ledger: Ledger, name: str, *, samples: int = 1, seed: int = 0) -> bpy.types.Scene:
    """A new scene ``name`` recorded in ``ledger``, set up for Cycles bakes (``use_cycles``)."""
    scene = ledger.add(bpy.data.scenes.new(name))
    use_cycles(scene, samples=samples, seed=seed)
    return scene


def placed_copy(obj, scene, material, *, own_mesh=False, ledger=None):
    """A copy of ``obj`` linked into ``scene``, standing where ``obj`` stands (unparented, no
    animation or constraints, renderable), every slot showing ``material``.

    With ``own_mesh`` the copy gets its own copy of the mesh (to write bake results into);
    otherwise it shares ``obj``'s, whose materials stay untouched (object-linked slots).
    A ``ledger`` records the copy (and its own mesh) for removal.
    """
    copy = obj.copy()
    if ledger is not None:
        ledger.add(copy)
    if own_mesh:
        copy.data = obj.data.copy()
        if ledger is not None:
            ledger.add(copy.data)
        copy.data.materials.clear()
        copy.data.materials.append(material)
    copy.animation_data_clear()
    copy.constraints.clear()
    copy.parent = None
    copy.matrix_world = obj.matrix_world.copy()
    copy.hide_render = False
    for slot in copy.material_slots:
        slot.link = "OBJECT"
        slot.material = material
    scene.collection.objects.link(copy)
    return copy


@dataclass(frozen=True)
class Rendered:
    """An object as the render sees it: ``evaluated``, its evaluated copy, and ``mesh``, that
    copy's mesh (modifiers applied at their render settings)."""

    evaluated: bpy.types.Object
    mesh: bpy.types.Mesh

    @property
    def matrix_world(self) -> np.ndarray:
        return np.array(self.evaluated.matrix_world, dtype=np.float64)


@contextmanager
def rendered(obj: bpy.types.Object, modifiers: int | None = None) -> Iterator[Rendered]:
    """``obj`` evaluated as a render (and every Cycles bake) evaluates it, not as the viewport
    does: a copy of it in a temporary scene whose modifiers show what they render (Subdivision
    at its render levels, modifiers off in renders off), only its first ``modifiers`` ones if
    given. Its mesh is what the maps are made on; the user's object and scene are untouched. A
    Geometry Nodes tree that asks whether it is in the viewport still answers yes (docs/maps.md)."""
    with Ledger() as made:
        scene = made.add(bpy.data.scenes.new("PW Render Mesh"))
        copy = placed_copy(obj, scene, None, ledger=made)
        # where the object stands now: its matrix_world is stale until its scene is evaluated
        copy.matrix_world = obj.evaluated_get(bpy.context.evaluated_depsgraph_get()).matrix_world.copy()
        for index, modifier in enumerate(copy.modifiers):
            modifier.show_viewport = modifier.show_render and (modifiers is None or index < modifiers)
            if hasattr(modifier, "render_levels"):  # Subdivision Surface, Multiresolution
                modifier.levels = modifier.render_levels
        with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
            depsgraph = bpy.context.evaluated_depsgraph_get()
        evaluated = copy.evaluated_get(depsgraph)
        mesh = evaluated.to_mesh()
        try:
            yield Rendered(evaluated, mesh)
        finally:
            evaluated.to_mesh_clear()


def check_corners_kept(obj: bpy.types.Object, seen: Rendered) -> None:
    """Raise ValueError, in one line, unless ``seen`` (``obj`` as rendered) has the vertices and
    face corners of ``obj``'s mesh, which attribute maps are values of."""
    if len(seen.mesh.vertices) != len(obj.data.vertices) or len(seen.mesh.loops) != len(obj.data.loops):
        raise ValueError(
            f"object '{obj.name}': its modifiers ({', '.join(m.name for m in obj.modifiers)}) change its vertices, "
            "so attribute maps cannot follow its mesh; bake to images (--target image) or apply the modifiers"
        )


#: Blender's report after each bake into an image, which a command line prints in the middle of
#: its progress bar: the bakes here read their images back themselves.
BAKE_NOTE = b"Info: Baking map saved to internal image"


def bake_alone(obj: bpy.types.Object, **settings) -> None:
    """``bpy.ops.object.bake(**settings)`` on ``obj`` alone, made the selected, active object of
    its (temporary) scene; Blender's output less its note that the image was saved internally."""
    with bpy.context.temp_override(**_only_selected(obj)), held_output.held((BAKE_NOTE, *compat.PROGRESS_NOTES)):
        bpy.ops.object.bake(**settings)


def _only_selected(obj):
    """Make ``obj`` the selected, active object of its scene; the context override in which it
    is the only selected one."""
    scene = obj.users_scene[0]
    view_layer = scene.view_layers[0]
    obj.select_set(True, view_layer=view_layer)
    view_layer.objects.active = obj
    return dict(
        scene=scene,
        view_layer=view_layer,
        object=obj,
        active_object=obj,
        selected_objects=[obj],
        selected_editable_objects=[obj],
    )


def aim_sun(sun, towards):
    """Rotate a sun so that the unit vector towards it is ``towards`` (its local +Z)."""
    towards = Vector(towards)
    if not towards.length > 0.0:
        raise ValueError(f"cannot aim the sun '{sun.name}' along a zero-length (or NaN) direction")
    sun.rotation_mode = "XYZ"
    sun.rotation_euler = towards.normalized().to_track_quat("Z", "Y").to_euler("XYZ")


def emission_probe(name, build):
    """A material that emits ``build(graph, geometry)`` (a colour Expr or socket) exactly.

    Cycles renders an Emission closure of strength 1 as its colour, so the pixels of a
    probe render are the shading quantity itself at each pixel's centre. A probe lights nothing:
    Cycles would otherwise make its mesh a light and build a light tree over every triangle
    before each bake (0.33 s of a 0.36 s EMIT bake of a 100k-triangle terrain at 128², 0.03 s
    without, the same texels).
    """
    material = compat.new_material(name)
    material.cycles.emission_sampling = "NONE"
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    geometry = graph.node("ShaderNodeNewGeometry", depth=0)
    colour = build(graph, geometry)
    emission = graph.node("ShaderNodeEmission", {"Color": colour, "Strength": 1.0})
    graph.node("ShaderNodeOutputMaterial", {"Surface": emission.outputs[0]})
    return material


def bake_point_values(obj, uv_map_name, resolution, values, *, margin=0):
    """(image, islands): ``values`` (one per vertex of ``obj``'s mesh) drawn into a float32
    (H, W) image of ``uv_map_name``, each texel interpolating its triangle's corners, and the
    (H, W) bool map of the texels on a UV island or its ``margin``. Top row first.

    ``margin`` texels around every island are filled from the island's edge (Blender's bake
    margin, EXTEND)."""
    name = "PW Point Values"

    def prepare(mesh):
        mesh.color_attributes.new(name, "FLOAT_COLOR", "POINT").data.foreach_set("color", mesh_arrays.grey_rgba(values))

    (baked,) = emit_bakes(
        obj,
        uv_map_name,
        resolution,
        [lambda graph, geometry: graph.node("ShaderNodeAttribute", attribute_name=name).outputs["Color"]],
        prepare=prepare,
        margin=margin,
    )
    return baked[..., 0].copy(), baked[..., 3] > 0


def emit_bakes(obj, uv_map_name, resolution, emitted, prepare=None, margin=0, origin=None):
    """One float RGBA (H, W, 4) array, top row first, per ``emitted(graph, geometry)``: exact
    Cycles EMIT bakes (one sample, the texel centre) of probe materials emitting it, on a copy
    of the object (its mesh first given to ``prepare``) in a temporary scene: the user's
    scene, mesh, materials and selection are untouched. Texels off every UV island and its
    ``margin`` (filled by EXTEND) have alpha 0. With ``origin`` (a world point, (3,)) the copy
    stands moved by ``-origin``: positions come out relative to it, in Cycles' single precision
    of the object's size rather than of its distance from the world's origin."""
    with Ledger() as made:
        image = made.add(bpy.data.images.new("PW Texel Bake", resolution, resolution, alpha=True, float_buffer=True))
        probes = [made.add(emission_probe(f"PW Texel Probe {index}", build)) for index, build in enumerate(emitted)]
        scene = temporary_scene(made, "PW Texel Bake")
        copy = placed_copy(obj, scene, probes[0], own_mesh=True, ledger=made)
        if origin is not None:
            moved = np.array(copy.matrix_world, dtype=np.float64)
            moved[:3, 3] -= origin
            copy.matrix_world = Matrix(moved.tolist())
        if prepare is not None:
            prepare(copy.data)
        baked = []
        for probe in probes:
            texture = probe.node_tree.nodes.new("ShaderNodeTexImage")
            texture.image = image
            probe.node_tree.nodes.active = texture
            for slot in copy.material_slots:
                slot.material = probe
            baked.append(emit_bake(copy, image, margin=margin, uv_map=uv_map_name))
        return baked


def emit_bake(
    obj: bpy.types.Object, image: bpy.types.Image, *, fill: float = 0.0, margin: int = 0, uv_map: str | None = None
) -> np.ndarray:
    """The exact Cycles EMIT bake of ``obj`` (alone in its temporary scene) into ``image``, the
    active Image Texture of its materials, on ``uv_map`` (default: the active UV map): float32
    (H, W, 4), top row first. Every texel holds ``fill`` before the bake, so those off every UV
    island and its ``margin`` (filled by EXTEND) still hold it."""
    width, height = image.size
    image.pixels.foreach_set(np.full(width * height * 4, fill, dtype=np.float32))
    settings = dict(
        type="EMIT",
        target="IMAGE_TEXTURES",
        margin=margin,
        margin_type="EXTEND",
        use_clear=False,
        use_selected_to_active=False,
    )
    if uv_map is not None:
        settings["uv_layer"] = uv_map
    bake_alone(obj, **settings)
    pixels = np.empty(width * height * 4, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    return pixels.reshape(height, width, 4)[::-1]  # Blender stores the bottom row first
