"""Write shader-node maths as Python expressions, so node builders read like model.py.

``Graph(tree)`` wraps a node tree; ``graph.wrap(socket)`` turns an output socket into an
``Expr``.  Arithmetic on Exprs adds one Math node (scalars) or Vector Math node (colours and
vectors) per operation; operations on Python numbers alone are folded at build time, so
constants cost no nodes.  Nodes are laid out in columns by their depth in the graph.
"""

import math

from . import voronoi

SCALAR, VECTOR = "SCALAR", "VECTOR"
#: Nodes whose outputs are not known when the group is built: the shading geometry, the texture
#: coordinates and the object's own data (its location).
VARYING_SOURCES = ("ShaderNodeNewGeometry", "ShaderNodeTexCoord", "ShaderNodeObjectInfo")
_COLUMN_WIDTH, _ROW_HEIGHT = 220, 180


class Graph:
    """A node tree being built, with a simple column layout."""

    def __init__(self, tree):
        self.tree = tree
        self._rows = {}
        self._made = {}  # (operation, operands) -> Expr: a shared sub-expression is built once
        self._sources = {}  # (bl_idname, properties) -> the one node of the shading point's own data
        self._varying = set()  # names of the nodes downstream of the Geometry node or a mask
        self._varying_sockets = set()  # group inputs that change from point to point (masks)

    def node(self, bl_idname, inputs=(), depth=None, **properties):
        """A new node with ``properties`` set and ``inputs`` (name or index -> value) connected; a
        source of the shading point's own data (``VARYING_SOURCES``, no inputs) is made once per
        tree, so that what is built from it (the point's place, its normal) is built once too."""
        if bl_idname in VARYING_SOURCES and not inputs:
            key = (bl_idname, depth, *sorted(properties.items()))
            if key not in self._sources:
                self._sources[key] = self._new_node(bl_idname, (), depth, properties)
            return self._sources[key]
        return self._new_node(bl_idname, inputs, depth, properties)

    def _new_node(self, bl_idname, inputs, depth, properties):
        node = self.tree.nodes.new(bl_idname)
        for key, value in properties.items():
            setattr(node, key, value)
        items = inputs.items() if isinstance(inputs, dict) else enumerate(inputs)
        depths = [0]
        varying = bl_idname in VARYING_SOURCES
        for key, value in items:
            depths.append(self.connect(value, node.inputs[key]))
            varying = varying or self.varies(value)
        if varying:
            self._varying.add(node.name)
        column = depth if depth is not None else max(depths) + 1
        row = self._rows.get(column, 0)
        self._rows[column] = row + 1
        node.location = (column * _COLUMN_WIDTH, -row * _ROW_HEIGHT)
        node["pw_depth"] = column
        return node

    def connect(self, value, socket):
        """Link an Expr or socket into ``socket``, or set a constant; returns the source depth."""
        if isinstance(value, Expr):
            value = value.socket
        if hasattr(value, "links"):  # an output socket
            self.tree.links.new(value, socket)
            return value.node.get("pw_depth", 0)
        if socket.type in ("VECTOR", "RGBA") and not isinstance(value, (tuple, list)):
            value = (value,) * len(socket.default_value)
        elif socket.type == "RGBA" and len(value) == 3:
            value = (*value, 1.0)
        socket.default_value = value
        return 0

    def varies(self, value):
        """Whether ``value`` changes from one shading point to the next: it depends on the
        Geometry node or on a group input marked varying (a mask, which a map feeds); other
        group inputs count as constants, which materials mostly leave them."""
        socket = value.socket if isinstance(value, Expr) else value
        if not hasattr(socket, "links"):
            return False
        return socket.node.name in self._varying or socket.as_pointer() in self._varying_sockets

    def wrap_varying(self, socket):
        """``wrap(socket)`` for a group input that changes from point to point."""
        self._varying_sockets.add(socket.as_pointer())
        return self.wrap(socket)

    def wrap(self, socket, kind=None):
        if kind is None:
            kind = SCALAR if socket.type in ("VALUE", "INT") else VECTOR
        return Expr(self, socket, kind)

    def math(self, operation, *operands):
        """One Math node (all scalar operands) or Vector Math node (any vector operand)."""
        if not any(isinstance(x, Expr) for x in operands):
            return _fold(operation, *operands)
        vector = any(isinstance(x, Expr) and x.kind == VECTOR for x in operands)
        if vector and operation == "POWER":
            raise TypeError("use Graph.power_rgb for a colour base")
        if operation == "SUBTRACT" and operands[0] == 1.0 and getattr(operands[1], "complement", None) is not None:
            return operands[1].complement  # 1 - (1 - y) is y: no node
        if operation in ("ADD", "SUBTRACT", "MULTIPLY_ADD"):
            simpler = self._sum(operation, *operands)
            if simpler is not None:
                return simpler
        if operation == "MULTIPLY" and vector and any(_is_scalar(x) for x in operands):
            return self._scale(*operands)
        if operation == "MULTIPLY" and not vector:
            return self._product(*operands)
        if (
            operation == "DIVIDE"
            and _is_nonzero_number(operands[1])
            and getattr(operands[0], "product", None) is not None
        ):
            return self._product(operands[0], 1.0 / operands[1])  # (x c) / d is x (c / d): one node per point
        key = (operation, *(_operand_key(x) for x in operands))
        if key not in self._made:
            kind = SCALAR if operation in _VECTOR_TO_SCALAR or not vector else VECTOR
            bl_idname = "ShaderNodeVectorMath" if vector else "ShaderNodeMath"
            output = "Vector" if vector and operation not in _VECTOR_TO_SCALAR else "Value"
            node = self.node(bl_idname, list(operands), operation=operation)
            made = Expr(self, node.outputs[output], kind)
            if operation == "SUBTRACT" and operands[0] == 1.0:
                made.complement = operands[1]
            if operation in ("SUBTRACT", "MINIMUM"):
                made.operands = operands
            if operation == "MULTIPLY_ADD" and not vector and self.varies(made) and not self.varies(operands[2]):
                made.affine = operands
            self._made[key] = made
        return self._made[key]

    def _sum(self, operation, *operands):
        """The same sum in fewer per-point nodes, or None: x + 0 and 0 b + x are x, 1 b + c is b + c, a
        constant added to a b + c (a multiply-add with a constant c) joins c, and a constant k
        times such a b + c (b constant too) plus a constant is a (k b) + (k c + ...): Cycles folds
        the constants where the material sets them, so that a sum or product of varying and
        constant terms costs one node."""
        if operation == "MULTIPLY_ADD":
            a, b, c = operands
            if _is_zero(a) or _is_zero(b):
                return c
            if _is_one(a) or _is_one(b):
                return self.math("ADD", b if _is_one(a) else a, c)
            for factor, term in ((a, b), (b, a)):
                if self._constant(factor) and self._constant(c) and self._constant_factor(term):
                    x, scale, offset = term.affine  # k (x s + o) + c is x (k s) + (k o + c)
                    return self.math("MULTIPLY_ADD", x, factor * scale, factor * offset + c)
            return None
        x, y = operands
        if _is_zero(y):
            return x
        if operation == "SUBTRACT" and not isinstance(x, Expr) and self.varies(y):
            subtracted = self._subtracted_from_constant(x, y)
            if subtracted is not None:
                return subtracted
        if operation == "ADD" and _is_zero(x):
            return y
        if operation == "ADD" and getattr(y, "affine", None) is not None and self._constant(x):
            x, y = y, x
        if getattr(x, "affine", None) is None or not self._constant(y):
            return None
        a, b, c = x.affine
        return self.math("MULTIPLY_ADD", a, b, self.math(operation, c, y))

    def _subtracted_from_constant(self, c, y):
        """c - y for a constant number c and a varying y in fewer per-point nodes, or None: c - s v
        (s a number) is one multiply-add, c - (e - v) is v + (c - e), and c - min(u, d) is
        max(c - u, c - d) (e, d constants), so that such a chain costs one node per point."""
        if y.scaled is not None and _is_nonzero_number(y.scaled[1]):
            return self.math("MULTIPLY_ADD", y.scaled[0], -y.scaled[1], c)
        operation = self._operation_of(y)
        if operation is None:
            return None
        a, b = y.operands
        if operation == "SUBTRACT" and not self.varies(a) and self.varies(b):
            return self.math("ADD", b, self.math("SUBTRACT", c, a))
        if operation == "MINIMUM" and self.varies(a) and not isinstance(b, Expr):
            return maximum(self.math("SUBTRACT", c, a), c - b)
        return None

    def _operation_of(self, y):
        """The operation of ``y`` if it is a Subtract or Minimum node (its ``operands`` kept), else None."""
        operands = getattr(y, "operands", None)
        return None if operands is None else y.socket.node.operation

    def _constant(self, x):
        return not _is_vector(x) and not self.varies(x)

    def _constant_factor(self, x):
        """Whether ``x`` is a multiply-add x s + o with constant s (and o)."""
        return getattr(x, "affine", None) is not None and self._constant(x.affine[1])

    def _product(self, a, b):
        """a b with its varying factors multiplied together and its constant ones together,
        the constants last: (x c) f is (x f) c, and (x c) d is x (c d), which Cycles folds
        where the material sets c and d; the same factors give the same nodes in any order
        of layers, so that a factor of exactly 1 leaves a result bit for bit unchanged.  A constant
        c times a varying 1 - y is c - c y, one multiply-add per point, and c times a smoothstep
        is the smoothstep's Map Range to [0, c] (0 + f (c - 0): f c to the bit), no node more."""
        for factor, other in ((a, b), (b, a)):
            if getattr(other, "ramp", None) is not None and self._constant(factor) and not _is_one(factor):
                return smoothstep(*other.ramp, top=factor)
            complement = getattr(other, "complement", None)
            if complement is not None and self.varies(other) and self._constant(factor) and not _is_one(factor):
                return self.math("MULTIPLY_ADD", complement, -factor, factor)
        (x1, c1), (x2, c2) = self._parts(a), self._parts(b)
        return self._times(self._times(x1, x2), self._times(c1, c2))

    def _times(self, a, b):
        """One Multiply node for a b; None is the empty product, and 1 costs no node."""
        if a is None or _is_one(a):
            return b
        if b is None or _is_one(b):
            return a
        if not isinstance(a, Expr) and not isinstance(b, Expr):
            return _fold("MULTIPLY", a, b)
        key = ("MULTIPLY", *sorted((_operand_key(a), _operand_key(b)), key=str))  # a b is b a
        if key not in self._made:
            node = self.node("ShaderNodeMath", [a, b], operation="MULTIPLY")
            made = Expr(self, node.outputs["Value"], SCALAR, bounds=_product_bounds(a, b))
            made.product = self._split(a, b)
            self._made[key] = made
        return self._made[key]

    def _split(self, a, b):
        """(varying part, constant part) of the product a b, or None when neither is a part."""
        varying, constant = zip(*(self._parts(x) for x in (a, b)))
        varying, constant = [x for x in varying if x is not None], [x for x in constant if x is not None]
        return (varying[0], constant[0]) if len(varying) == len(constant) == 1 else None

    def _parts(self, x):
        """(varying factor or None, constant factor or None) of a scalar operand."""
        if getattr(x, "product", None) is not None:
            return x.product
        return (x, None) if self.varies(x) else (None, x)

    def _scale(self, a, b):
        """A colour times a scalar: one Scale node, where Multiply would take a per-point scalar
        through a conversion to a colour (a node of its own in Cycles).  A scaled colour scaled
        again is the colour scaled once by the product of the scalars, which Cycles folds when
        both are constants (a weight that several layers scale, such as the water lobe's)."""
        vector, scalar = (a, b) if isinstance(a, Expr) and a.kind == VECTOR else (b, a)
        if vector.scaled is not None:
            vector, scalar = vector.scaled[0], vector.scaled[1] * scalar
        key = ("SCALE", _operand_key(vector), _operand_key(scalar))
        if key not in self._made:
            node = self.node("ShaderNodeVectorMath", {0: vector, "Scale": scalar}, operation="SCALE")
            made = Expr(self, node.outputs["Vector"], VECTOR)
            made.scaled = (vector, scalar)
            self._made[key] = made
        return self._made[key]

    def mix(self, factor, a, b):
        """a (1 - factor) + b factor in one Mix node: scalars, colours, or colours mixed per
        channel by a colour factor.  The factor is not clamped (the maths keeps it in [0, 1])."""
        if getattr(factor, "complement", None) is not None and self.varies(factor):
            return self.mix(factor.complement, b, a)  # a by 1 - y, b by y: no node for 1 - y per point
        kinds = {x.kind for x in (factor, a, b) if isinstance(x, Expr)}
        vector = VECTOR in kinds or any(isinstance(x, (tuple, list)) for x in (a, b))
        per_channel = isinstance(factor, Expr) and factor.kind == VECTOR
        suffix = "Vector" if vector else "Float"
        key = ("MIX", *(_operand_key(x) for x in (factor, a, b)))
        if key not in self._made:
            node = self.node(
                "ShaderNodeMix",
                {
                    _MIX_INPUTS[f"Factor_{'Vector' if per_channel else 'Float'}"]: factor,
                    _MIX_INPUTS[f"A_{suffix}"]: a,
                    _MIX_INPUTS[f"B_{suffix}"]: b,
                },
                data_type="VECTOR" if vector else "FLOAT",
                factor_mode="NON_UNIFORM" if per_channel else "UNIFORM",
                clamp_factor=False,
            )
            output = next(socket for socket in node.outputs if socket.identifier == f"Result_{suffix}")
            self._made[key] = Expr(self, output, VECTOR if vector else SCALAR)
        return self._made[key]

    def clamp01(self, x):
        """x clamped to [0, 1] by one Math node: max(x, 0) with the node's own output clamp."""
        node = self.node("ShaderNodeMath", [x, 0.0], operation="MAXIMUM", use_clamp=True)
        return Expr(self, node.outputs["Value"], SCALAR, bounds=(0.0, 1.0))

    def clamp(self, x, low, high):
        """A scalar x clamped to [low, high] by one Clamp node, where MIN and MAX take two."""
        key = ("CLAMP", *(_operand_key(value) for value in (x, low, high)))
        if key not in self._made:
            node = self.node("ShaderNodeClamp", {"Value": x, "Min": low, "Max": high}, clamp_type="MINMAX")
            bounds = (low, high) if not any(isinstance(x, Expr) for x in (low, high)) else None
            self._made[key] = Expr(self, node.outputs["Result"], SCALAR, bounds=bounds)
        return self._made[key]

    def power_rgb(self, base, exponent):
        """base^exponent per colour channel (Gamma node; 0^x stays 0, as for 0 < x)."""
        node = self.node("ShaderNodeGamma", {"Color": base, "Gamma": exponent})
        return Expr(self, node.outputs["Color"], VECTOR)


