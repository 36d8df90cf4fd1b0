"""``python -m app`` runs the ``facepair`` command line."""

from app.cli import main

main()
