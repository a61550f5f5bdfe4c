"""The one registry of engines: name -> :class:`~stackdsl.engines.backend.Backend`.

Every layer above the engines finds an engine here by name and asks it (its settings, its
world, its capabilities); none imports an adapter or compares engine names
(pyproject.toml's import contract, tests/test_registry.py). An adapter is a subpackage of
:mod:`stackdsl.engines` whose ``__init__`` defines ``BACKEND``; adding one is that subpackage
and one loader in :data:`BACKENDS`. A backend's subpackage is imported when it is first asked
for, and its engine's own package (pybullet, mujoco) only when a world is opened, so an
engine that is an optional extra is imported only when used.

>>> names()[:3]
['pybullet', 'mujoco', 'statics']
>>> backend("mujoco").extra, backend("pybullet").split_pulls
('mujoco', True)

Source: stackdsl's own.
"""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .backend import Backend, Loader
    from .protocol import EngineSettings


def _pybullet() -> Backend:
    from .pybullet import BACKEND

    return BACKEND


def _mujoco() -> Backend:
    from .mujoco import BACKEND

    return BACKEND


def _statics() -> Backend:
    from .statics import BACKEND

    return BACKEND


#: name -> what imports the subpackage of :mod:`stackdsl.engines` that defines its ``BACKEND``
#: and returns it (an import statement, which lint-imports sees, run when first asked for); the
#: first is the default engine.
BACKENDS: dict[str, Loader] = {
    "pybullet": _pybullet,
    "mujoco": _mujoco,
    "statics": _statics,
}


class UnknownBackend(KeyError):
    """A backend name not in :data:`BACKENDS`; its message lists the known ones."""

    def __str__(self) -> str:
        return str(self.args[0])


def names() -> list[str]:
    """The known backends' names, the default first (loads none of them)."""
    return list(BACKENDS)


@cache
def backend(name: str) -> Backend:
    """The backend called ``name``.

    Raises:
        UnknownBackend: no backend has that name (a KeyError whose message lists the known ones).
    """
    from .backend import Backend

    if name not in BACKENDS:
        raise UnknownBackend(f"unknown backend {name!r}; known: {', '.join(BACKENDS)}")
    found = BACKENDS[name]()
    if not isinstance(found, Backend) or found.name != name:
        raise TypeError(f"the backend registered as {name!r} is named {getattr(found, 'name', None)!r}")
    return found


def settings_class(name: str) -> type[EngineSettings]:
    """The settings class of backend ``name``.

    Raises:
        UnknownBackend: as :func:`backend`.
    """
    return backend(name).settings
