"""``porous_weathering.weathering``, weathered materials: the documented place (docs/api.md) of
``shading.weathering``. The module replaces itself in ``sys.modules`` with the layer's, so both
names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .shading import weathering

sys.modules[__name__] = weathering
