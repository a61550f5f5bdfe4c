"""One physics engine as the rest of stackdsl sees it: a :class:`Backend`, found by name in
:mod:`stackdsl.engines.registry`.

A backend says what its settings are (:class:`~stackdsl.engines.protocol.EngineSettings`
subclass, with its defaults per mode and its measured limits), how to open a world on it
(:class:`WorldFactory`, importing the engine only then), and the capabilities the compiler and
the runtime ask of it instead of its name. Source: stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from typing import Protocol

from .protocol import EngineSettings, World


class WorldFactory(Protocol):
    """Opens a new world for one run, closed on exit.

    Args:
        engine: the run's settings (of the backend's own class).
        ground_friction, ground_restitution: of the ground's material.
        shelve: static bodies nothing moving can reach may leave the engine's world (an
            engine with no such saving ignores it).
        movable_ground: the ground can be moved (:meth:`~stackdsl.engines.protocol.World.move_ground`).

    Raises:
        ImportError: the engine's package is not installed (an optional extra).
    """

    def __call__(
        self,
        engine: EngineSettings,
        ground_friction: float,
        ground_restitution: float,
        *,
        shelve: bool = True,
        movable_ground: bool = False,
    ) -> AbstractContextManager[World]: ...


@dataclass(frozen=True)
class Backend:
    """A physics engine: its name, settings, world and capabilities.

    Attributes:
        name: what ``engine: {backend: ...}`` and ``--backend`` call it.
        settings: its settings class (defaults per mode, limits, name in messages).
        world: opens a world on it (:class:`WorldFactory`).
        extra: the optional extra that installs its package (a name of
            :data:`stackdsl.util.extras.EXTRAS`), None when it is a dependency or needs none.
        split_pulls: with the extension acting, a pull (``actions: remove``) is stepped in
            steps of at most :data:`stackdsl.compile.program.PULL_STEP` (pybullet's friction at
            240 Hz drags what the pulled brick carries).
        dynamics: it simulates motion. False: it places bricks and solves statics only, and
            the compiler refuses what needs motion (impacts, actions, drops above
            :attr:`max_drop`, bricks placed together, floating bricks) with :attr:`refusal`.
        max_drop: metres, the largest drop gap it takes without dynamics (inf with dynamics).
        refusal: why a backend without dynamics refuses a scene that moves, in words.
        prepare: imports the engine's own package and its world adapter, and pays any other
            one-off start-up of the engine, once a process (None: nothing to prepare). :func:`stackdsl.runtime.run.run_program` calls it before its
            clock starts: importing MuJoCo took 0.17 s, eight times a small run, and the first
            run of each engine in a process (``stackdsl compare``'s first mode) paid it. Raises
            ImportError when the engine is an optional extra that is not installed.
    """

    name: str
    settings: type[EngineSettings]
    world: WorldFactory
    extra: str | None = None
    split_pulls: bool = False
    dynamics: bool = True
    max_drop: float = float("inf")
    refusal: str = ""
    prepare: Callable[[], object] | None = None

    @property
    def own_fields(self) -> tuple[str, ...]:
        """The settings only this backend has (fields of its class beyond
        :class:`~stackdsl.engines.protocol.EngineSettings`')."""
        return tuple(f for f in self.settings.model_fields if f not in EngineSettings.model_fields)


#: Loads a backend when it is first asked for (:data:`stackdsl.engines.registry.BACKENDS`).
Loader = Callable[[], Backend]
