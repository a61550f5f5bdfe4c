"""``python -m stackdsl``: the same as the ``stackdsl`` command."""

import sys

from ._entry import main

sys.exit(main())
