"""``python -m pinid`` is the ``pinid`` command."""

import sys

from pinid.cli.main import main

sys.exit(main())
