"""``porous_weathering.model``, the model in plain numpy, without bpy: the documented place
(docs/api.md) of ``core.model``. The module replaces itself in ``sys.modules`` with the layer's,
so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .core import model

sys.modules[__name__] = model
