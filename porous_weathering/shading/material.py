"""Materials built on the porous node groups, and the key-light wiring (docs/model.md §3)."""

import os
from collections.abc import Sequence
from dataclasses import dataclass

import bpy

import numpy as np

from ..blender import compat
from ..contracts import GROUP_NODE, KEY_LIGHT_PROPERTY, LIGHT_MODE_PROPERTY, PRESET_PROPERTY, STONE_NODE, STONE_PROPERTY
from ..core import model, stones
from ..core.arguments import choice, real_number
from ..core.shader_math import Graph
from . import nodes
from .presets import PRESETS


@dataclass(frozen=True)
class ColorAttribute:
    """k_d read from the mesh's colour attribute ``name`` (a scan's vertex colours) by an
    Attribute node."""

    name: str


#: k_d as a colour (RGB or RGBA), an image, an image file's path, or a colour attribute.
ColorSource = Sequence[float] | bpy.types.Image | ColorAttribute | str | os.PathLike
#: The base colours that vary over the surface: fed to the group by a node.
TEXTURED = (bpy.types.Image, ColorAttribute)

#: Light object types and the light mode each is wired as.
LIGHT_MODE_OF_TYPE = {"SUN": nodes.SUN, "POINT": nodes.POINT, "SPOT": nodes.POINT, "AREA": nodes.POINT}


def make_porous_material(
    name: str,
    *,
    base_color: ColorSource = (0.8, 0.8, 0.8),
    ks: float = 0.1,
    roughness: float = 0.4,
    porosity: float = 0.2,
    pore_depth_ratio: float = 2.0,
    key_light: "bpy.types.Object | str | None" = None,
    stone: str | None = None,
    variation: float = stones.DEFAULT_VARIATION,
    masonry: stones.Ashlar | stones.MeshBlocks | None = None,
) -> "bpy.types.Material":
    """A new material that renders the porous BRDF post-process (docs/model.md §2) in EEVEE and Cycles.

    ``base_color`` is k_d: an RGB(A) colour, a ``bpy.types.Image``, an image file path, or a
    ``ColorAttribute`` (the mesh's vertex colours).
    ``ks`` is k_s, ``roughness`` m, ``porosity`` alpha, ``pore_depth_ratio`` s_p.
    ``key_light`` is a light object (or its name) for the key-light mode; ``None`` gives the
    ambient mode.  ``stone`` (a preset key, e.g. "LIMESTONE") gives the material that stone's
    structure (docs/model.md §8): k_d, alpha, s_p and m vary from point to point around the values
    given, by ``variation`` in [0, 1] (1: as the stone shows it), at physical sizes in the scene's
    unit (``unit_settings.scale_length``, followed by a driver); ``stone=None`` or
    ``variation=0`` builds the uniform material.  ``masonry`` (a ``stones.Ashlar``, with a
    ``stone``) lays the stone as coursed ashlar, each block its own draw of the stone's
    parameters, its joints the mortar preset's (docs/model.md §8.5); a ``stones.MeshBlocks`` takes
    the blocks the mesh knows (an integer face attribute), each its own draw.  Out-of-range or
    NaN numbers are clamped with a ``PorousInputWarning``; a key light that is not a light, or an unknown stone, raises
    ``ValueError`` before anything is created.
    """
    base_color, values = porous_parameters(base_color, ks, roughness, porosity, pore_depth_ratio)
    structure = stone_structure(stone, variation, masonry)
    light = resolve_key_light(key_light)
    light_mode = LIGHT_MODE_OF_TYPE[light.data.type] if light else nodes.AMBIENT
    material = compat.new_material(name)
    try:
        group = nodes.porous_group(light_mode)
        group_node = _replace_with_group(material, group)
        graph = Graph(material.node_tree)
        for input_socket, value in values.items():
            group_node.inputs[input_socket].default_value = value
        _connect_base_color(graph, group_node, base_color)
        if structure:
            connect_stone(graph, group_node, stone, *structure, base_color)
        if light:
            wire_key_light(graph, group_node, light)
    except Exception:
        bpy.data.materials.remove(material)
        raise
    material[LIGHT_MODE_PROPERTY] = light_mode
    return material


def make_preset_material(
    preset_name: str,
    name: str | None = None,
    key_light: "bpy.types.Object | str | None" = None,
    variation: float = stones.DEFAULT_VARIATION,
) -> "bpy.types.Material":
    """A new porous material (see ``make_porous_material``) with the values of a preset.

    ``preset_name`` is a key of PRESETS (e.g. "LIMESTONE"); ``name`` defaults to the
    preset's label; ``key_light`` as in ``make_porous_material`` (None: ambient mode).  The
    material has the preset's stone structure (docs/model.md §8) at ``variation`` (0: uniform).
    """
    try:
        preset = PRESETS[preset_name]
    except KeyError:
        raise ValueError(f"unknown preset {preset_name!r}: choose one of {', '.join(PRESETS)}") from None
    params = preset.material_params()
    material = make_porous_material(
        name or preset.label, **params, key_light=key_light, stone=preset_name, variation=variation
    )
    material.diffuse_color = params["base_color"]  # the viewport's solid-mode colour
    material[PRESET_PROPERTY] = preset_name
    return material


