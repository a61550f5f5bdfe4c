"""Program to Outcome: the step loop, its subscribers (stability extension, collapse monitor,
recorder) and the world adapters in :mod:`stackdsl.engines`.

Source: stackdsl's own.
"""