_FOLD = {
    "ADD": lambda a, b: a + b,
    "SUBTRACT": lambda a, b: a - b,
    "MULTIPLY": lambda a, b: a * b,
    "DIVIDE": lambda a, b: a / b if b else 0.0,
    "MAXIMUM": max,
    "MINIMUM": min,
    "POWER": lambda a, b: a**b,
    "SQRT": lambda a: math.sqrt(max(a, 0.0)),
    "ARCCOSINE": lambda a: math.acos(min(max(a, -1.0), 1.0)),
    "FLOOR": math.floor,
}
_VECTOR_TO_SCALAR = {"DOT_PRODUCT", "LENGTH", "DISTANCE"}
#: Input indices of the Mix node by identifier (the same in Blender 4.5 and 5.2; several
#: inputs share each name, so names cannot tell them apart).
_MIX_INPUTS = {
    identifier: index
    for index, identifier in enumerate(
        ("Factor_Float", "Factor_Vector", "A_Float", "B_Float", "A_Vector", "B_Vector", "A_Color", "B_Color")
    )
}


def _operand_key(x):
    return x.socket.as_pointer() if isinstance(x, Expr) else x


def _is_one(x):
    return not isinstance(x, Expr) and x == 1.0


def _is_zero(x):
    return not isinstance(x, Expr) and x == 0.0


