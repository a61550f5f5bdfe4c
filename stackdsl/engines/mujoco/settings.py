"""MuJoCo's settings of a run and its defaults per mode; importing it loads no mujoco.

``raw`` is MuJoCo's own (2 ms, pyramidal cones, Euler, solref 0.02 s and damping ratio 1);
``tuned`` the most accurate measured for KAPLA bricks (docs/results/mujoco.md: elliptic cones,
impratio 10, implicitfast, solref 0.004 s and damping ratio 2, solimp 0.99, 0.999, 0.1 mm);
``extension`` the extension on the tuned settings at 4 ms, with the contact time constant
0.008 s (MuJoCo takes at least two timesteps): with MuJoCo's default contacts a placed brick
rings 134 ms before it can be frozen (62 ms tuned), with the tuned contacts but pyramidal
cones two slant towers fell 2 levels late, and at 4 ms every scene of the benchmark falls at
its closed form in half the steps of 2 ms (docs/results/mujoco.md).

>>> MuJoCoSettings(mode="extension", **MuJoCoSettings.DEFAULTS["extension"]).integrator
'implicitfast'

Source: stackdsl's own (docs/design.md, "The second engine").
"""

from __future__ import annotations

from typing import ClassVar, Literal

from ..protocol import SHAKEN, EngineSettings, Limits

_TUNED: dict[str, object] = dict(
    timestep=0.002,
    solver_iterations=100,
    ccd=True,
    elliptic_cones=True,
    impratio=10.0,
    integrator="implicitfast",
    solref=(0.004, 2.0),
    solimp=(0.99, 0.999, 1e-4),
)


#: Metres from a support's edge within which MuJoCo's soft contacts, not the geometry, were
#: measured deciding a brick's fate whatever ``solimp``'s width: at a width of 0.1 mm they held
#: a brick placed 0.28 mm past the edge of the one under it through its settle, and tipped one
#: placed 0.15 mm inside (the near-tie family of ``stackdsl bench verdicts``,
#: docs/results/verdicts.md). A near tie within it is decided by statics on the placed geometry.
SOFT_REACH = 0.0005