def stone_structure(
    stone: str | None, variation: float, masonry: "stones.Ashlar | stones.MeshBlocks | None" = None
) -> "tuple[stones.Stone, float, stones.Ashlar | stones.MeshBlocks | None] | None":
    """(the stone's structure, variation, masonry) for ``stone`` (a preset key), ``variation`` and
    ``masonry``, or None when the material is uniform (no stone, or variation 0 or a preset without
    a structure and no masonry); ValueError naming an unknown stone or mortar, a variation that is
    not a number, or masonry that is not an ``Ashlar`` or a ``MeshBlocks`` or has no stone."""
    variation = float(model.sanitize("variation", real_number("variation", variation), 0.0, 1.0))
    if masonry is not None:
        if not isinstance(masonry, (stones.Ashlar, stones.MeshBlocks)):
            raise ValueError(f"masonry must be a stones.Ashlar, a stones.MeshBlocks or None, not {masonry!r}")
        if stone is None:
            raise ValueError("masonry needs a stone (stone='LIMESTONE', say): its blocks are the stone's")
        if isinstance(masonry, stones.Ashlar):
            choice("mortar", masonry.mortar, PRESETS)
    if stone is None:
        return None
    preset = PRESETS[choice("stone", stone, PRESETS)]
    if masonry is None and (preset.structure is None or variation == 0.0):
        return None
    return preset.structure or stones.Stone((), 0.0, 0.0, 0.0, (0.0, 0.0, 0.0), "uniform"), variation, masonry


def metres_per_unit(scene: "bpy.types.Scene | None" = None) -> float:
    """The scene's length unit in metres (Scene > Units > Unit Scale): what the structure's physical
    sizes are read in (docs/model.md §8.2)."""
    scene = scene or bpy.context.scene
    return float(scene.unit_settings.scale_length) if scene is not None else 1.0


def object_metres_per_unit(obj: bpy.types.Object) -> float:
    """The unit scale of ``obj``'s scene (the first that holds it; else the context's)."""
    return metres_per_unit(obj.users_scene[0] if obj.users_scene else None)


def follow_unit_scale(socket: bpy.types.NodeSocket) -> None:
    """Feed a Metres Per Unit input the unit scale of the scene being rendered, by a plain driver
    (a SUM of one context property: Blender evaluates it without Python, so it follows with
    script auto-execution off, and it names no scene, so a material appended elsewhere brings
    none along): changing the unit rescales the stone's structure, its rivulets and lichens
    (docs/model.md §8.2).  The value is set now too, for what reads it before an evaluation."""
    socket.default_value = metres_per_unit()
    driver = socket.driver_add("default_value").driver
    driver.type = "SUM"
    variable = driver.variables.new()
    variable.name = "unit_scale"
    variable.type = "CONTEXT_PROP"
    target = variable.targets[0]
    target.context_property = "ACTIVE_SCENE"
    target.data_path = "unit_settings.scale_length"


def connect_stone(graph, group_node, key, structure, variation, masonry, base_color):
    """The stone group of ``key`` between the material's values and ``group_node``: it takes the
    base colour (or image), porosity, pore depth and roughness set on ``group_node`` as its means
    and feeds their per-point values (and, to a receptive weathered group, the receptivity, the
    porosity field and the variation: docs/model.md §8.3, §8.6, §8.7).
    With ``masonry`` an ``Ashlar``, the stone's masonry group, given the ashlar's lengths in
    metres and its mortar preset's values; a ``MeshBlocks``, the stone's group of the mesh's blocks."""
    if isinstance(masonry, stones.Ashlar):
        group = nodes.masonry_group(key, structure)
    elif isinstance(masonry, stones.MeshBlocks):
        group = nodes.mesh_blocks_group(key, structure, masonry.attribute)
    else:
        group = nodes.stone_group(key, structure)
    node = graph.node("ShaderNodeGroup", depth=1, node_tree=group)
    node.name = node.label = STONE_NODE
    inputs = group_node.inputs
    for socket in ("Porosity", "Pore Depth Ratio", "Roughness"):
        node.inputs[socket].default_value = inputs[socket].default_value
    if isinstance(base_color, TEXTURED):
        graph.connect(inputs["Base Color"].links[0].from_socket, node.inputs["Base Color"])
    else:
        node.inputs["Base Color"].default_value = inputs["Base Color"].default_value
    node.inputs["Variation"].default_value = variation
    follow_unit_scale(node.inputs[nodes.METRES_PER_UNIT])
    if isinstance(masonry, stones.Ashlar):
        for name, length in stones.ASHLAR_LENGTHS.items():
            node.inputs[length.label].default_value = getattr(masonry, name)
        mortar = PRESETS[masonry.mortar]
        values = (mortar.linear_base_color(), mortar.porosity, mortar.pore_depth_ratio, mortar.roughness)
        for socket, value in zip(nodes.MORTAR_SOCKETS, values):
            node.inputs[socket].default_value = value
    for socket in nodes.STONE_FEEDS:
        if socket in inputs:
            graph.connect(node.outputs[socket], inputs[socket])
    group_node.id_data[STONE_PROPERTY] = key
    return node


