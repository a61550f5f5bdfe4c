"""World adapters, one per engine, behind the :class:`~stackdsl.runtime.engines.world.World` protocol.

Source: stackdsl's own.
"""
