"""Shared test helpers: render harnesses whose images are checked pixel by pixel against model.py.

- ``assert_matches`` and ``TOLERANCE``: a render against the image model.py predicts.
- ``LitSphere``: a sphere under one sun. A porous pixel must equal k_d,poro * D + k_s,poro * G,
  where D and G are renders of a white Lambert and a white GGX lobe of the same roughness under
  the same light, and the weights come from model.py at that pixel's shading normal (read from
  a probe render).
- ``MaskedPlane``: a plane under one sun, its weathering masks varying across it.
- ``STONE``, ``weathered``, ``lobes``, ``model_weights``, ``expected_image``: a weathered stone
  and the image model.weathered_coefficients predicts for it, k_d D + k_s G + k_water W (W: a
  white GGX of the water's roughness).
- ``paper_modes``: the modes as the paper writes them, without the layers beyond it (docs/model.md §6).
- ``rain_only_modes``: the modes as they were before run-off (docs/model.md §7): the rain map's E
  where they now read the water W, and no dirty streaks.
- ``stone_probe``, ``stone_parameters``, ``stone_glossy_lobe``: the per-point parameters a material's
  "Stone" node gives (k_d, alpha, s_p, m, receptivity), read back from renders of its outputs,
  and the white GGX lobe of its per-point roughness (docs/model.md §8).
- ``run_cli``: ``python -m porous_weathering COMMAND ...`` in a subprocess, as users run it.
- ``corner_values``: a baked colour attribute's value at every corner of a mesh.
- ``counted_probes``: the number of probes each of the map bakes' probe bakes makes.
- ``cycles_corner_bake``: Cycles' own bake of a direct-light sky at every face corner, the
  reference the map bakes' probes are checked against.
- ``registered_toys``: the toy mode and map of tests/toys/ added as a mode and a map are (the
  ``toys`` fixture).
- ``bust_mesh``, ``add_bust``: the scan-like bust of sample_blends/scan_generator.py, in
  millimetres, and the same bust added to the scene (the ``bust`` fixture of conftest.py).
"""

import contextlib
import dataclasses
import functools
import itertools
import os
import pathlib
import subprocess
import sys

import bpy

import numpy as np

import porous_weathering as pw
import porous_weathering.maps as maps_package
from benchmarks import probes
from porous_weathering.blender import mesh_arrays, render, scratch_scene
from porous_weathering.contracts import GROUP_NODE, STONE_NODE
from porous_weathering.core import model
from porous_weathering.core import modes as weathering_modes
from porous_weathering.core.backends import NumpyOps
from porous_weathering.core.modes import base as mode_base
from porous_weathering.core.modes import biological, soiling, wet
from porous_weathering.maps import registry as maps
from porous_weathering.maps import sky_bake
from porous_weathering.samples import studio
from porous_weathering.shading import nodes, weathering
from scripts import load_script

#: Cycles evaluates the node maths in float32 and stores float32 EXR: agreement to 1e-4
#: of the brightest pixel is far tighter than anything visible (1/255 = 4e-3).
TOLERANCE = 1e-4

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.08, roughness=0.6, porosity=0.35, pore_depth_ratio=2.5)
WATER_ROUGHNESS = 0.3  # a lobe wide enough to be seen under a sun of angle 0


def assert_matches(image, expected, mask, tolerance=TOLERANCE):
    assert mask.sum() > 200, "the check must cover the lit part of the sphere"
    assert np.isfinite(image).all()
    error = np.abs(image[..., :3] - expected)[mask]
    scale = max(float(expected[mask].max()), 1e-6)
    assert error.max() <= tolerance * scale, f"max error {error.max():.3g} vs scale {scale:.3g}"