def _is_vector(x):
    return x.kind == VECTOR if isinstance(x, Expr) else isinstance(x, (tuple, list))


def _product_bounds(a, b):
    """The bounds of a b where both factors are known not to be negative, else None."""
    bounds = [x.bounds if isinstance(x, Expr) else (x, x) if isinstance(x, (int, float)) else None for x in (a, b)]
    if any(bound is None or bound[0] < 0.0 for bound in bounds):
        return None
    return bounds[0][0] * bounds[1][0], bounds[0][1] * bounds[1][1]


def _is_nonzero_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool) and x != 0


def _is_scalar(x):
    return x.kind == SCALAR if isinstance(x, Expr) else isinstance(x, (int, float))


def _fold(operation, *operands):
    return float(_FOLD[operation](*operands))


class Expr:
    """An output socket in a Graph, with Python operators that add nodes.

    ``bounds`` is the (low, high) range the value is known to lie in, or None: clip() of an
    Expr already inside the range adds no nodes.  ``complement`` is y when this is 1 - y.
    """

    def __init__(self, graph, socket, kind, bounds=None):
        self.graph, self.socket, self.kind, self.bounds = graph, socket, kind, bounds
        self.complement = None
        self.scaled = None  #: (colour, scalar) when this is that colour times that scalar
        #: (varying x, constant c) when this is x c (Graph.varies), so that a further constant
        #: factor joins c rather than costing a node per point
        self.product = None
        #: (a, b, c) when this is the scalar a b + c with a constant c, so that a constant added
        #: to it joins c (Graph._sum)
        self.affine = None
        #: the operands of a Subtract or Minimum node, for Graph._subtracted_from_constant
        self.operands = None
        #: (edge0, edge1, x) when this is smoothstep(edge0, edge1, x) in [0, 1], so that a constant
        #: factor becomes the Map Range's top (Graph._product)
        self.ramp = None

    def __add__(self, other):
        return self.graph.math("ADD", self, other)

    def __radd__(self, other):
        return self.graph.math("ADD", other, self)

    def __sub__(self, other):
        return self.graph.math("SUBTRACT", self, other)

    def __rsub__(self, other):
        return self.graph.math("SUBTRACT", other, self)

    def __mul__(self, other):
        return self.graph.math("MULTIPLY", self, other)

    def __rmul__(self, other):
        return self.graph.math("MULTIPLY", other, self)

    def __neg__(self):
        return self.graph.math("SUBTRACT", 0.0, self)

    def __truediv__(self, other):
        return self.graph.math("DIVIDE", self, other)

    def __rtruediv__(self, other):
        return self.graph.math("DIVIDE", other, self)