class MuJoCoSettings(EngineSettings):
    """:class:`~stackdsl.engines.protocol.EngineSettings` of MuJoCo: friction cones, impratio,
    integrator, ``solref`` (time constant in s, damping ratio), ``solimp`` (impedance: d0,
    dwidth, width in m) and ``sleep_tolerance`` (MuJoCo's own sleeping; None: off)."""

    DEFAULTS: ClassVar[dict[str, dict[str, object]]] = {
        "raw": dict(timestep=0.002, solver_iterations=100, ccd=False),
        "tuned": dict(_TUNED),
        "extension": dict(_TUNED, timestep=0.004, solref=(0.008, 2.0)),
    }
    enters_when_placed: ClassVar[bool] = False  # adding a body recompiles the model: park them all first

    #: None: a two-level card house at 20 deg that MuJoCo settled holds by rigid-block equilibrium
    #: up to 0.04 m/s^2 only, below the 0.06 at which tuned MuJoCo holds it for 10 s (it fells it
    #: at 0.079); the extension's own stepping of it fells it at any shake (docs/results/shake-table.md,
    #: "A margin for what leans").
    LEANING_MARGIN: ClassVar[float] = 1.0
    NAME: ClassVar[str] = "MuJoCo"
    LIMITS: ClassVar[Limits] = Limits(
        min_side=0.0015,
        max_speed=30.0,
        max_speed_no_substeps=6.0,
        max_mass_ratio=3000.0,
        max_restitution={"raw": 0.6, "tuned": 0.8, "extension": 0.8},
        measured={
            "min_side": "1.5 mm cubes settle within 0.02 mm in every mode and a column of ten stands in extension mode; "
            "smaller, a brick's 0.5 mm drop gap is not below half its side",
            "max_speed": "a brick thrown at 40 m/s passes through a fixed 8 mm wall even with substeps (its soft "
            "contacts cannot stop it in time; 35 m/s: it stays)",
            "max_speed_no_substeps": "a brick thrown at 10 m/s passes through a fixed wall (8 m/s: it stays)",
            "max_mass_ratio": "a heavy KAPLA brick crossed on a light one sinks"
            " 1.88 mm into it in tuned mode at a density ratio of 3000, "
            "3.14 mm at 5000 (the collapse threshold is 4 mm)",
            **{
                f"max_restitution_{mode}": f"a KAPLA brick of restitution {bad} {drop} {what}; at {good} none of 14 "
                f"drops (10 to 300 mm, flat, on an edge or a corner, onto a brick) kept more than {kept} of it"
                for mode, bad, drop, what, good, kept in (
                    ("raw", 0.7, "dropped 300 mm onto a corner", "spun up without bound (Euler integration)", 0.6, 0.47),
                    ("tuned", 0.9, "dropped 30 mm onto an edge", "rose with 1.12 times the energy it fell with", 0.8, 0.77),
                    (
                        "extension",
                        0.95,
                        "dropped 100 mm onto a brick",
                        "rose with 1.53 times the energy it fell with, and at 0.9 one kept 0.96 of it",
                        0.8,
                        0.76,
                    ),
                )
            },
        },
        max_speed_by_mode={
            "extension": (
                15.0,
                "in extension mode (4 ms steps, 8 ms contacts) a brick thrown at 20 m/s passes through a fixed "
                "8 mm wall even with substeps (18 m/s: it stays)",
            )
        },
        max_shake_acceleration=(9.81, SHAKEN),
        max_guided_speed_by_mode={
            "raw": (
                2.0,
                "a KAPLA brick pushed at 2.5 m/s at a fixed 8 mm wall 186 mm ahead sinks into it, its centre 1.2 mm "
                "above the ground, and at 10 m/s passes through it (2 m/s: it stops at the wall)",
            ),
            "tuned": (
                1.5,
                "a KAPLA brick pushed at 1.75 m/s at a fixed 8 mm wall 186 mm ahead rebounds 85 mm off it at "
                "restitution 0, 406 mm at 4 m/s, and from 6 m/s passes through it (1.5 m/s: it stops 38 mm short)",
            ),
            "extension": (
                1.5,
                "a KAPLA brick pushed at 1.75 m/s at a fixed 8 mm wall 186 mm ahead rebounds 75 mm off it at "
                "restitution 0, 716 mm at 4 m/s and 5.9 m at 10 m/s (1.5 m/s: it stops at the wall)",
            ),
        },
        max_pull_speed_by_mode={
            "raw": (
                0.1,
                "the middle brick of a 4-level KAPLA tower, pulled along its length at 0.2 m/s, drags the tower "
                "3.7 mm, at 0.3 m/s 12.8 mm and at 0.5 m/s 27 mm, and pulled 60 mm across it from 0.3 m/s passes "
                "through the brick beside it (0.1 m/s: 1.4 mm, and it drives that brick 59 mm)",
            ),
            "tuned": (
                0.5,
                "the middle brick of a 4-level KAPLA tower pulled 60 mm across it at 1 m/s drives the brick beside "
                "it 189 mm, 30 mm further than at a quarter of the step and 24 mm further than pybullet, at 1.5 m/s "
                "115 and 148 mm further (0.5 m/s: within 5 and 8 mm)",
            ),
            "extension": (
                0.5,
                "the middle brick of a 4-level KAPLA tower pulled 60 mm across it at 0.75 m/s drives the brick "
                "beside it 76 mm, 40 mm short of where a quarter of the step puts it (pybullet: 110 mm), and at 1.5 m/s "
                "391 mm, 68 mm further (0.5 m/s: within 2 mm of both)",
            ),
        },
    )

    mode: Literal["raw", "tuned", "extension"]
    backend: Literal["mujoco"] = "mujoco"
    elliptic_cones: bool = False
    impratio: float = 1.0
    integrator: Literal["euler", "implicitfast"] = "euler"
    solref: tuple[float, float] = (0.02, 1.0)
    solimp: tuple[float, float, float] = (0.9, 0.95, 0.001)
    sleep_tolerance: float | None = None

    @property
    def contact_margin(self) -> float:
        """The width of the contacts' impedance (``solimp``'s third value, m: how deep MuJoCo's
        soft contacts reach before they are stiff, 1 mm raw, 0.1 mm tuned), and no less than
        :data:`SOFT_REACH`, how far from an edge they were measured deciding a tie."""
        return max(self.solimp[2], SOFT_REACH)

    def details(self) -> str:
        on = {True: "on", False: "off"}
        sleep = "off" if self.sleep_tolerance is None else f"tolerance {self.sleep_tolerance:g}"
        return (
            f"{'elliptic' if self.elliptic_cones else 'pyramidal'} cones, impratio {self.impratio:g}, {self.integrator}, "
            f"solref ({self.solref[0]:g} s, {self.solref[1]:g}), solimp ({', '.join(f'{v:g}' for v in self.solimp)}), "
            f"MuJoCo's sleeping {sleep}, substeps for thrown bricks {on[self.ccd]}"
        )