class LitSphere:
    """A sphere under one sun, its shading normals read from a probe render."""

    def __init__(self, scene, towards=(0.5, 0.3, 0.8), size=48, samples=1, eevee=False):
        self.scene = scene
        self.sphere = studio.add_sphere(scene)
        self.sun = studio.add_sun(scene, towards)
        studio.add_ortho_camera(scene)
        if eevee:
            render.use_eevee(scene, size=size, samples=samples)
        else:
            render.use_cycles(scene, size=size, samples=samples)
        self.normals = self.probe_normals()

    def render(self, material):
        studio.assign(self.sphere, material)
        return render.render_array(self.scene)

    def probe_normals(self):
        """(H, W, 3) unit shading normals and an (H, W) mask of the covered pixels."""
        probe = self.render(probes.normal_probe())
        self.covered = probe[..., 3] > 0.999
        normals = probe[..., :3] * 2.0 - 1.0
        return normals / np.maximum(np.linalg.norm(normals, axis=-1, keepdims=True), 1e-9)

    def cosines(self):
        """(N.S, N.V) per pixel for the current sun direction."""
        towards = np.array(self.sun.matrix_world.to_3x3().col[2])
        return self.normals @ towards, self.normals @ np.array(probes.VIEW_DIRECTION)

    def lobes(self, roughness):
        """Renders of the white Lambert lobe D and the white GGX lobe G."""
        diffuse = self.render(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0, roughness=roughness))
        glossy = self.render(pw.make_base_material("G", base_color=(0, 0, 0), ks=1.0, roughness=roughness))
        return diffuse[..., :3], glossy[..., :3]

    def expected(self, kd, ks, m, alpha, sp, ambient=False):
        """The porous image model.py predicts, and the mask of lit, covered pixels."""
        n_dot_l, n_dot_v = self.cosines()
        diffuse, glossy = self.lobes(m)
        kd_poro, ks_poro = model.porous_coefficients(kd, ks, m, alpha, sp, None if ambient else n_dot_l, n_dot_v)
        image = kd_poro * diffuse + np.asarray(ks_poro)[..., None] * glossy
        return image, self.covered & (n_dot_l > 0.0)


class MaskedPlane:
    """A plane facing +Z under a tilted sun, its masks varying across it."""

    def __init__(self, scene, size=32):
        self.scene = scene
        self.plane = studio.add_plane(scene)
        self.sun = studio.add_sun(scene, (0.5, 0.3, 0.8))
        studio.add_ortho_camera(scene)
        render.use_cycles(scene, size=size, samples=1)

    def render(self, material):
        studio.assign(self.plane, material)
        return render.render_array(self.scene)

    def probe(self, source):
        """Per-pixel values of a mask source, read through the same nodes the material uses."""
        probe = probes.emission_probe("Mask Probe", lambda graph, geometry: weathering.mask_socket(graph, source))
        return self.render(probe)[..., 0]


def gradient_image(name, values):
    """A float image whose rows are ``values`` (a 2D array, top row last as Blender stores it)."""
    height, width = values.shape
    image = bpy.data.images.new(name, width, height, float_buffer=True, is_data=True)
    rgba = np.repeat(values[..., None], 4, axis=-1).astype(np.float32)
    rgba[..., 3] = 1.0
    image.pixels.foreach_set(rgba.ravel())
    return image


def weathered(name, modes, key_light=None, **state):
    """A weathered material on the test stone with the API's plain defaults (no environment), as
    model_weights takes them; the environments' values are held in tests/test_environments.py."""
    return pw.make_weathered_material(
        name, modes=modes, key_light=key_light, water_roughness=WATER_ROUGHNESS, environment=None, **STONE, **state
    )


def lobes(render_with, roughness):
    """White Lambert, white GGX at the stone's roughness and at the water's."""
    diffuse = render_with(pw.make_base_material("D", base_color=(1, 1, 1), ks=0.0, roughness=roughness))
    glossy = render_with(pw.make_base_material("G", base_color=(0, 0, 0), ks=1.0, roughness=roughness))
    water = render_with(pw.make_base_material("W", base_color=(0, 0, 0), ks=1.0, roughness=WATER_ROUGHNESS))
    return diffuse[..., :3], glossy[..., :3], water[..., :3]


