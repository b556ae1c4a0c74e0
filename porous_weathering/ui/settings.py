"""The scene's Porous Weathering settings (``Scene.porous_weathering``): what the panel's Make
button builds. Generated from the registries at registration: the stone (its variation and
masonry), the environment, the key light, one switch per weathering mode and one slider per
weathering input marked for the panel;
the age in years; the measured colours of a survey; the material they act on (``active_material``,
``time_socket``), which the panel and the operators read."""

import bpy

import numpy as np

from ..contracts import BLOCK_ATTRIBUTE, GROUP_NODE, STONE_NODE, socket_name
from ..core import aging, environments, stones
from ..core import modes as weathering_modes
from ..shading import presets

#: The Stone choice that keeps the object's own material (its base colour and roughness images, or
#: its vertex colours).
FROM_MATERIAL = "FROM_MATERIAL"
DEFAULT_SOURCE = "LIMESTONE"
#: The Masonry choices (docs/model.md §8.5): none, coursed ashlar from the point's place, or blocks
#: the mesh knows (presets.BLOCK_SOURCES: its loose parts or its sculpt face sets).
NO_MASONRY, ASHLAR = "NONE", "ASHLAR"
MASONRY_ITEMS = [
    (NO_MASONRY, "None", "One stone, no blocks or joints"),
    (ASHLAR, "Coursed Ashlar", "Blocks in courses with lime-mortar joints, laid out from each point's place in metres"),
    *(
        (source, f"Blocks: {label}", f"{what}; Make writes each face's block into the face attribute {BLOCK_ATTRIBUTE}")
        for source, (label, what) in presets.BLOCK_SOURCES.items()
    ),
]


def _is_light(_settings, obj):
    return obj.type == "LIGHT"


def _apply_source(settings, _context):
    """Picking a stone or an environment sets the panel's weathering inputs to their values."""
    for name, value in presets.weathering_values(settings.source, settings.environment).items():
        setattr(settings, name, value)


def active_material(context: "bpy.types.Context") -> "bpy.types.Material | None":
    """The material the panel shows: the Properties editor's, else the active object's."""
    obj = context.active_object
    return getattr(context, "material", None) or (obj.active_material if obj is not None else None)


def variation_socket(mat: "bpy.types.Material | None") -> "bpy.types.NodeSocket | None":
    """The Variation input of ``mat``'s stone node (docs/model.md §8.2); None for a material
    without a stone (made uniform: no stone node to vary)."""
    stone = mat.node_tree.nodes.get(STONE_NODE) if mat and mat.node_tree else None
    return stone.inputs["Variation"] if stone is not None else None


def time_socket(mat: "bpy.types.Material | None") -> "bpy.types.NodeSocket | None":
    """The Time input of ``mat``'s Porous group node; None for a material without it."""
    return clock_sockets(mat).get("time")


def clock_sockets(mat: "bpy.types.Material | None") -> "dict[str, bpy.types.NodeSocket]":
    """{clock input: socket} of ``mat``'s Porous group node: the clocks ``ages_for_years`` sets (t,
    the biological years: docs/model.md §9.4) that its modes have; empty for a material that does
    not age."""
    group = mat.node_tree.nodes.get(GROUP_NODE) if mat and mat.node_tree else None
    if group is None:
        return {}
    clocks = aging.ages_for_years(0.0, 1.0)  # the clocks' names
    return {name: group.inputs[socket_name(name)] for name in clocks if socket_name(name) in group.inputs}


def aging_targets(context: "bpy.types.Context") -> "list[bpy.types.Material]":
    """The materials Years and Keyframe Aging age: the active material, then the active material
    of every other selected object that ages (what one Make gave the selected objects), each once."""
    found = [active_material(context), *(obj.active_material for obj in context.selected_objects)]
    targets = []
    for mat in found:
        if mat is not None and clock_sockets(mat) and mat not in targets:
            targets.append(mat)
    return targets


