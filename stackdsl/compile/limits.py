"""What the chosen engine simulates faithfully: brick sides, projectile speeds, mass ratios, restitution.

The language's bounds (:mod:`stackdsl.lang.bounds`) hold for every engine; each engine has
narrower ones of its own, measured on it (:class:`stackdsl.engines.protocol.Limits`,
``stackdsl bench limits``). A scene beyond them would run, and give an answer that is the
engine's artefact, not the scene's: a 2 mm cube that falls over on pybullet's ground, a brick
thrown, pushed or pulled through a wall, a light brick crushed under a heavy one by a solver that cannot
balance a mass ratio of 10,000, a brick that bounces higher than it fell. So the compiler refuses it, at the field to
change, naming the engine, what was measured, and an engine or setting that would take it when
there is one. The check uses the engine the run uses, after ``--backend`` and ``--mode``.

Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from ..engines.protocol import BrickSpec, EngineSettings
from ..engines.registry import backend as backend_named
from ..engines.registry import names
from ..lang.errors import FieldPath
from ..lang.schema import Scenario
from ..lang.schema_generators import HALF
from .layouts import LaidBrick
from .overlap import REST_TOLERANCE
from .program import speed_words


def check_limits(
    scenario: Scenario,
    engine: EngineSettings,
    specs: Mapping[str, BrickSpec],
    moving: Sequence[str],
    made_by: Mapping[str, FieldPath] | None = None,
    fixed: Sequence[str] = (),
    bricks: Sequence[LaidBrick] | None = None,
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
        bricks: the structure's bricks (not its fixtures) where they are built. Given, and in a
            scene with no impact and no action, a mass ratio counts only between a brick and a
            lighter one it can come to rest on or fall onto (:class:`_Reach`); else between
            every two types of ``moving``.

    Raises:
        ScenarioError: at a brick type's ``size`` (a side below the engine's smallest; a
            wall's half brick's at the wall's ``brick``), an impact's ``speed`` (faster than the
            engine holds), a push's ``speed`` (the same, or a mode's measured limit for a pushed
            brick), a pull's ``speed`` (the push's limit, or a mode's measured limit for a pulled brick), a shake's ``amplitude`` (its table as fast), a material's ``density`` or brick type's ``size`` (a mass ratio
            beyond the engine's) or a material's ``restitution`` (a contact bouncier than the
            engine holds in the run's mode).
    """
    _check_sides(scenario, engine, specs, made_by)
    thinnest = min(2 * min(s.half_extents) for s in specs.values())
    _check_impacts(scenario, engine, thinnest)
    _check_motions(scenario, engine, thinnest)
    _check_masses(scenario, engine, specs, moving, bricks)
    _check_restitution(scenario, engine, moving, [*fixed, *(t for t in specs if t not in set(moving))])


