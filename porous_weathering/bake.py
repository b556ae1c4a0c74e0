"""``porous_weathering.bake``, the one bake pipeline of the weathering maps: the documented place
(docs/api.md) of ``maps.bake``. The module replaces itself in ``sys.modules`` with the layer's,
so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import bake

sys.modules[__name__] = bake
