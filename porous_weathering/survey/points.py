"""The points a survey classifies (docs/model.md §10): sample points on every triangle of an
object's mesh as rendered, each standing for an equal share of its triangle's true area in m²,
and the weathered material's inputs at them, read as the material reads them: a socket's value,
a colour attribute (point or corner) or an image at the point's UV (bilinear, extended at the
edges, as the mask's Image Texture node), the stone's structure as its mean."""

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import bpy

import numpy as np

from ..blender import mesh_arrays, scratch_scene
from ..contracts import MODES_PROPERTY, STONE_NODE
from ..core import model
from ..core import modes as weathering_modes
from ..core.colorimetry import srgb_to_linear
from ..core.vectors import cross
from ..publish.textures import porous_node
from ..shading.material import metres_per_unit
from ..shading.weathering import image_uv_map

#: Sample points per object: each triangle gets k² of them, k chosen so that the whole surface
#: has about this many (at most MAX_SPLIT² per triangle, at least one). A front crossing a
#: triangle is then placed to 1/MAX_SPLIT of its height: 0.2% of a box's face (docs/model.md §10.2).
TARGET_SAMPLES = 1_000_000
MAX_SPLIT = 128

#: The stone's own inputs (docs/model.md §1) as the group names them, and the model's names.
STONE_INPUTS = {"kd": "Base Color", "ks": "Specular", "m": "Roughness", "alpha": "Porosity", "sp": "Pore Depth Ratio"}


def barycentric_centroids(k: int) -> np.ndarray:
    """(k², 3) barycentric coordinates of the centroids of the k² equal triangles that split a
    triangle k times along each edge: each stands for 1/k² of its area, exactly."""
    up = [((i + 1 / 3) / k, (j + 1 / 3) / k) for i in range(k) for j in range(k - i)]
    down = [((i + 2 / 3) / k, (j + 2 / 3) / k) for i in range(k - 1) for j in range(k - 1 - i)]
    second = np.array(up + down, dtype=np.float64).reshape(-1, 2)
    return np.column_stack([1.0 - second.sum(axis=1), second])


def sub_triangles(k: int) -> np.ndarray:
    """(k², 3, 3) barycentric corners of the k² equal triangles that split a triangle k times along
    each edge, in the order of ``barycentric_centroids`` and wound as the triangle is."""
    up = [[(i, j), (i + 1, j), (i, j + 1)] for i in range(k) for j in range(k - i)]
    down = [[(i + 1, j), (i + 1, j + 1), (i, j + 1)] for i in range(k - 1) for j in range(k - 1 - i)]
    second = np.array(up + down, dtype=np.float64).reshape(-1, 3, 2) / k
    return np.concatenate([1.0 - second.sum(axis=-1, keepdims=True), second], axis=-1)


def small_triangles(found: "Surface", triangle: np.ndarray, part: np.ndarray, splits: np.ndarray) -> np.ndarray:
    """(m, 3, 3) world corners in metres of the small triangles ``part`` (an index into
    ``sub_triangles(k)``) of ``found``'s triangles ``triangle``, each split ``splits[triangle]``
    times along its edges: what each sample point stands for."""
    corners = np.empty((len(triangle), 3, 3))
    k_of = splits[triangle]
    for k in np.unique(k_of):
        chosen = k_of == k
        bary = sub_triangles(int(k))[part[chosen]]
        corners[chosen] = np.einsum("mkc,mjk->mjc", found.triangles_m[triangle[chosen]], bary)
    return corners


@dataclass
class Surface:
    """An object's mesh as rendered, in metres: its triangles' world corners ``triangles_m``
    (n, 3, 3), their corners' loop indices (n, 3), material slot (n,), areas in m² (n,) and
    unit normals (n, 3); its UV maps ({name: (corners, 2)}, "" the active render one) and colour
    attributes ({name: (corners, 3)}, linear RGB) per corner; and its origin in the
    world in metres (the Object Info node's Location: the shader's textures of the point's place
    are read from it, docs/model.md §8.2)."""

    triangles_m: np.ndarray
    loops: np.ndarray
    slots: np.ndarray
    areas_m2: np.ndarray
    normals: np.ndarray
    uv_maps: dict
    colour_attributes: dict
    origin_m: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def splits(self, target: int = TARGET_SAMPLES, triangles: np.ndarray | None = None) -> np.ndarray:
        """k per triangle (of ``triangles``, default all): about ``target`` sample points over
        them, by area."""
        areas = self.areas_m2 if triangles is None else self.areas_m2[triangles]
        wanted = np.sqrt(target * areas / max(float(areas.sum()), 1e-300))
        return np.clip(np.ceil(wanted), 1, MAX_SPLIT).astype(np.int64)