def _check_sides(
    scenario: Scenario, engine: EngineSettings, specs: Mapping[str, BrickSpec], made_by: Mapping[str, FieldPath] | None
) -> None:
    """Refuse a brick type (of ``specs``, in name order) with a side below the smallest ``engine``
    simulates faithfully: at its ``size`` when the file declares it, at the wall's ``brick``
    (``made_by``) when it is a wall's half brick of a declared type.

    Raises:
        ScenarioError: at the brick type's ``size`` or the wall's ``brick``.
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


def _check_impacts(scenario: Scenario, engine: EngineSettings, thinnest: float) -> None:
    """Refuse an impact faster than ``engine`` simulates faithfully: with substeps, its measured
    fastest in the run's mode; without, what a step holds for the ``thinnest`` side (m).

    Raises:
        ScenarioError: at the impact's ``speed``.
    """
    kind = type(engine)
    limits, name = kind.LIMITS, kind.NAME
    for index, impact in enumerate(scenario.impacts):
        if engine.ccd:
            most, measured = limits.fastest(engine.mode)
            why = f"with substeps: at most {most:g} m/s (measured: {measured})"
        else:
            most, why = _stepped_whole(engine, thinnest, "without substeps (engine.ccd off)", "measured")
            why += f"; with substeps (engine: {{ccd: true}}) up to {limits.fastest(engine.mode)[0]:g} m/s"
        if impact.speed > most * (1 + 1e-9):
            raise scenario.source.error(
                ("impacts", index, "speed"), f"{impact.speed:g} m/s is faster than {name} simulates faithfully {why}"
            )


def _check_masses(
    scenario: Scenario,
    engine: EngineSettings,
    specs: Mapping[str, BrickSpec],
    moving: Sequence[str],
    bricks: Sequence[LaidBrick] | None,
) -> None:
    """Refuse two types of ``moving`` bodies whose mass ratio is beyond what ``engine`` simulates
    faithfully (see :func:`check_limits` for which pairs count).

    Raises:
        ScenarioError: at the material's ``density`` or the brick type's ``size`` that makes the
            heavier one heavy (:func:`_mass_field`).
    """
    kind = type(engine)
    limits, name = kind.LIMITS, kind.NAME
    masses = {t: specs[t].mass for t in set(moving)}
    if len(masses) > 1:
        static = bricks is not None and not scenario.impacts and not scenario.actions
        reach = _Reach(bricks or [], specs) if static else None

        def beyond(most: float) -> tuple[str, str, str] | None:
            """The pair of types past ``most`` that the measurement speaks for, and how they meet."""
            if reach is not None:
                return reach.worst(most * (1 + 1e-9))
            heavy, light = max(masses, key=masses.__getitem__), min(masses, key=masses.__getitem__)
            return (heavy, light, "") if masses[heavy] > masses[light] * most * (1 + 1e-9) else None

        found = beyond(limits.max_mass_ratio)  # a ratio of exactly the limit, give or take rounding, is in
        if found is not None:
            heavy, light, how = found
            ratio = masses[heavy] / masses[light]
            taken = _elsewhere(engine, "max_mass_ratio", ratio, lambda most: beyond(most) is None)
            raise scenario.source.error(
                _mass_field(scenario, heavy, light),
                f"brick type {heavy!r} ({masses[heavy]:.3g} kg) is {ratio:.4g} times as heavy as {light!r} "
                f"({masses[light]:.3g} kg){how}; {name} simulates at most {limits.max_mass_ratio:g} times faithfully "
                f"(measured: {limits.measured['max_mass_ratio']}){taken}",
            )


def _guided_speed(engine: EngineSettings, thinnest: float, pull: bool = False) -> tuple[float, str]:
    """m/s, the fastest a guided body (a pusher and the brick it drives, a pulled brick and what it
    drives) may move in ``engine``'s run, and why. Substeps follow the structure's bricks only in extension mode (:class:`stackdsl.runtime.subscribers.Substeps`); in the other modes a
    pushed brick is stepped whole, as a throw without substeps. A mode may hold less still,
    measured with a pusher (:attr:`Limits.max_guided_speed_by_mode`), and a ``pull`` less than
    that, measured with a pulled brick (:attr:`Limits.max_pull_speed_by_mode`: a pulled brick is
    driven by its own mass, not held, so the bricks it meets can hold it back)."""
    kind = type(engine)
    limits = kind.LIMITS
    if engine.ccd and engine.mode == "extension":
        most, measured = limits.fastest(engine.mode)
        why = f"with substeps: at most {most:g} m/s (measured for a thrown brick: {measured})"
    else:
        lead = f"in {engine.mode} mode, without substeps for the structure's bricks"
        most, why = _stepped_whole(engine, thinnest, lead, "measured for a thrown brick")
    own = limits.max_guided_speed_by_mode.get(engine.mode)
    if own is not None and own[0] < most:
        most, why = own[0], f"in {engine.mode} mode: at most {own[0]:g} m/s (measured: {own[1]})"
    pulled = limits.max_pull_speed_by_mode.get(engine.mode) if pull else None
    if pulled is not None and pulled[0] < most:
        most, why = pulled[0], f"in {engine.mode} mode: at most {pulled[0]:g} m/s (measured: {pulled[1]})"
    return most, why


def _check_motions(scenario: Scenario, engine: EngineSettings, thinnest: float) -> None:
    """Refuse a push or a pull faster than ``engine`` follows in the run's mode (:func:`_guided_speed`), and
    a shake whose table accelerates (at up to ``amplitude (2 pi frequency)^2``) more than the
    engine follows (:attr:`~stackdsl.engines.protocol.Limits.max_shake_acceleration`). Within the
    language's 100 mm amplitude that also keeps the table's peak speed under 1 m/s, below every
    mode's push limit. Source: stackdsl's own, measured (docs/results/shake-table.md)."""
    kind = type(engine)
    most, why = _guided_speed(engine, thinnest)
    pull_most, pull_why = _guided_speed(engine, thinnest, pull=True)
    for index, action in enumerate(scenario.actions):
        if action.push is not None and action.push.speed > most * (1 + 1e-9):
            raise scenario.source.error(
                ("actions", index, "push", "speed"),
                f"a push at {action.push.speed:g} m/s is faster than {kind.NAME} simulates faithfully {why}; "
                f"the pusher and the brick it drives move at that speed",
            )
        remove = action.remove
        if remove is not None and remove.speed > pull_most * (1 + 1e-9):
            raise scenario.source.error(
                ("actions", index, "remove", "speed"),
                f"a pull at {speed_words(remove.speed)} is faster than {kind.NAME} simulates faithfully {pull_why}; "
                f"the pulled brick moves at that speed, dragging what rests on it and driving what lies in its way",
            )
        shake = action.shake
        if shake is None:
            continue
        w = 2 * math.pi * shake.frequency
        top, measured = kind.LIMITS.max_shake_acceleration
        if shake.amplitude * w * w > top * (1 + 1e-9):
            raise scenario.source.error(
                ("actions", index, "shake", "amplitude"),
                f"{_mm(shake.amplitude)} at {shake.frequency:g} Hz accelerates the table at up to "
                f"{shake.amplitude * w * w:.3g} m/s^2 (amplitude x (2 pi frequency)^2), more than {kind.NAME} follows "
                f"faithfully: at most {top:g} m/s^2 (measured: {measured}); at {shake.frequency:g} Hz give at most "
                f"{_mm(top / (w * w))}",
            )


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
    for backend, kind in _others():
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


def _elsewhere(engine: EngineSettings, bound: str, value: float, takes: Callable[[float], bool] | None = None) -> str:
    """``; MuJoCo takes it (engine: {backend: mujoco})`` when another engine's bound admits ``value``
    (a mass ratio: when ``takes`` says that engine's largest ratio admits the scene)."""
    for backend, kind in _others():
        limits = kind.LIMITS
        if bound == "min_side":
            ok = value >= limits.min_side
        else:
            ok = takes(limits.max_mass_ratio) if takes else value <= limits.max_mass_ratio * (1 + 1e-9)
        if backend != engine.backend and ok:
            return f"; {kind.NAME} takes it (engine: {{backend: {backend}}})"
    return ""


def _stepped_whole(engine: EngineSettings, thinnest: float, lead: str, measured: str) -> tuple[float, str]:
    """m/s, the fastest a body stepped whole (no substeps) may move in ``engine``'s run: the
    engine's measured limit, and less than ``thinnest`` (m) a step; and why, in words after
    ``lead`` (``measured`` names what the limit was measured on)."""
    limits = type(engine).LIMITS
    per_step = thinnest / engine.timestep
    most = min(limits.max_speed_no_substeps, per_step)
    why = f"{lead}: at most {most:.3g} m/s, " + (
        f"or in one {engine.timestep * 1000:.3g} ms step it moves further than the thinnest brick ({_mm(thinnest)}) "
        "and may pass through it"
        if per_step < limits.max_speed_no_substeps
        else f"({measured}: {limits.measured['max_speed_no_substeps']})"
    )
    return most, why


def _mm(metres: float) -> str:
    return f"{metres * 1000:.3g} mm"


class _Reach:
    """Which bricks of a scene with no impact and no action can press on or strike which.

    The mass-ratio limit is measured as a heavy KAPLA brick crossed on a light one: the solver
    lets the light one give under the load (``stackdsl bench limits``). A light brick on a heavy
    one is what every brick on the ground is (the ground is infinitely heavy), and bricks that
    never meet have no contact to balance. So a pair counts when the heavier brick can come to
    rest on, or land on, the lighter: when it can move at all and the lighter lies within its
    reach. Without an impact or an action, a brick moves only by falling or by being struck:

    * it can fall when it stands on something other than the ground (its lowest point more
      than :data:`REST_TOLERANCE` up, resting on a brick or a fixture) or stands on the ground
      other than on its largest face (it can topple); its reach is then every brick whose box
      comes within twice its top's height plus its longest side, sideways, of its own box (a
      brick that topples from the top lands and slides well within that);
    * a brick within the reach of a moving one moves too, with that reach, unless the moving
      one is over the limit lighter than it (it then leaves at under 2/limit of the striker's
      speed: a KAPLA brick landing on an 8 kg board does not set it going).

    Boxes are axis-aligned around each brick, so the reach is an overestimate.
    """

    def __init__(self, bricks: Sequence[LaidBrick], specs: Mapping[str, BrickSpec]) -> None:
        self.ids = [b.id for b in bricks]
        self.types = [b.type for b in bricks]
        n = len(bricks)
        half = np.array([specs[t].half_extents for t in self.types], dtype=float).reshape(n, 3)
        centre = np.array([b.position for b in bricks], dtype=float).reshape(n, 3)
        axes = Rotation.from_euler("ZYX", [[b.yaw, b.pitch, b.roll] for b in bricks], degrees=True).as_matrix()
        extent = (np.abs(axes.reshape(n, 3, 3)) @ half[:, :, None])[:, :, 0]
        self.low, self.high = centre - extent, centre + extent
        self.mass = np.array([specs[t].mass for t in self.types], dtype=float)
        flat = centre[:, 2] <= half.min(axis=1) + REST_TOLERANCE  # on its largest face on the ground: nowhere to fall
        falls = (self.low[:, 2] > REST_TOLERANCE) | ~flat
        self.falls = falls
        self.span = np.where(falls, 2 * self.high[:, 2] + 2 * half.max(axis=1), 0.0)

    def _gap(self, i: int) -> np.ndarray:
        """The sideways distance from brick ``i``'s box to every brick's, m."""
        d = np.maximum(0.0, np.maximum(self.low[:, :2] - self.high[i, :2], self.low[i, :2] - self.high[:, :2]))
        gap: np.ndarray = np.hypot(d[:, 0], d[:, 1])
        return gap

    def worst(self, most: float) -> tuple[str, str, str] | None:
        """The heaviest over lightest pair of types more than ``most`` times as heavy where the
        heavier can press on or strike the lighter, with how they meet (", and brick 'x' rests on
        'y'"), or None."""
        if len(self.mass) < 2 or self.mass.max() <= self.mass.min() * most:
            return None
        span = self.span.copy()
        frontier: list[int] = np.flatnonzero(self.falls).tolist()
        why = dict.fromkeys(frontier, "")
        best: tuple[tuple[float, bool], int, int] | None = None
        while frontier:
            i = frontier.pop()
            near = self._gap(i) <= span[i]
            near[i] = False
            hit = np.flatnonzero(near & (self.mass * most < self.mass[i]))
            if hit.size:
                hit = hit[self.mass[hit] == self.mass[hit].min()]
                resting = self._rests(i, hit)
                j = int(hit[np.argmax(resting)])  # a brick resting on another is said first
                key = (float(self.mass[i] / self.mass[j]), bool(resting.any()))
                if best is None or key > best[0]:
                    best = (key, i, j)
            knocked = np.flatnonzero(near & (self.mass[i] * most >= self.mass) & (span < span[i]))
            for k in knocked.tolist():
                span[k] = span[i]
                why.setdefault(k, f" be struck by brick {self.ids[i]!r} and")
                frontier.append(k)
        if best is None:
            return None
        (_, on), i, j = best
        how = (
            f", and brick {self.ids[i]!r} rests on brick {self.ids[j]!r}"
            if on
            else f", and brick {self.ids[i]!r} can{why.get(i, '') or ' fall and'} reach brick {self.ids[j]!r}"
        )
        return self.types[i], self.types[j], how

    def _rests(self, i: int, under: np.ndarray) -> np.ndarray:
        """Whether brick ``i``'s box sits on each of the bricks ``under`` (within :data:`REST_TOLERANCE`)."""
        low, high = self.low[under], self.high[under]
        touching = np.all(self.low[i, :2] <= high[:, :2], axis=1) & np.all(low[:, :2] <= self.high[i, :2], axis=1)
        rests: np.ndarray = touching & (np.abs(self.low[i, 2] - high[:, 2]) <= REST_TOLERANCE)
        return rests


def _others() -> list[tuple[str, type[EngineSettings]]]:
    """Each engine that simulates motion, by name, and its settings class: where a refused scene
    might go instead."""
    return [(name, backend_named(name).settings) for name in names() if backend_named(name).dynamics]
