"""The main job: bake the bundled limestone façade's maps and render how it weathers.

``python -m porous_weathering demo --out out`` writes to the output folder:

- ``porous_vs_base.png``: the paper's Fig. 11, the same stone without and with porosity;
- ``<mode>_t<age>.png``: the façade at ages t = 0, 0.33, 0.66 and 1 for soiling, wetting and
  efflorescence (the rain and edge maps are baked first, as colour attributes);
- ``comparison.png``: all of them side by side, one row per mode.

``python -m porous_weathering demo --docs`` regenerates every picture of docs/images/ instead:
``porous_vs_base.png``, ``facade_aging.png`` (the façade new and fully weathered, a row per
mode), ``<mode>_before_after.png``, a sample scene new (left) and fully weathered (right) for
each mode (DOCS_BEFORE_AFTER), ``stone_flat_vs_structured.png`` and ``stone_mm_vs_m.png``, a wall
of the façade's stone flat and structured, in metres and in millimetres (STONE_WALL),
``bust_weathering.png``, the scan-like bust (DOCS_BUST), and docs/survey.md's
``facade_survey_<years>y.png`` and ``facade_survey_<years>y_render.png``, the soiled façade's
condition map and its render at each of DOCS_SURVEY_YEARS.

Pictures are ``--size`` pixels high (default 540: the façade's are 960 x 540), denoised, each
labelled with its mode and age; the documentation's are written at DOCS_SCALE.

``Sample`` (a sample scene opened, its maps made, its weathered materials at any age) is what
the tests of the sample scenes use too.
"""

import math
import os
import shutil
import sys
import tempfile
import time
from dataclasses import dataclass, field, replace

import bpy

import numpy as np
from mathutils import Vector

from ..blender import blend_file, render
from ..common import options
from ..common.options import option
from ..common.progress import ProgressBar
from ..contracts import EXIT_USAGE, EXTENSION_ROOT, GROUP_NODE, SAMPLES_DIR, socket_name
from ..core import aging, environments, model
from ..core import modes as weathering_modes
from ..maps import bake, efflorescence_map, rain, sky_bake, sun
from ..maps import registry as maps
from ..shading import material, presets, weathering
from ..survey import condition_survey
from . import studio

DOCS_IMAGES = os.path.join(EXTENSION_ROOT, "docs", "images")
FACADE = "limestone_facade"
AGES = (0.0, 0.33, 0.66, 1.0)
#: The documentation's sheets are written at this scale of the renders (smaller files).
DOCS_SCALE = 0.75

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.25, roughness=0.35)
POROUS = dict(porosity=0.4, pore_depth_ratio=3.0)

#: Rain driven 25 degrees from the vertical by a wind from the front (the samples face -Y), a fact
#: of the samples' site: it reaches the open walls (E = sin 25 = 0.42 there), while cornices,
#: sills and window heads keep what lies below dry. Vertical rain would leave every wall face
#: with no rain of its own (E = 0), only the water that runs down it.
DRIVEN_RAIN = dict(wind_azimuth=-90.0, wind_tilt=25.0)
#: The brick sample's efflorescence map: salt along the joints of its bond, reaching a few
#: millimetres into each brick. Rows and bricks per row are the sample's courses and bricks per
#: course, whose UV map build_samples.py projects onto the bond.
JOINT_MAP = dict(size=512, rows=16, bricks_per_row=9, mortar=0.01, reach=0.006, noise=0.5)


@dataclass(frozen=True)
class View:
    """How the main job frames a sample: its camera (``location`` and ``target`` in the scene's
    units, ``lens`` in mm), the pictures' ``aspect`` (width over height) and, if not None, the
    direction towards its sun (``sun``) and the sun's strength."""

    location: tuple
    target: tuple
    lens: float
    aspect: float = 16 / 9
    sun: tuple | None = None
    sun_strength: float | None = None


