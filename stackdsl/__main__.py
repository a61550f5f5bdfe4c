"""``python -m stackdsl``: the same as the ``stackdsl`` command."""

import sys

from ._cli import main

sys.exit(main())