def _apply_years(settings, context):
    """Setting Years sets the clocks of the materials it ages (``aging_targets``): Time by the
    soiling law at the environment's soot, and the clocks counted in years (docs/model.md §9.4)."""
    ages = aging.ages_for_years(settings.years, settings.elemental_carbon())
    for mat in aging_targets(context):
        for name, socket in clock_sockets(mat).items():
            socket.default_value = ages[name]


class SettingsBase:
    """Porous Weathering choices of a scene: what the panel's Make button builds"""

    def modes(self) -> tuple[str, ...]:
        return tuple(mode for mode in weathering_modes.names() if getattr(self, mode))

    def weathering_values(self, modes) -> dict:
        """{input: value} of the panel's weathering inputs that ``modes`` use."""
        return {item.name: getattr(self, item.name) for item in weathering_modes.inputs_of(modes) if item.panel}

    def preset(self) -> str | None:
        """The stone preset chosen, None for the object's own material."""
        return None if self.source == FROM_MATERIAL else self.source

    def masonry_for(
        self, obj: "bpy.types.Object"
    ) -> "tuple[stones.Ashlar | stones.MeshBlocks | None, np.ndarray | None]":
        """The chosen masonry for ``obj`` (None without a preset: masonry lays a stone) and, for
        blocks the mesh knows, each face's block (``presets.face_blocks``), for Make to write
        (``presets.write_blocks``) once its material is made, so that a Make that fails edits
        nothing. ValueError for lengths no ashlar has or a mesh without the face sets asked for."""
        if self.preset() is None or self.masonry == NO_MASONRY:
            return None, None
        if self.masonry == ASHLAR:
            return stones.Ashlar(**{name: getattr(self, name) for name in stones.ASHLAR_LENGTHS}), None
        return stones.MeshBlocks(), presets.face_blocks(obj, self.masonry)

    def elemental_carbon(self) -> float:
        """The chosen environment's typical elemental-carbon concentration, µg/m³."""
        return environments.get(self.environment).elemental_carbon

    def measured(self) -> dict:
        """make_weathered_material's keywords from the measured colours (presets.from_colorimetry), on
        the chosen stone (limestone for the object's own material); ValueError for colours no setting gives."""
        colours = [tuple(getattr(self, f"measured_{name}")) for name in ("clean", "soiled", "crust")]
        return presets.from_colorimetry(
            *colours, space=self.measured_space.lower(), preset=self.preset() or DEFAULT_SOURCE
        )


