"""``porous_weathering.rain``, the rain-exposure map: the documented place (docs/api.md) of
``maps.rain``. The module replaces itself in ``sys.modules`` with the layer's, so both names are
one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import rain

sys.modules[__name__] = rain
