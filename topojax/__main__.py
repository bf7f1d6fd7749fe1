"""``python -m topojax``: the ``topojax`` command."""

import sys

from .cli import main

sys.exit(main())
