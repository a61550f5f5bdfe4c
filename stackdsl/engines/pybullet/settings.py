"""pybullet's settings of a run and its defaults per mode; importing it loads no pybullet.

``raw`` is pybullet's own (240 Hz, 50 iterations); ``tuned`` is the most accurate setting
measured for small bricks (docs/design.md, modes: maximal coordinates, 1 ms, 150 iterations,
friction anchors); ``extension`` is the report's set-up, the stability extension on the
unmodified engine.

>>> PyBulletSettings(mode="tuned", **PyBulletSettings.DEFAULTS["tuned"]).maximal_coordinates
True

Source: stackdsl's own (docs/design.md, engine facts).
"""

from __future__ import annotations

from typing import ClassVar, Literal

from ..protocol import EngineSettings


class PyBulletSettings(EngineSettings):
    """:class:`~stackdsl.engines.protocol.EngineSettings` of pybullet: friction anchors (stop a
    resting brick's creep) and maximal coordinates (rigid bodies instead of multibodies)."""

    DEFAULTS: ClassVar[dict[str, dict[str, object]]] = {
        "raw": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False, ccd=False),
        "tuned": dict(timestep=1 / 1000, solver_iterations=150, friction_anchors=True, maximal_coordinates=True, ccd=True),
        "extension": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False, ccd=True),
    }

    mode: Literal["raw", "tuned", "extension"]
    backend: Literal["pybullet"] = "pybullet"
    friction_anchors: bool = False
    maximal_coordinates: bool = False

    def details(self) -> str:
        on = {True: "on", False: "off"}
        return (
            f"friction anchors {on[self.friction_anchors]}, maximal coordinates {on[self.maximal_coordinates]}, "
            f"continuous collision detection for thrown bricks {on[self.ccd]}"
        )
