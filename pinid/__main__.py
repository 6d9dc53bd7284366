"""``python -m pinid`` is the ``pinid`` command."""

import sys

from .cli import main

sys.exit(main())
