"""The one registry of engines: name -> :class:`~stackdsl.engines.backend.Backend`.

Every layer above the engines finds an engine here by name and asks it (its settings, its
world, its capabilities); none imports an adapter or compares engine names
(pyproject.toml's import contract, tests/test_registry.py). An adapter is a subpackage of
:mod:`stackdsl.engines` whose ``__init__`` defines ``BACKEND``; adding one is that subpackage
and one line of :data:`BACKENDS`. A backend's subpackage is imported when it is first asked
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
from importlib import import_module
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .backend import Backend
    from .protocol import EngineSettings

#: name -> the subpackage of :mod:`stackdsl.engines` that defines its ``BACKEND``; the first is
#: the default engine.
BACKENDS: dict[str, str] = {
    "pybullet": ".pybullet",
    "mujoco": ".mujoco",
    "statics": ".statics",
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
    found = getattr(import_module(BACKENDS[name], __package__), "BACKEND", None)
    if not isinstance(found, Backend) or found.name != name:
        raise TypeError(f"stackdsl.engines{BACKENDS[name]} defines no BACKEND named {name!r}")
    return found


def settings_class(name: str) -> type[EngineSettings]:
    """The settings class of backend ``name``.

    Raises:
        UnknownBackend: as :func:`backend`.
    """
    return backend(name).settings
