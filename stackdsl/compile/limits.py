"""What the chosen engine simulates faithfully: brick sides, projectile speeds, mass ratios.

The language's bounds (:mod:`stackdsl.lang.bounds`) hold for every engine; each engine has
narrower ones of its own, measured on it (:class:`stackdsl.engines.protocol.Limits`,
``stackdsl bench limits``). A scene beyond them would run, and give an answer that is the
engine's artefact, not the scene's: a 2 mm cube that falls over on pybullet's ground, a brick
thrown through a wall, a light brick crushed by a solver that cannot balance a mass ratio of
10,000. So the compiler refuses it, at the field to change, naming the engine, what was
measured, and an engine or setting that would take it when there is one. The check uses the
engine the run uses, after ``--backend`` and ``--mode``.

Source: stackdsl's own.
"""

from __future__ import annotations

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

    Raises:
        ScenarioError: at a brick type's ``size`` (a side below the engine's smallest; a
            wall's half brick's at the wall's ``brick``), an impact's ``speed`` (faster than the
            engine holds) or a material's ``density`` or brick type's ``size`` (a mass ratio
            beyond the engine's).
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
