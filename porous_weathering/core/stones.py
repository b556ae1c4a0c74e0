"""The stone's own structure (docs/model.md §8): each preset's grain, bedding, veins or speckle,
at its physical size, and the maths that turns it into per-point k_d, alpha, s_p and m.

A ``Stone`` is one record per preset key: its structure as a few ``Texture`` layers (each a
Blender procedural texture kind with a physical feature size in metres) that make two zero-mean
fields in [-1, 1], the porosity field z_p and the colour field z_c, and the amplitudes by which
they move the parameters around the material's own values.  The maths (``texture_value``,
``fields``, ``point_parameters``, ``receptivity``) is written once against a backend ``xp``
(``backends.py``): numpy evaluates it on fields read from a render (the tests), the stone's
node group builds it as nodes (``shading/nodes.py``).  What only a shader has, the procedural
textures themselves, stays in ``shading/nodes.py``.

Masonry (docs/model.md §8.5): an ``Ashlar`` record lays blocks out in courses with mortar joints;
``ashlar`` finds a point's course, block and joint, ``block_fields`` shifts the fields by the
block's own draw (each block its own bed), ``jointed`` mixes the mortar's parameters in.

``plausible_size`` holds the one rule of which object sizes are plausible in metres (the units
warning of Make and the bake).
"""

import math
from dataclasses import dataclass

from ..contracts import BLOCK_ATTRIBUTE

#: Texture kinds: Blender's Noise (patches, mottling), Wave bands (laminae, veins), Voronoi cells,
#: each cell its own random value (grains, crystals, aggregate), and beds: a 1D Voronoi along the
#: world's Z, each bed its own random value and thickness (bedding, docs/model.md §8.1).
NOISE, WAVE, CELLS, BEDS = "NOISE", "WAVE", "CELLS", "BEDS"

#: Per kind, the factor that spreads a texture's value v (mean 1/2) into z = clip(gain (v - 1/2),
#: -1, 1) (``texture_value``).  A Voronoi cell's (or bed's) random value and a sine band are
#: uniform-like over [0, 1] (gain 2); Blender's normalised fBm noise stays mostly within 0.5 +- 0.2,
#: so its gain is larger: 2.5 for two octaves of halving amplitude, and for other octaves that times
#: the ratio of their spreads (``Texture.gain``, docs/model.md §8.1).  Each distribution is symmetric about 1/2,
#: and the clip is symmetric, so z has mean 0.
GAIN = {NOISE: 2.5, WAVE: 2.0, CELLS: 2.0, BEDS: 2.0}
#: The octaves (detail, roughness) at which GAIN[NOISE] spreads a noise as wide as the others.
NOISE_GAIN_OCTAVES = (1.0, 0.5)

#: Blender's Wave texture (bands) has the phase 20 x (scale x coordinate): its period along the
#: bands' direction is 2 pi / 20 / scale.  So a period P metres needs the scale 2 pi / (20 P).
WAVE_PHASE_PER_UNIT = 20.0

#: How many beds a block's own draw b in [-1, 1] moves the bedding along Z in masonry (docs/model.md
#: §8.5): blocks cut from other places in the quarry, so that the beds of two blocks of one course
#: do not run on across their joint; two draws 1/64 apart already see unrelated beds.
BED_SHIFT = 64.0

#: The object sizes (largest bounding-box side, metres) a stone object plausibly has: a pebble to
#: a cathedral.  Outside, the scene's unit is probably wrong (docs/model.md §8.4).
PLAUSIBLE_SIZE = (0.01, 200.0)
#: The unit scales offered to bring an implausible size back, metres per scene unit.
UNIT_SCALES = {"millimetres": 0.001, "centimetres": 0.01, "metres": 1.0, "kilometres": 1000.0}

#: The spacing across the fall line of the streaks the run-off leaves, metres (docs/model.md §8.8):
#: one storm's rivulets are a few capillary lengths wide (2.7 mm for water) and meander over a few
#: centimetres; the paths they keep to over the years, a decimetre apart (a decision measured on
#: the texture benchmark's shapes); a stone whose streaks run closer or further apart sets its own.
RIVULET_SPACING = 0.1


