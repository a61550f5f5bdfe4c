"""The statics backend's settings: nothing to tune, the same in every mode; importing it loads
no engine.

>>> StaticsSettings(mode="raw", **StaticsSettings.DEFAULTS["raw"]).timestep
0.01

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import ClassVar, Literal

from ..protocol import EngineSettings

#: The settings of every mode: a 10 ms step (the longest a scenario may ask for), one "iteration"
#: (there is no solver to iterate), no continuous collision detection (nothing is thrown).
_SAME = dict(timestep=0.01, solver_iterations=1, ccd=False)


class StaticsSettings(EngineSettings):
    """:class:`~stackdsl.engines.protocol.EngineSettings` of the statics backend
    (:mod:`stackdsl.engines.statics`): every mode the same, since nothing moves."""

    DEFAULTS: ClassVar[dict[str, dict[str, object]]] = {mode: dict(_SAME) for mode in ("raw", "tuned", "extension")}
    NAME: ClassVar[str] = "statics"

    mode: Literal["raw", "tuned", "extension"]
    backend: Literal["statics"] = "statics"

    def details(self) -> str:
        return "rigid-block equilibrium of the placed bricks, no dynamics"