def make_base_material(
    name: str, *, base_color: ColorSource = (0.8, 0.8, 0.8), ks: float = 0.1, roughness: float = 0.4
) -> "bpy.types.Material":
    """The same Diffuse + Glossy (GGX) material without porosity: the paper's 'Phong' base."""
    base_color, values = porous_parameters(base_color, ks, roughness, 0.0, 0.0)
    material = compat.new_material(name)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    if isinstance(base_color, TEXTURED):
        base_color = _base_color_output(graph, base_color)
    bsdf = nodes.diffuse_plus_glossy(graph, base_color, values["Specular"], values["Roughness"])
    graph.node("ShaderNodeOutputMaterial", {"Surface": bsdf})
    return material


def porous_parameters(
    base_color: ColorSource, ks: float, roughness: float, porosity: float, pore_depth_ratio: float
) -> tuple[bpy.types.Image | np.ndarray, dict[str, float]]:
    """Validated (base colour or image, {group input: value}), as model.py clamps them;
    ValueError naming a parameter that is not a number."""
    ks, roughness = real_number("ks", ks), real_number("roughness", roughness)
    porosity, pore_depth_ratio = real_number("porosity", porosity), real_number("pore_depth_ratio", pore_depth_ratio)
    if isinstance(base_color, (str, os.PathLike)):
        base_color = load_image(base_color)
    if isinstance(base_color, ColorAttribute) and not (isinstance(base_color.name, str) and base_color.name):
        raise ValueError(f"base_color's colour attribute needs a name, not {base_color.name!r}")
    if isinstance(base_color, TEXTURED):
        ks = model.sanitize("k_s", ks, 0.0, 1.0)
    else:
        rgb = np.asarray(base_color, dtype=np.float64).ravel()
        if rgb.size not in (3, 4):
            raise ValueError(f"base_color must be an RGB or RGBA colour or an image, not {base_color!r}")
        kd, ks = model.valid_albedo(rgb[:3], ks)
        base_color = (*kd.tolist(), 1.0)
    values = {
        "Specular": float(ks),
        "Roughness": float(model.sanitize("m", roughness, 0.0, 1.5)),
        "Porosity": float(model.sanitize("alpha", porosity, 0.0, 1.0)),
        "Pore Depth Ratio": float(model.sanitize("s_p", pore_depth_ratio, 0.0, 10.0)),
    }
    return base_color, values


def load_image(path: str | os.PathLike) -> bpy.types.Image:
    """An image datablock for ``path`` (reused if loaded), or ValueError naming the file."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"base colour image not found: {path}")
    _check_readable_image(path)
    try:
        image = bpy.data.images.load(path, check_existing=True)
    except RuntimeError as error:
        raise ValueError(f"cannot read base colour image {path}: {error}") from None
    if not image.size[0]:  # Blender loads lazily and keeps an empty (pink) image it cannot decode
        if not image.users:
            bpy.data.images.remove(image)
        raise ValueError(f"cannot read base colour image {path}: Blender cannot decode it")
    return image


def _check_readable_image(path):
    """ValueError with OpenImageIO's message when ``path`` is not a readable image file."""
    import OpenImageIO as oiio

    image = oiio.ImageInput.open(path)
    if image is None:
        raise ValueError(f"cannot read base colour image {path}: {oiio.geterror() or 'unknown format'}")
    image.close()


def resolve_key_light(key_light: bpy.types.Object | str | None) -> bpy.types.Object | None:
    """The light object named or given, or None; ValueError if it is not a light."""
    if key_light is None:
        return None
    light = bpy.data.objects.get(key_light) if isinstance(key_light, str) else key_light
    if light is None:
        raise ValueError(f"key light {key_light!r}: no object of that name")
    if not isinstance(light, bpy.types.Object) or light.type != "LIGHT":
        raise ValueError(f"key light {getattr(light, 'name', light)!r} is not a light object")
    return light