def expected_image(weights, lobe_images):
    kd_w, ks_w, water_w = weights
    diffuse, glossy, water = lobe_images
    return kd_w * diffuse + np.asarray(ks_w)[..., None] * glossy + water_w * water


def model_weights(modes, n_dot_l, n_dot_v, **state):
    p = STONE
    return model.weathered_coefficients(
        p["base_color"], p["ks"], p["roughness"], p["porosity"], p["pore_depth_ratio"], n_dot_l, n_dot_v, modes, **state
    )


#: The layers beyond the paper (docs/model.md §6): the black crust and the wet darkening.
BEYOND_PAPER = (soiling.lay_crust, wet.darken_under_water)


@contextlib.contextmanager
def mode_variants(names, prefix, layers_of):
    """Registers, for the block, a copy of each mode of ``names`` named "<prefix>_<mode>" whose
    layers are ``layers_of(record)`` (its inputs unchanged). Yields those names."""
    records = [
        dataclasses.replace(
            weathering_modes.get(name), name=f"{prefix}_{name}", layers=layers_of(weathering_modes.get(name))
        )
        for name in names
    ]
    for record in records:
        weathering_modes.register(record)
    try:
        yield tuple(record.name for record in records)
    finally:
        for record in records:
            weathering_modes.unregister(record.name)


def paper_modes(names):
    """Each mode of ``names`` as the paper writes it: its own record without the layers beyond
    the paper, named "paper_<mode>" (a context manager yielding those names)."""
    return mode_variants(
        names, "paper", lambda mode: tuple(layer for layer in mode.layers if layer.apply not in BEYOND_PAPER)
    )


def _carbon_from_rain(xp, point):
    """Soiling's black area as docs/model.md §4.1 wrote it before run-off: sheltered from E."""
    s = point.state
    sheltered = soiling.sheltered_fraction(xp, s["rain_map"], s["rain_threshold"], s["front_width"])
    fill = mode_base.pore_fill(xp, s["edge_map"], s["time"], s["soiling_level"], s["front_width"])
    carbon = mode_base.local_share(xp, sheltered * fill, point.spread)
    ap = mode_base.filled_absorption(xp, point.ka, point.sp, carbon, point.theta_i, point.theta_r)
    polluted = soiling.polluted_diffuse(xp, point.kd, s["pollution_color"], point.pore, ap)
    point.kd_w = mode_base.blend(xp, point.kd_w, polluted, xp.channel(carbon))
    point.notes["sheltered"] = sheltered


def _deposit_without_streaks(xp, point):
    """The grey deposit alone (docs/model.md §4.1): one cover of coverage c (at the point of a stone,
    docs/model.md §8.6, §8.7)."""
    s = point.state
    coverage = soiling.deposit_coverage(point.notes["sheltered"], point.m, s["time"], s["soiling_level"])
    colour = soiling.deposit_seen(xp, point.kd, s["deposit_color"], point.variation)
    mode_base.cover(xp, point, colour, mode_base.local_share(xp, coverage, point.spread))


def _water_from_rain(xp, point):
    """The wet front as docs/model.md §4.2 wrote it before run-off: it sweeps E."""
    s = point.state
    fill = mode_base.pore_fill(xp, s["rain_map"], s["time"], s["wet_level"], s["front_width"])
    water = mode_base.local_share(xp, fill, point.spread)
    ap = mode_base.filled_absorption(xp, point.ka, point.sp, water, point.theta_i, point.theta_r)
    kd_wet, water_lobe = wet.wet_weights(xp, point.kd, xp.channel(s["water_specular"]), point.pore, ap)
    point.kd_w = mode_base.blend(xp, point.kd_w, kd_wet, xp.channel(water))
    point.water_w = xp.channel(water) * water_lobe
    point.notes["water"] = water


#: The layers that read the water W or lay the streaks, and what they were before run-off.
BEFORE_RUNOFF = {
    soiling.fill_with_carbon: _carbon_from_rain,
    soiling.lay_deposit: _deposit_without_streaks,
    wet.fill_with_water: _water_from_rain,
}


