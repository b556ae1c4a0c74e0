"""``porous_weathering.uv``, the lightmap UVs image maps are baked on: the documented place
(docs/api.md) of ``maps.lightmap``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import lightmap as uv

sys.modules[__name__] = uv