@dataclass(frozen=True)
class Texture:
    """One layer of a stone's structure: a procedural texture at a physical size, and how much
    of it goes into the porosity field and the colour field (each may be negative)."""

    kind: str  #: NOISE, WAVE, CELLS or BEDS
    size: float  #: metres: a noise's feature size, a wave's period, a cell's diameter, a bed's mean thickness
    porosity: float  #: weight in z_p
    colour: float  #: weight in z_c
    detail: float = 2.0  #: octaves of noise (NOISE), of the bands' distortion (WAVE)
    distortion: float = 0.0  #: WAVE: how far the bands wander (veins); NOISE: domain distortion
    #: WAVE: the bands' axis along the world's axes (docs/model.md §8.2), "Z" for horizontal bedding,
    #: "DIAGONAL" for veins.
    direction: str = "Z"
    #: NOISE: each octave's size over the next's (Blender's Lacunarity) and its amplitude's
    #: (Roughness): 2 and 0.5 halve both; 8 and 1 give octaves a factor 8 apart, as strong.
    lacunarity: float = 2.0
    roughness: float = 0.5

    @property
    def scale(self) -> float:
        """The Blender texture's Scale for this physical size, in texture units per metre."""
        if self.kind == WAVE:
            return 2.0 * math.pi / (WAVE_PHASE_PER_UNIT * self.size)
        return 1.0 / self.size

    @property
    def gain(self) -> float:
        """The factor that spreads this layer's value into z (``GAIN``): a noise's by how narrow
        its normalised octaves leave it against NOISE_GAIN_OCTAVES', so that every noise spreads
        alike."""
        if self.kind != NOISE:
            return GAIN[self.kind]
        return GAIN[NOISE] * fbm_spread(*NOISE_GAIN_OCTAVES) / fbm_spread(self.detail, self.roughness)


def fbm_spread(detail: float, roughness: float) -> float:
    """How wide Blender's normalised fBm of ``detail`` octaves spreads, relative to one octave:
    sqrt(sum w_i^2), w_i each (independent, equally spread) octave's weight in it.  Whole octaves
    weigh a_i / sum a_i, a_i = roughness^i; a fractional ``detail`` mixes, by its fraction, that
    sum with the one of an octave more, each normalised by its own amplitudes, as Blender does."""
    whole, fraction = int(detail), detail - int(detail)
    amplitudes = [roughness**i for i in range(whole + 2)]
    without, with_next = sum(amplitudes[:-1]), sum(amplitudes)
    weights = [a * ((1.0 - fraction) / without + fraction / with_next) for a in amplitudes[:-1]]
    weights.append(amplitudes[-1] * fraction / with_next)
    return math.sqrt(sum(w * w for w in weights))


@dataclass(frozen=True)
class Stone:
    """A stone's structure and how it moves the material's parameters (docs/model.md §8).

    ``porosity``, ``roughness`` and ``pore_depth`` are relative amplitudes at variation 1:
    alpha = alpha_mean (1 + porosity z_p), and so on; all three rise together with z_p (more
    porous is rougher and thirstier).  ``colour`` is the relative shift per RGB channel of k_d at
    z_c = 1: k_d = k_d_mean (1 + colour z_c); a direction along the stone's own hue.
    """

    textures: tuple[Texture, ...]
    porosity: float
    roughness: float
    pore_depth: float
    colour: tuple[float, float, float]
    description: str
    #: Masonry (docs/model.md §8.5): the share of the porosity field and of the colour field that
    #: is the block's own draw b (each block from its own bed), in [0, 1]; 0: every block alike.
    block_porosity: float = 0.0
    block_colour: float = 0.0
    #: The spacing of the rivulets the run-off gathers into on this stone, metres (docs/model.md §8.8).
    rivulet_spacing: float = RIVULET_SPACING

    def __post_init__(self):
        for name in ("porosity", "colour"):
            total = sum(abs(getattr(texture, name)) for texture in self.textures)
            if total > 1.0 + 1e-9:
                raise ValueError(f"a stone's {name} weights must add up to at most 1 (|z| <= 1), not {total}")
        if not all(0.0 <= share <= 1.0 for share in (self.block_porosity, self.block_colour)):
            raise ValueError("a stone's block shares must lie in [0, 1], so that |z| <= 1")
        if not self.rivulet_spacing > 0.0:
            raise ValueError("a stone's rivulet spacing must be a positive length in metres")
        if not all(0.0 <= a < 1.0 for a in (self.porosity, self.roughness, self.pore_depth, *map(abs, self.colour))):
            raise ValueError("a stone's relative amplitudes must lie in [0, 1), so no parameter changes sign")


