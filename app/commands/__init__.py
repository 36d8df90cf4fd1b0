"""Subcommand groups of the ``facepair`` CLI, one module per job (registered in app.cli)."""