def rain_only_modes(names):
    """Each mode of ``names`` as it was before run-off (docs/model.md §7): its record with the
    layers of BEFORE_RUNOFF in place of today's, named "rain_only_<mode>" (its inputs unchanged,
    so the run-off ones are accepted and unused; a context manager yielding those names)."""
    return mode_variants(
        names,
        "rain_only",
        lambda mode: tuple(
            dataclasses.replace(layer, apply=BEFORE_RUNOFF.get(layer.apply, layer.apply)) for layer in mode.layers
        ),
    )


# --- the stone node's outputs, read back --------------------------------------------------------


def _surface_of_copy(material, surface):
    """A copy of ``material`` whose surface is ``surface(tree, stone_node)`` (a shader socket)."""
    copy = material.copy()
    tree = copy.node_tree
    output = next(node for node in tree.nodes if node.type == "OUTPUT_MATERIAL")
    tree.links.new(surface(tree, tree.nodes[STONE_NODE]), output.inputs["Surface"])
    return copy


def lichen_seed_probe(plane, density):
    """The lichens' seeds (biological.LICHEN_SEEDS: the nearest seed's distance in cells, value and size
    draw, then the second nearest's) per pixel of the plane facing +Z, from 2D Voronoi textures of the
    same seeds built here (docs/model.md §9.3: the x-y plane, shifted by the plane offset, ``density``
    seeds per m²; F1, then F2, each its Distance and its Color's red and blue), not through the shading
    code."""
    spacing = density**0.5

    def probe(feature):
        def build(graph, geometry):
            position = graph.node("ShaderNodeSeparateXYZ", {"Vector": geometry.outputs["Position"]})
            shifted = graph.wrap(position.outputs["Y"]) + biological.PLANE_OFFSET
            place = graph.node("ShaderNodeCombineXYZ", {"X": position.outputs["X"], "Y": shifted, "Z": 0.0})
            voronoi = graph.node(
                "ShaderNodeTexVoronoi",
                {"Vector": place.outputs[0], "Scale": spacing},
                voronoi_dimensions="2D",
                feature=feature,
            )
            draws = graph.node("ShaderNodeSeparateColor", {"Color": voronoi.outputs["Color"]})  # the cell's own
            emitted = {"X": voronoi.outputs["Distance"], "Y": draws.outputs["Red"], "Z": draws.outputs["Blue"]}
            return graph.node("ShaderNodeCombineXYZ", emitted).outputs[0]

        seeds = plane.render(probes.emission_probe(f"Seed Probe {feature}", build))
        return seeds[..., 0], seeds[..., 1], seeds[..., 2]

    return (*probe("F1"), *probe("F2"))


def stone_probe(render_with, material, outputs, shift=0.0):
    """(H, W, 3) of the ``outputs`` of ``material``'s stone node (a colour output alone, or up to
    three scalars), plus ``shift``, emitted by a copy of the material rendered by ``render_with``."""
    return render_with(_surface_of_copy(material, lambda tree, stone: _emitted(tree, stone, outputs, shift)))[..., :3]


def _emitted(tree, stone, outputs, shift=0.0):
    """An Emission of the stone node's ``outputs`` (a colour output alone, or up to three
    scalars), plus ``shift``."""
    if len(outputs) == 1:
        return _emission(tree, stone.outputs[outputs[0]], shift)
    combine = tree.nodes.new("ShaderNodeCombineXYZ")
    for index, name in enumerate(outputs):
        tree.links.new(stone.outputs[name], combine.inputs[index])
    return _emission(tree, combine.outputs[0], shift)


def _emission(tree, value, shift=0.0):
    """An Emission of strength 1 of the socket ``value`` plus ``shift`` (an emission is not
    negative: a signed value is emitted shifted up)."""
    if shift:
        add = tree.nodes.new("ShaderNodeVectorMath")
        add.inputs[1].default_value = (shift, shift, shift)
        tree.links.new(value, add.inputs[0])
        value = add.outputs[0]
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(value, emission.inputs["Color"])
    return emission.outputs[0]


