"""Copies of the user's objects in temporary scenes, where the bakes work: the user's
scene, meshes, materials and selection are never touched."""

#: Object types that have surfaces, materials and therefore something to bake or shade.
GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


def placed_copy(obj, scene, material, *, own_mesh=False):
    """A copy of ``obj`` linked into ``scene``, standing where ``obj`` stands (unparented, no
    animation or constraints, renderable), every slot showing ``material``.

    With ``own_mesh`` the copy gets its own copy of the mesh (to write bake results into);
    otherwise it shares ``obj``'s, whose materials stay untouched (object-linked slots).
    """
    copy = obj.copy()
    if own_mesh:
        copy.data = obj.data.copy()
        copy.data.materials.clear()
        copy.data.materials.append(material)
    copy.animation_data_clear()
    copy.constraints.clear()
    copy.parent = None
    copy.matrix_world = obj.matrix_world.copy()
    copy.hide_render = False
    for slot in copy.material_slots:
        slot.link = "OBJECT"
        slot.material = material
    scene.collection.objects.link(copy)
    return copy


def only_selected(obj):
    """Make ``obj`` the selected, active object of its (temporary) scene; returns the context
    override under which ``bpy.ops.object.bake`` works on it alone."""
    scene = obj.users_scene[0]
    view_layer = scene.view_layers[0]
    obj.select_set(True, view_layer=view_layer)
    view_layer.objects.active = obj
    return dict(scene=scene, view_layer=view_layer, object=obj, active_object=obj,
                selected_objects=[obj], selected_editable_objects=[obj])
