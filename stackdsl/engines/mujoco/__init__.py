"""MuJoCo: its settings and defaults (light) and its world adapter and materials (import mujoco).

Source: stackdsl's own.
"""
