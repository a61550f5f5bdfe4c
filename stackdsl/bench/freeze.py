"""``stackdsl bench freeze``: the ways to freeze a brick on MuJoCo, measured side by side.

A 4 stack of N levels is assembled at its poses, MuJoCo's tuned settings (the compiler's); every brick but the
top one is frozen by one means, the top one is placed 0.5 mm above its pose, and one second
is simulated. Each means is timed per step, with how far its frozen bricks moved and, for
MuJoCo's sleeping, how many bricks were awake at the end:

* ``free``: nothing frozen (the reference);
* ``weld``: a weld equality to the world on each frozen brick, active;
* ``sleep``: MuJoCo's own sleeping (tolerance 1e-4), each frozen brick's tree put to sleep;
* ``held``: each frozen brick a mocap body (what :class:`stackdsl.engines.mujoco.world.MuJoCoWorld` does).

Source: stackdsl's own, on MuJoCo 4.0's Python bindings.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..engines.mujoco.settings import MuJoCoSettings

MEANS = ("free", "weld", "sleep", "held")
_HALF = (0.06, 0.012, 0.004)
_TUNED = MuJoCoSettings.model_validate({"mode": "tuned", **MuJoCoSettings.DEFAULTS["tuned"]})
_SOLREF, _SOLIMP = list(_TUNED.solref), [*_TUNED.solimp, 0.5, 2.0]


@dataclass(frozen=True)
class FreezeCost:
    """One means at one height: microseconds a step, the farthest a frozen brick moved (mm),
    and the bricks awake at the end (MuJoCo's sleeping only, else None)."""

    means: str
    levels: int
    us_per_step: float
    frozen_moved_mm: float
    awake: int | None


def _layout(levels: int) -> list[tuple[tuple[float, float, float], list[float]]]:
    out = []
    turn = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]  # (w, x, y, z): 90 deg about z
    for k in range(levels):
        z = 0.004 + 0.008 * k
        for side in (-0.048, 0.048):
            out.append(((0.0, side, z), [1.0, 0.0, 0.0, 0.0]) if k % 2 == 0 else ((side, 0.0, z), turn))
    return out


def _model(levels: int, means: str) -> tuple[object, object]:
    import mujoco

    spec = mujoco.MjSpec()
    option = spec.option
    option.timestep, option.iterations, option.impratio = _TUNED.timestep, _TUNED.solver_iterations, _TUNED.impratio
    option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC if _TUNED.elliptic_cones else mujoco.mjtCone.mjCONE_PYRAMIDAL
    option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{_TUNED.integrator.upper()}")
    if means == "sleep":
        option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
        option.sleep_tolerance = 1e-4
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], solref=_SOLREF, solimp=_SOLIMP)
    bricks = _layout(levels)
    for i, (position, quaternion) in enumerate(bricks):
        top = i == len(bricks) - 1
        at = [position[0], position[1], position[2] + (0.0005 if top else 0.0)]
        body = spec.worldbody.add_body(name=f"b{i}", pos=at, quat=quaternion, mocap=means == "held" and not top)
        if not body.mocap:
            body.add_freejoint()
        body.add_geom(
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=list(_HALF),
            mass=0.0106,
            friction=[0.5, 0.005, 0.0001],
            solref=_SOLREF,
            solimp=_SOLIMP,
        )
        if means == "weld" and not top:
            spec.add_equality(
                type=mujoco.mjtEq.mjEQ_WELD, name1=f"b{i}", objtype=mujoco.mjtObj.mjOBJ_BODY, solref=_SOLREF, solimp=_SOLIMP
            )
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    if means == "sleep":
        for tree in range(model.ntree - 1):  # every tree but the top brick's, each a cycle of one
            data.tree_asleep[tree] = tree
        mujoco.mj_forward(model, data)
    return model, data


def freeze_cost(levels: int, means: str, seconds: float = 1.0) -> FreezeCost:
    """Measure ``means`` (one of :data:`MEANS`) on a tower of ``levels``.

    Raises:
        ValueError: an unknown means or fewer than 2 levels.
    """
    import mujoco

    if means not in MEANS or levels < 2:
        raise ValueError(f"means is one of {', '.join(MEANS)} and levels at least 2, not {means!r}, {levels}")
    model, data = _model(levels, means)
    start = np.array(data.xpos).copy()  # type: ignore[attr-defined]
    steps = round(seconds / model.opt.timestep)  # type: ignore[attr-defined]
    clock = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    wall = time.perf_counter() - clock
    moved = np.linalg.norm(np.array(data.xpos)[1:-1] - start[1:-1], axis=1).max() * 1000  # type: ignore[attr-defined]
    awake = int((np.array(data.tree_asleep) < 0).sum()) if means == "sleep" else None  # type: ignore[attr-defined]
    return FreezeCost(means, levels, wall / steps * 1e6, float(moved), awake)


def format_freeze(costs: list[FreezeCost]) -> str:
    """A Markdown table of :func:`freeze_cost` results."""
    lines = ["| levels | means | us a step | frozen bricks moved (mm) | bricks awake at the end |", "|---|---|---|---|---|"]
    for c in costs:
        awake = "" if c.awake is None else f"{c.awake} of {2 * c.levels}"
        lines.append(f"| {c.levels} | {c.means} | {c.us_per_step:.1f} | {c.frozen_moved_mm:.3f} | {awake} |")
    return "\n".join(lines)
