"""``porous_weathering.scan_checks``, the warnings the bake gives about scans: the documented place
(docs/api.md) of ``maps.scan_checks``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .maps import scan_checks

sys.modules[__name__] = scan_checks
