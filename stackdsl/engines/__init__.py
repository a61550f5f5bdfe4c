"""World adapters, one per engine, behind the :class:`~stackdsl.runtime.engines.protocol.World` protocol.

Source: stackdsl's own.
"""
