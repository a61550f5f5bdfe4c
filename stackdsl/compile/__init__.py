"""Scenario to Program: brick poses, placement times, impacts and engine settings, checked
for overlaps and unreachable expectations before anything is simulated. Uses only :mod:`stackdsl.lang`.

Source: stackdsl's own.
"""
