"""The two evaluators of the maths written once in ``porous.py`` and ``modes/``.

Every maths function takes a backend ``xp`` first and uses only Python arithmetic and the
operations below, so the same lines evaluate numpy arrays (``NumpyOps``: the model, the
ground truth) and build shader nodes (``NODE_OPS``: the groups, via ``shader_math.Expr``).
Neither backend imports bpy.
"""

import numpy as np

from . import shader_math, voronoi


class NumpyOps:
    """numpy arrays.  ``colour``: colours carry RGB on the last axis, so a per-point scalar
    gets a channel axis to broadcast against them (``channel``)."""

    clip = staticmethod(np.clip)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    power = staticmethod(np.power)
    sqrt = staticmethod(np.sqrt)
    arccos = staticmethod(np.arccos)
    floor = staticmethod(np.floor)

    def __init__(self, colour: bool = True):
        self.colour = colour

    @staticmethod
    def multiply_add(a, b, c):
        return a * b + c

    @staticmethod
    def cross(a, b):
        """The cross product of vectors on the last axis."""
        return np.cross(a, b)

    @staticmethod
    def dot(a, b):
        """The dot product of vectors on the last axis: a scalar per point."""
        return np.sum(np.multiply(a, b), axis=-1)

    @classmethod
    def length(cls, v):
        return np.sqrt(cls.dot(v, v))

    @staticmethod
    def white_noise(w):
        """Blender's White Noise of ``w`` in 1D, its three channels (``voronoi.white_noise_colour``),
        in double precision as the rest of the model (the single-precision draws exactly)."""
        return tuple(channel.astype(np.float64) for channel in voronoi.white_noise_colour(w))

    @staticmethod
    def face_upward(x):
        """Vectors x (..., 3) or -x, whichever has z > 0 (-x where z = 0: Blender's Faceforward)."""
        return np.where(x[..., 2:3] > 0.0, x, -x)

    @staticmethod
    def to_nearer_end(x):
        """min(x, 1 - x): the distance of x in [0, 1] to the nearer of 0 and 1."""
        return np.minimum(x, 1.0 - x)

    @staticmethod
    def mix(factor, a, b):
        """a (1 - factor) + b factor (the Mix node): exactly a at 0 and b at 1."""
        return a * (1.0 - factor) + b * factor

    @staticmethod
    def smoothstep(edge0, edge1, x):
        """0 below edge0, 1 above edge1, 3t^2 - 2t^3 between (as GLSL and the Map Range node)."""
        t = np.clip((x - edge0) / (edge1 - edge0), 0.0, 1.0)
        return t * t * (3.0 - 2.0 * t)

    @classmethod
    def front(cls, mask, advance, lag, width):
        """A front over ``mask`` (docs/model.md §4): 0 below the edge 1 - advance + lag, 1 above the
        edge plus ``width``, smooth between."""
        edge = 1.0 - advance + lag
        return cls.smoothstep(edge, edge + width, mask)

    def channel(self, x):
        """A per-point scalar made to broadcast against a colour."""
        return np.asarray(x)[..., None] if self.colour else x


class NodeOps:
    """Shader nodes: each operation on an ``Expr`` adds a Math or Vector Math node; Blender
    broadcasts a scalar socket into a colour one by itself."""

    clip = staticmethod(shader_math.clip)
    maximum = staticmethod(shader_math.maximum)
    minimum = staticmethod(shader_math.minimum)
    power = staticmethod(shader_math.power)
    sqrt = staticmethod(shader_math.sqrt)
    arccos = staticmethod(shader_math.arccos)
    floor = staticmethod(shader_math.floor)
    white_noise = staticmethod(shader_math.white_noise)
    face_upward = staticmethod(shader_math.face_upward)
    smoothstep = staticmethod(shader_math.smoothstep)
    front = staticmethod(shader_math.front)
    multiply_add = staticmethod(shader_math.multiply_add)
    cross = staticmethod(shader_math.cross)
    dot = staticmethod(shader_math.dot)
    length = staticmethod(shader_math.length)
    mix = staticmethod(shader_math.mix)
    to_nearer_end = staticmethod(shader_math.to_nearer_end)

    @staticmethod
    def channel(x):
        return x


NODE_OPS = NodeOps()


def numpy_ops(kd) -> NumpyOps:
    """The numpy backend for a colour ``kd``: with a channel axis unless ``kd`` is a scalar grey."""
    return NumpyOps(colour=bool(np.ndim(kd)))
