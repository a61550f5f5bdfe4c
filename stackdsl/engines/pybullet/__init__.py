"""pybullet: its settings and defaults (light) and its world adapter (imports pybullet).

Source: stackdsl's own.
"""
