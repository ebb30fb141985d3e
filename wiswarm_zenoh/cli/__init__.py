"""The ``wiswarm`` command line: one module per group of subcommands."""
