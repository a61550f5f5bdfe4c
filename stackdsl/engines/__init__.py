"""World adapters, one per engine, behind the :class:`~stackdsl.engines.protocol.World` protocol.

Source: stackdsl's own.
"""
