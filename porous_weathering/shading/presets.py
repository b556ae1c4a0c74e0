"""Porous material presets: building stones, brick, terracotta, plaster and concrete.

Porosity alpha is picked inside the open-porosity range that handbooks give for each
material; the pore aspect s_p, the colour k_d, k_s and the roughness m are this project's
picks; a stone may also set the weathering inputs the panel shows (the black crust).
docs/presets.md gives the source of every range and value and the reasoning behind each pick.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from ..contracts import PRESET_PROPERTY
from ..core import colorimetry
from ..core import modes as weathering_modes
from ..core.environments import DEFAULT_ENVIRONMENT, ENVIRONMENTS, Environment  # noqa: F401  (public: docs/api.md)

if TYPE_CHECKING:
    import bpy


@dataclass(frozen=True)
class Preset:
    label: str
    porosity: float  #: alpha, our pick inside porosity_range
    porosity_range: tuple  #: (low, high) open porosity from the literature, as a fraction
    pore_depth_ratio: float  #: s_p
    base_color: str  #: k_d as an sRGB hex colour, as an artist would pick it from a photograph
    ks: float
    roughness: float  #: m
    description: str
    #: Panel weathering inputs this stone sets ({"crust": 0.75}); the others keep the API defaults.
    weathering: dict = field(default_factory=dict)

    def panel_weathering(self) -> dict:
        """{input: value} of every weathering input the panel shows: this stone's, else the default."""
        return {
            item.name: self.weathering.get(item.name, item.default)
            for item in weathering_modes.inputs().values()
            if item.panel
        }

    def material_params(self):
        """The keyword arguments of make_porous_material (and make_weathered_material) it gives."""
        return dict(
            base_color=self.linear_base_color(),
            ks=self.ks,
            roughness=self.roughness,
            porosity=self.porosity,
            pore_depth_ratio=self.pore_depth_ratio,
        )

    def linear_base_color(self):
        """k_d: the sRGB hex colour decoded to linear RGBA, which is what shaders take."""
        return (*colorimetry.measured_linear(self.base_color, "srgb").tolist(), 1.0)


PRESETS = {
    "SANDSTONE": Preset(
        "Sandstone",
        0.15,
        (0.05, 0.25),
        2.0,
        "#C4AA82",
        0.04,
        0.7,
        "Buff quartz sandstone: medium porosity, grainy and matt",
        weathering=dict(crust=0.75),
    ),
    "LIMESTONE": Preset(
        "Limestone",
        0.18,
        (0.05, 0.30),
        2.5,
        "#D6CDB8",
        0.04,
        0.6,
        "Pale oolitic building limestone; soft stones such as Lecce or Caen are more porous",
    ),
    "MARBLE": Preset(
        "Marble",
        0.01,
        (0.002, 0.02),
        1.0,
        "#EBE9E4",
        0.10,
        0.2,
        "Honed white marble: almost no open pores, slightly glossy",
        weathering=dict(crust=0.9),
    ),
    "BRICK": Preset(
        "Fired-Clay Brick",
        0.30,
        (0.15, 0.40),
        3.0,
        "#A0523C",
        0.03,
        0.8,
        "Red fired-clay brick: highly porous, deep capillary pores",
        weathering=dict(crust=0.6),
    ),
    "TERRACOTTA": Preset(
        "Terracotta",
        0.22,
        (0.15, 0.30),
        2.5,
        "#C86E46",
        0.05,
        0.6,
        "Unglazed terracotta: finer and smoother than brick",
        weathering=dict(crust=0.65),
    ),
    "PLASTER": Preset(
        "Lime Plaster",
        0.30,
        (0.20, 0.40),
        2.0,
        "#E1DCCD",
        0.03,
        0.8,
        "Lime plaster or render: very porous, chalky white",
    ),
    "CONCRETE": Preset(
        "Concrete",
        0.12,
        (0.10, 0.20),
        1.5,
        "#969691",
        0.05,
        0.7,
        "Ordinary Portland-cement concrete, grey and matt",
        weathering=dict(crust=0.7),
    ),
}


def panel_inputs() -> list[weathering_modes.Input]:
    """The weathering inputs the panel shows (``Input.panel``), each once, in socket order."""
    return [item for item in weathering_modes.inputs().values() if item.panel]


def weathering_values(source: str, environment: str = DEFAULT_ENVIRONMENT) -> dict:
    """{panel input: value} a stone and a site set, as the panel's Stone and Environment choices
    do: the preset ``source``'s own values (else, e.g. for the object's own material, the API
    defaults), then the environment's, its crust a share of the stone's."""
    preset = PRESETS.get(source)
    values = preset.panel_weathering() if preset else {item.name: item.default for item in panel_inputs()}
    site = ENVIRONMENTS[environment].weathering(crust=values["crust"])
    return {name: site.get(name, value) for name, value in values.items()}


def make_preset_material(
    preset_name: str, name: str | None = None, key_light: "bpy.types.Object | str | None" = None
) -> "bpy.types.Material":
    """A new porous material (see ``make_porous_material``) with the values of a preset.

    ``preset_name`` is a key of PRESETS (e.g. "LIMESTONE"); ``name`` defaults to the
    preset's label; ``key_light`` as in ``make_porous_material`` (None: ambient mode).
    """
    from .material import make_porous_material

    try:
        preset = PRESETS[preset_name]
    except KeyError:
        raise ValueError(f"unknown preset {preset_name!r}: choose one of {', '.join(PRESETS)}") from None
    params = preset.material_params()
    material = make_porous_material(name or preset.label, **params, key_light=key_light)
    material.diffuse_color = params["base_color"]  # the viewport's solid-mode colour
    material[PRESET_PROPERTY] = preset_name
    return material


def from_colorimetry(
    clean: Sequence[float] | str,
    soiled: Sequence[float] | str,
    crust: Sequence[float] | str,
    *,
    space: str = "lab",
    preset: str = "LIMESTONE",
) -> dict:
    """make_weathered_material's keywords that reproduce a survey's colours at t = 1 (face on,
    ambient light; docs/presets.md, "From measured colours"): the stone's ``base_color`` and the
    ``preset``'s ks, roughness, porosity and pore depth, the ``deposit_color``, the
    ``pollution_color`` and the ``crust`` coverage.

    ``clean``, ``soiled`` and ``crust`` are the clean stone, the grey (sheltered) soiled stone and
    the black crust, each three floats, CIE L*a*b* (D65) with ``space="lab"`` or sRGB in [0, 1]
    with ``space="srgb"``, or a "#RRGGBB" string (sRGB).  ValueError, before anything is made, for
    colours no setting gives (out of gamut, not darkening from clean to soiled to crust, a soiled
    stone darker than a deposit makes it, ...).
    """
    stone = PRESETS.get(preset)
    if stone is None:
        raise ValueError(f"unknown preset {preset!r}: choose one of {', '.join(PRESETS)}")
    params = stone.material_params()
    colours = [colorimetry.measured_linear(colour, space) for colour in (clean, soiled, crust)]
    model_stone = dict(ks=stone.ks, m=stone.roughness, alpha=stone.porosity, sp=stone.pore_depth_ratio)
    found = colorimetry.invert(*colours, model_stone, stone.panel_weathering()["crust"])
    return {
        **params,
        "base_color": (*found["kd"].tolist(), 1.0),
        "deposit_color": tuple(found["deposit_color"].tolist()),
        "pollution_color": tuple(found["pollution_color"].tolist()),
        "crust": found["crust"],
    }
