"""``porous_weathering.runoff_flow``, the run-off's flow in numpy: the documented place
(docs/api.md) of ``maps.runoff_flow``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import runoff_flow

sys.modules[__name__] = runoff_flow
