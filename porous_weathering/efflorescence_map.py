"""``porous_weathering.efflorescence_map``, efflorescence location maps: the documented place
(docs/api.md) of ``maps.efflorescence_map``. The module replaces itself in ``sys.modules`` with
the layer's, so both names are one module with one state (docs/architecture.md, "The public
API").
"""

import sys

from .maps import efflorescence_map

sys.modules[__name__] = efflorescence_map
