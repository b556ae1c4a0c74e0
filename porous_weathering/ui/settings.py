"""The scene's Porous Weathering settings (``Scene.porous_weathering``): what the panel's Make
button builds. Generated from the registries at registration: the stone, the key light, one
switch per weathering mode and one slider per weathering input marked for the panel."""

import bpy

from ..core import modes as weathering_modes
from ..shading import presets

#: The Stone choice that keeps the object's own material (its base colour and roughness images).
FROM_MATERIAL = "FROM_MATERIAL"
DEFAULT_SOURCE = "LIMESTONE"


def _is_light(_settings, obj):
    return obj.type == "LIGHT"


def panel_inputs() -> list[weathering_modes.Input]:
    """The weathering inputs the panel shows (``Input.panel``), each once, in socket order."""
    return [item for item in weathering_modes.inputs().values() if item.panel]


def source_weathering(source: str) -> dict:
    """{panel input: value} a stone source sets: a preset's own values, else the API defaults."""
    preset = presets.PRESETS.get(source)
    return preset.panel_weathering() if preset else {item.name: item.default for item in panel_inputs()}


def _apply_source(settings, _context):
    """Picking a stone sets the panel's weathering inputs to that stone's values."""
    for name, value in source_weathering(settings.source).items():
        setattr(settings, name, value)


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
                    "Keep the base colour and roughness images of the object's current material",
                )
            ],
            update=_apply_source,
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
    defaults = source_weathering(DEFAULT_SOURCE)
    for item in panel_inputs():
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