def surface(obj: "bpy.types.Object") -> Surface:
    """The ``Surface`` of ``obj`` as the render sees it (``scratch_scene.rendered``)."""
    scale = metres_per_unit()
    with scratch_scene.rendered(obj) as seen:
        mesh = seen.mesh
        mesh.calc_loop_triangles()
        count = len(mesh.loop_triangles)
        # Blender's own types (int32, float32): foreach_get copies them whole, and converts
        # element by element into any other (seconds on a scan)
        loops = np.empty(count * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("loops", loops)
        verts = np.empty(count * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", verts)
        slots = np.empty(count, dtype=np.int32)
        mesh.loop_triangles.foreach_get("material_index", slots)
        positions = mesh_arrays.attribute(mesh, "position", np.float32, 3).astype(np.float64)
        matrix = np.array(seen.matrix_world)
        world = (positions @ matrix[:3, :3].T + matrix[:3, 3]) * scale
        corner_vert = mesh_arrays.attribute(mesh, ".corner_vert", np.int32)
        uv_maps = {}
        for layer in mesh.uv_layers:
            uv_maps[layer.name] = mesh_arrays.attribute(mesh, layer.name, np.float32, 2).astype(np.float64)
        active = next((layer.name for layer in mesh.uv_layers if layer.active_render), None)
        if active is not None:
            uv_maps[""] = uv_maps[active]  # what an Image Texture without a UV Map node reads
        colours = {}
        for attribute in mesh.color_attributes:
            values = mesh_arrays.attribute(mesh, attribute.name, np.float32, 4)[:, :3].astype(np.float64)
            colours[attribute.name] = values[corner_vert] if attribute.domain == "POINT" else values
        # out of the object, as the render shades it (the bakes' rule)
        outward = -1.0 if mesh_arrays.winding_reversed(matrix, mesh_arrays.is_inside_out(mesh)) else 1.0
    triangles = world[verts.reshape(-1, 3)]
    area_vectors = outward * cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    doubled = np.linalg.norm(area_vectors, axis=1)
    normals = area_vectors / np.maximum(doubled, 1e-300)[:, None]
    origin = matrix[:3, 3] * scale
    return Surface(
        triangles,
        loops.reshape(-1, 3).astype(np.int64),
        slots.astype(np.int64),
        doubled / 2.0,
        normals,
        uv_maps,
        colours,
        origin,
    )


# --- a material's inputs at the points ---------------------------------------------------------

#: A reader: (triangle indices (n,), barycentric (s, 3)) -> values (n, s) or colours (n, s, 3).
Reader = Callable[[np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class Material:
    """A weathered material as the survey reads it: its modes and a reader per model input."""

    name: str
    modes: tuple
    readers: dict  #: model input ('kd', 'time', 'rain_map', ...) -> Reader
    sources: dict  #: model input -> what feeds it, for the paradata


def material_of(obj: "bpy.types.Object", index: int, found: Surface) -> Material:
    """The weathered material in slot ``index`` of ``obj``, read on its ``found`` surface;
    ValueError naming the object and slot when it is no Porous Weathering material."""
    material = obj.material_slots[index].material if index < len(obj.material_slots) else None
    group = porous_node(material)
    if group is None:
        what = f"material '{material.name}'" if material else "no material"
        raise ValueError(f"object '{obj.name}', slot {index + 1} has {what}, not a Porous Weathering material")
    modes = tuple(mode for mode in (material.get(MODES_PROPERTY) or "").split(",") if mode)
    modes = model.weathering_modes(modes)
    readers, sources = {}, {}
    wanted = dict(STONE_INPUTS)
    wanted.update({item.name: item.socket for item in weathering_modes.inputs_of(modes)})
    for name, socket in wanted.items():
        readers[name], sources[name] = _reader(obj, material, group.inputs[socket], found)
    return Material(material.name, modes, readers, sources)


def _reader(obj, material, socket, found):
    """(Reader, description) of what feeds ``socket``."""
    if not socket.is_linked:
        return _constant(socket.default_value), _value(socket.default_value)
    node = socket.links[0].from_node
    if node.type == "ATTRIBUTE":
        name = node.attribute_name
        values = found.colour_attributes.get(name)
        if values is None:  # the shader reads 0 where the attribute is missing
            return _constant(0.0), {"attribute": name, "missing": True}
        # a colour input reads the node's Color (a scan's vertex colours), any other its Fac, the average
        colour = socket.type == "RGBA"
        return _corners(values if colour else values.mean(axis=1), found, colour), {"attribute": name}
    if node.type == "TEX_IMAGE" and node.image is not None:
        uv_map = _uv_map_of(node)
        if uv_map not in found.uv_maps:
            raise ValueError(f"object '{obj.name}': material '{material.name}' reads a UV map it has not ({uv_map!r})")
        return _image(node.image, found.uv_maps[uv_map], found, socket.type == "RGBA"), {"image": node.image.name}
    if node.name == STONE_NODE and socket.name in node.inputs:  # the stone's structure: its mean
        return _reader(obj, material, node.inputs[socket.name], found)
    warnings.warn(
        f"material '{material.name}': {socket.name} is fed by a {node.bl_idname} the survey cannot read; "
        "taken as its value",
        stacklevel=3,
    )
    return _constant(socket.default_value), _value(socket.default_value)


def _value(value):
    return round(float(value), 6) if isinstance(value, float) else [round(v, 6) for v in tuple(value)[:3]]


def _constant(value):
    value = np.asarray(tuple(value)[:3] if hasattr(value, "__len__") else value, dtype=np.float64)
    return lambda triangles, bary: np.broadcast_to(value, (len(triangles), len(bary), *value.shape))


def _corners(per_loop, found, colour=False):
    """Per-corner values (corners,) or colours (corners, 3) read at barycentric ``bary`` (s, 3)
    of ``triangles`` (n,): (n, s) or (n, s, 3)."""

    def read(triangles, bary):
        at = per_loop[found.loops[triangles]]  # (n, 3) or (n, 3, 3)
        return np.einsum("nkc,sk->nsc", at, bary) if colour else at @ bary.T

    return read


def _uv_map_of(node):
    """The UV map an Image Texture reads: its UV Map node's, the image's own (baked maps), else
    the active render one ("")."""
    vector = node.inputs["Vector"]
    if vector.is_linked and vector.links[0].from_node.type == "UVMAP":
        return vector.links[0].from_node.uv_map
    return image_uv_map(node.image) or ""


def _image(image, uv, found, colour):
    width, height = image.size
    pixels = np.empty(width * height * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, image.channels)[..., :3].astype(np.float64)
    if colour and not image.is_float and image.colorspace_settings.name == "sRGB":
        pixels = srgb_to_linear(pixels)  # what the Image Texture node gives the shader
    if not colour:
        pixels = pixels.mean(axis=-1)

    def read(triangles, bary):
        at = np.einsum("nkc,sk->nsc", uv[found.loops[triangles]], bary)
        x = np.clip(at[..., 0] * width - 0.5, 0.0, width - 1.0)
        y = np.clip(at[..., 1] * height - 0.5, 0.0, height - 1.0)
        x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
        x1, y1 = np.minimum(x0 + 1, width - 1), np.minimum(y0 + 1, height - 1)
        fx, fy = x - x0, y - y0
        if colour:
            fx, fy = fx[..., None], fy[..., None]
        top = pixels[y0, x0] * (1 - fx) + pixels[y0, x1] * fx
        bottom = pixels[y1, x0] * (1 - fx) + pixels[y1, x1] * fx
        return top * (1 - fy) + bottom * fy

    return read