def maximum(a, b):
    """max(a, b); no node when a is known to lie at or above the constant b (``Expr.bounds``)."""
    if isinstance(a, Expr) and a.bounds is not None and not isinstance(b, Expr) and a.bounds[0] >= b:
        return a
    return _graph_of(a, b).math("MAXIMUM", a, b) if _graph_of(a, b) else max(a, b)


def minimum(a, b):
    return _graph_of(a, b).math("MINIMUM", a, b) if _graph_of(a, b) else min(a, b)


def clip(x, low, high):
    """x clamped to [low, high]: one node for a scalar (a Math node's own clamp into [0, 1], else a
    Clamp node), two for a colour (MIN/MAX); each replaces NaN by a bound in Cycles."""
    if not isinstance(x, Expr):
        return min(max(x, low), high)
    if x.bounds is not None and low <= x.bounds[0] and x.bounds[1] <= high:
        return x
    if x.kind == SCALAR and (low, high) == (0.0, 1.0):
        return x.graph.clamp01(x)
    if x.kind == SCALAR:
        return x.graph.clamp(x, low, high)
    clipped = minimum(maximum(x, low), high)
    return Expr(x.graph, clipped.socket, clipped.kind, bounds=(low, high))


def multiply_add(a, b, c):
    """a * b + c in one Math or Vector Math node."""
    graph = _graph_of(a, b, c)
    return a * b + c if graph is None else graph.math("MULTIPLY_ADD", a, b, c)


