"""Porous material presets: building stones (granite among them), brick, terracotta, plaster and concrete.

Porosity alpha is picked inside the open-porosity range that handbooks give for each
material; the pore aspect s_p, the colour k_d, k_s and the roughness m are this project's
picks; a stone may also set the weathering inputs the panel shows (the black crust).
docs/presets.md gives the source of every range and value and the reasoning behind each pick.
"""

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..blender import mesh_arrays
from ..core import colorimetry
from ..core import modes as weathering_modes
from ..core.arguments import choice
from ..core.environments import DEFAULT_ENVIRONMENT, ENVIRONMENTS, Environment  # noqa: F401  (public: docs/api.md)
from ..core.stones import (  # noqa: F401  (Ashlar, MeshBlocks: docs/api.md)
    BEDS,
    CELLS,
    DEFAULT_VARIATION,
    NOISE,
    WAVE,
    Ashlar,
    MeshBlocks,
    Stone,
    Texture,
)

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
    #: The stone's own structure (docs/model.md §8): grain, bedding, veins or speckle at their
    #: physical sizes, and how they move k_d, alpha, s_p and m; None: a uniform material.
    structure: Stone | None = None

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


#: A stone's patches (cementation, firing, trowelling, pour): two octaves of noise as strong, the
#: second an eighth of the first (docs/model.md §8.1): a stone carries its texture's power down to
#: its centimetres as it does at its decimetres, as the photographs' spectra show, where octaves of
#: halving amplitude a half apart left nothing below a few centimetres; at two octaves' cost.
PATCH_OCTAVES = dict(detail=1.0, lacunarity=8.0, roughness=1.0)

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
        structure=Stone(
            (
                Texture(CELLS, 0.0005, 0.35, 0.25),  # sand grains, ~0.5 mm
                Texture(WAVE, 0.04, 0.45, 0.55, detail=0.0, distortion=1.5, direction="Z"),  # bedding, cm
                Texture(NOISE, 0.15, 0.2, 0.2, **PATCH_OCTAVES),  # cementation patches, dm
            ),
            porosity=0.3,
            roughness=0.15,
            pore_depth=0.15,
            colour=(-0.10, -0.16, -0.24),
            description="Quartz grains, cross-bedded laminae a few cm apart, patchy cement",
            block_porosity=0.4,
            block_colour=0.5,
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.001, 0.3, 0.15),  # ooids, ~1 mm
                # beds a decimetre thick on average, each its own: seen more than they weather
                # (a freestone, docs/model.md §8.1)
                Texture(BEDS, 0.12, 0.1, 0.45),
                Texture(NOISE, 0.08, 0.6, 0.4, **PATCH_OCTAVES),  # patches, cm-dm
            ),
            porosity=0.3,
            roughness=0.15,
            pore_depth=0.15,
            colour=(-0.06, -0.09, -0.15),
            description="Ooids ~1 mm, bedding a decimetre apart, softer porous patches",
            block_porosity=0.4,
            block_colour=0.5,
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.002, 0.5, 0.2),  # calcite crystals, ~2 mm
                Texture(WAVE, 0.15, 0.5, 0.8, detail=2.0, distortion=6.0, direction="DIAGONAL"),  # veins
            ),
            porosity=0.2,
            roughness=0.1,
            pore_depth=0.1,
            colour=(-0.08, -0.08, -0.07),  # near-white: at most k_d + k_s = 1
            description="Calcite crystals ~2 mm and grey veins wandering across",
            block_porosity=0.3,
            block_colour=0.3,
        ),
    ),
    "GRANITE": Preset(
        "Granite",
        0.01,
        (0.004, 0.015),
        1.0,
        "#9C9893",
        0.06,
        0.5,
        "Grey granite, sawn or flamed: very little open porosity in microcracks between its crystals",
        weathering=dict(crust=0.75),
        structure=Stone(
            (
                Texture(CELLS, 0.004, 0.4, 0.85),  # feldspar, quartz and mica crystals, ~4 mm
                Texture(NOISE, 0.1, 0.6, 0.15, **PATCH_OCTAVES),  # weathered patches
            ),
            porosity=0.3,
            roughness=0.1,
            pore_depth=0.1,
            colour=(-0.65, -0.66, -0.67),
            description="Interlocking crystals a few mm across: dark mica, grey quartz, pale feldspar",
            block_porosity=0.2,
            block_colour=0.15,
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.0015, 0.3, 0.2),  # grog and sand, ~1.5 mm
                Texture(NOISE, 0.1, 0.5, 0.6, **PATCH_OCTAVES),  # firing patches, dm
                Texture(NOISE, 0.01, 0.2, 0.2, detail=1.0),  # mottling, cm
            ),
            porosity=0.25,
            roughness=0.1,
            pore_depth=0.1,
            colour=(-0.22, -0.28, -0.30),
            description="Grog specks, darker and lighter firing patches",
            block_porosity=0.4,
            block_colour=0.5,
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.001, 0.3, 0.2),  # fine grog, ~1 mm
                Texture(NOISE, 0.06, 0.7, 0.6, **PATCH_OCTAVES),  # firing patches
            ),
            porosity=0.2,
            roughness=0.1,
            pore_depth=0.1,
            colour=(-0.15, -0.20, -0.22),
            description="Fine grog and soft firing patches",
            block_porosity=0.3,
            block_colour=0.4,
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.0008, 0.2, 0.1),  # lime and sand grains
                Texture(NOISE, 0.05, 0.8, 0.7, **PATCH_OCTAVES),  # trowelling, carbonation patches
            ),
            porosity=0.25,
            roughness=0.15,
            pore_depth=0.1,
            colour=(-0.05, -0.07, -0.10),
            description="Sand grains in lime, trowelled patches",
        ),
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
        structure=Stone(
            (
                Texture(CELLS, 0.008, 0.5, 0.55),  # aggregate against paste, ~8 mm
                Texture(NOISE, 0.2, 0.5, 0.35, **PATCH_OCTAVES),  # pour and curing patches
            ),
            porosity=0.3,
            roughness=0.15,
            pore_depth=0.15,
            colour=(-0.18, -0.18, -0.17),
            description="Aggregate in cement paste, patches from the pour",
            block_porosity=0.3,
            block_colour=0.3,
        ),
    ),
    "LIME_MORTAR": Preset(
        "Lime Mortar",
        0.32,
        (0.20, 0.40),
        2.5,
        "#C2B9A6",
        0.03,
        0.85,
        "Lime and sand mortar of the joints: very porous, sandy and rough, greyer than the stone",
        weathering=dict(crust=0.75),
        structure=Stone(
            (
                Texture(CELLS, 0.001, 0.3, 0.3),  # sand in lime, ~1 mm
                Texture(NOISE, 0.03, 0.7, 0.7, **PATCH_OCTAVES),  # pointing and carbonation patches, cm
            ),
            porosity=0.25,
            roughness=0.1,
            pore_depth=0.1,
            colour=(-0.06, -0.08, -0.11),
            description="Sand grains in lime, patches of the pointing",
        ),
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


#: Where mark_blocks finds each face's block (one record per source: its name and what it takes
#: as a block, which the panel's Masonry choice shows): its loose part, or its sculpt face set.
BLOCK_SOURCES = {
    "ISLANDS": ("Loose Parts", "Each loose part of the mesh a block of its own (a wall modelled block by block)"),
    "FACE_SETS": ("Face Sets", "Each sculpt face set a block of its own"),
}
#: The face attribute Blender keeps the sculpt face sets in.
FACE_SET_ATTRIBUTE = ".sculpt_face_set"


def face_blocks(obj: "bpy.types.Object", source: str = "ISLANDS") -> np.ndarray:
    """Each face's block of ``obj``'s mesh (docs/model.md §8.5), read, not written: its loose part
    ("ISLANDS": a wall modelled block by block; a block split along its seams, as importers leave
    a glTF's, is one part) or its sculpt face set ("FACE_SETS"). ValueError
    for an object without a mesh, an unknown source, or a mesh without face sets."""
    if getattr(obj, "type", None) != "MESH":
        raise ValueError(f"{getattr(obj, 'name', obj)!r} is not a mesh object: its blocks come from its faces")
    mesh = obj.data
    if choice("source", source, BLOCK_SOURCES) == "FACE_SETS":
        if FACE_SET_ATTRIBUTE not in mesh.attributes:
            raise ValueError(f"{obj.name!r} has no face sets: make them in Sculpt mode, or use source='ISLANDS'")
        return mesh_arrays.attribute(mesh, FACE_SET_ATTRIBUTE, np.int32)
    return mesh_arrays.face_islands(mesh, mesh_arrays.border_places(mesh))


def write_blocks(obj: "bpy.types.Object", blocks: np.ndarray, attribute: str = MeshBlocks.attribute) -> int:
    """Write ``blocks`` (``face_blocks``) into the integer face attribute ``attribute`` of ``obj``'s
    mesh, for ``MeshBlocks``; returns the number of blocks."""
    mesh = obj.data
    if attribute in mesh.attributes:
        mesh.attributes.remove(mesh.attributes[attribute])
    mesh.attributes.new(attribute, "INT", "FACE").data.foreach_set("value", blocks)
    return len(np.unique(blocks))


def mark_blocks(obj: "bpy.types.Object", source: str = "ISLANDS", attribute: str = MeshBlocks.attribute) -> int:
    """Write each face's block into the integer face attribute ``attribute`` of ``obj``'s mesh
    (``face_blocks`` then ``write_blocks``); returns the number of blocks. ValueError before
    anything is written for an object without a mesh, an unknown source, or a mesh without face
    sets."""
    return write_blocks(obj, face_blocks(obj, source), attribute)


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
