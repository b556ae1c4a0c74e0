"""``porous_weathering.presets``, porous material presets: the documented place (docs/api.md) of
``shading.presets``. The module replaces itself in ``sys.modules`` with the layer's, so both
names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .shading import presets

sys.modules[__name__] = presets
