"""MuJoCo: its settings and defaults (light) and its world adapter and materials (import
mujoco when a world is opened); :data:`BACKEND` is its entry in :mod:`stackdsl.engines.registry`.

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ..backend import Backend
from ..protocol import EngineSettings, World
from .settings import MuJoCoSettings


@contextmanager
def _world(
    engine: EngineSettings,
    ground_friction: float,
    ground_restitution: float,
    *,
    shelve: bool = True,
    movable_ground: bool = False,
) -> Iterator[World]:
    """A :class:`~stackdsl.engines.mujoco.world.MuJoCoWorld` (``shelve`` is pybullet's saving: ignored)."""
    from .world import MuJoCoWorld

    assert isinstance(engine, MuJoCoSettings)
    yield MuJoCoWorld(engine, ground_friction, ground_restitution, movable_ground=movable_ground)


def _prepare() -> object:
    """Import MuJoCo and the world adapter (:attr:`Backend.prepare`)."""
    import mujoco

    from . import world

    return (mujoco, world)


#: MuJoCo, the ``mujoco`` extra; a guided brick's velocity is set once a step, so its pulls are
#: not split (a brick lying on it then slips less than on pybullet).
BACKEND = Backend(name="mujoco", settings=MuJoCoSettings, world=_world, extra="mujoco", prepare=_prepare)
