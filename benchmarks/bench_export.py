"""Publishing weathered states (docs/export.md): speed, accuracy of the glTF mapping, and the picture.

    python benchmarks/bench_export.py speed [--size 2048]
    python benchmarks/bench_export.py accuracy [--size 1024] [--height 240] [--samples 256]
    python benchmarks/bench_export.py picture [--size 1024] [--out docs/images/export_variants.png]
    python benchmarks/bench_export.py lobes [--height 48] [--samples 512]
    python benchmarks/bench_export.py water [--height 48] [--samples 512]

speed: the export of the façade sample (sample_blends/limestone_facade.blend, its 11 objects,
soiling at ages 0, 0.5, 1 and wet) at ``--size``², per stage (the lightmaps, the bakes of each
texture, the textures, the write), and a plain Cycles bake of the same textures (the weathered
material's DIFFUSE and GLOSSY colour passes, two per state as the export's probes, plus its
water lobe for the wet state, on the same UV maps at the same size) in the same run, for the
ratio. The machine is shared: the load average is printed with the numbers.

accuracy: each sample scene exported, re-imported with Blender's glTF importer (its Principled
BSDF materials, as a viewer builds them) and rendered beside the node material in the ambient
mode (what the export bakes), in Cycles under the same neutral sky, for each variant: the RMSE
over the objects' pixels as a share of the node render's mean, and the same for two renders
of the node material with different seeds (the noise floor of the comparison).

picture: the exported façade, re-imported and rendered under the neutral sky, one column per
variant (the docs picture).

lobes: the roughness of the one glossy lobe that carries the stone's and the water's (``lobes``).

water: the water lobe weighted by water's Fresnel reflectance (wet_darkening), against the
mapping, a Fresnel rise in its one lobe and a clearcoat (``water``).
"""

import argparse
import dataclasses
import os
import pathlib
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import bpy  # noqa: E402

import machine  # noqa: E402  (benchmarks/machine.py)
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

from porous_weathering.blender import compat, render, scratch_scene
from porous_weathering.core import model
from porous_weathering.core.modes.wet import WATER_NORMAL_REFLECTANCE  # noqa: E402
from porous_weathering.core.shader_math import Graph  # noqa: E402
from porous_weathering.publish import export, mapping, textures
from porous_weathering.samples import demo
from porous_weathering.shading import weathering  # noqa: E402

AGES = (0.0, 0.5, 1.0)
#: The sample scenes exported: each ages by soiling (the weathering every one of them has a
#: recipe for) and has a wet variant (its rain map).
SCENES = (demo.FACADE, "brick_wall", "sculpted_stone")
#: The neutral sky: zenith, horizon and ground radiance (linear RGB), a soft overcast daylight.
ZENITH, HORIZON, GROUND = (0.55, 0.62, 0.75), (1.0, 1.0, 0.97), (0.32, 0.30, 0.27)


def prepare(name, work, bake_samples=32):
    """The sample ``name`` opened with its maps baked (attributes), its objects given their
    soiling material (sun mode, as the panel's Make gives it) and saved in ``work``. The objects
    are the .blend's own: the main job's union of the façade into one object (its recipe's
    ``unite``) is not made, as the lightmap cannot be made for that union yet (docs/export.md)."""
    demo.RECIPES[name] = dataclasses.replace(demo.RECIPES[name], unite=None)
    sample = demo.Sample(name, map_dir=str(work), bake_samples=bake_samples)
    sample.show(model.SOILING, 0.0)
    bpy.ops.wm.save_as_mainfile(filepath=str(work / f"{name}.blend"))
    return sample


