"""Write shader-node maths as Python expressions, so node builders read like model.py.

``Graph(tree)`` wraps a node tree; ``graph.wrap(socket)`` turns an output socket into an
``Expr``.  Arithmetic on Exprs adds one Math node (scalars) or Vector Math node (colours and
vectors) per operation; operations on Python numbers alone are folded at build time, so
constants cost no nodes.  Nodes are laid out in columns by their depth in the graph.
"""

import math

SCALAR, VECTOR = "SCALAR", "VECTOR"
_COLUMN_WIDTH, _ROW_HEIGHT = 220, 180


class Graph:
    """A node tree being built, with a simple column layout."""

    def __init__(self, tree):
        self.tree = tree
        self._rows = {}
        self._made = {}  # (operation, operands) -> Expr: a shared sub-expression is built once

    def node(self, bl_idname, inputs=(), depth=None, **properties):
        """A new node with ``properties`` set and ``inputs`` (name or index -> value) connected."""
        node = self.tree.nodes.new(bl_idname)
        for key, value in properties.items():
            setattr(node, key, value)
        items = inputs.items() if isinstance(inputs, dict) else enumerate(inputs)
        depths = [0]
        for key, value in items:
            depths.append(self.connect(value, node.inputs[key]))
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
        key = (operation, *(x.socket.as_pointer() if isinstance(x, Expr) else x for x in operands))
        if key not in self._made:
            kind = SCALAR if operation in _VECTOR_TO_SCALAR or not vector else VECTOR
            bl_idname = "ShaderNodeVectorMath" if vector else "ShaderNodeMath"
            output = "Vector" if vector and operation not in _VECTOR_TO_SCALAR else "Value"
            node = self.node(bl_idname, list(operands), operation=operation)
            made = Expr(self, node.outputs[output], kind)
            if operation == "SUBTRACT" and operands[0] == 1.0:
                made.complement = operands[1]
            self._made[key] = made
        return self._made[key]

    def clamp01(self, x):
        """x clamped to [0, 1] by one Math node: max(x, 0) with the node's own output clamp."""
        node = self.node("ShaderNodeMath", [x, 0.0], operation="MAXIMUM", use_clamp=True)
        return Expr(self, node.outputs["Value"], SCALAR, bounds=(0.0, 1.0))

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
    "ARCCOSINE": lambda a: math.acos(min(max(a, -1.0), 1.0)),
}
_VECTOR_TO_SCALAR = {"DOT_PRODUCT", "LENGTH", "DISTANCE"}


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
    return _graph_of(a, b).math("MAXIMUM", a, b) if _graph_of(a, b) else max(a, b)


def minimum(a, b):
    return _graph_of(a, b).math("MINIMUM", a, b) if _graph_of(a, b) else min(a, b)


def clip(x, low, high):
    """x clamped to [low, high]: one node for a scalar into [0, 1], else two (MIN/MAX, which
    also replace NaN by the bound in Cycles, as the Math node's clamp does)."""
    if not isinstance(x, Expr):
        return min(max(x, low), high)
    if x.bounds is not None and low <= x.bounds[0] and x.bounds[1] <= high:
        return x
    if x.kind == SCALAR and (low, high) == (0.0, 1.0):
        return x.graph.clamp01(x)
    clipped = minimum(maximum(x, low), high)
    return Expr(x.graph, clipped.socket, clipped.kind, bounds=(low, high))


def multiply_add(a, b, c):
    """a * b + c in one Math or Vector Math node."""
    graph = _graph_of(a, b, c)
    return a * b + c if graph is None else graph.math("MULTIPLY_ADD", a, b, c)


def smoothstep(edge0, edge1, x):
    """0 below edge0, 1 above edge1, 3t^2 - 2t^3 between (t = (x - edge0) / (edge1 - edge0)):
    one Map Range node, where clamping and the cubic would take eight Math nodes."""
    graph = _graph_of(edge0, edge1, x)
    if graph is None:
        t = min(max((x - edge0) / (edge1 - edge0), 0.0), 1.0)
        return t * t * (3.0 - 2.0 * t)
    node = graph.node(
        "ShaderNodeMapRange",
        {"Value": x, "From Min": edge0, "From Max": edge1, "To Min": 0.0, "To Max": 1.0},
        data_type="FLOAT",
        interpolation_type="SMOOTHSTEP",
        clamp=True,
    )
    return Expr(graph, node.outputs["Result"], SCALAR, bounds=(0.0, 1.0))


def arccos(x):
    return x.graph.math("ARCCOSINE", x) if isinstance(x, Expr) else math.acos(x)


def power(base, exponent):
    """Scalar power, or per-channel power of a colour base."""
    graph = _graph_of(base, exponent)
    if graph is None:
        return base**exponent
    if isinstance(base, Expr) and base.kind == VECTOR:
        return graph.power_rgb(base, exponent)
    return graph.math("POWER", base, exponent)


def dot(a, b):
    return a.graph.math("DOT_PRODUCT", a, b)


def normalize(v):
    return v.graph.math("NORMALIZE", v)


def _graph_of(*values):
    for value in values:
        if isinstance(value, Expr):
            return value.graph
    return None
