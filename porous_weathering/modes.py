"""``porous_weathering.modes``, the registry of weathering modes: the documented place
(docs/api.md) of ``core.modes``. The module replaces itself in ``sys.modules`` with the layer's,
so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .core import modes

sys.modules[__name__] = modes