def neutral_sky(scene):
    """A world of ZENITH overhead fading to HORIZON, and GROUND below the horizon."""
    world = bpy.data.worlds.new("Neutral Sky")
    compat.use_world_nodes(world)
    tree = world.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    up = graph.node("ShaderNodeSeparateXYZ", {"Vector": graph.node("ShaderNodeTexCoord").outputs["Generated"]})
    height = up.outputs["Z"]
    sky = graph.node("ShaderNodeMix", {"Factor": height, "A": (*HORIZON, 1.0), "B": (*ZENITH, 1.0)}, data_type="RGBA")
    below = graph.node("ShaderNodeMath", {0: height, 1: 0.0}, operation="LESS_THAN")
    colour = graph.node(
        "ShaderNodeMix", {"Factor": below.outputs[0], "A": sky.outputs[2], "B": (*GROUND, 1.0)}, data_type="RGBA"
    )
    graph.node(
        "ShaderNodeOutputWorld",
        {"Surface": graph.node("ShaderNodeBackground", {"Color": colour.outputs[2]}).outputs[0]},
    )
    scene.world = world
    for obj in scene.objects:
        if obj.type == "LIGHT" or obj.name == "Ground":
            obj.hide_render = True


def import_variants(path):
    """Import a .glb; {variant name: {imported object: material}}."""
    preferences = bpy.context.preferences.addons["io_scene_gltf2"].preferences
    if not preferences.KHR_materials_variants_ui:  # setting it again registers the add-on's classes again
        preferences.KHR_materials_variants_ui = True
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=str(path))
    names = [item.name for item in bpy.data.scenes[0].gltf2_KHR_materials_variants_variants]
    variants = {name: {} for name in names}
    for obj in set(bpy.data.objects) - before:
        for entry in obj.data.gltf2_variant_mesh_data:
            for item in entry.variants:
                variants[names[item.variant.variant_idx]][obj] = entry.material
    return variants


def node_material(sample, state):
    """The weathered material of ``state`` in the ambient mode, made with the public API (the
    reference the export's textures are compared with): the sample's stone, laid in its masonry, as
    the exported material has it."""
    modes = (model.SOILING, model.WET) if state.wet else (model.SOILING,)
    masks = {mask: sample.sources[map_name] for mask, map_name in sample.recipe.masks[model.SOILING].items()}
    inputs = {name: value for mode in modes for name, value in sample.inputs(mode).items()}
    return weathering.make_weathered_material(
        f"{sample.name} {state.name} reference",
        modes=modes,
        key_light=None,
        time=state.age,
        environment=sample.recipe.environment,
        stone=sample.recipe.stone,
        masonry=sample.recipe.masonry,
        **sample.stone,
        **masks,
        **inputs,
    )


def show(objects, material_of):
    for obj in objects:
        obj.hide_render = material_of is None
        if material_of is not None:
            for slot in obj.material_slots:
                slot.link = "OBJECT"
                slot.material = material_of(obj)


def rmse_share(image, reference):
    """RMSE of ``image`` against ``reference`` over the pixels both cover, over the reference's mean."""
    both = (image[..., 3] > 0.999) & (reference[..., 3] > 0.999)
    difference = image[both, :3] - reference[both, :3]
    return float(np.sqrt(np.mean(difference**2)) / np.mean(reference[both, :3]))


