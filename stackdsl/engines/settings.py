"""Every engine's settings class, by backend name: what the compiler resolves a scenario's
``engine:`` section into, and the defaults it starts from.

>>> sorted(SETTINGS), defaults("mujoco", "raw")["timestep"]
(['mujoco', 'pybullet'], 0.002)

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import Annotated, cast

from pydantic import Field

from .mujoco.settings import MuJoCoSettings
from .protocol import EngineSettings
from .pybullet.settings import PyBulletSettings

#: backend -> its settings class.
SETTINGS: dict[str, type[EngineSettings]] = {"pybullet": PyBulletSettings, "mujoco": MuJoCoSettings}
#: A run's settings, of whichever engine (the ``backend`` field says which).
AnySettings = Annotated[PyBulletSettings | MuJoCoSettings, Field(discriminator="backend")]


def defaults(backend: str, mode: str) -> dict[str, object]:
    """The engine's own values for ``mode``.

    Raises:
        KeyError: an unknown backend or mode.
    """
    return dict(SETTINGS[backend].DEFAULTS[mode])


def settings(backend: str, **values: object) -> PyBulletSettings | MuJoCoSettings:
    """Validated settings of ``backend`` from ``values`` (mode, timestep, ...).

    Raises:
        KeyError: an unknown backend; pydantic.ValidationError: a bad or foreign value.
    """
    return cast(PyBulletSettings | MuJoCoSettings, SETTINGS[backend].model_validate({"backend": backend, **values}))
