"""The ``stackdsl`` command: argument parsing and one module per subcommand.

Source: stackdsl's own.
"""
