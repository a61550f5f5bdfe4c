"""Outcome to verdicts: expectations judged, statistics, the rigid-block oracle, closed forms and
golden snapshots.

Source: stackdsl's own.
"""
