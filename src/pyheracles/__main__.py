"""``python -m pyheracles`` runs the ``heracles`` command."""

from pyheracles.cli import run

run()
