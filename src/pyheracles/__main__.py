"""``python -m pyheracles`` runs the ``heracles`` command."""

import sys

from pyheracles.cli import main

sys.exit(main())
