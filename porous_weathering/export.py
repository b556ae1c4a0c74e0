"""``porous_weathering.export``, weathered states published as glTF: the documented place
(docs/api.md) of ``publish.export``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .publish import export

sys.modules[__name__] = export
