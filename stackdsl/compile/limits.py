"""What the chosen engine simulates faithfully: brick sides, projectile speeds, mass ratios, restitution.

The language's bounds (:mod:`stackdsl.lang.bounds`) hold for every engine; each engine has
narrower ones of its own, measured on it (:class:`stackdsl.engines.protocol.Limits`,
``stackdsl bench limits``). A scene beyond them would run, and give an answer that is the
engine's artefact, not the scene's: a 2 mm cube that falls over on pybullet's ground, a brick
thrown through a wall, a light brick crushed by a solver that cannot balance a mass ratio of
10,000, a brick that bounces higher than it fell. So the compiler refuses it, at the field to
change, naming the engine, what was measured, and an engine or setting that would take it when
there is one. The check uses the engine the run uses, after ``--backend`` and ``--mode``.

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence

from ..engines.protocol import BrickSpec, EngineSettings
from ..engines.settings import SETTINGS
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_generators import HALF


def check_limits(
    scenario: Scenario,
    engine: EngineSettings,
    specs: Mapping[str, BrickSpec],
    moving: Sequence[str],
    made_by: Mapping[str, FieldPath] | None = None,
    fixed: Sequence[str] = (),
) -> None:
    """Refuse what ``engine`` does not simulate faithfully (see the module's docstring).

    Args:
        scenario: for its source map, brick types, materials and impacts.
        engine: the settings the run uses.
        specs: brick type name -> its body, for every type the scene uses.
        moving: the type names of every body that moves: the structure's bricks (not its
            fixtures) and the projectiles.
        made_by: brick type name -> the field of a generator that lays bricks of it, for the
            half bricks (``NAME/2``) a wall makes of the type it is given.
        fixed: the type names of the bodies that do not move and that moving ones may touch:
            the fixtures (and a push's pusher, a type of ``specs`` not in ``moving``).

    Raises:
        ScenarioError: at a brick type's ``size`` (a side below the engine's smallest; a
            wall's half brick's at the wall's ``brick``), an impact's ``speed`` (faster than the
            engine holds), a material's ``density`` or brick type's ``size`` (a mass ratio
            beyond the engine's) or a material's ``restitution`` (a contact bouncier than the
            engine holds in the run's mode).
    """
    kind = type(engine)
    limits, name = kind.LIMITS, kind.NAME
    for type_name in sorted(specs):
        side = 2 * min(specs[type_name].half_extents)
        if side >= limits.min_side * (1 - 1e-9):
            continue
        measured = f"(measured: {limits.measured['min_side']}){_elsewhere(engine, 'min_side', side)}"
        if type_name in scenario.brick_types:
            raise scenario.source.error(
                ("brick_types", type_name, "size"),
                f"a side of {_mm(side)} is below what {name} simulates faithfully: at least {_mm(limits.min_side)} {measured}",
            )
        whole = type_name.removesuffix(HALF)
        if whole != type_name and whole in scenario.brick_types:  # a wall's closer, cut from a type of the file
            size = " x ".join(f"{2000 * h:.3g}" for h in specs[type_name].half_extents)
            raise scenario.source.error(
                (*(made_by or {}).get(type_name, ("structure",)), "brick"),
                f"the wall's half brick {type_name!r} ({size} mm: {whole!r} cut to half its length, its even courses' "
                f"closers) has a side of {_mm(side)}, below what {name} simulates faithfully: at least "
                f"{_mm(limits.min_side)} {measured}; give the wall a brick type at least {_mm(2 * limits.min_side)} long",
            )
    thinnest = min(2 * min(s.half_extents) for s in specs.values())
    for index, impact in enumerate(scenario.impacts):
        if engine.ccd:
            most, measured = limits.fastest(engine.mode)
            why = f"with substeps: at most {most:g} m/s (measured: {measured})"
        else:
            per_step = thinnest / engine.timestep
            most = min(limits.max_speed_no_substeps, per_step)
            why = f"without substeps (engine.ccd off): at most {most:.3g} m/s, " + (
                f"or in one {engine.timestep * 1000:.3g} ms step it moves further than the thinnest brick ({_mm(thinnest)}) "
                "and may pass through it"
                if per_step < limits.max_speed_no_substeps
                else f"(measured: {limits.measured['max_speed_no_substeps']})"
            )
            why += f"; with substeps (engine: {{ccd: true}}) up to {limits.fastest(engine.mode)[0]:g} m/s"
        if impact.speed > most * (1 + 1e-9):
            raise scenario.source.error(
                ("impacts", index, "speed"), f"{impact.speed:g} m/s is faster than {name} simulates faithfully {why}"
            )
    masses = {t: specs[t].mass for t in set(moving)}
    if len(masses) > 1:
        heavy, light = max(masses, key=masses.__getitem__), min(masses, key=masses.__getitem__)
        ratio = masses[heavy] / masses[light]
        if ratio > limits.max_mass_ratio * (1 + 1e-9):  # a ratio of exactly the limit, give or take rounding, is in
            raise scenario.source.error(
                _mass_field(scenario, heavy, light),
                f"brick type {heavy!r} ({masses[heavy]:.3g} kg) is {ratio:.4g} times as heavy as {light!r} "
                f"({masses[light]:.3g} kg); {name} simulates at most {limits.max_mass_ratio:g} times faithfully "
                f"(measured: {limits.measured['max_mass_ratio']}){_elsewhere(engine, 'max_mass_ratio', ratio)}",
            )
    _check_restitution(scenario, engine, moving, [*fixed, *(t for t in specs if t not in set(moving))])


def _check_restitution(scenario: Scenario, engine: EngineSettings, moving: Sequence[str], still: Sequence[str]) -> None:
    """Refuse a contact that may happen with a restitution above the engine's in the run's mode,
    at the restitution of the bouncier of its two materials. Both engines give a contact of two
    materials the geometric mean of their restitutions. A moving body may touch the ground,
    every body that does not move (``still``'s types) and every other moving body: a material
    touches itself when two moving bodies have it, or one moves and the ground or a body that
    does not move has it."""
    kind = type(engine)
    most = kind.LIMITS.restitution(engine.mode)
    if most >= 1.0:
        return
    count = Counter(scenario.brick_type(t).material for t in moving)
    others = {scenario.ground.material} | {scenario.brick_type(t).material for t in still}
    pairs = {(a, b) for a in count for b in {*count, *others} if a != b or count[a] > 1 or a in others}
    e = {name: scenario.material(name).restitution for pair in pairs for name in pair}
    worst = max(pairs, key=lambda p: (math.sqrt(e[p[0]] * e[p[1]]), e[p[0]], p), default=None)
    if worst is None or math.sqrt(e[worst[0]] * e[worst[1]]) <= most * (1 + 1e-9):
        return
    mine, other = sorted(worst, key=lambda name: (-e[name], name not in scenario.materials))
    contact = math.sqrt(e[mine] * e[other])
    what = f"restitution {e[mine]:g}" + (
        "" if mine == other else f" makes a contact of restitution {contact:.3g} with material {other!r} ({e[other]:g}), which"
    )
    raise scenario.source.error(
        ("materials", mine, "restitution"),
        f"{what} is more than {kind.NAME} simulates faithfully in {engine.mode} mode: at most {most:g} "
        f"(measured: {kind.LIMITS.measured[f'max_restitution_{engine.mode}']}){_bouncier(engine, contact)}",
    )


def _bouncier(engine: EngineSettings, restitution: float) -> str:
    """``; tuned mode takes it (engine: {mode: tuned})`` when another mode of the engine, or
    else a mode of another engine, holds a contact of ``restitution``."""
    own = type(engine)
    for mode in own.DEFAULTS:
        if mode != engine.mode and restitution <= own.LIMITS.restitution(mode) * (1 + 1e-9):
            return f"; {mode} mode takes it (engine: {{mode: {mode}}})"
    for backend, kind in SETTINGS.items():
        for mode in kind.DEFAULTS:
            if backend != engine.backend and restitution <= kind.LIMITS.restitution(mode) * (1 + 1e-9):
                return f"; {kind.NAME} takes it in {mode} mode (engine: {{backend: {backend}, mode: {mode}}})"
    return ""


def _mass_field(scenario: Scenario, heavy: str, light: str) -> FieldPath:
    """Where a mass ratio is set: the density of a material the file defines (the heavier
    brick's first), else the size of a brick type it defines."""
    for type_name in (heavy, light):
        if type_name in scenario.brick_types:
            material = scenario.brick_types[type_name].material
            if material in scenario.materials:
                return ("materials", material, "density")
    return ("brick_types", heavy if heavy in scenario.brick_types else light, "size")


def _elsewhere(engine: EngineSettings, bound: str, value: float) -> str:
    """``; MuJoCo takes it (engine: {backend: mujoco})`` when another engine's bound admits ``value``."""
    for backend, kind in SETTINGS.items():
        limits = kind.LIMITS
        ok = value >= limits.min_side if bound == "min_side" else value <= limits.max_mass_ratio * (1 + 1e-9)
        if backend != engine.backend and ok:
            return f"; {kind.NAME} takes it (engine: {{backend: {backend}}})"
    return ""


def _mm(metres: float) -> str:
    return f"{metres * 1000:.3g} mm"
