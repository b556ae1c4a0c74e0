"""The bake operator: a thin modal wrapper over ``bake.iter_bake`` (one step per timer tick,
progress in the window manager's progress bar, Esc cancels between steps)."""

import bpy

from . import bake, rain


class PW_OT_bake_maps(bpy.types.Operator):
    """Bake rain-exposure and edge/cavity maps of the selected meshes (Esc cancels between maps)"""

    bl_idname = "porous_weathering.bake_maps"
    bl_label = "Bake Weathering Maps"
    bl_options = {"REGISTER", "UNDO"}

    maps: bpy.props.EnumProperty(
        name="Maps", options={"ENUM_FLAG"}, default={"rain", "edges"},
        description="Which maps to bake: the weathering modes read rain exposure and the edge/cavity mask",
        items=[("rain", "Rain Exposure", "Cosine-weighted fraction of the rain cone that reaches the surface"),
               ("edges", "Edges", "Edge/cavity mask: Sobel of the normal map (image) or mesh curvature (attribute)")])
    target: bpy.props.EnumProperty(
        name="Target", default="image",
        description="Where the maps go: image files on a lightmap UV map, or colour attributes on the mesh (scans "
                    "without UVs)",
        items=[("image", "Image", "Float EXR files on a lightmap UV map"),
               ("attribute", "Colour Attribute", "Colour attributes pw_rain / pw_edges on the mesh")])
    resolution: bpy.props.IntProperty(name="Resolution", default=bake.DEFAULT_RESOLUTION, min=8, max=16384,
                                      description="Width and height of the image maps, in texels")
    samples: bpy.props.IntProperty(name="Samples", default=rain.DEFAULT_SAMPLES, min=1,
                                   description="Rain samples per texel or corner")
    rain_cone: bpy.props.FloatProperty(name="Rain Cone", default=rain.RainSettings.cone, min=0.5, max=89.0,
                                       description="Half-angle of the cone of rain directions, degrees")
    wind_azimuth: bpy.props.FloatProperty(name="Wind Azimuth", default=0.0,
                                          description="Side the rain is driven from, degrees from +X towards +Y")
    wind_tilt: bpy.props.FloatProperty(name="Wind Tilt", default=0.0, min=0.0, max=90.0,
                                       description="Lean of the mean rain direction from the vertical, degrees")
    occluders: bpy.props.StringProperty(
        name="Occluders", description="Collection whose objects shelter the surfaces; empty: every other object")
    out_dir: bpy.props.StringProperty(name="Folder", subtype="DIR_PATH", default="//maps/",
                                      description="Folder of the image maps (// is the .blend's folder)")

    _steps = None
    _timer = None

    @classmethod
    def poll(cls, context):
        if not any(obj.type == "MESH" for obj in context.selected_objects):
            cls.poll_message_set("Select the mesh objects to bake")
            return False
        return True

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        try:
            options = bake.BakeOptions(
                maps=tuple(sorted(self.maps, key=bake.MAPS.index)), target=self.target, resolution=self.resolution,
                out_dir=bpy.path.abspath(self.out_dir), occluders=self._occluder_collection(),
                rain_settings=rain.RainSettings(cone=self.rain_cone, wind_azimuth=self.wind_azimuth,
                                                wind_tilt=self.wind_tilt, samples=self.samples))
            objects = [obj for obj in context.selected_objects if obj.type == "MESH"]
            self._steps = bake.iter_bake(objects, options)  # refuses bad objects or folders here
        except (ValueError, OSError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        self._objects, self._options = objects, options
        self._outcomes = []
        context.window_manager.progress_begin(0, 1)
        if bpy.app.background or context.window is None:  # no event loop: run to the end
            return self._finish(context, self._run_all(context))
        self._timer = context.window_manager.event_timer_add(0.05, window=context.window)
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        if event.type == "ESC":
            self._steps.close()  # undoes the unfinished object's new lightmap UV map
            self.report({"WARNING"}, f"Bake cancelled after {len(self._outcomes)} map(s)")
            return self._finish(context, {"CANCELLED"})
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        try:
            step = next(self._steps)
        except StopIteration:
            return self._finish(context, {"FINISHED"})
        except (ValueError, OSError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return self._finish(context, {"CANCELLED"})
        self._show(context, step)
        return {"RUNNING_MODAL"}

    def _run_all(self, context):
        try:
            for step in self._steps:
                self._show(context, step)
        except (ValueError, OSError, RuntimeError) as error:
            self.report({"ERROR"}, str(error))
            return {"CANCELLED"}
        return {"FINISHED"}

    def _show(self, context, step):
        context.window_manager.progress_update((step.index + (step.outcome is not None)) / step.total)
        if step.outcome is not None:
            self._outcomes.append(step.outcome)
            self.report({"INFO"}, f"{step.object}: {step.map} {step.outcome.status} ({step.outcome.where})")

    def _finish(self, context, result):
        if self._timer is not None:
            context.window_manager.event_timer_remove(self._timer)
        context.window_manager.progress_end()
        if result == {"FINISHED"} and self.target == "image":
            bake.link_images(self._objects, self._options)
        return result

    def _occluder_collection(self):
        return bake.occluder_collection(self.occluders)


CLASSES = (PW_OT_bake_maps,)


def register():
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
