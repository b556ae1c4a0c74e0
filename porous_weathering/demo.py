"""``porous_weathering.demo``, the main job on the bundled samples: the documented place
(docs/quickstart.md) of ``samples.demo``. The module replaces itself in ``sys.modules`` with the
layer's, so both names are one module with one state (docs/architecture.md, "The public API").
"""

import sys

from .samples import demo

sys.modules[__name__] = demo
