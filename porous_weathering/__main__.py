import sys

from porous_weathering.cli import main

sys.exit(main())