@dataclass(frozen=True)
class Recipe:
    """How a sample scene weathers: only what a user picks in the panel, and facts of the scene,
    never a tuning of the model. The objects (None: every mesh but the ground); their ``stone``
    (a key of presets.PRESETS, whose structure the materials have at the default variation:
    docs/model.md §8) and ``environment`` (a key of environments.ENVIRONMENTS), the panel's Stone
    and Environment choices; ``masonry``: if not None, the ``presets.Ashlar`` the stone is laid
    in, or ``presets.MeshBlocks`` for blocks the mesh knows (docs/model.md §8.5), a fact of the
    building; ``parts``: {object: stone}, the other objects
    weathered beside them, each as its own stone with the same maps and site and no masonry (the
    panel's Make run on them with that Stone: the brick wall's mortar); its ``modes``, whose masks read what the
    panel's Make wires (``masks``): each its baked map (baked as colour attributes with the bake's
    defaults, as the command line bakes them), and for a map that is made, not baked, the one
    ``made`` names ("joints": JOINT_MAP, an image on the bricks' UV map), else its fallback map
    (docs/model.md §7.2); the ``rain`` of the
    site (rain.RainSettings fields: its wind); the main job's ``view`` (None: the scene's own
    camera, sun and aspect); and how the scene's geometry is prepared for per-corner maps:
    ``unite``: if not None, the name of the one object the weathered objects are united into (a
    Boolean union) before the bake, so that the corners between parts built as separate boxes
    (a wall and its cornice, a wall and a sill) are concave corners of one surface, as on a real
    building or a scan: the edge mask sees curvature only within a surface; and ``cell``: if not
    None, the size (scene units) of the cells the weathered objects' faces are cut into before
    the bake, so that the per-corner maps resolve shelter and corners at the scale of the main
    job's pictures."""

    objects: tuple
    stone: str
    modes: tuple
    made: dict = field(default_factory=dict)
    rain: dict = field(default_factory=lambda: DRIVEN_RAIN)
    environment: str = environments.DEFAULT_ENVIRONMENT
    view: View | None = None
    unite: str | None = None
    cell: float | None = None
    masonry: presets.Ashlar | presets.MeshBlocks | None = None
    #: The site's sun (sun.SunSettings fields: its latitude, where north is).
    sun: dict = field(default_factory=dict)
    parts: dict = field(default_factory=dict)

    @property
    def masks(self) -> dict:
        """{mode: {mask input: the map it reads}}, from the mode and map registries."""
        baked = set(maps.names())
        return {
            mode: {
                item.name: item.map if item.map in baked else self.made.get(item.map, item.fallback_map)
                for item in weathering_modes.inputs_of((mode,))
                if item.map
            }
            for mode in self.modes
        }


#: The façade from the front left at eye height (the undersides of the cornice and the sills
#: show), 16:9. A low sun from the front right (10.5 degrees up) lights the wall and the band the
#: cornice shelters, and its mirror direction meets the wall at the right-hand pilaster (x = 3.6 m,
#: 4 m up), so that wet stone there shows the water's sheen.
FACADE_VIEW = View(
    location=(-2.6, -12.5, 1.4), target=(-0.2, 0.0, 3.1), lens=33.0, sun=(0.437, -0.881, 0.183), sun_strength=3.0
)
#: The façade's coursed ashlar, from its proportions (sample_blends/build_samples.py; the stone is
#: read in metres from the origin, at ground level): courses 0.4 m high, so that the 0.8 m plinth
#: is two courses with a bed joint on its top and the 2 m window openings five; blocks 0.7 m long
#: (1.75 times the course, as ashlar is cut), five to each 3.5 m bay between the pilasters' centres;
#: 10 mm lime-mortar joints, as fine ashlar is pointed.
FACADE_ASHLAR = presets.Ashlar(course_height=0.4, block_length=0.7, joint_width=0.01)
RECIPES = {
    # Efflorescence on the façade follows the water it absorbs, the run-off map, as the panel's
    # Make connects it where no location map was made (docs/model.md §7.2).
    FACADE: Recipe(
        None,
        "LIMESTONE",
        (model.SOILING, model.WET, model.EFFLORESCENCE),
        view=FACADE_VIEW,
        unite="Facade",
        cell=0.1,
        masonry=FACADE_ASHLAR,
    ),
    # Modelled brick by brick: each brick its own draw of the brick (its loose part, marked by
    # build_samples.py), the recessed mortar behind them weathering as the lime mortar it is.
    "brick_wall": Recipe(
        ("Bricks",),
        "BRICK",
        (model.SOILING, model.WET, model.EFFLORESCENCE),
        made={efflorescence_map.MAP_NAME: "joints"},
        masonry=presets.MeshBlocks(),
        parts={"Mortar": "LIME_MORTAR"},
    ),
    # Vertical rain: the hollows and the undersides of the ridges are the sheltered places.
    "sculpted_stone": Recipe(("Sculpted Stone",), "LIMESTONE", (model.SOILING,), rain={}),
    # The scan-like bust (millimetres, no UV map): driven rain reaches the hat and the chest,
    # the brim shelters the face.
    "bust": Recipe(
        ("Bust",),
        "LIMESTONE",
        (model.SOILING, model.WET),
        view=View(location=(-520.0, -900.0, 200.0), target=(0.0, 0.0, 300.0), lens=55.0, aspect=1.0, sun_strength=2.5),
    ),
}
#: The scan-like bust in docs/images/bust_weathering.png: (mode, age) of each picture.
DOCS_BUST = ((model.SOILING, 0.0), (model.SOILING, 1.0), (model.WET, 1.0))
#: The sample scene that shows each mode in docs/images/<mode>_before_after.png.
DOCS_BEFORE_AFTER = {model.SOILING: "sculpted_stone", model.WET: "brick_wall", model.EFFLORESCENCE: "brick_wall"}
#: docs/images/runoff_before_after.png: the façade soiled at t = 1 by the rain alone (the modes
#: without run-off: docs/model.md §7.2) and by the rain and its run-off (the defaults).
DOCS_RUNOFF = (("rain alone", dict(runoff=0.0, streaks=0.0)), ("rain and run-off", {}))
#: docs/images/facade_life.png (docs/model.md §9): the façade in the country, life alone, at these
#: years since it was last clean, at 50° N, a row for each way its front faces: to the north, in
#: the shade most of the day, and to the south, in the sun. The way is a fact of the site, given to
#: its sun map as the angle of north from +Y (the front faces -Y): 180 puts north in front of it.
DOCS_LIFE_YEARS = (5.0, 20.0, 50.0)
DOCS_LIFE_FRONTS = {"north": 180.0, "south": 0.0}
LIFE = "biological"
#: docs/survey.md (docs/model.md §10): the soiled façade in its site surveyed at these years, each
#: condition map (docs/images/facade_survey_<years>y.png) beside its render (..._render.png).
DOCS_SURVEY_YEARS = (10.0, 25.0, 50.0)
#: docs/images/stone_flat_vs_structured.png and stone_mm_vs_m.png (docs/model.md §8): a square wall
#: of the façade's stone and masonry, ``side`` metres, new and soiled, its masks constant (a wall
#: half reached by the rain, mid-way down the edge mask): what varies is the stone's alone.
STONE_WALL = dict(stone="LIMESTONE", side=1.6, masks=dict(rain_map=0.3, edge_map=0.6))