def _replace_with_group(material, group):
    """Clear the material's nodes; a group node of ``group`` feeding the material output."""
    tree = material.node_tree
    tree.nodes.clear()
    group_node = tree.nodes.new("ShaderNodeGroup")
    group_node.node_tree = group
    group_node.name = group_node.label = GROUP_NODE
    group_node["pw_depth"] = 2
    group_node.location = (2 * 220, 0)
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    output.location = (3 * 220 + 60, 0)
    tree.links.new(group_node.outputs["BSDF"], output.inputs["Surface"])
    return group_node


def _image_node(graph, image):
    return graph.node("ShaderNodeTexImage", depth=1, image=image)


def _base_color_output(graph, source):
    """The socket giving a varying base colour: an Image Texture's, or an Attribute node's."""
    if isinstance(source, ColorAttribute):
        return graph.node("ShaderNodeAttribute", depth=1, attribute_name=source.name).outputs["Color"]
    return _image_node(graph, source).outputs["Color"]


def _connect_base_color(graph, group_node, base_color):
    if isinstance(base_color, TEXTURED):
        graph.connect(_base_color_output(graph, base_color), group_node.inputs["Base Color"])
    else:
        group_node.inputs["Base Color"].default_value = base_color


def wire_key_light(graph: Graph, group_node: bpy.types.Node, light: bpy.types.Object) -> bpy.types.Node:
    """Feed the light's world direction (sun) or position (others) with plain drivers.

    The drivers are TRANSFORMS variables of SUM drivers: Blender evaluates them without
    Python, so the material renders with script auto-execution off.
    """
    if LIGHT_MODE_OF_TYPE[light.data.type] == nodes.SUN:
        rotation = _driven_vector(graph, light, ("ROT_X", "ROT_Y", "ROT_Z"), "Key Light Rotation")
        # A sun shines along its local -Z: the direction towards it is its local +Z.  A Mapping
        # node rotates it: Cycles folds it to a constant (a Vector Rotate node it would evaluate
        # at every shaded point).
        direction = graph.node(
            "ShaderNodeMapping", {"Vector": (0.0, 0.0, 1.0), "Rotation": rotation}, vector_type="VECTOR", depth=1
        )
        graph.connect(direction.outputs["Vector"], group_node.inputs["Light Direction"])
    else:
        position = _driven_vector(graph, light, ("LOC_X", "LOC_Y", "LOC_Z"), "Key Light Position")
        graph.connect(position, group_node.inputs["Light Position"])
    group_node.id_data[KEY_LIGHT_PROPERTY] = light.name


def _driven_vector(graph, light, transform_types, label):
    combine = graph.node("ShaderNodeCombineXYZ", depth=0)
    combine.label = label
    for socket, transform_type in zip(combine.inputs, transform_types):
        driver = socket.driver_add("default_value").driver
        driver.type = "SUM"
        variable = driver.variables.new()
        variable.name = transform_type.lower()
        variable.type = "TRANSFORMS"
        target = variable.targets[0]
        target.id = light
        target.transform_type = transform_type
        target.transform_space = "WORLD_SPACE"
        target.rotation_mode = "XYZ"
    return combine.outputs["Vector"]


def principled_textures(material: bpy.types.Material) -> dict[str, bpy.types.Image | ColorAttribute]:
    """{'Base Color': image or colour attribute, 'Roughness': image} of what feeds an existing
    material's Principled BSDF directly (what an artist's scan or texture set usually is: its
    images, or a scan's vertex colours read by a Color Attribute or Attribute node)."""
    found = {}
    if material is None or material.node_tree is None:
        return found
    for node in material.node_tree.nodes:
        if node.type != "BSDF_PRINCIPLED":
            continue
        for socket_name in ("Base Color", "Roughness"):
            links = node.inputs[socket_name].links
            source = links[0].from_node if links else None
            if source is not None and source.type == "TEX_IMAGE" and source.image is not None:
                found.setdefault(socket_name, source.image)
            elif socket_name == "Base Color" and source is not None:
                name = {"VERTEX_COLOR": "layer_name", "ATTRIBUTE": "attribute_name"}.get(source.type)
                if name and getattr(source, name):
                    found.setdefault(socket_name, ColorAttribute(getattr(source, name)))
    return found


def connect_roughness_image(material: bpy.types.Material, image: bpy.types.Image) -> None:
    """Drive the porous group's roughness m of ``material`` by ``image`` (with a stone: the mean
    roughness its structure varies around)."""
    graph = Graph(material.node_tree)
    roughness = graph.node("ShaderNodeTexImage", depth=1, image=image)
    target = material.node_tree.nodes.get(STONE_NODE) or material.node_tree.nodes[GROUP_NODE]
    graph.connect(roughness.outputs["Color"], target.inputs["Roughness"])
