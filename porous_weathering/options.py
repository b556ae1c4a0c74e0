"""``porous_weathering.options``, options declared once for every front end: the documented place
(docs/api.md) of ``common.options``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .common import options

sys.modules[__name__] = options
