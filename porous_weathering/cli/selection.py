"""What the ``bake``, ``survey`` and ``export`` commands share: the ``--objects`` /
``--collection`` arguments (declared once, each command saying what its default is), the words
that give them again to a Dask worker, the objects they choose in a .blend (opened by
``blender.blend_file.open_blend``), and an error's message on one line."""

import argparse
import warnings

import bpy

from ..maps.bake import has_faces
from ..maps.edges import surface_box
from ..publish.textures import porous_node


def add_arguments(parser: argparse.ArgumentParser, *, objects_help: str, collection_help: str) -> None:
    """``--objects NAME [NAME ...]`` (default: none, ``()``) and ``--collection NAME``, with the
    command's help texts (what it does with them, and without them)."""
    parser.add_argument("--objects", nargs="+", metavar="NAME", default=(), help=objects_help)
    parser.add_argument("--collection", metavar="NAME", help=collection_help)


def chosen(args: argparse.Namespace) -> bool:
    """Whether ``args`` choose objects (``--objects`` or ``--collection``)."""
    return bool(args.objects or args.collection)


def to_argv(args: argparse.Namespace) -> list[str]:
    """The command-line words that choose the same objects (for the Dask workers)."""
    if args.collection:
        return [f"--collection={args.collection}"]
    return ["--objects", *args.objects] if args.objects else []


def chosen_objects(args: argparse.Namespace, verb: str = "bake") -> list["bpy.types.Object"]:
    """The objects ``--objects`` names, in its order; else the mesh objects of ``--collection``
    (children included), else of the scene, sorted by name. ValueError naming what is missing,
    or when there is no mesh object to ``verb``."""
    if args.objects:
        missing = [name for name in args.objects if name not in bpy.data.objects]
        if missing:
            raise ValueError(f"no object named {', '.join(missing)}")
        return [bpy.data.objects[name] for name in args.objects]
    if args.collection:
        if args.collection not in bpy.data.collections:
            raise ValueError(f"no collection named {args.collection}")
        candidates = bpy.data.collections[args.collection].all_objects
    else:
        candidates = bpy.context.scene.objects
    objects = sorted((o for o in candidates if o.type == "MESH"), key=lambda o: o.name)
    if not objects:
        raise ValueError(f"no mesh objects to {verb}")
    return objects


def weathered_objects(args: argparse.Namespace, verb: str) -> list["bpy.types.Object"]:
    """The objects ``args`` choose (``chosen_objects``), else every mesh object of the scene whose
    materials are all Porous Weathering ones, sorted by name: what ``survey`` and ``export``
    ``verb``. ValueError when the scene has none."""
    if chosen(args):
        return chosen_objects(args, verb)
    objects = sorted(
        (
            obj
            for obj in bpy.context.scene.objects
            if obj.type == "MESH"
            and obj.material_slots
            and all(porous_node(slot.material) for slot in obj.material_slots)
        ),
        key=lambda obj: obj.name,
    )
    if not objects:
        raise ValueError(
            f"no mesh object of the scene has only Porous Weathering materials to {verb}: give them one first "
            "(the panel's Make, or make_weathered_material), or name them with --objects"
        )
    return objects


def without_faceless(objects: list["bpy.types.Object"]) -> list["bpy.types.Object"]:
    """``objects`` without the meshes that have no face (none, or none left after their
    modifiers: ``bake.has_faces``) or none of non-zero area (``edges.surface_box``), each left
    out with a warning; ValueError when none is left."""
    kept = []
    for obj in objects:
        if not has_faces(obj):
            warnings.warn(f"object '{obj.name}' is left out: its mesh has no faces (after its modifiers)", stacklevel=2)
        elif surface_box(obj) is None:
            warnings.warn(f"object '{obj.name}' is left out: its mesh has no face of non-zero area", stacklevel=2)
        else:
            kept.append(obj)
    if not kept:
        names = ", ".join(repr(obj.name) for obj in objects)
        raise ValueError(
            f"no mesh object with faces: {names} {'has' if len(objects) == 1 else 'have'} none "
            "(a scan's point cloud must be meshed first)"
        )
    return kept


def one_line(error: BaseException | str) -> str:
    """An exception's message on one line, without the "Error: " Blender puts before its own;
    never empty (an exception without a message gives its kind)."""
    text = " ".join(str(error).split()).removeprefix("Error: ")
    return text or (type(error).__name__ if isinstance(error, BaseException) else "no reason given")
