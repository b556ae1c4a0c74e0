"""The texture bakes of an export: the UV map each object is baked on, the bake materials (a
copy of each weathered material in the ambient light mode whose output is an Emission probe:
``Probe``), and the textures and PBR materials made of the baked weights (``Textures``,
``pbr_material``). The bakes themselves are ``scratch_scene.emit_bake``."""

import hashlib
import os

import bpy

import numpy as np

from ..blender import compat
from ..contracts import GROUP_NODE, safe_file_name, socket_name
from ..core import modes as weathering_modes
from ..core.modes import Input
from ..core.shader_math import Graph
from ..maps import lightmap
from ..shading import nodes
from .mapping import SPECULAR_COLOR_FACTOR, is_uniform, linear_to_srgb, texel_codes

#: Samples per texel of the EMIT bakes (an Emission closure bakes exactly; more only averages a texel).
BAKE_SAMPLES = 1
#: What a texel holds before a bake: texels it still holds afterwards are outside every UV island.
UNBAKED = -1.0
#: The three probes: the group output(s) each bakes (see Probe).
DIFFUSE, SPECULAR, WATER = "diffuse", "specular", "water"
#: The bake material's record of its weathered material's water levels ({socket: value}).
WATER_LEVELS_PROPERTY = "pw_export_water_levels"


def porous_node(material: "bpy.types.Material | None") -> "bpy.types.ShaderNodeGroup | None":
    """The "Porous" group node of a Porous Weathering material, or None."""
    tree = material.node_tree if material is not None else None
    node = tree.nodes.get(GROUP_NODE) if tree is not None else None
    if node is None or node.type != "GROUP" or node.node_tree is None:
        return None
    return node if {"Diffuse Weight", "Specular Weight"} <= set(node.outputs.keys()) else None


def water_modes() -> tuple[str, ...]:
    """The registered weathering modes that add the water lobe (``Mode.water_lobe``), in
    registry order: the modes a wet state adds."""
    return tuple(name for name in weathering_modes.names() if weathering_modes.get(name).water_lobe)


def water_levels() -> tuple[Input, ...]:
    """The inputs that set how far the water of each water-lobe mode reaches (its
    ``<mode>_level``): a wet state keeps the material's own, every other state sets them to 0."""
    return tuple(
        item for name in water_modes() for item in weathering_modes.get(name).inputs if item.name == f"{name}_level"
    )


#: The UV map the export makes on its copy of an object for its textures where the object's own
#: lightmap, which its baked maps are read through, was made for a smaller bake.
EXPORT_UV = "PW Export"


def bake_uv_map(mesh: "bpy.types.Mesh", size: int) -> tuple[str, bool]:
    """(the UV map of ``mesh``, the export's copy, to bake on, whether it was made now): one that
    can hold a bake at ``size``², else a new lightmap (as the map bake makes it). Where the
    object's own lightmap was made for a smaller bake (its faces, fine at that size, come too
    close at this one) its baked maps are still read through it, and the textures get a lightmap
    of their own, EXPORT_UV; one that holds a bake at no size (distorted since) is refused."""
    existing = lightmap.find_bakeable_uv_map(mesh, size)
    if existing is not None:
        return existing, False
    name = lightmap.LIGHTMAP_UV
    if name in mesh.uv_layers:
        geometry = lightmap.Geometry.of(mesh)
        uvs, areas = lightmap.corner_uvs(mesh, name)[geometry.corners], geometry.areas()
        sizes = [2**power for power in range(3, size.bit_length() - 1)]  # 8² up to half the size
        if not any(lightmap.check_uvs(uvs, areas, smaller).ok for smaller in sizes):
            raise ValueError(
                f"its UV map '{name}' holds a bake at no size (distorted since its maps were baked?): bake its "
                "maps again, or remove it to let the export make a new one"
            )
        name = EXPORT_UV
    lightmap.add_uv_map(mesh, name, lightmap.lightmap_uvs(mesh, size))
    return name, True


# --- the bake materials ---------------------------------------------------------------------