def texture_value(xp, value, texture):
    """z of one layer: its texture's value v (mean 1/2) spread into [-1, 1], symmetric about 0:
    gain (v' - 1/2), v' the value clipped where the gain would take z beyond (``clipped_value``)."""
    return xp.multiply_add(clipped_value(xp, value, texture), texture.gain, -0.5 * texture.gain)


def clipped_value(xp, value, texture):
    """A layer's texture value clipped to [1/2 - 1/gain, 1/2 + 1/gain], where its z lies in
    [-1, 1]: clip(gain (v - 1/2), -1, 1) is gain (clip(v, ...) - 1/2), the gain increasing.  A
    texture's value lies in [0, 1], so at a gain of at most 2 (cells, bands) it is the value itself,
    no clip built; a noise's gain needs the clip."""
    if unclipped(texture):
        return value
    reach = 1.0 / texture.gain
    return xp.clip(value, 0.5 - reach, 0.5 + reach)


def unclipped(texture):
    """Whether ``texture``'s layer needs no clip: a texture's value lies in [0, 1], so at a gain of
    at most 2 its z already lies in [-1, 1] (cells and bands; a noise's larger gain needs the clip)."""
    return texture.gain <= 2.0


def fields(xp, stone, values):
    """(z_p, z_c): the porosity and colour fields, sums of the layers' z (``values``: each
    layer's texture value, in the order of ``stone.textures``) by their weights; in [-1, 1].
    Each layer's z is gain (v' - 1/2), affine in its clipped value v' (``texture_value``): each
    field takes it as (weight x gain) v', the constants -weight x gain / 2 of all the layers summed
    once at the start, so that a layer costs one multiply-add per field (docs/model.md §8.1)."""
    z_p = sum(-0.5 * t.gain * t.porosity for t in stone.textures)
    z_c = sum(-0.5 * t.gain * t.colour for t in stone.textures)
    for texture, value in zip(stone.textures, values):
        clipped, gain = clipped_value(xp, value, texture), texture.gain
        if texture.porosity:
            z_p = xp.multiply_add(clipped, texture.porosity * gain, z_p)
        if texture.colour:
            z_c = xp.multiply_add(clipped, texture.colour * gain, z_c)
    return z_p, z_c


def grains_mirror(xp, normal):
    """The mirror whose Reflect takes a point's place onto the world's plane most nearly along its
    face, as that place's (x, y) (docs/model.md §8.1): the face's true normal turned upwards, each
    component rounded to -1, 0 or 1, plus Z.  (+-1, 0, 1) swaps x and z, (0, 0, 2) leaves (x, y);
    its z is 1 or 2, so it is never the zero vector."""
    return xp.floor(xp.face_upward(normal) + (0.5, 0.5, 1.5))


#: The ranges a point's alpha, s_p and m are kept in (docs/model.md §1), so that what reads the
#: stone's values may take them as they are (the receptive weathered group: docs/model.md §8.3).
#: m's least value, above 0 by what no render shows: its k = 2 m^2 / pi lies above porous.K_FLOOR (by
#: 7%, in single precision too), so what reads it needs no floor of k per point (docs/model.md §8.2).
LEAST_ROUGHNESS = 1.3e-15
POROSITY_RANGE, PORE_DEPTH_RANGE, ROUGHNESS_RANGE = (0.0, 1.0), (0.0, math.inf), (LEAST_ROUGHNESS, 1.5)


def around(xp, mean, z, amplitude, variation):
    """mean (1 + amplitude x variation x z): a parameter moved by a field (mean: ``mean``), as one
    multiply-add of z by the constant mean x amplitude x variation."""
    return xp.multiply_add(z, mean * (amplitude * variation), mean)


