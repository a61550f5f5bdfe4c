"""Every engine's settings, by backend name (:mod:`stackdsl.engines.registry`): what the
compiler resolves a scenario's ``engine:`` section into, and the defaults it starts from.

>>> defaults("mujoco", "raw")["timestep"], type(settings("pybullet", mode="raw", timestep=0.01, solver_iterations=5)).__name__
(0.002, 'PyBulletSettings')

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import Annotated

from pydantic import BeforeValidator, SerializeAsAny

from .protocol import EngineSettings
from .registry import backend as _backend


def defaults(backend: str, mode: str) -> dict[str, object]:
    """The engine's own values for ``mode``.

    Raises:
        KeyError: an unknown backend (:class:`~stackdsl.engines.registry.UnknownBackend`) or mode.
    """
    return dict(_backend(backend).settings.DEFAULTS[mode])


def settings(backend: str, **values: object) -> EngineSettings:
    """Validated settings of ``backend`` from ``values`` (mode, timestep, ...), of its own class.

    Raises:
        KeyError: an unknown backend; pydantic.ValidationError: a bad or foreign value.
    """
    return _backend(backend).settings.model_validate({"backend": backend, **values})


def _of_its_backend(value: object) -> object:
    """A mapping of settings (a program read back from JSON) as its backend's own class."""
    if isinstance(value, dict) and isinstance(value.get("backend"), str):
        return settings(value["backend"], **{k: v for k, v in value.items() if k != "backend"})
    return value


#: A run's settings, of whichever engine's class (its ``backend`` field says which), written
#: with that class's own fields.
AnySettings = Annotated[SerializeAsAny[EngineSettings], BeforeValidator(_of_its_backend)]