def smoothstep(edge0, edge1, x, top=1.0):
    """0 below edge0, 1 above edge1, 3t^2 - 2t^3 between (t = (x - edge0) / (edge1 - edge0)), times
    ``top``: one Map Range node, where clamping and the cubic would take eight Math nodes."""
    graph = _graph_of(edge0, edge1, x, top)
    if graph is None:
        t = min(max((x - edge0) / (edge1 - edge0), 0.0), 1.0)
        return t * t * (3.0 - 2.0 * t) * top
    node = graph.node(
        "ShaderNodeMapRange",
        {"Value": x, "From Min": edge0, "From Max": edge1, "To Min": 0.0, "To Max": top},
        data_type="FLOAT",
        interpolation_type="SMOOTHSTEP",
        clamp=False,  # the cubic stays in [0, 1]; Cycles would add a Clamp node
    )
    top_bounds = top.bounds if isinstance(top, Expr) else (top, top)
    bounds = (0.0, top_bounds[1]) if top_bounds is not None and top_bounds[0] >= 0.0 else None
    made = Expr(graph, node.outputs["Result"], SCALAR, bounds=bounds)
    if _is_one(top):
        made.ramp = (edge0, edge1, x)
    return made


def front(mask, advance, lag, width):
    """smoothstep(e, e + width, mask) for the edge e = 1 - advance + lag (``NumpyOps.front``). Where
    the advance changes from point to point (a stone's local age), the same t = (mask - e) / width
    is taken as (mask + advance) against the constant edges 1 + lag and 1 + lag + width: one
    multiply-add of the advance (a varying age times a constant level) per point, where the two
    edges would cost three nodes (docs/model.md §8.9)."""
    graph = _graph_of(mask, advance, lag, width)
    if graph is None or not graph.varies(advance):
        edge = 1.0 - advance + lag
        return smoothstep(edge, edge + width, mask)
    age, level = advance.product or (advance, 1.0)
    edge = 1.0 + lag
    return smoothstep(edge, edge + width, multiply_add(age, level, mask))


