"""statics: a backend without dynamics, deciding by rigid-block equilibrium alone.

Each brick is placed in its pose and stays there while forces exist that balance every brick
(:mod:`stackdsl.engines.statics.world`); the first placement after which none do is the
collapse, at its level. It answers in milliseconds what the engines answer in seconds, for a
static scene only: the compiler refuses (:attr:`stackdsl.engines.backend.Backend.dynamics`)
impacts, actions (a pull, a push, a shake), floating bricks, drop gaps above :data:`MAX_DROP`,
and expectations of where fallen bricks end (``moved``, ``toppled``, ``stays``, ``may_fall``),
all of which need motion. :data:`BACKEND` is its entry in :mod:`stackdsl.engines.registry`.

Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from ..backend import Backend
from ..protocol import EngineSettings, World
from .settings import StaticsSettings

#: Metres: the largest drop gap taken (a brick placed higher would fall onto its support).
MAX_DROP = 0.001


@contextmanager
def _world(
    engine: EngineSettings,
    ground_friction: float,
    ground_restitution: float,
    *,
    shelve: bool = True,
    movable_ground: bool = False,
) -> Iterator[World]:
    """A :class:`~stackdsl.engines.statics.world.StaticsWorld` (restitution, shelving and a movable
    ground have no meaning without motion: ignored)."""
    from .world import StaticsWorld

    yield StaticsWorld(engine, ground_friction)


#: The statics backend: no dynamics, no optional extra.
BACKEND = Backend(
    name="statics",
    settings=StaticsSettings,
    world=_world,
    dynamics=False,
    max_drop=MAX_DROP,
    refusal="statics places bricks and solves rigid-block equilibrium, without motion",
)
