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

from ..protocol import SHAKEN, EngineSettings, Limits


class PyBulletSettings(EngineSettings):
    """:class:`~stackdsl.engines.protocol.EngineSettings` of pybullet: friction anchors (stop a
    resting brick's creep) and maximal coordinates (rigid bodies instead of multibodies)."""

    DEFAULTS: ClassVar[dict[str, dict[str, object]]] = {
        "raw": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False, ccd=False),
        "tuned": dict(timestep=1 / 1000, solver_iterations=150, friction_anchors=True, maximal_coordinates=True, ccd=True),
        "extension": dict(timestep=1 / 240, solver_iterations=50, friction_anchors=False, maximal_coordinates=False, ccd=True),
    }

    #: A brick at rest sinks 0.010-0.016 mm into the ground or a brick (raw and tuned mode,
    #: measured). Placed at zero distance, the box-box collider finds 2 of the patch's 4
    #: corners in the first step, and the solver loads one end: a brick 0.64 mm inside its
    #: support's edge tipped off it. Placed 0.01 mm in, it meets all four and stays.
    SEAT: ClassVar[float] = 1e-5
    NAME: ClassVar[str] = "pybullet"
    LIMITS: ClassVar[Limits] = Limits(
        min_side=0.003,
        max_speed=100.0,
        max_speed_no_substeps=20.0,
        max_mass_ratio=300.0,
        max_restitution={"raw": 0.6, "tuned": 0.8, "extension": 0.7},
        measured={
            "min_side": "3 mm cubes settle within 0.1 mm and a column of ten stands; below 3 mm not every use is "
            "measured yet (cubes of 1.5 to 2.5 mm now settle within 0.25 mm; a 2 mm one fell over on its ground "
            "before placed bricks were lowered onto their resting height)",
            "max_speed": "a brick thrown at 100 m/s stays in front of a fixed 3 or 8 mm wall with substeps",
            "max_speed_no_substeps": "a brick thrown at 30 m/s passes through a fixed wall (25 m/s: it stays)",
            "max_mass_ratio": "a heavy KAPLA brick crossed on a light one sinks"
            " 1.96 mm into it in tuned mode at a density ratio of 300, "
            "3.36 mm at 500 (the collapse threshold is 4 mm)",
            **{
                f"max_restitution_{mode}": f"a KAPLA brick of restitution {bad} {drop} rose with {gain} times the energy it "
                f"fell with; at {good} none of 14 drops (10 to 300 mm, flat, on an edge or a corner, onto a brick) kept "
                f"more than {kept} of it"
                for mode, bad, drop, gain, good, kept in (
                    ("raw", 0.7, "dropped 300 mm onto a corner", 1.06, 0.6, 0.5),
                    ("tuned", 0.9, "dropped flat 300 mm", 1.2, 0.8, 0.88),
                    ("extension", 0.8, "dropped flat 10 mm", 1.2, 0.7, 0.85),
                )
            },
        },
        max_shake_acceleration=(9.81, SHAKEN),
        max_guided_speed_by_mode={
            "raw": (
                1.5,
                "a KAPLA brick pushed at 1.75 m/s at a fixed 8 mm wall 186 mm ahead ends 23 mm inside it, at 2 m/s "
                "16 mm, at 2.5 m/s through it, and from 4 m/s the pusher passes through the brick (1.5 m/s: it "
                "stops at the wall)",
            )
        },
    )

    mode: Literal["raw", "tuned", "extension"]
    backend: Literal["pybullet"] = "pybullet"
    friction_anchors: bool = False
    maximal_coordinates: bool = False

    @property
    def contact_margin(self) -> float:
        """1 mm: the collision margin of pybullet's box shapes, within which a brick near its
        support's edge is tipped or kept by the engine's contact points (docs/design.md)."""
        return 0.001

    def details(self) -> str:
        on = {True: "on", False: "off"}
        return (
            f"friction anchors {on[self.friction_anchors]}, maximal coordinates {on[self.maximal_coordinates]}, "
            f"continuous collision detection for thrown bricks {on[self.ccd]}"
        )
