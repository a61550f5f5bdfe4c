"""pybullet: its settings and defaults (light) and its world adapter (imports pybullet when a
world is opened); :data:`BACKEND` is its entry in :mod:`stackdsl.engines.registry`.

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

from ..backend import Backend
from ..protocol import EngineSettings, World
from .settings import PyBulletSettings


@contextmanager
def _world(
    engine: EngineSettings,
    ground_friction: float,
    ground_restitution: float,
    *,
    shelve: bool = True,
    movable_ground: bool = False,
) -> Iterator[World]:
    """A :class:`~stackdsl.engines.pybullet.world.PyBulletWorld` on its own DIRECT client, closed on exit."""
    from .world import pybullet_world

    assert isinstance(engine, PyBulletSettings)
    with pybullet_world(engine, ground_friction, ground_restitution, shelve=shelve, movable_ground=movable_ground) as world:
        yield world


@cache
def _prepare() -> object:
    """Import pybullet and the world adapter, and open and close one client (:attr:`Backend.prepare`):
    a process's first DIRECT client took 21 ms, the next 5 and 1.4 ms."""
    from . import world
    from .client import direct_client

    with direct_client():
        pass
    return world


#: pybullet, the default engine; the extension splits its pulls (its friction at 240 Hz drags
#: what a pulled brick carries: :data:`stackdsl.compile.program.PULL_STEP`).
BACKEND = Backend(name="pybullet", settings=PyBulletSettings, world=_world, split_pulls=True, prepare=_prepare)