def stone_shifted(render_with, material, socket):
    """(H, W) of a field output of the stone node, in [-1, 1]: emitted shifted by +1 (an
    emission is not negative)."""
    return stone_probe(render_with, material, (socket,), shift=1.0)[..., 0] - 1.0


def stone_parameters(render_with, material, extra=()):
    """The per-pixel parameters ``material``'s stone node gives: {kd, alpha, sp, m, r} and up to
    two ``extra`` scalar outputs (keyed by their socket names), in three probe renders."""
    alpha, m, sp = np.moveaxis(stone_probe(render_with, material, ("Porosity", "Roughness", "Pore Depth Ratio")), -1, 0)
    scalars = (nodes.RECEPTIVITY, *extra, *extra[-1:] * (2 - len(extra)))  # padded to three outputs
    r, *others = np.moveaxis(stone_probe(render_with, material, scalars), -1, 0)
    kd = stone_probe(render_with, material, ("Base Color",))
    return dict(kd=kd, alpha=alpha, m=m, sp=sp, r=r, **{name: value for name, value in zip(extra, others)})


def stone_weights(stone, ks, n_dot_l, n_dot_v, modes, variation, **state):
    """model.weathered_coefficients at the stone's per-point values read back from a render
    (``stone_parameters`` with its porosity field as ``z_p``: ``stone_shifted``)."""
    return model.weathered_coefficients(
        stone["kd"], ks, stone["m"], stone["alpha"], stone["sp"], n_dot_l, n_dot_v, modes,
        receptivity=stone["r"], field=stone["z_p"], variation=variation, **state,
    )  # fmt: skip


def stone_texels(obj, outputs, size, shift=0.0):
    """(size, size, 3), top row first: the ``outputs`` of the stone node of ``obj``'s material
    (as ``stone_probe`` emits them) at the texel centres of its active UV map (``texel_bake``);
    emitted ``shift`` up (an emission is not negative) and given back without it."""
    return texel_bake(obj, lambda tree, stone: _emitted(tree, stone, outputs, shift), size) - shift


def position_texels(obj, size, shift):
    """(size, size, 3), top row first: the world position at the texel centres of ``obj``'s active
    UV map (``texel_bake``), emitted ``shift`` up (an emission is not negative): the very points
    a texture's texels hold, where the bake's own rasterising of the UV map puts them."""

    def emit(tree, stone):
        return _emission(tree, tree.nodes.new("ShaderNodeNewGeometry").outputs["Position"], shift)

    return texel_bake(obj, emit, size) - shift


def texel_bake(obj, surface, size):
    """(size, size, 3), top row first: what a copy of ``obj``'s material whose surface is
    ``surface(tree, stone_node)`` emits at the texel centres of its active UV map, by the exact
    one-sample Cycles EMIT bake the glTF export bakes its textures with."""
    with scratch_scene.Ledger() as made:
        probe = made.add(_surface_of_copy(obj.active_material, surface))
        image = made.add(bpy.data.images.new("Texels", size, size, alpha=True, float_buffer=True))
        target = probe.node_tree.nodes.new("ShaderNodeTexImage")
        target.image = image
        probe.node_tree.nodes.active = target
        copy = scratch_scene.placed_copy(obj, scratch_scene.temporary_scene(made, "Texels"), probe, ledger=made)
        return scratch_scene.emit_bake(copy, image)[..., :3].astype(np.float64)


def rivulets_of(material, points, normals, obj, scene):
    """The model's ``rivulets`` (docs/model.md §8.8) of ``material`` at world ``points`` (units) with
    unit ``normals`` on ``obj``: the place across the fall line in metres from the object's
    origin, the normals' horizontal part and the material's rivulet spacing; None where its group
    has no rivulets (no stone, or no run-off map)."""
    group = material.node_tree.nodes[GROUP_NODE]
    if nodes.RIVULET_SPACING not in group.inputs:
        return None
    metres = (points - np.array(obj.matrix_world.translation)) * scene.unit_settings.scale_length
    scalar = NumpyOps(colour=False)
    across, horizontal = mode_base.fall_line(scalar, metres, normals)
    return across, horizontal, group.inputs[nodes.RIVULET_SPACING].default_value