def bake_material(slot, name: str, metres_per_unit: float) -> "bpy.types.Material":
    """A copy of the slot's weathered material in the ambient mode (and with the water-lobe
    modes when the slot needs them), whose output is an Emission probe (Probe) and whose active
    node is an Image Texture (the bake's target); its structure at ``metres_per_unit``, the
    object's scene's (the bake's scene has a unit of its own)."""
    material = slot.material.copy()
    material.name = name
    tree = material.node_tree
    tree.animation_data_clear()  # the key light's and the unit's drivers, and any keyframed age
    for node in tree.nodes:
        if nodes.METRES_PER_UNIT in node.inputs:
            node.inputs[nodes.METRES_PER_UNIT].default_value = metres_per_unit
    old = tree.nodes[GROUP_NODE]
    group = tree.nodes.new("ShaderNodeGroup")
    # a stone's structure feeds its receptivity to a receptive group (docs/model.md §8.3), its
    # rivulets to one whose run-off gathers into them (§8.8)
    group.node_tree = nodes.weathered_group(
        slot.modes,
        nodes.AMBIENT,
        receptive=nodes.RECEPTIVITY in old.inputs,
        rivulets=nodes.RIVULET_SPACING in old.inputs,
    )
    for socket in old.inputs:
        target = group.inputs.get(socket.name)
        if target is None:  # the key light's direction or position
            continue
        if socket.is_linked:
            tree.links.new(socket.links[0].from_socket, target)
        else:
            target.default_value = socket.default_value
    own_water_levels = {
        level.socket: old.inputs[level.socket].default_value if level.socket in old.inputs else 1.0
        for level in water_levels()
    }
    tree.nodes.remove(old)
    group.name = group.label = GROUP_NODE
    _keep_only_what_feeds(tree, group)
    Probe.build(material, group, own_water_levels)
    return material


def _keep_only_what_feeds(tree, node):
    """Remove every node of ``tree`` that does not feed ``node`` (the old output, the drivers)."""
    keep, todo = {node.name}, [node]
    while todo:
        for socket in todo.pop().inputs:
            for link in socket.links:
                if link.from_node.name not in keep:
                    keep.add(link.from_node.name)
                    todo.append(link.from_node)
    for name in [n.name for n in tree.nodes if n.name not in keep]:
        tree.nodes.remove(tree.nodes[name])


class Probe:
    """The probe of a bake material: an Emission shader showing one pass (DIFFUSE: the Diffuse
    Weight; SPECULAR: (Specular Weight, m, water roughness); WATER: the Water Weight), and the
    state inputs (time, water levels)."""

    def __init__(self, material):
        self.material = material
        self.tree = material.node_tree
        self.group = self.tree.nodes[GROUP_NODE]
        self.emission = self.tree.nodes["PW Probe"]
        self.specular = self.tree.nodes["PW Specular"]
        self.image = self.tree.nodes["PW Target"]

    @classmethod
    def build(cls, material, group, own_water_levels):
        tree = material.node_tree
        graph = Graph(tree)
        channels = {"Red": group.outputs["Specular Weight"]}
        for channel, input_socket in (("Green", "Roughness"), ("Blue", "Water Roughness")):
            source = group.inputs.get(input_socket)
            if source is None:
                channels[channel] = 0.0
            elif source.is_linked:
                channels[channel] = source.links[0].from_socket
            else:
                channels[channel] = source.default_value
        specular = graph.node("ShaderNodeCombineColor", channels)
        specular.name = "PW Specular"
        emission = graph.node("ShaderNodeEmission", {"Color": group.outputs["Diffuse Weight"], "Strength": 1.0})
        emission.name = "PW Probe"
        output = graph.node("ShaderNodeOutputMaterial", {"Surface": emission.outputs[0]})
        output.is_active_output = True
        target = graph.node("ShaderNodeTexImage", depth=0)
        target.name = "PW Target"
        tree.nodes.active = target
        material[WATER_LEVELS_PROPERTY] = own_water_levels

    def show(self, pass_name):
        source = {
            DIFFUSE: self.group.outputs["Diffuse Weight"],
            SPECULAR: self.specular.outputs[0],
            WATER: self.group.outputs.get("Water Weight"),
        }[pass_name]
        colour = self.emission.inputs["Color"]
        if source is None:  # a slot without the water lobe: no water
            for link in colour.links:
                self.tree.links.remove(link)
            colour.default_value = (0.0, 0.0, 0.0, 1.0)
        else:
            self.tree.links.new(source, colour)

    def set_state(self, state):
        inputs = self.group.inputs
        if socket_name("time") in inputs:
            inputs[socket_name("time")].default_value = state.age
        own = self.material[WATER_LEVELS_PROPERTY]
        for socket in own.keys():
            if socket in inputs:
                inputs[socket].default_value = own[socket] if state.wet else 0.0


# --- textures and PBR materials -------------------------------------------------------------