def settings_class() -> type:
    """The scene's settings: the stone, the key light, one switch per registered mode and one
    slider per weathering input the registry marks for the panel (defaults: the default stone's)."""
    properties = {
        "source": bpy.props.EnumProperty(
            name="Stone",
            description="Porous stone to start from; picking one also sets its weathering values below",
            default=DEFAULT_SOURCE,
            items=[(key, preset.label, preset.description) for key, preset in presets.PRESETS.items()]
            + [
                (
                    FROM_MATERIAL,
                    "Object's Own Material",
                    "Keep the base colour and roughness images of the object's current material, "
                    "or its vertex colours (a scan's)",
                )
            ],
            update=_apply_source,
        ),
        "variation": bpy.props.FloatProperty(
            name="Variation",
            description="How much the stone's own structure (grain, bedding, veins, speckle) varies its colour, "
            "porosity and roughness from point to point, and so how its weathering breaks up: 1 as the stone "
            "shows it, 0 a uniform stone (docs/model.md §8)",
            default=stones.DEFAULT_VARIATION,
            min=0.0,
            max=1.0,
        ),
        "masonry": bpy.props.EnumProperty(
            name="Masonry",
            description="Lay the stone in blocks, each its own draw of the stone's porosity and colour, with "
            "lime-mortar joints (docs/model.md §8.5)",
            default=NO_MASONRY,
            items=MASONRY_ITEMS,
        ),
        **{
            name: bpy.props.FloatProperty(
                name=length.label,
                description=f"{length.description} of the ashlar, in metres (the scene's unit scale applies)",
                default=getattr(stones.Ashlar, name),
                min=1e-4,
                soft_max=length.soft_max,
                precision=3,
            )
            for name, length in stones.ASHLAR_LENGTHS.items()
        },
        "environment": bpy.props.EnumProperty(
            name="Environment",
            description="Where the stone stands: sets the site's weathering values (deposit, crust, streaks, salt) "
            "and the soot concentration that turns Years into Time",
            default=environments.DEFAULT_ENVIRONMENT,
            items=[(key, site.label, site.description) for key, site in environments.ENVIRONMENTS.items()],
            update=_apply_source,
        ),
        "years": bpy.props.FloatProperty(
            name="Years",
            description="Years of exposure: sets the Time of the selected objects' materials by the soiling law of "
            "sheltered stone at the environment's soot concentration (t = 1: 30% of the reflectance lost); "
            "Keyframe Years spans the frame range over them",
            default=0.0,
            min=0.0,
            soft_max=200.0,
            update=_apply_years,
        ),
        "measured_space": bpy.props.EnumProperty(
            name="Measured As",
            description="How the measured colours below are given",
            items=[
                ("LAB", "CIE L*a*b* (D65)", "L* in [0, 100], a* and b*, as colorimeters report them"),
                ("SRGB", "sRGB", "sRGB components in [0, 1], e.g. from a calibrated photograph"),
            ],
        ),
        "key_light": bpy.props.PointerProperty(
            name="Key Light",
            type=bpy.types.Object,
            poll=_is_light,
            description="Light whose direction the pores follow exactly; empty: the scene's strongest sun, "
            "or ambient mode (for scenes lit by a sky) when it has none",
        ),
    }
    for mode in map(weathering_modes.get, weathering_modes.names()):
        properties[mode.name] = bpy.props.BoolProperty(name=mode.label, description=mode.description)
    for name, label, default in (
        ("clean", "Clean", (80.0, 1.5, 9.0)),
        ("soiled", "Soiled (Grey)", (62.0, 1.0, 6.0)),
        ("crust", "Black Crust", (35.0, 0.5, 2.0)),
    ):
        properties[f"measured_{name}"] = bpy.props.FloatVectorProperty(
            name=label,
            description=f"Measured colour of the {label.lower()} stone, as Measured As says (Make from Measured "
            "Colours reproduces it at t = 1)",
            size=3,
            default=default,
        )
    defaults = presets.weathering_values(DEFAULT_SOURCE)
    for item in presets.panel_inputs():
        properties[item.name] = bpy.props.FloatProperty(
            name=item.socket,
            description=item.tooltip,
            default=defaults[item.name],
            min=item.low,
            max=item.high,
            subtype="FACTOR",
        )
    return type(
        "PW_Settings",
        (SettingsBase, bpy.types.PropertyGroup),
        {"__annotations__": properties, "__doc__": SettingsBase.__doc__},
    )


def scene_sun(scene: "bpy.types.Scene") -> "bpy.types.Object | None":
    """The sun Make wires when the Key Light field is empty: the scene's strongest sun that
    renders (not hidden from renders, strength above 0), the first by name among equals; None
    without one (ambient mode: point, spot and area lights are never picked for the artist)."""
    suns = [
        obj
        for obj in scene.objects
        if obj.type == "LIGHT" and obj.data.type == "SUN" and not obj.hide_render and obj.data.energy > 0.0
    ]
    return max(sorted(suns, key=lambda obj: obj.name), key=lambda obj: obj.data.energy, default=None)


def key_light(scene: "bpy.types.Scene", settings: SettingsBase) -> "bpy.types.Object | None":
    """The panel's Key Light, else the scene's sun (scene_sun)."""
    return settings.key_light or scene_sun(scene)