def point_parameters(xp, stone, kd, alpha, sp, m, z_p, z_c, variation):
    """(k_d, alpha, s_p, m) at a point of fields (z_p, z_c), around the material's values
    (k_d a colour): each linear in z, so its mean over a field of mean 0 is the material's
    value; alpha, s_p and m clamped to the model's ranges (docs/model.md §1), k_d left to the
    porous group's own clamp (k_d to [0, 1 - k_s]: the presets' amplitudes keep it inside).  k_d
    moves along the stone's colour direction by a Mix of k_d and k_d (1 + colour) by z_c: k_d
    itself at z_c = 0."""
    variation = xp.clip(variation, 0.0, 1.0)
    kd = xp.maximum(kd, 0.0)  # so k_d stays >= 0 at every point (1 + colour z_c v > 0)
    # alpha's and s_p's means kept >= 0 keep every point's (1 + amplitude z v > 0): alpha needs
    # only its top clipped per point, s_p nothing
    alpha = around(xp, xp.maximum(alpha, POROSITY_RANGE[0]), z_p, stone.porosity, variation)
    alpha = xp.minimum(alpha, POROSITY_RANGE[1])
    sp = around(xp, xp.maximum(sp, PORE_DEPTH_RANGE[0]), z_p, stone.pore_depth, variation)
    m = xp.clip(around(xp, m, z_p, stone.roughness, variation), *ROUGHNESS_RANGE)
    kd = xp.mix(xp.channel(z_c * variation), kd, kd * tuple(1.0 + c for c in stone.colour))
    return kd, alpha, sp, m


def receptivity(xp, stone, z_p, variation):
    """r = ((alpha / alpha_mean)(m / m_mean))^(1/2) (docs/model.md §8.3): how much faster than the
    stone's mean a point's pores fill; 1 where the stone is at its mean.  The ratios are 1 + a z
    and 1 + b z (a, b the porosity's and roughness's amplitudes times v), and their product
    1 + z (a + b + a b z) takes two multiply-adds."""
    variation = xp.clip(variation, 0.0, 1.0)
    a, b = stone.porosity * variation, stone.roughness * variation
    return receptivity_of(xp, xp.multiply_add(z_p, xp.multiply_add(z_p, a * b, a + b), 1.0))


def receptivity_of(xp, ratios):
    """r from the product of alpha / alpha_mean and m / m_mean (docs/model.md §8.3): their
    geometric mean."""
    return xp.sqrt(ratios)


# --- masonry (docs/model.md §8.5) -----------------------------------------------------------

#: The joints' edges (the blocks' arrises) blend stone into mortar over this width, metres (a
#: chamfer of a millimetre), or over half the joint if that is less.
ARRIS = 0.001


@dataclass(frozen=True)
class Ashlar:
    """Coursed ashlar (docs/model.md §8.5): courses ``course_height`` metres high, each of blocks
    ``block_length`` metres long, every other course set over by half a block (a running bond),
    the joints ``joint_width`` metres wide and filled with the preset ``mortar``.  The courses
    run along the world's Z, the blocks along X and Y (walls in the world's axes)."""

    course_height: float = 0.35
    block_length: float = 0.7
    joint_width: float = 0.01
    mortar: str = "LIME_MORTAR"

    def __post_init__(self):
        lengths = (self.course_height, self.block_length, self.joint_width)
        if not all(isinstance(x, (int, float)) and math.isfinite(x) and x > 0.0 for x in lengths):
            raise ValueError(f"an ashlar's lengths (course, block, joint) must be > 0 m, not {lengths}")
        if self.joint_width >= min(self.course_height, self.block_length) / 2.0:
            raise ValueError(f"an ashlar's joint width ({self.joint_width:g} m) must be under half a course and block")


@dataclass(frozen=True)
class AshlarLength:
    """One of ``Ashlar``'s lengths (a field, metres): its name on the masonry group's socket and
    the panel's slider, what it is, the socket's least value and the slider's soft top."""

    label: str
    description: str
    least: float
    soft_max: float


#: ``Ashlar``'s lengths, by field: the masonry group's sockets, Make's wiring of them and the
#: panel's sliders are made from this record.
ASHLAR_LENGTHS = {
    "course_height": AshlarLength("Course Height", "Height of a course", 1e-6, 2.0),
    "block_length": AshlarLength("Block Length", "Length of a block", 1e-6, 4.0),
    "joint_width": AshlarLength("Joint Width", "Width of the mortar joints", 0.0, 0.05),
}


@dataclass(frozen=True)
class MeshBlocks:
    """Blocks the mesh knows (docs/model.md §8.5): each face's block is the whole number in its
    integer face attribute ``attribute`` (``presets.mark_blocks`` writes it from the mesh's loose
    parts or face sets; a user's own attribute does as well), and each block takes its own draw
    of the stone's parameters. The joints are the mesh's own: model them, and give the mortar's
    faces or object the lime mortar preset."""

    attribute: str = BLOCK_ATTRIBUTE

    def __post_init__(self):
        if not (isinstance(self.attribute, str) and self.attribute):
            raise ValueError(f"a MeshBlocks' attribute must be an attribute's name, not {self.attribute!r}")


