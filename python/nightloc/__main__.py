"""``python -m nightloc``: the same command line as the ``nightloc`` script."""

import sys

from .cli import main

sys.exit(main())