class Textures:
    """The textures of one object: 8-bit PNG files in a folder of their own in ``folder``,
    loaded as Images (recorded in ``ledger``); a texture whose covered texels (some, always:
    the export checks) are all the same code is a factor instead, and identical textures are
    one Image."""

    def __init__(self, ledger, folder, object_name):
        self.ledger, self.object_name = ledger, object_name
        self.folder = ledger.folder(dir=folder)
        self.images = {}  # sha256 of the codes -> Image

    def colour(self, label, linear, covered):
        """A base colour: ("factor", linear RGB) or ("texture", sRGB Image)."""
        codes = texel_codes(linear_to_srgb(linear), covered)
        if is_uniform(codes, covered):
            return ("factor", tuple(float(v) for v in linear[covered].mean(axis=0)))
        return ("texture", self._image(label, codes, "sRGB"))

    def scalar(self, label, values, covered):
        """A roughness: ("factor", value) or ("texture", Non-Color Image, grey)."""
        codes = texel_codes(values[..., None], covered)
        if is_uniform(codes, covered):
            return ("factor", float(values[covered].mean()))
        return ("texture", self._image(label, codes[..., 0], "Non-Color"))

    def specular(self, label, values, covered):
        """The specular factor S: ("factor", S) or ("texture", S_max, Non-Color Image whose
        alpha is S / S_max, read as glTF reads specularTexture)."""
        top = float(values[covered].max())
        codes = texel_codes((values / top if top > 0.0 else values)[..., None], covered)
        if top == 0.0 or is_uniform(codes, covered):
            return ("factor", float(values[covered].mean()))
        rgba = np.repeat(codes, 4, axis=-1)
        return ("texture", top, self._image(label, rgba, "Non-Color"))

    def _image(self, label, codes, colorspace):
        key = hashlib.sha256(codes.tobytes() + str(codes.shape).encode() + colorspace.encode()).hexdigest()
        if key not in self.images:
            # the exporter names a glTF image after its file: "<object> <label>", in a folder per object
            path = os.path.join(self.folder, safe_file_name(f"{self.object_name} {label}") + ".png")
            _write_png(path, codes)
            image = self.ledger.add(bpy.data.images.load(path))
            image.name = f"{self.object_name} {label}"
            image.colorspace_settings.name = colorspace
            self.images[key] = image
        return self.images[key]


def _write_png(path, codes):
    import OpenImageIO as oiio

    codes = np.ascontiguousarray(codes if codes.ndim == 3 else codes[..., None])
    height, width, channels = codes.shape
    output = oiio.ImageOutput.create(path)
    if output is None or not output.open(path, oiio.ImageSpec(width, height, channels, oiio.UINT8)):
        raise OSError(f"cannot write the texture {path}: {oiio.geterror()}")
    written = output.write_image(codes)
    output.close()
    if not written:
        raise OSError(f"cannot write the texture {path}: {oiio.geterror()}")


def pbr_material(name: str, base: tuple, roughness: tuple, specular: tuple) -> "bpy.types.Material":
    """A Principled BSDF material built as Blender's glTF importer builds one: what the
    exporter writes back as baseColor, metallicRoughness and KHR_materials_specular. ``base``,
    ``roughness`` and ``specular`` are what ``Textures`` returns."""
    material = compat.new_material(name)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    principled = graph.node("ShaderNodeBsdfPrincipled", depth=3)
    graph.node("ShaderNodeOutputMaterial", {"Surface": principled.outputs["BSDF"]}, depth=4)
    inputs = principled.inputs
    inputs["Metallic"].default_value = 0.0
    inputs["IOR"].default_value = 1.5
    inputs["Specular Tint"].default_value = (SPECULAR_COLOR_FACTOR,) * 3 + (1.0,)
    if base[0] == "factor":
        inputs["Base Color"].default_value = (*base[1], 1.0)
    else:
        graph.connect(_texture(graph, base[1]).outputs["Color"], inputs["Base Color"])
    if roughness[0] == "factor":
        inputs["Roughness"].default_value = roughness[1]
    else:
        channels = graph.node("ShaderNodeSeparateColor", {"Color": _texture(graph, roughness[1]).outputs["Color"]})
        graph.connect(channels.outputs["Green"], inputs["Roughness"])
    # glTF specular (F0 = F90 = S) is Blender's Specular IOR Level S / 2 (the importer's mapping)
    if specular[0] == "factor":
        inputs["Specular IOR Level"].default_value = 0.5 * specular[1]
    else:
        alpha = _texture(graph, specular[2]).outputs["Alpha"]
        level = graph.node("ShaderNodeMath", {0: alpha, 1: 0.5 * specular[1]}, operation="MULTIPLY")
        graph.connect(level.outputs[0], inputs["Specular IOR Level"])
    return material


def _texture(graph, image):
    return graph.node("ShaderNodeTexImage", depth=0, image=image, interpolation="Linear", extension="EXTEND")
