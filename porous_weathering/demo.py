"""The main job: render the bundled default scene and write pictures to an output folder.

``python -m porous_weathering demo --out out``: the paper's Fig. 11 (the same stone with
and without porosity, side by side) under a low key sun and a faint sky.
"""

import os
import sys
import time

import bpy

from . import material, render, studio

STONE = dict(base_color=(0.62, 0.55, 0.45), ks=0.25, roughness=0.35)
POROUS = dict(porosity=0.4, pore_depth_ratio=3.0)


def configure_parser(parser):
    parser.add_argument("--out", default="out", help="folder the pictures are written to (default: out)")
    parser.add_argument("--samples", type=int, default=64, help="Cycles samples per pixel (default: 64)")
    parser.add_argument("--size", type=int, default=256, help="picture height in pixels (default: 256)")


def run(args):
    os.makedirs(args.out, exist_ok=True)
    started = time.time()
    path = render_porous_vs_base(os.path.join(args.out, "porous_vs_base.png"), args.size, args.samples)
    print(f"wrote {path} ({time.time() - started:.1f} s)", file=sys.stderr)
    return 0


def render_porous_vs_base(path, size=256, samples=64):
    """Fig. 11: left the Diffuse + Glossy base, right the same with porosity (key-light mode)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    sun = studio.add_sun(scene, (-0.55, 0.35, 0.76), strength=2.5)
    world = bpy.data.worlds.new("Sky")
    world.color = (0.02, 0.025, 0.03)
    scene.world = world
    for x, mat in ((-1.1, material.make_base_material("Base", **STONE)),
                   (1.1, material.make_porous_material("Porous", **STONE, **POROUS, key_light=sun))):
        sphere = studio.add_sphere(scene, name=mat.name)
        sphere.location.x = x
        studio.assign(sphere, mat)
    camera = studio.add_ortho_camera(scene, scale=4.6)
    camera.rotation_euler = (0.0, 0.0, 0.0)
    render.use_cycles(scene, size=size, samples=samples, bounces=4, pixel_filter=1.5)
    scene.render.resolution_x = 2 * size
    return render.render_picture(scene, path)