def ashlar(xp, x, y, z, course_height, block_length, joint_width):
    """(course, block, joint) at the point (x, y, z) in metres of an ashlar of those lengths
    (metres): the course's and the block's whole-number indices (a block is the pair) and the
    joint's share j in [0, 1] (1 in the mortar, 0 in the stone, blending over the arris).  The
    blocks run along x + y, which is continuous round the corners of a wall in the world's X and
    Y axes (a block turns the corner as a quoin does)."""
    half = joint_width * 0.5
    arris = xp.minimum(half, ARRIS) * 0.5
    rows = z / course_height
    course = xp.floor(rows)
    parity = course - 2.0 * xp.floor(course * 0.5)  # 0 or 1: every other course set over
    along = xp.multiply_add(parity, 0.5, (x + y) / block_length)
    block = xp.floor(along)
    bed, head = rows - course, along - block  # where in its course, in its block: [0, 1)
    bed_distance = xp.minimum(bed, 1.0 - bed) * course_height  # metres to the nearest bed joint's centre
    head_distance = xp.minimum(head, 1.0 - head) * block_length
    low, high = half - arris, half + arris
    in_stone = xp.minimum(xp.smoothstep(low, high, bed_distance), xp.smoothstep(low, high, head_distance))
    return course, block, 1.0 - in_stone


def block_fields(xp, stone, z_p, z_c, draw):
    """(z_p, z_c) of a block whose own draw is ``draw`` (b in [-1, 1], mean 0): each field mixed
    with b by the stone's block share, so it stays in [-1, 1] and of mean 0, and a block's mean
    is its share of b (its bed)."""
    return xp.mix(stone.block_porosity, z_p, draw), xp.mix(stone.block_colour, z_c, draw)


#: The least mean porosity or roughness the mortar's receptivity is taken relative to.
LEAST_MEAN = 1e-3


def mortar_receptivity(xp, mortar_alpha, mortar_m, alpha, m):
    """The mortar's r relative to the stone's means alpha and m (docs/model.md §8.3, §8.5): a
    mortar more porous and rougher than the stone takes up soot, water and salt faster."""
    return receptivity_of(xp, mortar_alpha / xp.maximum(alpha, LEAST_MEAN) * (mortar_m / xp.maximum(m, LEAST_MEAN)))


def jointed(xp, joint, stone_values, mortar_values):
    """Each of ``stone_values`` (k_d, alpha, s_p, m, r) mixed with the mortar's by the joint's share,
    the mortar's k_d, alpha, s_p and m kept in their ranges as the stone's are (so are their mixes)."""
    kd, *scalars = stone_values
    mortar_kd, alpha, sp, m, r = mortar_values
    mortar_kd = xp.maximum(mortar_kd, 0.0)
    mortar_scalars = (
        xp.clip(alpha, *POROSITY_RANGE),
        xp.maximum(sp, PORE_DEPTH_RANGE[0]),
        xp.clip(m, *ROUGHNESS_RANGE),
        r,
    )
    return (
        xp.mix(xp.channel(joint), kd, mortar_kd),
        *(xp.mix(joint, a, b) for a, b in zip(scalars, mortar_scalars)),
    )


def plausible_size(size: float, metres_per_unit: float) -> str | None:
    """None when an object ``size`` scene units across is plausible for a stone object at
    ``metres_per_unit``; else a one-line advice naming the unit scale that makes it plausible
    (Scene > Units > Unit Scale)."""
    low, high = PLAUSIBLE_SIZE
    metres = size * metres_per_unit
    if not (size > 0.0 and math.isfinite(metres)) or low <= metres <= high:
        return None
    fits = [
        f"{scale:g} if it is modelled in {unit}" for unit, scale in UNIT_SCALES.items() if low <= size * scale <= high
    ]
    advice = "set Scene > Units > Unit Scale to its unit in metres" + (f" ({', '.join(fits)})" if fits else "")
    return (
        f"is {metres:.3g} m across at the scene's unit scale {metres_per_unit:g} m per unit, "
        f"implausible for stone ({low:g}–{high:g} m): {advice} (its materials follow the unit; "
        "a rising-damp map needs baking again)"
    )


#: The variation the presets' materials and the panel's Make use: the stone as it shows itself.
DEFAULT_VARIATION = 1.0
