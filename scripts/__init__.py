"""Entry points: the ``recent`` command and its subcommands."""
