"""``python -m topojax.cli``: the ``topojax`` command."""

import sys

from . import main

sys.exit(main())