def accuracy(args):
    """The table of docs/export.md, "Error": the node render (seed 0) against the published one
    (seed 1), and against itself with seed 1 (the noise floor, per variant: the relative noise
    changes with the variant); with independent noise of the same size in both, the
    mapping's own error is sqrt(raw² - floor²)."""
    print(machine.describe(bpy.app.version_string))
    print(f"textures {args.size}², pictures {args.height} px high, {args.samples} samples, 2 bounces, neutral sky")
    print("| sample | variant | RMSE / mean | noise floor | mapping error |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="pw_bench_export_") as folder:
        work = pathlib.Path(folder)
        for name in args.scenes:
            sample = prepare(name, work)
            result = export.export_variants(sample.objects, AGES, wet=True, size=args.size, out_dir=str(work))
            scene = sample.scene
            neutral_sky(scene)
            sample.use_cycles(args.height, args.samples)
            scene.cycles.use_denoising = False
            scene.cycles.max_bounces = 2
            imported = import_variants(result.path)
            for state in export.states(AGES, True):
                reference = node_material(sample, state)
                show(imported[state.name], None)
                show(sample.objects, lambda _obj, reference=reference: reference)
                node = render_with_seed(scene, 0)
                floor = rmse_share(render_with_seed(scene, 1), node)
                show(sample.objects, None)
                show(imported[state.name], imported[state.name].get)
                raw = rmse_share(render_with_seed(scene, 1), node)
                show(imported[state.name], None)
                mapping = np.sqrt(max(raw**2 - floor**2, 0.0))
                print(f"| {name} | {state.name} | {100 * raw:.1f}% | {100 * floor:.1f}% | {100 * mapping:.1f}% |")


def render_with_seed(scene, seed):
    scene.cycles.seed = seed
    return render.render_array(scene)


def lobes(args):
    """One glossy lobe for the stone's and the water's: the choice of its roughness. A vertical
    wall seen from eye level under the neutral sky (its horizon is the sharpest thing a wet wall
    reflects), the node material's two lobes (limestone k_s 0.03, m 0.6; water m 0.05) against
    the Principled BSDF of the mapping with each candidate roughness, for three water weights."""
    scene, wall = _eye_level_wall(args)
    kd, ks, m, m_water = WALL_STONE
    candidates = {
        "alphas by weight": lambda w: np.sqrt((ks * m**2 + w * m_water**2) / (ks + w)),
        "roughness by weight": lambda w: (ks * m + w * m_water) / (ks + w),
        "alphas by weight² (the mapping)": lambda w: export.pbr_from_weights(kd, ks, (w, w, w), m, m_water)[2],
        "the water's": lambda w: m_water,
    }
    print(machine.describe(bpy.app.version_string))
    print(f"{args.height} px, {args.samples} samples; RMSE / mean against the two lobes")
    print("| roughness | " + " | ".join(f"water {w}" for w in (0.05, 0.15, 0.3)) + " |")
    print("|---|---|---|---|")
    rows = {name: [] for name in candidates}
    for w in (0.05, 0.15, 0.3):
        tree = _two_lobes(wall, kd, ks, m, w, m_water)
        reference = render.render_array(scene)
        base, specular, _ = export.pbr_from_weights(kd, ks, (w, w, w), m, m_water)
        for name, roughness in candidates.items():
            _principled(tree, base, float(specular), float(roughness(w)))
            rows[name].append(f"{100 * rmse_share(render.render_array(scene), reference):.1f}%")
    for name, cells in rows.items():
        print(f"| {name} | " + " | ".join(cells) + " |")


#: The water lobe's weights W of the water study (its weight at grazing views: the filled pores' share).
WATER_WEIGHTS = (0.05, 0.15, 0.3)
#: The stone of the lobes and water studies: limestone k_d, k_s 0.03, m 0.6; water roughness 0.05.
WALL_STONE = (np.array([0.35, 0.32, 0.27]), 0.03, 0.6, 0.05)


def _eye_level_wall(args):
    """An empty scene under the neutral sky with a 4 m vertical wall seen from eye level, 6 m
    away and a little to the side (N.V from about 0.2 to 1): (scene, wall)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    neutral_sky(scene)
    wall = bpy.data.objects.new("Wall", bpy.data.meshes.new("Wall"))
    wall.data.from_pydata([(-2, 0, 0), (2, 0, 0), (2, 0, 4), (-2, 0, 4)], [], [(0, 1, 2, 3)])
    scene.collection.objects.link(wall)
    camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    camera.data.lens = 30.0
    camera.location, camera.rotation_euler = (1.5, -6.0, 1.2), (np.radians(88.0), 0.0, np.radians(14.0))
    scene.collection.objects.link(camera)
    scene.camera = camera
    render.use_cycles(scene, size=args.height, samples=args.samples, bounces=1, pixel_filter=1.5)
    return scene, wall


def water(args):
    """The water lobe with water's Fresnel reflectance (wet_darkening 1): the node material's
    lobes, the water's weighted by W F(N.V) (F Schlick's, 2% face on), against what a glTF
    material can make of them, on the eye-level wall: the mapping (one lobe, F0 = F90 =
    k_s + w0 with w0 = W F0 the face-on weight the bake sees), a Fresnel rise in the one lobe
    (F0 = k_s + w0, F90 = k_s + W: a specular colour of F0 / (0.04 F90)), and the water as
    KHR_materials_clearcoat (F0 0.04, F90 1, its own roughness) of weight W F0 / 0.04 (its
    face-on reflectance right) or W (its grazing one). The noise floor is the node material
    rendered with another seed."""
    scene, wall = _eye_level_wall(args)
    kd, ks, m, m_water = WALL_STONE
    f0_water = WATER_NORMAL_REFLECTANCE
    print(machine.describe(bpy.app.version_string))
    print(f"{args.height} px, {args.samples} samples; RMSE / mean against the node lobes (water weighted by F)")
    print("| glTF material | " + " | ".join(f"W {w}" for w in WATER_WEIGHTS) + " |")
    print("|---|---|---|---|")
    rows = {}
    for w in WATER_WEIGHTS:
        tree = _two_lobes(wall, kd, ks, m, w, m_water, fresnel=f0_water)
        reference = render_with_seed(scene, 0)
        rows.setdefault("noise floor (the node material, another seed)", []).append(
            rmse_share(render_with_seed(scene, 1), reference)
        )
        face_on = w * f0_water
        base, specular, roughness = export.pbr_from_weights(kd, ks, (face_on,) * 3, m, m_water)
        stone_base, stone_specular, stone_roughness = export.pbr_from_weights(kd, ks, (0.0,) * 3, m, m_water)
        rise_f0, rise_f90 = ks + face_on, ks + w
        candidates = {
            "one lobe, F0 = F90 = k_s + w0 (the mapping)": dict(
                base=base, specular=float(specular), roughness=float(roughness)
            ),
            "one lobe, F0 = k_s + w0, F90 = k_s + W": dict(
                base=np.minimum(kd / (1.0 - rise_f0), 1.0),
                specular=rise_f90,
                roughness=float(roughness),
                tint=rise_f0 / (mapping.DIELECTRIC_F0 * rise_f90),
            ),
        }
        for label, coat in (("W F0 / 0.04", face_on / mapping.DIELECTRIC_F0), ("W", w)):
            candidates[f"clearcoat of weight {label}"] = dict(
                base=np.minimum(stone_base / (1.0 - mapping.DIELECTRIC_F0 * coat), 1.0),
                specular=float(stone_specular),
                roughness=float(stone_roughness),
                coat=coat,
                coat_roughness=m_water,
            )
        for name, material in candidates.items():
            _principled(tree, **material)
            rows.setdefault(name, []).append(rmse_share(render_with_seed(scene, 1), reference))
    for name, cells in rows.items():
        print(f"| {name} | " + " | ".join(f"{100 * cell:.1f}%" for cell in cells) + " |")


def _two_lobes(obj, kd, ks, m, water, m_water, fresnel=None):
    """Give ``obj`` a material of Lambert k_d + GGX(m) k_s + GGX(m_water) water (the porous
    material's lobes, weights fixed; with ``fresnel`` = F0, the water's weight times Schlick's
    F0 + (1 - F0)(1 - N.V)^5, as the wet mode weights it); its node tree."""
    material = compat.new_material("Two Lobes")
    obj.data.materials.clear()
    obj.data.materials.append(material)
    tree = material.node_tree
    tree.nodes.clear()
    graph = Graph(tree)
    water_weight = (water,) * 3 + (1.0,)
    if fresnel is not None:
        geometry = graph.node("ShaderNodeNewGeometry")
        n_dot_v = graph.node(
            "ShaderNodeVectorMath", [geometry.outputs["Normal"], geometry.outputs["Incoming"]], operation="DOT_PRODUCT"
        )
        grazing = graph.node(
            "ShaderNodeMath", {0: 1.0, 1: n_dot_v.outputs["Value"]}, operation="SUBTRACT", use_clamp=True
        )
        power = graph.node("ShaderNodeMath", {0: grazing.outputs[0], 1: 5.0}, operation="POWER")
        schlick = graph.node(
            "ShaderNodeMath", {0: power.outputs[0], 1: 1.0 - fresnel, 2: fresnel}, operation="MULTIPLY_ADD"
        )
        water_weight = graph.node("ShaderNodeMath", {0: schlick.outputs[0], 1: water}, operation="MULTIPLY").outputs[0]
    diffuse = graph.node("ShaderNodeBsdfDiffuse", {"Color": (*kd, 1.0)})
    stone = graph.node("ShaderNodeBsdfGlossy", {"Color": (ks,) * 3, "Roughness": m}, distribution="GGX")
    wet = graph.node("ShaderNodeBsdfGlossy", {"Color": water_weight, "Roughness": m_water}, distribution="GGX")
    both = graph.node("ShaderNodeAddShader", [diffuse.outputs[0], stone.outputs[0]])
    graph.node(
        "ShaderNodeOutputMaterial",
        {"Surface": graph.node("ShaderNodeAddShader", [both.outputs[0], wet.outputs[0]]).outputs[0]},
    )
    return tree


def _principled(tree, base, specular, roughness, tint=mapping.SPECULAR_COLOR_FACTOR, coat=0.0, coat_roughness=0.0):
    """Make ``tree`` the Principled BSDF of a glTF material as the glTF importer builds it: the
    mapping's (specular factor ``specular``, specular colour factor ``tint``), with a clearcoat
    of weight ``coat`` (IOR 1.5, as glTF's) if given."""
    tree.nodes.clear()
    graph = Graph(tree)
    principled = graph.node("ShaderNodeBsdfPrincipled")
    for name, value in (
        ("Base Color", (*base, 1.0)),
        ("Metallic", 0.0),
        ("Roughness", roughness),
        ("Specular IOR Level", specular / 2),
        ("Specular Tint", (tint,) * 3 + (1.0,)),
        ("Coat Weight", coat),
        ("Coat Roughness", coat_roughness),
        ("Coat IOR", 1.5),
    ):
        principled.inputs[name].default_value = value
    graph.node("ShaderNodeOutputMaterial", {"Surface": principled.outputs[0]})


class StageClock:
    """Seconds per stage of ``export.iter_export``: each step runs until the next one starts."""

    def __init__(self):
        self.seconds, self.counts = {}, {}
        self._stage, self._started = None, None

    def __call__(self, step):
        now = time.perf_counter()
        if self._stage is not None:
            self.seconds[self._stage] = self.seconds.get(self._stage, 0.0) + now - self._started
            self.counts[self._stage] = self.counts.get(self._stage, 0) + 1
        self._stage, self._started = _stage_of(step), now


def _stage_of(step):
    """'bake diffuse', 'bake specular', ... for bakes (the texture is the message's last word)."""
    return f"bake {step.message.rsplit(' ', 1)[1]}" if step.stage == "bake" else step.stage


def plain_bake(sample, size):
    """Seconds of a plain Cycles bake of the same textures: DIFFUSE and GLOSSY colour passes of
    each object's weathered material per state (and the water lobe's GLOSSY pass once more for
    the wet state), on the UV maps the export bakes on, at the same size."""
    seconds = 0.0
    states = export.states(AGES, True)
    scene = bpy.data.scenes.new("PW Plain Bake")
    render.use_cycles(scene, samples=textures.BAKE_SAMPLES)
    try:
        for obj in sample.objects:
            copy = scratch_scene.placed_copy(obj, scene, obj.active_material, own_mesh=True)
            uv_map, _ = textures.bake_uv_map(copy.data, size)  # the map the export bakes on (not timed)
            copy.data.uv_layers.active = copy.data.uv_layers[uv_map]
            image = bpy.data.images.new("plain", size, size, float_buffer=True)
            tree = obj.active_material.node_tree
            target = tree.nodes.new("ShaderNodeTexImage")
            target.image = image
            tree.nodes.active = target
            for state in states:
                passes = ["DIFFUSE", "GLOSSY"] + (["GLOSSY"] if state.wet else [])
                for kind in passes:
                    started = time.perf_counter()
                    scratch_scene.bake_alone(copy, type=kind, pass_filter={"COLOR"}, target="IMAGE_TEXTURES", margin=4)
                    seconds += time.perf_counter() - started
            tree.nodes.remove(target)
            bpy.data.images.remove(image)
            bpy.data.objects.remove(copy)
    finally:
        bpy.data.scenes.remove(scene)
    return seconds


def speed(args):
    print(machine.describe(bpy.app.version_string))
    with tempfile.TemporaryDirectory(prefix="pw_bench_export_") as folder:
        work = pathlib.Path(folder)
        sample = prepare(demo.FACADE, work)
        clock = StageClock()
        options = export.ExportOptions(ages=AGES, wet=True, size=args.size, out_dir=str(work))
        started = time.perf_counter()
        steps = export.iter_export(sample.objects, options)
        for step in steps:
            clock(step)
        total = time.perf_counter() - started
        size_mb = os.path.getsize(work / f"{demo.FACADE}.glb") / 1e6
        plain = plain_bake(sample, args.size)
        load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    bakes = {stage: seconds for stage, seconds in clock.seconds.items() if stage.startswith("bake")}
    print(f"façade: {len(sample.objects)} objects, 4 variants, textures {args.size}², .glb {size_mb:.0f} MB")
    print("| stage | steps | seconds | per step |")
    print("|---|---|---|---|")
    for stage, seconds in clock.seconds.items():
        count = clock.counts[stage]
        print(f"| {stage} | {count} | {seconds:.1f} | {seconds / count:.2f} |")
    print(f"| **total** | | {total:.1f} | |")
    print(
        f"plain Cycles bake of the same {sum(clock.counts[s] for s in bakes)} textures: {plain:.1f} s; "
        f"export bakes / plain bake = {sum(bakes.values()) / plain:.2f}, whole export / plain bake = "
        f"{total / plain:.2f} (load average {load:.1f} at the end)"
    )


#: The picture's camera, as a viewer opens the façade: from the front, a little to the right, at
#: eye level (location and target in metres, lens in mm, width over height).
PICTURE_VIEW = dict(location=(3.5, -15.0, 2.5), target=(0.0, 0.0, 2.9), lens=45.0, aspect=4 / 3)


def frame(scene, view):
    camera = scene.camera
    camera.data.lens = view["lens"]
    camera.location = view["location"]
    direction = np.subtract(view["target"], view["location"])
    camera.rotation_euler = Vector(direction).to_track_quat("-Z", "Y").to_euler()
    scene.render.resolution_x = round(scene.render.resolution_y * view["aspect"])


def picture(args):
    with tempfile.TemporaryDirectory(prefix="pw_bench_export_") as folder:
        work = pathlib.Path(folder)
        sample = prepare(demo.FACADE, work)
        result = export.export_variants(sample.objects, AGES, wet=True, size=args.size, out_dir=str(work))
        scene = sample.scene
        neutral_sky(scene)
        show(sample.objects, None)
        imported = import_variants(result.path)
        sample.use_cycles(args.height, args.samples)
        frame(scene, PICTURE_VIEW)
        tiles = []
        for state in export.states(AGES, True):  # every variant maps the same imported objects
            show(imported[state.name], imported[state.name].get)
            tiles.append(render.render_picture(scene, str(work / f"{state.name}.png"), view_transform="Standard"))
        demo.side_by_side(tiles, len(tiles), args.out)
    print(f"wrote {args.out}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=("speed", "accuracy", "picture", "lobes", "water"))
    parser.add_argument("--size", type=int, default=None, help="texture size (speed 2048, accuracy 1024, picture 1024)")
    parser.add_argument("--height", type=int, default=240, help="picture height in pixels")
    parser.add_argument("--samples", type=int, default=256, help="Cycles samples per pixel")
    parser.add_argument("--out", default=str(ROOT / "docs" / "images" / "export_variants.png"))
    parser.add_argument("--scenes", nargs="+", choices=SCENES, default=SCENES, help="accuracy: the samples")
    args = parser.parse_args()
    args.size = args.size or (2048 if args.what == "speed" else 1024)
    {"speed": speed, "accuracy": accuracy, "picture": picture, "lobes": lobes, "water": water}[args.what](args)
    compat.end_process(0)  # bpy 4.5 can hang at interpreter exit


if __name__ == "__main__":
    main()