def stone_glossy_lobe(render_with, material):
    """A white GGX lobe whose roughness is ``material``'s per-point m (its stone node's)."""

    def glossy(tree, stone):
        lobe = tree.nodes.new("ShaderNodeBsdfGlossy")
        lobe.distribution = "GGX"
        lobe.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
        tree.links.new(stone.outputs["Roughness"], lobe.inputs["Roughness"])
        return lobe.outputs[0]

    return render_with(_surface_of_copy(material, glossy))[..., :3]


# --- the command line -------------------------------------------------------------------------

ROOT = pathlib.Path(__file__).resolve().parent.parent


def cli_command(command, *args):
    """The words of ``python -m porous_weathering COMMAND ARGS`` (arguments made strings)."""
    return [sys.executable, "-m", "porous_weathering", command, *map(str, args)]


def temporary_env(folder):
    """This process's environment with ``folder`` (made if need be) as the system's temporary
    folder (TMPDIR): what a child process leaves there, and not in the system's, can be checked."""
    pathlib.Path(folder).mkdir(parents=True, exist_ok=True)
    return {**os.environ, "TMPDIR": str(folder)}


def run_cli(command, *args, timeout=120, temporary=None):
    """Runs ``python -m porous_weathering COMMAND ARGS`` from the repository root, its output
    captured; with ``temporary``, that folder as its system temporary folder (``temporary_env``).
    Its environment is ``os.environ``, as a shell gives it: not what Blender set in this process's
    own (OCIO, once its colour management has started: the command would log "Using OCIO=..."
    among its output lines)."""
    env = dict(os.environ) if temporary is None else temporary_env(temporary)
    return subprocess.run(
        cli_command(command, *args), cwd=ROOT, capture_output=True, text=True, timeout=timeout, env=env
    )


# --- the scan-like bust -----------------------------------------------------------------------

SCAN = load_script("sample_blends/scan_generator.py")


@functools.cache
def bust_mesh(triangles=20_000, scan_noise=True):
    """(vertices, faces) of the scan-like bust of ~``triangles`` faces, in millimetres, seed 0;
    without ``scan_noise`` the 1.2-4 mm noise field is left out (its 20-80 mm erosion relief stays:
    the same random draws either way). Built once per argument set (read-only arrays)."""
    generator_noise = SCAN._fourier_noise

    def noise(points, rng, terms, shortest, longest, rms):
        values = generator_noise(points, rng, terms, shortest, longest, rms)  # the same draws either way
        return values if scan_noise or shortest > 10.0 else np.zeros_like(values)

    SCAN._fourier_noise = noise
    try:
        vertices, faces = SCAN.bust_mesh(triangles, seed=0)
    finally:
        SCAN._fourier_noise = generator_noise
    vertices.flags.writeable = faces.flags.writeable = False
    return vertices, faces


def add_bust(triangles=20_000, name="Bust", *, scale=1.0, rotation=(0.0, 0.0, 0.0), scan_noise=True):
    """The bust of ``bust_mesh(triangles, scan_noise)``, scaled from millimetres by ``scale`` and
    rotated by the Euler angles ``rotation``, as a new object ``name`` in the scene, whose unit
    scale says so (0.001 / ``scale`` metres per unit: a scan's unit, docs/model.md §8.4)."""
    vertices, faces = bust_mesh(triangles, scan_noise)
    bpy.context.scene.unit_settings.scale_length = 0.001 / scale
    obj = SCAN.add_to_scene(name, vertices * scale, faces)
    obj.rotation_euler = rotation
    bpy.context.view_layer.update()
    return obj


