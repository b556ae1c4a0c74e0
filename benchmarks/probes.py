"""Scene probes for the checks and the benchmarks, outside the shipped package as the reference
renderer is (docs/architecture.md, "No test kit in production"): materials that read a shading
quantity out as pixels (a point's position, its normal: ``emission_probe`` makes one of your
own), a holdout that cuts an object out of a render, a point light of zero radius, and the view
direction of ``samples.studio``'s camera."""

import bpy

from porous_weathering.blender import compat
from porous_weathering.blender.scratch_scene import emission_probe
from porous_weathering.samples import studio

#: studio.add_ortho_camera looks down -Z, so the unit vector towards the viewer is +Z everywhere.
VIEW_DIRECTION = (0.0, 0.0, 1.0)


def add_point_light(scene, location, power=1000.0, name="Lamp", kind="POINT"):
    """A light of zero radius (``kind`` POINT or SPOT; an AREA light keeps its size) at ``location``."""
    light = bpy.data.lights.new(name, kind)
    light.energy = power
    if kind in ("POINT", "SPOT"):
        light.shadow_soft_size = 0.0
    lamp = studio.link(scene, bpy.data.objects.new(name, light))
    lamp.location = location
    return lamp


def position_probe(scale=0.1):
    """Emits the world-space position times ``scale``, plus 1/2."""
    return emission_probe(
        "Position Probe", lambda graph, geometry: graph.wrap(geometry.outputs["Position"]) * scale + 0.5
    )


def normal_probe():
    """Emits the world-space shading normal, encoded as N / 2 + 1/2."""
    return emission_probe("Normal Probe", lambda graph, geometry: graph.wrap(geometry.outputs["Normal"]) * 0.5 + 0.5)


def holdout_material():
    """Cuts what it covers out of a render (alpha 0): to see one object of a scene alone."""
    material = compat.new_material("Holdout")
    material.node_tree.nodes.clear()
    holdout = material.node_tree.nodes.new("ShaderNodeHoldout")
    output = material.node_tree.nodes.new("ShaderNodeOutputMaterial")
    material.node_tree.links.new(holdout.outputs[0], output.inputs["Surface"])
    return material
