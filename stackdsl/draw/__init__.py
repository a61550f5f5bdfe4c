"""Pictures from a recorded trajectory: stills, clips, brick-graph and sweep plots.

Source: stackdsl's own.
"""
