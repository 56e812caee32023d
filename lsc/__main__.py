"""``python -m lsc``: the ``lsc`` command line."""

import sys

from .cli import main

sys.exit(main())
