"""Deterministic headless renders into numpy arrays (tests, benchmarks, docs pictures, demo)."""

import os
import tempfile

import bpy

from ..common import held_output, imageio
from . import compat, scratch_scene


def use_cycles(scene, *, size=48, samples=4, seed=0, bounces=0, pixel_filter=0.01):
    """CPU Cycles with a fixed seed, no denoising, no adaptive sampling (the bakes' set-up,
    ``scratch_scene.use_cycles``), linear output.

    ``pixel_filter`` is the pixel filter width in pixels: the default 0.01 samples every
    pixel at its centre, so a pixel is the shading of one point and can be checked exactly.
    """
    scratch_scene.use_cycles(scene, samples=samples, seed=seed, bounces=bounces)
    scene.cycles.filter_width = pixel_filter
    _common(scene, size)


def use_eevee(scene, *, size=32, samples=4):
    scene.render.engine = compat.EEVEE_ENGINE
    scene.eevee.taa_render_samples = samples
    _common(scene, size)


def _common(scene, size):
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = True  # alpha marks the pixels an object covers
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    scene.render.image_settings.file_format = "OPEN_EXR"
    scene.render.image_settings.color_depth = "32"


def render_array(scene=None, path=None):
    """Render ``scene`` and return its linear RGBA pixels, top row first, as float32 (H, W, 4).

    The image goes through a float EXR file (``path``, or a temporary one), because the
    Render Result has no pixels in background mode.
    """
    scene = scene or bpy.context.scene
    keep = path is not None
    if not keep:
        handle, path = tempfile.mkstemp(suffix=".exr", prefix="pw_render_")
        os.close(handle)
    try:
        write_still(scene, path)
        return imageio.read_image(path)[0]
    finally:
        if not keep:
            os.remove(path)


def render_picture(scene, path, view_transform="AgX"):
    """Render ``scene`` to a PNG picture at ``path`` through a display view transform."""
    return write_still(
        scene,
        path,
        {
            (scene.render.image_settings, "file_format"): "PNG",
            (scene.render.image_settings, "color_depth"): "8",
            (scene.view_settings, "view_transform"): view_transform,
            (scene.render, "film_transparent"): False,
        },
    )


#: Blender's note on each picture it writes, which the main job's progress bar would carry.
SAVED_NOTE = b"Saved: '"


def write_still(scene, path, overrides=None):
    """Render ``scene`` into the file ``path`` with ``{(owner, attribute): value}`` set for the
    render only; the scene's own settings are restored afterwards. Blender's note that it saved
    the file is left out of the output."""
    overrides = {(scene.render, "filepath"): os.fspath(path), **(overrides or {})}
    previous = {key: getattr(*key) for key in overrides}
    try:
        for (owner, attribute), value in overrides.items():
            setattr(owner, attribute, value)
        with held_output.held((SAVED_NOTE, *compat.PROGRESS_NOTES)):
            bpy.ops.render.render(write_still=True, scene=scene.name)
    finally:
        for (owner, attribute), value in previous.items():
            setattr(owner, attribute, value)
    return path