class Sample:
    """A sample scene, opened, with the maps its recipe needs made (baked into colour
    attributes, or generated into image files in ``map_dir``), ready to show any of its modes
    at any age."""

    def __init__(self, name, *, map_dir, bake_samples=32, progress=False, recipe=None):
        blend_file.open_blend(sample_path(name))
        self.name, self.recipe = name, recipe or RECIPES[name]
        self.scene = bpy.context.scene
        self.sun = next(obj for obj in self.scene.objects if obj.type == "LIGHT")
        self.objects = [
            obj
            for obj in self.scene.objects
            if obj.type == "MESH" and (obj.name in self.recipe.objects if self.recipe.objects else obj.name != "Ground")
        ]
        if self.recipe.unite:
            self.objects = [unite(self.objects, self.recipe.unite)]
        if self.recipe.cell:
            for obj in self.objects:
                refine(obj, self.recipe.cell)
        self.parts = [self.scene.objects[name] for name in self.recipe.parts]
        self.sources = self._make_maps(bake_samples, map_dir, progress)
        self._materials = {}
        if self.recipe.view:
            self._frame(self.recipe.view)

    def _frame(self, view):
        """The recipe's camera, aspect and sun (after the bake: rain and edges do not see them)."""
        camera = self.scene.camera
        camera.data.lens = view.lens
        camera.location = view.location
        direction = Vector(view.target) - Vector(view.location)
        camera.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()
        height = self.scene.render.resolution_y
        self.scene.render.resolution_x = round(height * view.aspect)
        if view.sun is not None:
            studio.aim_sun(self.sun, view.sun)
        if view.sun_strength is not None:
            self.sun.data.energy = view.sun_strength

    def _make_maps(self, bake_samples, map_dir, progress):
        used = {source for masks in self.recipe.masks.values() for source in masks.values()}
        baked = tuple(map_name for map_name in maps.names() if map_name in used)
        sources = {map_name: maps.get(map_name).attribute for map_name in baked}
        if baked:
            bake_options = bake.BakeOptions(
                maps=baked,
                target="attribute",
                rain_settings=rain.RainSettings(samples=bake_samples, **self.recipe.rain),
                sun_settings=sun.SunSettings(samples=bake_samples, **self.recipe.sun),
            )
            bar = ProgressBar(f"baking the maps of {self.name}") if progress else None
            bake.bake_maps([*self.objects, *self.parts], bake_options, progress=bar)
            if bar:
                bar.finish()
        if "joints" in used:  # a file, as a user's own location map would be
            path = os.path.join(map_dir, f"{self.name}.efflorescence.exr")
            sources["joints"] = efflorescence_map.save_map(efflorescence_map.brick_joint_map(**JOINT_MAP), path)
        return sources

    def inputs(self, mode, stone=None, **changes):
        """The weathering inputs ``mode``'s material is given: the panel's values for ``stone``
        (None: the recipe's) and the recipe's environment (presets.weathering_values) that
        ``mode`` reads, then the environment's other inputs, updated with ``changes`` (e.g. the
        paper-exact ``crust=0``); the rest keep the API's defaults."""
        used = model.inputs_of(mode)
        panel = presets.weathering_values(stone or self.recipe.stone, self.recipe.environment)
        site = environments.weathering_inputs(self.recipe.environment, (mode,))
        return {**site, **{name: value for name, value in panel.items() if name in used}, **changes}

    @property
    def stone(self):
        """make_weathered_material's material keywords of the recipe's stone preset (its means:
        the materials vary about them with the stone's structure)."""
        return presets.PRESETS[self.recipe.stone].material_params()

    def material(self, mode, stone=None, **changes):
        """The weathered material of ``mode`` (made once per stone and set of ``changes``: see
        ``inputs``) on ``stone`` (None: the recipe's, laid in its masonry; a part's stone takes
        none), with its structure at the default variation, and on its maps, as the panel's Make
        makes it."""
        laid = stone is None  # the recipe's own stone, in its masonry
        stone = stone or self.recipe.stone
        key = (mode, stone, laid, tuple(sorted(changes.items())))
        if key not in self._materials:
            masks = {mask: self.sources[map_name] for mask, map_name in self.recipe.masks[mode].items()}
            name = f"{self.name} {mode}" + ("" if laid else f" {stone}")
            name += "".join(f" {k}={v}" for k, v in sorted(changes.items()))
            self._materials[key] = weathering.make_weathered_material(
                name,
                modes=(mode,),
                key_light=self.sun,
                environment=self.recipe.environment,
                stone=stone,
                masonry=self.recipe.masonry if laid else None,
                **presets.PRESETS[stone].material_params(),
                **masks,
                **self.inputs(mode, stone, **changes),
            )
        return self._materials[key]

    def _weathered(self, mode, **changes):
        """(objects, their material) of ``mode``: the recipe's objects, then each part."""
        yield self.objects, self.material(mode, **changes)
        for obj in self.parts:
            yield [obj], self.material(mode, self.recipe.parts[obj.name], **changes)

    def show(self, mode, age, **changes):
        """Give the weathered objects ``mode``'s material (``changes``: see ``material``) at age ``age``."""
        for objects, weathered in self._weathered(mode, **changes):
            weathering.set_input(weathered.node_tree.nodes[GROUP_NODE], "time", age)
            for obj in objects:
                studio.assign(obj, weathered)

    def render_years(self, mode, years, path):
        """A picture of ``mode`` after ``years`` in the recipe's site: every clock of its
        material set from the years (``aging.ages_for_years``, docs/model.md §9.4), as the
        condition survey sets them."""
        carbon = environments.get(self.recipe.environment).elemental_carbon
        for objects, weathered in self._weathered(mode):
            group = weathered.node_tree.nodes[GROUP_NODE]
            for clock, value in aging.ages_for_years(years, carbon).items():
                if socket_name(clock) in group.inputs:
                    weathering.set_input(group, clock, value)
            for obj in objects:
                studio.assign(obj, weathered)
        return render.render_picture(self.scene, path, view_transform="Standard")

    def render(self, mode, age, path, **changes):
        """A picture of ``mode`` at ``age`` (``changes``: see ``material``). The Standard view
        keeps the contrast that AgX, made for bright highlights, squeezes out of the weathered
        areas: a deposit that halves the light looks only a little darker through AgX."""
        self.show(mode, age, **changes)
        return render.render_picture(self.scene, path, view_transform="Standard")

    def use_cycles(self, size, samples):
        """Cycles for pictures ``size`` pixels high, in the scene's own aspect ratio, denoised
        (OpenImageDenoise: a few samples per pixel give a clean picture)."""
        aspect = self.scene.render.resolution_x / self.scene.render.resolution_y
        render.use_cycles(self.scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
        self.scene.render.resolution_x = round(size * aspect)
        self.scene.cycles.use_denoising = True
        self.scene.render.use_persistent_data = True  # the next age reuses the BVH and the images


def unite(objects, name):
    """One object ``name``: the Boolean union of ``objects`` (the first keeps its material and
    place in the scene; the others are removed). Blender's Manifold solver (4.5 and later): the
    sample's parts are closed meshes, and it unites the façade's in a fraction of a second."""
    first, others = objects[0], objects[1:]
    parts = bpy.data.collections.new(f"{name} parts")
    for obj in others:
        parts.objects.link(obj)
    modifier = first.modifiers.new("Unite", "BOOLEAN")
    modifier.operation, modifier.operand_type, modifier.collection = "UNION", "COLLECTION", parts
    modifier.solver = "MANIFOLD"
    mesh = bpy.data.meshes.new_from_object(first.evaluated_get(bpy.context.evaluated_depsgraph_get()))
    first.modifiers.clear()
    first.data, mesh.name, first.name = mesh, name, name
    for obj in others:
        bpy.data.objects.remove(obj)
    bpy.data.collections.remove(parts)
    return first


def refine(obj, cell):
    """Cut ``obj``'s mesh by planes across each axis, no more than ``cell`` apart: every face
    becomes cells a per-corner map can vary over, and the shape stays exactly the same (the
    main job's ``Recipe.cell``; sample_blends/build_samples.py cuts the façade's faces and the
    brick wall's mortar with it)."""
    import bmesh

    mesh = bmesh.new()
    mesh.from_mesh(obj.data)
    corners = [vertex.co for vertex in mesh.verts]
    for axis in range(3):
        low, high = min(c[axis] for c in corners), max(c[axis] for c in corners)
        count = math.ceil((high - low) / cell - 1e-3)  # a float32 0.8 over 0.2 is 4 on every line
        normal = Vector([float(axis == k) for k in range(3)])
        for k in range(1, count):
            point = normal * (low + k * (high - low) / count)
            geometry = mesh.verts[:] + mesh.edges[:] + mesh.faces[:]
            bmesh.ops.bisect_plane(mesh, geom=geometry, dist=1e-5, plane_co=point, plane_no=normal)
    mesh.to_mesh(obj.data)
    mesh.free()


def configure_parser(parser):
    parser.add_argument("--out", default="out", help="folder the pictures are written to (default: out)")
    parser.add_argument(
        "--docs",
        action="store_true",
        help=f"regenerate the documentation's pictures in {os.path.relpath(DOCS_IMAGES, EXTENSION_ROOT)}/ "
        "instead (--out is ignored)",
    )
    options.add_arguments(parser, options.entries(DemoOptions))


@dataclass(frozen=True)
class DemoOptions:
    """The pictures' quality, the command's flags (``options.add_arguments``): checked on creation,
    before any work (ValueError naming the option)."""

    samples: int = option(
        4,
        label="Samples",
        flag="--samples",
        low=1,
        high=sky_bake.MAX_SAMPLES // 2,  # Cycles' bound, and Fig. 11 renders twice as many
        whole=True,
        metavar="N",
        tooltip="Cycles samples per pixel, denoised (Fig. 11: twice as many)",
    )
    size: int = option(
        540,
        label="Size",
        flag="--size",
        low=16,
        high=16384,
        whole=True,
        metavar="PX",
        tooltip="picture height in pixels",
    )
    bake_samples: int = option(
        32,
        label="Bake Samples",
        flag="--bake-samples",
        low=1,
        high=min(sky_bake.MAX_SAMPLES, sun.MAX_SAMPLES),  # the rain's and the sun's
        whole=True,
        metavar="N",
        tooltip="rain and sun samples per face corner",
    )

    def __post_init__(self):
        options.check(self)


def sample_path(name: str) -> str:
    """The bundled sample scene ``name`` (a key of RECIPES), beside the package."""
    return os.path.join(SAMPLES_DIR, f"{name}.blend")


def run(args):
    started = time.time()
    try:
        DemoOptions(**options.argument_values(args, options.entries(DemoOptions)))
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    # the samples ship with the repository and the extension's zip, not with `pip install .`
    missing = [name for name in (RECIPES if args.docs else (FACADE,)) if not os.path.isfile(sample_path(name))]
    if missing:
        print(
            f"error: no sample scene {sample_path(missing[0])}: the demo runs from the repository or the "
            "installed extension, which hold the sample scenes",
            file=sys.stderr,
        )
        return EXIT_USAGE
    try:
        bake.check_writable_folder(DOCS_IMAGES if args.docs else args.out)
    except OSError as error:
        print(f"error: {error}", file=sys.stderr)
        return EXIT_USAGE
    if args.docs:
        written = docs_pictures(args)
    else:
        written = [render_porous_vs_base(os.path.join(args.out, "porous_vs_base.png"), args.size, args.samples * 2)]
        _, aging = render_aging(args.out, args.size, args.samples, args.bake_samples)
        labels = [f"{mode}, t = {age:g}" for mode in RECIPES[FACADE].masks for age in AGES]
        written += aging + [side_by_side(aging, len(AGES), os.path.join(args.out, "comparison.png"), labels)]
    folder = DOCS_IMAGES if args.docs else args.out
    print(f"wrote {len(written)} pictures to {folder} in {time.time() - started:.0f} s", file=sys.stderr)
    return 0


def docs_pictures(args):
    """Every picture of docs/images/; the façade's single ages go to a temporary folder."""
    written = [render_porous_vs_base(os.path.join(DOCS_IMAGES, "porous_vs_base.png"), args.size, args.samples * 2)]
    with tempfile.TemporaryDirectory(prefix="pw_docs_") as work:
        # The README's sheet: new and fully weathered, a row per mode (the main job's has four ages).
        ends = (AGES[0], AGES[-1])
        facade, aging = render_aging(work, args.size, args.samples, args.bake_samples, ends)
        labels = [f"{mode}, t = {age:g}" for mode in RECIPES[FACADE].masks for age in ends]
        written.append(side_by_side(aging, 2, os.path.join(DOCS_IMAGES, "facade_aging.png"), labels, DOCS_SCALE))
        written.append(render_runoff_before_after(facade, work, os.path.join(DOCS_IMAGES, "runoff_before_after.png")))
        modes_of = {}  # sample -> the modes it shows: each sample is opened and baked once
        for mode, name in DOCS_BEFORE_AFTER.items():
            modes_of.setdefault(name, []).append(mode)
        for name, modes in modes_of.items():
            sample = Sample(name, bake_samples=args.bake_samples, map_dir=work, progress=True)
            sample.use_cycles(args.size, args.samples)
            for mode in modes:
                pictures = [
                    sample.render(mode, age, os.path.join(work, f"{name}_{mode}_{age}.png")) for age in (0.0, 1.0)
                ]
                labels = [f"{mode}, t = {age:g}" for age in (0, 1)]
                out = os.path.join(DOCS_IMAGES, f"{mode}_before_after.png")
                written.append(side_by_side(pictures, 2, out, labels, DOCS_SCALE))
        written += render_stone_walls(work, args.size, args.samples)
        written.append(render_facade_life(work, args.size, args.samples, args.bake_samples))
        facade = Sample(FACADE, bake_samples=args.bake_samples, map_dir=work, progress=True)
        facade.use_cycles(args.size, args.samples)
        written += render_facade_survey(facade, survey_facade(facade, DOCS_SURVEY_YEARS, work), work)
        bust = Sample("bust", bake_samples=args.bake_samples, map_dir=work, progress=True)
        bust.use_cycles(args.size, args.samples)
        pictures = [bust.render(mode, age, os.path.join(work, f"bust_{mode}_{age}.png")) for mode, age in DOCS_BUST]
        labels = [f"{mode}, t = {age:g}" for mode, age in DOCS_BUST]
        out = os.path.join(DOCS_IMAGES, "bust_weathering.png")
        written.append(side_by_side(pictures, len(pictures), out, labels, DOCS_SCALE))
    return written


def render_porous_vs_base(path, size=256, samples=64):
    """Fig. 11: left the Diffuse + Glossy base, right the same with porosity (key-light mode)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sun = studio.add_sun(scene, (-0.55, 0.35, 0.76), strength=2.5)
    world = bpy.data.worlds.new("Sky")
    world.color = (0.02, 0.025, 0.03)
    scene.world = world
    for x, mat in (
        (-1.1, material.make_base_material("Base", **STONE)),
        (1.1, material.make_porous_material("Porous", **STONE, **POROUS, key_light=sun)),
    ):
        sphere = studio.add_sphere(scene, name=mat.name)
        sphere.location.x = x
        studio.assign(sphere, mat)
    studio.add_ortho_camera(scene, scale=4.6)
    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = 2 * size
    scene.cycles.use_denoising = True
    return render.render_picture(scene, path)


def render_facade_life(work, size, samples, bake_samples):
    """docs/images/facade_life.png: the façade in RURAL, biological mode alone, at DOCS_LIFE_YEARS
    (every clock of its material set from the years, ``ages_for_years``), a row for each of
    DOCS_LIFE_FRONTS."""
    pictures, labels = [], []
    for front, north_angle in DOCS_LIFE_FRONTS.items():
        sun_site = dict(latitude=50.0, north_angle=north_angle)
        recipe = replace(RECIPES[FACADE], modes=(LIFE,), environment="RURAL", sun=sun_site)
        facade = Sample(FACADE, bake_samples=bake_samples, map_dir=work, progress=True, recipe=recipe)
        facade.use_cycles(size, samples)
        for years in DOCS_LIFE_YEARS:
            pictures.append(facade.render_years(LIFE, years, os.path.join(work, f"facade_life_{front}_{years:g}.png")))
            labels.append(f"biological, rural, front to the {front}, {years:g} years")
    out = os.path.join(DOCS_IMAGES, "facade_life.png")
    return side_by_side(pictures, len(DOCS_LIFE_YEARS), out, labels, DOCS_SCALE)


def survey_facade(facade, years, out_dir):
    """The condition survey (docs/survey.md) of the façade (an opened ``Sample``) soiled in its
    site at ``years``, its files in ``out_dir``: the ``SurveyResult``."""
    facade.show(model.SOILING, 0.0)
    return condition_survey(
        facade.objects, years=years, environment=facade.recipe.environment, out_dir=out_dir, name="facade", force=True
    )


def render_facade_survey(facade, result, work, out=DOCS_IMAGES):
    """The façade (an opened ``Sample``) rendered soiled at each age of its survey ``result``
    (``survey_facade``), by the survey's clocks, beside that age's condition map: the pictures
    written to ``out``, per age ``facade_survey_<years>y.png`` (the map; none without matplotlib)
    and ``facade_survey_<years>y_render.png``."""
    environment = facade.recipe.environment
    carbon = environments.get(environment).elemental_carbon
    written = []
    for age in sorted({float(row["years"]) for row in result.rows}):
        stem = os.path.join(out, f"facade_survey_{age:g}y")
        drawn = [path for path in result.drawings if path.endswith(f".{age:g}y.png")]
        if drawn:  # none where matplotlib is missing (docs/survey.md)
            shutil.copyfile(drawn[0], stem + ".png")
            written.append(stem + ".png")
        picture = facade.render_years(model.SOILING, age, os.path.join(work, f"facade_survey_{age:g}y.png"))
        label = f"soiling, {environment.lower()}, {age:g} years (t = {aging.age_for_years(age, carbon):.2f})"
        written.append(side_by_side([picture], 1, stem + "_render.png", [label], DOCS_SCALE))
    return written


def stone_wall_scene(metres_per_unit):
    """STONE_WALL standing in the XZ plane, facing -Y, in a scene of ``metres_per_unit``, seen
    square-on by an orthographic camera and lit from the front left: (scene, wall, sun)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.scale_length = metres_per_unit
    side = STONE_WALL["side"] / metres_per_unit
    wall = studio.add_plane(scene, "Wall", size=side)
    wall.rotation_euler.x = math.pi / 2  # +Z turns to -Y
    world = bpy.data.worlds.new("Sky")
    world.color = (0.05, 0.055, 0.06)
    scene.world = world
    sun = studio.add_sun(scene, (-0.5, -0.75, 0.45), strength=3.0)
    camera = studio.add_ortho_camera(scene, scale=side)
    camera.location = (0.0, -2.0 * side, 0.0)
    camera.rotation_euler = (math.pi / 2, 0.0, 0.0)
    camera.data.clip_end = 4.0 * side
    return scene, wall, sun


def stone_wall_material(sun, variation, metres_per_unit=1.0):
    """The soiled STONE_WALL's material (docs/model.md §8) at ``variation``."""
    stone = STONE_WALL["stone"]
    inputs = {
        **environments.weathering_inputs(environments.DEFAULT_ENVIRONMENT, (model.SOILING,)),
        **{k: v for k, v in presets.weathering_values(stone).items() if k in model.inputs_of((model.SOILING,))},
        **STONE_WALL["masks"],
    }
    return weathering.make_weathered_material(
        f"{stone} wall, variation {variation:g}, {metres_per_unit:g} m per unit",
        modes=(model.SOILING,),
        key_light=sun,
        stone=stone,
        variation=variation,
        masonry=FACADE_ASHLAR,
        **presets.PRESETS[stone].material_params(),
        **inputs,
    )


def render_stone_walls(work, size, samples):
    """docs/images/stone_flat_vs_structured.png (the wall flat and structured, new and soiled) and
    stone_mm_vs_m.png (the same wall in metres and in millimetres, new and soiled)."""
    pictures, labels = {}, {}
    for unit, unit_label in ((1.0, "metres"), (0.001, "millimetres")):
        scene, wall, sun = stone_wall_scene(unit)
        render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
        scene.cycles.use_denoising = True
        for variation in (0.0, 1.0) if unit == 1.0 else (1.0,):
            weathered = stone_wall_material(sun, variation, unit)
            studio.assign(wall, weathered)
            for age in (0.0, 1.0):
                weathering.set_input(weathered.node_tree.nodes[GROUP_NODE], "time", age)
                key = (unit, variation, age)
                path = os.path.join(work, f"stone_wall_{unit:g}_{variation:g}_{age:g}.png")
                pictures[key] = render.render_picture(scene, path, view_transform="Standard")
                look = "flat" if variation == 0 else "structured"
                labels[key] = f"{look}, {unit_label}, t = {age:g}"
    sheets = {
        "stone_flat_vs_structured.png": [(1.0, v, age) for age in (0.0, 1.0) for v in (0.0, 1.0)],
        "stone_mm_vs_m.png": [(unit, 1.0, age) for age in (0.0, 1.0) for unit in (1.0, 0.001)],
    }
    return [
        side_by_side([pictures[k] for k in keys], 2, os.path.join(DOCS_IMAGES, name), [labels[k] for k in keys])
        for name, keys in sheets.items()
    ]


def render_aging(out, size, samples, bake_samples, ages=AGES):
    """Bake the façade's maps, then render each weathering mode at each of ``ages``: (the façade's
    ``Sample``, the pictures)."""
    facade = Sample(FACADE, bake_samples=bake_samples, map_dir=out, progress=True)
    facade.use_cycles(size, samples)
    modes = list(facade.recipe.masks)
    pictures = []
    progress = ProgressBar("rendering the aging sequence")
    for row, mode in enumerate(modes):
        for column, age in enumerate(ages):
            progress((row * len(ages) + column) / (len(modes) * len(ages)), f"{mode}, t = {age:.2f}")
            pictures.append(facade.render(mode, age, os.path.join(out, f"{mode}_t{age:.2f}.png")))
    progress(1.0, "done")
    progress.finish()
    return facade, pictures


def render_runoff_before_after(facade, work, path):
    """The façade (an opened ``Sample``) soiled at t = 1 without and with run-off (DOCS_RUNOFF)."""
    pictures = [
        facade.render(model.SOILING, 1.0, os.path.join(work, f"runoff {label}.png"), **changes)
        for label, changes in DOCS_RUNOFF
    ]
    labels = [f"soiling, t = 1, {label}" for label, _ in DOCS_RUNOFF]
    return side_by_side(pictures, len(pictures), path, labels, DOCS_SCALE)


def side_by_side(paths, columns, out_path, labels=(), scale=1.0):
    """One picture of ``paths`` laid out in rows of ``columns`` (OpenImageIO), each tile with its
    label (if any) in its top left corner, the whole scaled by ``scale``."""
    import OpenImageIO as oiio

    tiles = [oiio.ImageBuf(path) for path in paths]
    if scale != 1.0:
        tiles = [_scaled(tile, scale) for tile in tiles]
    for tile, label in zip(tiles, labels):
        _label(tile, label)
    width, height = tiles[0].spec().width, tiles[0].spec().height
    rows = -(-len(tiles) // columns)
    sheet = oiio.ImageBuf(oiio.ImageSpec(width * columns, height * rows, tiles[0].spec().nchannels, oiio.UINT8))
    for index, tile in enumerate(tiles):
        oiio.ImageBufAlgo.paste(sheet, (index % columns) * width, (index // columns) * height, 0, 0, tile)
    if not sheet.write(out_path):
        raise OSError(f"cannot write {out_path}: {sheet.geterror()}")
    return out_path


def _scaled(tile, scale):
    import OpenImageIO as oiio

    spec = tile.spec()
    size = oiio.ROI(0, round(spec.width * scale), 0, round(spec.height * scale), 0, 1, 0, spec.nchannels)
    return oiio.ImageBufAlgo.resize(tile, roi=size)


def _label(tile, text):
    """Write ``text`` in white on a darkened band at the top left of ``tile``; without a font
    (OpenImageIO finds none on some machines) the tile stays as it is."""
    import OpenImageIO as oiio

    spec = tile.spec()
    height = max(12, spec.height // 18)
    text_layer = oiio.ImageBuf(oiio.ImageSpec(spec.width, spec.height, spec.nchannels, oiio.FLOAT))
    white = [1.0] * spec.nchannels
    if not oiio.ImageBufAlgo.render_text(text_layer, height // 2, round(height * 1.15), text, height, "", white):
        return
    pixels = tile.get_pixels(oiio.FLOAT)
    width = min(spec.width, round(height * 0.62 * len(text)) + height)
    pixels[: round(height * 1.5), :width, :3] *= 0.4
    pixels = np.maximum(pixels, text_layer.get_pixels(oiio.FLOAT))
    tile.set_pixels(oiio.ROI(0, spec.width, 0, spec.height, 0, 1, 0, spec.nchannels), pixels)