def mix(factor, a, b):
    """a (1 - factor) + b factor: exactly a at factor 0 and b at factor 1."""
    graph = _graph_of(factor, a, b)
    if graph is not None and not isinstance(factor, Expr) and factor in (0.0, 1.0):
        return b if factor else a
    if graph is None:
        return a * (1.0 - factor) + b * factor
    return graph.mix(factor, a, b)


def floor(x):
    """The largest whole number not above x (a scalar, or each component of a vector): one Math or
    Vector Math node."""
    return x.graph.math("FLOOR", x) if isinstance(x, Expr) else float(math.floor(x))


def white_noise(w):
    """Three draws in [0, 1] of a scalar ``w``: the White Noise texture's Color in 1D, one node and
    the Separate Color of its channels; of a constant, the numbers themselves
    (``voronoi.white_noise_colour``, as numpy draws them)."""
    if not isinstance(w, Expr):
        return tuple(float(channel) for channel in voronoi.white_noise_colour(w))
    noise = w.graph.node("ShaderNodeTexWhiteNoise", {"W": w}, noise_dimensions="1D")
    channels = w.graph.node("ShaderNodeSeparateColor", {"Color": noise.outputs["Color"]})
    return tuple(w.graph.wrap(output) for output in channels.outputs[:3])


def face_upward(x):
    """The vector x or -x, whichever has z > 0 (-x where z = 0): one Vector Math Faceforward."""
    return x.graph.math("FACEFORWARD", x, (0.0, 0.0, -1.0), x)


def arccos(x):
    return x.graph.math("ARCCOSINE", x) if isinstance(x, Expr) else math.acos(x)


def power(base, exponent):
    """Scalar power, or per-channel power of a colour base."""
    graph = _graph_of(base, exponent)
    if graph is None:
        return base**exponent
    if _is_one(exponent):  # x^1 is x, bit for bit
        return base
    if isinstance(base, Expr) and base.kind == VECTOR:
        return graph.power_rgb(base, exponent)
    return graph.math("POWER", base, exponent)


def sqrt(x):
    """The square root of a scalar: one Math node (Cycles takes 0 below 0)."""
    return x.graph.math("SQRT", x) if isinstance(x, Expr) else math.sqrt(x)


def to_nearer_end(x):
    """min(x, 1 - x) of x in [0, 1], its distance to the nearer end: one Ping-Pong node (x
    reflected at every multiple of 1/2), where MIN and 1 - x take two."""
    return x.graph.math("PINGPONG", x, 0.5) if isinstance(x, Expr) else min(x, 1.0 - x)


def dot(a, b):
    return a.graph.math("DOT_PRODUCT", a, b)


def cross(a, b):
    return _graph_of(a, b).math("CROSS_PRODUCT", a, b)


def length(v):
    return v.graph.math("LENGTH", v)


def normalize(v):
    return v.graph.math("NORMALIZE", v)


def _graph_of(*values):
    for value in values:
        if isinstance(value, Expr):
            return value.graph
    return None
