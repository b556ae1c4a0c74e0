"""The toy mode of the registry tests, written as a mode is: this one module in core/modes/ (the
``toys`` fixture puts this folder on that package's path), its inputs, its maths as layers and
its one ``Mode`` record, ``MODE`` (docs/architecture.md, "Add a mode")."""

from .base import TIME, Input, Layer, Mode

GRIME = Input("grime", 0.0, 0.0, 1.0, "Toy grime: darkens the diffuse where the toy map is high", mask=True, map="toy")
STRENGTH = Input("grime_strength", 0.5, 0.0, 1.0, "How much the grime darkens at t = 1")


def darken_with_grime(xp, point):
    """Written once: evaluated by numpy in the model, built as nodes in the group."""
    s = point.state
    point.kd_w = point.kd_w * (1.0 - xp.channel(s["grime"] * s["grime_strength"] * s["time"]))


MODE = Mode(
    "grime",
    "Grime",
    "Toy mode of the registry tests",
    (TIME, GRIME, STRENGTH),
    (Layer(50, darken_with_grime),),
    catalog="Grime",
    asset_summary="Toy grime",
)
