"""Helpers that know nothing of scenarios: output files written whole, the optional extras.

The lowest floor of the import contract (pyproject.toml): every other floor may use it, and it
imports none of them. Source: stackdsl's own.
"""
