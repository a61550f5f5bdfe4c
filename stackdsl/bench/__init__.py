"""``stackdsl bench``: speed against error, hard cases, verdict agreement, sweeps at scale.

Source: stackdsl's own.
"""
