"""``porous_weathering.runoff``, the run-off map: the documented place (docs/api.md) of
``maps.runoff``. The module replaces itself in ``sys.modules`` with the layer's, so both names
are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import runoff

sys.modules[__name__] = runoff
