"""Many scenarios at once: ``check`` over folders, sweeps, worker pools and the reports of a run.

Source: stackdsl's own.
"""