def corner_values(obj, name):
    """The first channel of the colour attribute ``name`` of ``obj``'s mesh at every corner
    (a point attribute read through each corner's vertex)."""
    attribute = obj.data.color_attributes[name]
    values = np.empty(len(attribute.data) * 4, np.float32)
    attribute.data.foreach_get("color", values)
    values = values[0::4]
    if attribute.domain == "POINT":
        values = values[mesh_arrays.attribute(obj.data, ".corner_vert", np.int32)]
    return values


def counted_probes(monkeypatch):
    """A list that gets the number of points of every ``sky_bake._bake_probes`` call from now on."""
    probes = []
    original = sky_bake._bake_probes

    def counted(copy, points, *rest):
        probes.append(len(points))
        return original(copy, points, *rest)

    monkeypatch.setattr(sky_bake, "_bake_probes", counted)
    return probes


def cycles_corner_bake(obj, sky, occluders=()):
    """``sky`` (a ``sky_bake.Sky``) baked by Cycles itself at every face corner of ``obj``
    (target VERTEX_COLORS, each corner at its vertex on its face), in the maps' bake scene:
    float32 (len(mesh.loops),)."""
    with sky_bake._bake_scene(obj, occluders, sky, sky_bake.unit_placing(obj)) as copy:
        attribute = copy.data.color_attributes.new("PW Corner Reference", "FLOAT_COLOR", "CORNER")
        copy.data.color_attributes.active_color = attribute
        scratch_scene.bake_alone(
            copy, type="DIFFUSE", pass_filter={"DIRECT"}, target="VERTEX_COLORS", margin=0, use_clear=True
        )
        colours = np.empty(len(attribute.data) * 4, dtype=np.float32)
        attribute.data.foreach_get("color", colours)
    return colours[0::4].copy()


# --- a toy mode and a toy map: one module each is enough (the ``toys`` fixture) ---------------

#: The toy mode's module (modes/grime.py) and the toy map's (maps/toy.py).
TOYS = pathlib.Path(__file__).resolve().parent / "toys"


@contextlib.contextmanager
def registered_toys():
    """The toy mode and the toy map added as a mode and a map are: their folders put on the paths
    of core/modes/ and maps/, where the registries find each module's record."""
    folders = ((weathering_modes, str(TOYS / "modes")), (maps_package, str(TOYS / "maps")))
    for package, folder in folders:
        package.__path__.append(folder)
    try:
        weathering_modes.discover()
        maps.discover()
        yield
    finally:
        for package, folder in folders:
            package.__path__.remove(folder)
        weathering_modes.discover()
        maps.discover()


# --- every node group the package builds ----------------------------------------------------


def weathered_mode_sets():
    """Every non-empty set of the registered weathering modes, in registry order."""
    names = weathering_modes.names()
    return [modes for size in range(1, len(names) + 1) for modes in itertools.combinations(names, size)]


def presets_row(section: str, label: str) -> list[str]:
    """The cells of the row of ``label`` in the first table after the heading ``section`` of
    docs/presets.md (``"## Masonry"``)."""
    text = (ROOT / "docs" / "presets.md").read_text(encoding="utf-8")
    row = next(line for line in text.split(section, 1)[1].splitlines() if line.startswith(f"| {label} |"))
    return [cell.strip() for cell in row.strip("|").split("|")]


class _Recorder:
    """A stand-in for a panel's layout that records what is drawn (no window is open here)."""

    def __init__(self, calls):
        object.__setattr__(self, "calls", calls)

    def __getattr__(self, name):
        def draw(*args, **kwargs):
            self.calls.append((name, args))
            return _Recorder(self.calls)

        return draw

    def __setattr__(self, name, value):  # use_property_split, an operator's properties, ...
        pass


def panel_calls(context=None):
    """[(layout call, its positional arguments)] of the panel drawn for ``context`` (default: the
    current one), e.g. ("operator", ("porous_weathering.export_variants",)) or ("prop", (socket,
    "default_value"))."""
    from porous_weathering.ui import panel

    calls = []
    panel.draw_panel(_Recorder(calls), context or bpy.context)
    return calls
