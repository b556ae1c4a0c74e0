"""``porous_weathering.edges``, the edge/cavity mask: the documented place (docs/api.md) of
``maps.edges``. The module replaces itself in ``sys.modules`` with the layer's, so both names
are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import edges

sys.modules[__name__] = edges
