"""Scenario -> Program: expand generators, schedule placements and impacts, check times.

Every action time must be a whole number of timesteps (as dm_control's composer checks
control timesteps): an interval of 0.301 s at 1/240 s is an error pointing at the file,
not a silently rounded schedule.

The work budget: every run is estimated before anything is simulated, in *body-steps*
(one body in the engine for one physics step or substep; :func:`stackdsl.compile.program.estimate_work`)::

    raw, tuned:  sum over bricks of (steps from its placement to the end) x max(1, iterations / 50)
                 + steps (the runtime's loop) + fixtures x steps
    extension:   after each placement, only the steps until the brick is at rest
                 (fall + 20 ms + rest_duration) x (every body in the engine); the run jumps
                 over the time in which every brick is frozen
    projectiles: every body moving from launch to 1 s after arrival, x substeps

and refused over :data:`MAX_WORK` with a ScenarioError at the field to change: a
timestep below the mode's default (``engine.timestep``), more solver iterations than the
default (``engine.solver_iterations``), raw or tuned mode where extension mode would fit
(``engine.mode``), or else the size (``structure.tower.levels``,
``structure.card_house.levels``, ``structure.bricks``), with how many levels or bricks
would fit. The bound admits every shipped scenario and every scene of ``stackdsl bench``
(its longest, a 100-level tower at 1 ms and 150 iterations, is 6.1e7 body-steps and 39
minutes); measured on a 2-core machine a body-step costs 1.7e-5 to 3.9e-5 s moving and
2.3e-6 s resting, so a refused run would take over an hour in raw or tuned mode and over
about 4 minutes in extension mode (a 5000-brick tower: 2.4e8 body-steps, over 10 minutes).

The layouts themselves (tower, card house, bricks by hand) are :mod:`stackdsl.compile.layouts`'.

Source: stackdsl's own.
"""

from __future__ import annotations

import math
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import NamedTuple

import numpy as np
from shapely.geometry import MultiPoint

from stability import Box, Pose, StabilityConfig

from ..engines.protocol import BrickSpec, EngineSettings
from ..engines.registry import UnknownBackend, names
from ..engines.registry import backend as backend_named
from ..engines.settings import defaults, settings
from ..lang.bounds import MAX_SIMULATED_TIME
from ..lang.errors import FieldPath, ScenarioError, format_path
from ..lang.schema import BUILTIN_BRICKS, Scenario, reference_errors
from ..lang.schema_impacts import SIDES, AfterLevel, Impact
from ..util.extras import installed, missing
from .actions import check_measured, compile_actions, heading, not_built, warn_during_build, warn_pushed_stands
from .aim import outer_face, stepped_fall
from .clearance import check_launch, check_pusher, warn_wide_pusher
from .dynamics import check_motion
from .generators import warn_wrapped_rows
from .layouts import LaidBrick, with_placement_error
from .limits import check_limits
from .overlap import Body
from .parts import arrange, summaries
from .precheck import precheck
from .program import MAX_SUBSTEPS, End, Fixture, Kinematic, Launch, Place, Program, Push, Remove, Shake
from .require import accept
from .rules import choose_rules

#: Engine defaults per backend and mode, as each engine's settings class owns them
#: (:mod:`stackdsl.engines.registry`: each backend's ``settings.DEFAULTS``).
BACKEND_DEFAULTS: dict[str, dict[str, dict[str, object]]] = {name: backend_named(name).settings.DEFAULTS for name in names()}


class ModeDefaults(dict[str, dict[str, object]]):
    """The engine modes and what each sets, on the default backend (pybullet, the first of
    :data:`stackdsl.engines.registry.BACKENDS`): mode
    (``"raw"``, ``"tuned"``, ``"extension"``) -> engine setting (``timestep`` in s,
    ``solver_iterations``, ``friction_anchors``, ``maximal_coordinates``, ``ccd``) -> its value.

    A scenario picks its mode in ``engine: {mode: ...}`` (``stackdsl check --mode`` overrides
    it) and any setting it writes there replaces the mode's. The values are the default
    backend's settings class's ``DEFAULTS``; every backend's are :data:`BACKEND_DEFAULTS` in
    :mod:`stackdsl.compile.compiler`. A dict, of a class of
    its own so that ``help(stackdsl.MODE_DEFAULTS)`` says this. Source: stackdsl's own.

    >>> import stackdsl
    >>> sorted(stackdsl.MODE_DEFAULTS), stackdsl.MODE_DEFAULTS["tuned"]["timestep"]
    (['extension', 'raw', 'tuned'], 0.001)
    """


#: The engine modes and the default backend's settings each one sets (:class:`ModeDefaults`).
MODE_DEFAULTS = ModeDefaults(BACKEND_DEFAULTS[names()[0]])
GRAVITY = 9.81

MAX_WORK = 1e8
"""Body-steps a run may take at most (see the module's docstring); more is a ScenarioError."""


def _not_a_scenario(value: object) -> str:
    """The message of :func:`compile_scenario`'s TypeError for ``value``: what it takes and how
    to get one from what it was given."""
    if isinstance(value, (str, os.PathLike)):
        how = "read a file with load_scenario(path), or YAML text with parse_scenario(text), first"
    elif isinstance(value, Program):
        how = "this one is compiled already: run it with run_program(program)"
    else:
        how = "load_scenario(path) reads one from a file, parse_scenario(text) from YAML text"
    return f"compile_scenario takes a Scenario, not {type(value).__name__}: {how}"


def compile_scenario(
    scenario: Scenario,
    mode: str | None = None,
    model: str | None = None,
    backend: str | None = None,
    *,
    limits: bool = True,
    draw_time: float | None = None,
) -> Program:
    """Compile a scenario into a :class:`Program`: the passes of :data:`PASSES`, in order.

    Args:
        scenario: a validated scenario.
        mode: ``"raw"``, ``"tuned"`` or ``"extension"`` to override the scenario's mode;
            the mode picks the engine defaults the scenario does not set.
        model: ``"report"`` or ``"equilibrium"`` to override the scenario's stability model.
        backend: ``"pybullet"`` or ``"mujoco"`` to override the scenario's engine; the
            other engine's own settings in the scenario are then left out, a
            :class:`~stackdsl.lang.errors.ScenarioWarning` at each.
        limits: False skips the engine's own limits (:mod:`stackdsl.compile.limits`), to
            measure them (``stackdsl bench limits``); a run beyond them is the engine's artefact.
        draw_time: wall seconds the draws that meet ``require:`` may take (a run's ``--timeout``),
            at most :data:`stackdsl.compile.require.DRAW_TIME` (30 s), the default.

    Raises:
        ScenarioError: an action time is not a whole number of timesteps, an impact
            names a level that is not built, none of whose bricks is placed when it is thrown, or whose bricks are all pulled out before it arrives, the run would exceed the time limit or the
            work budget (:data:`MAX_WORK`), or a check before simulating fails
            (:mod:`stackdsl.compile.precheck`: bricks that overlap or rest on nothing where
            placed, expectations about levels never built), the scene is beyond what the
            engine simulates faithfully (:mod:`stackdsl.compile.limits`), the engine is
            MuJoCo and it is not installed (the ``mujoco`` extra), or no draw of a random scene
            meets its ``require:`` within its draws or ``draw_time``.
        TypeError: ``scenario`` is not a :class:`Scenario` (a file name or YAML text: the
            message names :func:`stackdsl.load_scenario` or :func:`stackdsl.parse_scenario`).
    """
    state = Compilation(scenario, Asked(mode, model, backend, limits, draw_time))
    for compiler_pass in PASSES:
        state = compiler_pass(state)
    return state.built


class Asked(NamedTuple):
    """What :func:`compile_scenario` was asked besides the scenario (its arguments of the same names)."""

    mode: str | None = None
    model: str | None = None
    backend: str | None = None
    limits: bool = True
    draw_time: float | None = None


@dataclass
class Compilation:
    """A scenario on its way to a :class:`Program`: what the passes of :data:`PASSES` have found
    so far, each pass filling in its part (SI units, steps of the engine's timestep).

    Attributes:
        scenario: the scenario; after :func:`draw`, the random scene's sample that meets ``require:``.
        asked: :func:`compile_scenario`'s other arguments.
        draws: the draws :func:`draw` took (1 without ``require:``).
        settings: the engine's settings (:func:`choose_engine`; :attr:`engine` reads them).
        nominal: every brick and fixture as laid out, in placement order; laid: the same with
            the placement error (:func:`lay_out`).
        bricks, fixed: the structure's bricks and the fixtures, of ``laid``.
        specs: brick type -> its body, for every type the scene uses.
        per_slot, settle: steps between two placements and after the last action (:func:`place`).
        slots: each brick's placement slot (a brick placed ``together`` shares the one before it).
        placements: a :class:`Place` for each brick.
        motions: the actions' pulls, pushes and shakes, in the order written (:func:`act`).
        launches: a :class:`Launch` for each impact (:func:`throw`).
        actions: every action in time order, :class:`End` last (:func:`schedule`).
        program: the program (:func:`assemble`; :attr:`built` reads it).
    """

    scenario: Scenario
    asked: Asked = field(default_factory=Asked)
    draws: int = 1
    settings: EngineSettings | None = None
    nominal: list[LaidBrick] = field(default_factory=list)
    laid: list[LaidBrick] = field(default_factory=list)
    bricks: list[LaidBrick] = field(default_factory=list)
    fixed: list[LaidBrick] = field(default_factory=list)
    specs: dict[str, BrickSpec] = field(default_factory=dict)
    per_slot: int = 0
    settle: int = 0
    slots: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    placements: list[Place] = field(default_factory=list)
    motions: list[Kinematic] = field(default_factory=list)
    launches: list[Launch] = field(default_factory=list)
    actions: list[Place | Launch | Remove | Push | Shake | End] = field(default_factory=list)
    program: Program | None = None

    @property
    def engine(self) -> EngineSettings:
        """The engine's settings.

        Raises:
            RuntimeError: asked before :func:`choose_engine` (a pass out of order).
        """
        if self.settings is None:
            raise RuntimeError("the engine is chosen by choose_engine, a pass not run yet")
        return self.settings

    @property
    def built(self) -> Program:
        """The program.

        Raises:
            RuntimeError: asked before :func:`assemble` (a pass out of order).
        """
        if self.program is None:
            raise RuntimeError("the program is made by assemble, a pass not run yet")
        return self.program

    @property
    def threshold(self) -> float:
        """Metres, the collapse threshold: the scenario's, else half the thinnest side of its bricks."""
        return self.scenario.collapse_threshold or min(min(self.specs[b.type].half_extents) for b in self.bricks)

    def steps(self, path: FieldPath, seconds: float) -> int:
        """``seconds`` as a whole number of the engine's timesteps, or a ScenarioError at ``path`` (:func:`_steps`),
        which says whose the timestep is when the file does not write it (a mode's, or the other engine's)."""
        e = self.engine
        whose = "" if _written(self.scenario, ("engine", "timestep")) else f", {e.backend}'s in {e.mode} mode"
        return _steps(self.scenario, path, seconds, e.timestep, whose)

    def present(self, step: int) -> list[tuple[str, BrickSpec, Pose]]:
        """(id, body, pose as placed) of every body in the scene at ``step``: the bricks placed by
        then and not yet pulled out and taken away, then the fixtures."""
        gone = {m.id: m.end_step for m in self.motions if isinstance(m, Remove)}
        there = [
            (b.id, self.specs[b.type], b.pose())
            for b, k in zip(self.bricks, self.slots)
            if int(k) * self.per_slot <= step and gone.get(b.id, step + 1) > step
        ]
        return there + [(b.id, self.specs[b.type], b.pose()) for b in self.fixed]


def read(state: Compilation) -> Compilation:
    """Pass 1: take only a :class:`Scenario` whose names all refer to something.

    Raises:
        TypeError: not a Scenario (the message says how to get one from what it is).
        ScenarioError: at the first name that refers to nothing (refused when a scenario is
            validated; here for one made without, ``Scenario.model_construct``).
    """
    scenario = state.scenario
    if not isinstance(scenario, Scenario):
        raise TypeError(_not_a_scenario(scenario))
    unknown = reference_errors(scenario)
    if unknown:
        raise scenario.source.error(*unknown[0], more=len(unknown) - 1)
    return state


def draw(state: Compilation) -> Compilation:
    """Pass 2: a random scene's first draw that meets its ``require:`` (:func:`stackdsl.compile.require.accept`),
    within ``asked.draw_time`` seconds; a scene without ``require:`` as it is.

    Raises:
        ScenarioError: no draw meets it within its draws or the time.
    """
    state.scenario, state.draws = accept(state.scenario, state.asked.draw_time)
    return state


def choose_engine(state: Compilation) -> Compilation:
    """Pass 3: the engine's settings: the backend and mode asked (else the file's), the mode's
    defaults, then what the file writes (the other backend's own settings left out).

    Raises:
        ValueError: an unknown backend or mode asked.
        ScenarioError: the backend's extra (MuJoCo's) is not installed (at ``engine.backend`` when
            the file asks for it), or the backend cannot move what the scene asks it to
            (:func:`stackdsl.compile.dynamics.check_motion`).
    """
    scenario, mode, backend = state.scenario, state.asked.mode, state.asked.backend
    engine = _engine(scenario, mode, backend)
    extra = backend_named(engine.backend).extra
    if extra is not None and not installed(extra):
        if backend is None or backend == scenario.engine.backend:  # the file asks for it: say where
            raise scenario.source.error(("engine", "backend"), missing(extra))
        raise ScenarioError(missing(extra, f"backend={backend!r}"), file=scenario.source.file)
    check_motion(scenario, backend_named(engine.backend))
    _warn_left_out(scenario, engine)
    state.settings = engine
    return state


def _warn_left_out(scenario: Scenario, engine: EngineSettings) -> None:
    """Warn, at each field, of the file's own engine's settings that a ``backend`` asked over
    the file's (``--backend``) leaves out: ``sleep_tolerance`` under pybullet, ``friction_anchors``
    under MuJoCo. A warning, not a refusal: the file is right for its own engine, and running a
    scenario on each engine (``compare --backend pybullet,mujoco``) is what the option is for; the
    run takes the other engine's default for that mode, and says so."""
    written = scenario.engine.backend
    if engine.backend == written:
        return
    for name in backend_named(written).own_fields:
        if getattr(scenario.engine, name, None) is not None:
            warnings.warn(
                scenario.source.warning(
                    ("engine", name),
                    f"{written}'s own setting, not applied: this run is on {engine.backend} (asked over the "
                    f"file's backend, {written}), which has no such setting and runs at its {engine.mode} defaults",
                ),
                stacklevel=2,
            )


def lay_out(state: Compilation) -> Compilation:
    """Pass 4: every brick and fixture where the structure puts it (:func:`stackdsl.compile.parts.arrange`),
    then moved by the placement error; the body of each brick type the scene uses (projectiles'
    and pushers' included).

    Raises:
        ScenarioError: a layout that cannot be built (:func:`stackdsl.compile.parts.arrange`).
    """
    scenario = state.scenario
    state.nominal = arrange(scenario)
    state.laid = with_placement_error(scenario, state.nominal)
    state.bricks = [b for b in state.laid if not b.fixed]
    state.fixed = [b for b in state.laid if b.fixed]
    used = {b.type for b in state.laid} | {i.projectile for i in scenario.impacts}
    used |= {a.push.pusher for a in scenario.actions if a.push is not None and a.push.pusher in scenario_types(scenario)}
    state.specs = {name: _spec(scenario, name) for name in sorted(used)}
    return state


def place(state: Compilation) -> Compilation:
    """Pass 5: the placements, one slot of ``timing.interval`` each (bricks placed ``together``
    share one), ``timing.drop_gap`` above their poses.

    Raises:
        ScenarioError: ``timing.interval`` or ``timing.settle`` is not a whole number of timesteps.
    """
    timing = state.scenario.timing
    state.per_slot = state.steps(("timing", "interval"), timing.interval)
    state.settle = state.steps(("timing", "settle"), timing.settle)
    state.slots = np.cumsum([not b.together for b in state.bricks]) - 1
    state.placements = [
        Place(
            step=int(k) * state.per_slot,
            time=int(k) * timing.interval,
            id=b.id,
            level=b.level,
            brick=state.specs[b.type],
            position=tuple(b.position),
            yaw=b.yaw,
            pitch=b.pitch,
            roll=b.roll,
            drop=timing.drop_gap,
        )
        for b, k in zip(state.bricks, state.slots)
    ]
    return state


def act(state: Compilation) -> Compilation:
    """Pass 6: the scenario's ``actions`` (pulls, pushes, shakes) as motions, in the order written
    (:func:`stackdsl.compile.actions.compile_actions`, which says what it refuses)."""
    state.motions = compile_actions(
        state.scenario,
        state.bricks,
        state.slots,
        state.specs,
        state.placements,
        state.engine.timestep,
        state.steps,
        [b.id for b in state.fixed],
        state.fixed,
    )
    return state


def throw(state: Compilation) -> Compilation:
    """Pass 7: each impact's projectile, aimed as the engine steps its fall (:func:`_launch`),
    with a clear path to its target among the bodies there when it is thrown
    (:func:`stackdsl.compile.clearance.check_launch`).

    Raises:
        ScenarioError: at the impact: a level not built, not placed yet or all pulled out, a time
            off the timestep grid, a path blocked.
    """
    scenario, dt = state.scenario, state.engine.timestep
    pulls = {m.id: (j, m) for j, m in enumerate(state.motions) if isinstance(m, Remove)}
    # a projectile's steps are split as the run's Substeps splits them (with continuous collision detection)
    split = state.threshold if state.engine.ccd else None
    state.launches = [
        _launch(scenario, i, imp, state.bricks, state.slots, state.specs[imp.projectile], (dt, split), pulls)
        for i, imp in enumerate(scenario.impacts)
    ]
    for i, (imp, launch) in enumerate(zip(scenario.impacts, state.launches)):
        check_launch(scenario, i, imp, launch, state.present(launch.step))
    return state


def engine_limits(state: Compilation) -> Compilation:
    """Pass 8: the scene within what the engine simulates faithfully (:func:`stackdsl.compile.limits.check_limits`),
    unless ``asked.limits`` is False.

    Raises:
        ScenarioError: beyond a limit; when the command line's engine or mode refuses, the
            message says whether the file's own takes it (:func:`_asked`).
    """
    if not state.asked.limits:
        return state
    scenario, bricks = state.scenario, state.bricks
    moving = [b.type for b in bricks] + [i.projectile for i in scenario.impacts]
    made_by = {b.type: b.source for b in reversed(state.laid)}
    still = [b.type for b in state.fixed]
    try:
        check_limits(scenario, state.engine, state.specs, moving, made_by, still, bricks)
    except ScenarioError as exc:
        raise _asked(
            exc,
            scenario,
            state.asked.mode,
            state.asked.backend,
            lambda own: check_limits(scenario, own, state.specs, moving, made_by, still, bricks),
        ) from None
    return state


def check_hands(state: Compilation) -> Compilation:
    """Pass 9: what the hands do, against the structure: expectations that measure only pulled
    bricks (:func:`stackdsl.compile.actions.check_measured`), a projectile's or pusher's id that
    is taken (:func:`_own_ids`), a brick placed on one being pulled (:func:`_nothing_placed_on_pulled`),
    a pusher with no room (:func:`stackdsl.compile.clearance.check_pusher`), and warnings of a
    pusher wider than the place it moves into (:func:`stackdsl.compile.clearance.warn_wide_pusher`)
    and of ``stands: true`` with a brick pushed past the threshold
    (:func:`stackdsl.compile.actions.warn_pushed_stands`).

    Raises:
        ScenarioError: at the field of the first of these.
    """
    scenario, motions = state.scenario, state.motions
    levels = {b.id: b.level for b in state.bricks}
    check_measured(scenario, levels)
    warn_pushed_stands(scenario, levels, state.threshold)
    _own_ids(scenario, [b.id for b in state.laid], state.launches, motions)
    _nothing_placed_on_pulled(scenario, state.bricks, state.specs, state.placements, motions)
    for i, motion in enumerate(motions):
        if isinstance(motion, Push):
            check_pusher(scenario, i, motion, state.present(motion.step))
            warn_wide_pusher(scenario, i, motion, state.present(motion.step))
    return state


def schedule(state: Compilation) -> Compilation:
    """Pass 10: every action in time order (a placement before what happens at its step), then
    :class:`End` ``timing.settle`` after the last; the expectations checked against the run's end
    (:func:`_measurable`).

    Raises:
        ScenarioError: the run would last more than :data:`stackdsl.lang.bounds.MAX_SIMULATED_TIME`
            (at what makes it long), or an expectation it cannot measure.
    """
    scenario, motions, launches = state.scenario, state.motions, state.launches
    actions: list[Place | Launch | Remove | Push | Shake | End] = sorted(
        [*state.placements, *launches, *motions], key=lambda a: (a.step, a.kind != "place")
    )
    last_time = max([actions[-1].time, *(m.end_time for m in motions)])
    last_step = max([actions[-1].step, *(m.end_step for m in motions)])
    end = last_time + scenario.timing.settle
    if end > MAX_SIMULATED_TIME:
        last = actions[-1]  # what makes the run long: the last impact's time, or the placements' interval
        where: FieldPath = ("impacts", launches.index(last), "at") if last in launches else ("timing", "interval")
        why = ""
        if motions and max(m.end_time for m in motions) >= last.time:
            latest = max(motions, key=lambda m: m.end_time)
            where = ("actions", motions.index(latest), latest.kind, "at")
        elif last not in launches:  # the placements: at the interval if written, else at the structure
            why = (
                f": {len(state.placements)} bricks placed {scenario.timing.interval:g} s apart, then {scenario.timing.settle:g} s "
                "to settle; place them faster (timing.interval) or build fewer"
            )
            where = where if where in scenario.source.values else ("structure",)
        message = f"the run would last {_seconds(end)} s; at most {MAX_SIMULATED_TIME:.0f} s are simulated{why}"
        raise scenario.source.error(where, message)
    actions.append(End(step=last_step + state.settle, time=end))
    _measurable(scenario, end, len(state.bricks))
    state.actions = actions
    return state


def assemble(state: Compilation) -> Compilation:
    """Pass 11: the :class:`Program`: the extension's rules this scene needs
    (:func:`stackdsl.compile.rules.choose_rules`), the stability settings (the scenario's, the
    model asked, the engine's gravity, those rules), the ground's material, the fixtures, the
    parts' summaries."""
    scenario, engine = state.scenario, state.engine
    ground = scenario.material(scenario.ground.material)
    rules = choose_rules(state.bricks, state.launches, scenario.expect, state.motions, backend_named(engine.backend).split_pulls)
    on = {r.name: r.on for r in rules}
    model = state.asked.model
    settings = {**scenario.stability.model_dump(exclude_none=True), **({"model": model} if model else {})}
    state.program = Program(
        name=scenario.name or "scenario",
        engine=engine,
        ground_friction=ground.friction,
        ground_restitution=ground.restitution,
        stability=StabilityConfig(
            **settings,
            gravity=engine.gravity,
            leaning=on["leaning"],
            impacts=on["impacts"],
            leaning_margin=engine.LEANING_MARGIN,
        ),
        rules=rules,
        fixtures=tuple(
            Fixture(id=b.id, brick=state.specs[b.type], position=tuple(b.position), yaw=b.yaw, pitch=b.pitch, roll=b.roll)
            for b in state.fixed
        ),
        collapse_threshold=state.threshold,
        settle=scenario.timing.settle,
        actions=tuple(state.actions),
        draws=state.draws,
        parts=summaries(scenario, state.nominal),
        judged_at=scenario.expect.judged_at,
        watch_motion=scenario.expect.still is not None,
    )
    return state


def work_budget(state: Compilation) -> Compilation:
    """Pass 12: the run's estimated work within :data:`MAX_WORK` (:func:`_budget`), before the
    checks of the placements, which take a while on a huge scene.

    Raises:
        ScenarioError: over it, at the field to change (:func:`_budget`, :func:`_asked`).
    """
    scenario, program = state.scenario, state.built
    try:
        _budget(scenario, program)
    except ScenarioError as exc:
        raise _asked(
            exc, scenario, state.asked.mode, state.asked.backend, lambda own: _budget(scenario, _retimed(program, own))
        ) from None
    return state


def check_placements(state: Compilation) -> Compilation:
    """Pass 13: the checks before simulating (:func:`stackdsl.compile.precheck.precheck`: bricks
    that overlap or rest on nothing where placed, expectations about levels never built); the
    program notes the bricks allowed to rest on nothing.

    Raises:
        ScenarioError: the first check that fails.
    """
    slots = dict(zip(map(id, state.bricks), state.slots))
    floating = precheck(state.scenario, _bodies(state.scenario, state.laid, state.nominal, state.specs, slots))
    state.program = state.built.model_copy(update={"floating": floating})
    return state


def late_warnings(state: Compilation) -> Compilation:
    """Pass 14: the warnings that wait until nothing refuses the file (a refusal comes alone, on
    the first line): a pull or a push given a time while bricks are still to be placed
    (:func:`stackdsl.compile.actions.warn_during_build`), a row of dominoes that runs round its
    arc past its start (:func:`stackdsl.compile.generators.warn_wrapped_rows`)."""
    warn_during_build(state.scenario, state.motions, state.placements, state.bricks)
    warn_wrapped_rows(state.scenario, state.nominal)
    return state


#: The compiler's passes, in the order :func:`compile_scenario` runs them; each takes the
#: :class:`Compilation` so far and returns it with its own part found (or raises).
PASSES: tuple[Callable[[Compilation], Compilation], ...] = (
    read,
    draw,
    choose_engine,
    lay_out,
    place,
    act,
    throw,
    engine_limits,
    check_hands,
    schedule,
    assemble,
    work_budget,
    check_placements,
    late_warnings,
)


def scenario_types(scenario: Scenario) -> set[str]:
    """The brick types a scenario may name: the built-in ones and its own."""
    return {*BUILTIN_BRICKS, *scenario.brick_types}


def _budget(scenario: Scenario, program: Program) -> None:
    """Refuse a run whose estimated work exceeds :data:`MAX_WORK`, at the field to change:
    the first of a short timestep, many solver iterations, a mode without jumps or the
    equilibrium model whose default would fit, else the structure's size (with how much of
    it fits)."""
    work = program.work
    if work <= MAX_WORK:
        return
    e = program.engine
    given = scenario.engine
    bricks = len(program.placements)
    head = (
        f"the run would take too long: {bricks} brick{'s' * (bricks != 1)} over {program.duration:g} s simulated, "
        f"{e.timestep * 1000:.3g} ms steps, {e.solver_iterations} solver iterations, mode {e.mode}, is "
        f"{work:,.0f} body-steps (about {_duration(program.wall_estimate)}); at most {MAX_WORK:,.0f} are allowed"
    )
    default = settings(e.backend, mode=e.mode, **defaults(e.backend, e.mode))
    options: list[tuple[FieldPath, str, Program]] = []
    if given.timestep is not None and e.timestep < default.timestep:
        step = default.timestep
        faster = _retimed(program, e.model_copy(update={"timestep": step}))
        options.append((("engine", "timestep"), f"the {e.mode} default, {step * 1000:.3g} ms,", faster))
    if given.solver_iterations is not None and e.solver_iterations > default.solver_iterations:
        n = default.solver_iterations
        fewer = e.model_copy(update={"solver_iterations": n})
        options.append((("engine", "solver_iterations"), f"the {e.mode} default, {n},", _retimed(program, fewer)))
    if e.mode != "extension":
        extension = _retimed(program, _engine(scenario, "extension", e.backend))
        options.append((("engine", "mode"), "extension (it skips the time in which every brick is frozen)", extension))
    if program.stability.model == "equilibrium":
        report = program.model_copy(update={"stability": replace(program.stability, model="report")})
        options.append((("stability", "model"), "the report's model (no linear program each time a brick freezes)", report))
    for path, change, other in options:
        if other.work <= MAX_WORK:
            raise scenario.source.error(
                path, f"{head}. With {change} it would be {other.work:.2g} (about {_duration(other.wall_estimate)})"
            )
    raise scenario.source.error(_size_field(scenario), f"{head}. {_what_fits(program, tower=bool(scenario.structure.tower))}")


def _retimed(program: Program, engine: EngineSettings) -> Program:
    """``program`` with other engine settings, its actions moved to the new timestep (for estimates only)."""
    actions = tuple(a.model_copy(update={"step": round(a.time / engine.timestep)}) for a in program.actions)
    return program.model_copy(update={"engine": engine, "actions": actions})


def _size_field(scenario: Scenario) -> FieldPath:
    structure = scenario.structure
    if structure.parts is not None:
        return ("structure",)
    sizes = {"tower": "levels", "card_house": "levels", "wall": "courses", "pyramid": "base", "dominoes": "count"}
    kind = structure.layout_name or "bricks"
    return ("structure", kind, sizes[kind]) if kind in sizes else ("structure", kind)


def _what_fits(program: Program, tower: bool) -> str:
    """How many of the program's levels (of a tower) or bricks fit the budget, built in order."""
    places = program.placements
    levels = sorted({a.level for a in places})
    settle = round(program.settle / program.engine.timestep)

    def fits(top: int) -> bool:
        last = max((a for a in places if a.level <= top), key=lambda a: a.step)
        kept = [a for a in program.actions[:-1] if (a.level <= top if isinstance(a, Place) else a.step <= last.step)]
        tail = End(step=kept[-1].step + settle, time=kept[-1].time + program.settle)
        return program.model_copy(update={"actions": (*kept, tail)}).work <= MAX_WORK

    low, high = 0, len(levels)  # levels[:low] fit, levels[:high + 1] do not
    while low < high:
        mid = (low + high + 1) // 2
        if fits(levels[mid - 1]):
            low = mid
        else:
            high = mid - 1
    if low == 0:
        return "Not even the first level fits: make the run shorter (timing.settle, timing.interval)"
    fitting = sum(a.level <= levels[low - 1] for a in places)
    if tower:
        return f"At most {levels[low - 1]} levels ({fitting} bricks) would fit"
    return f"The first {fitting} of its {len(places)} bricks would fit"


def _seconds(seconds: float) -> str:
    """A run's length in s, whole below a million, else in three figures: ``3601.6`` -> ``'3602'``,
    ``1e300`` -> ``'1e+300'``."""
    return f"{seconds:.0f}" if seconds < 1e6 else f"{seconds:.3g}"


def _duration(seconds: float) -> str:
    """``42.0`` -> ``'42 s'``, ``5400.0`` -> ``'1.5 h'``."""
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _bodies(
    scenario: Scenario, placed: list[LaidBrick], nominal: list[LaidBrick], specs: dict[str, BrickSpec], slots: dict[int, int]
) -> list[Body]:
    """The bricks and fixtures for :func:`stackdsl.compile.precheck.precheck`, each with the field that made it."""
    interval = scenario.timing.interval
    return [
        Body(
            id=b.id,
            half_extents=specs[b.type].half_extents,
            position=tuple(b.position),
            nominal=tuple(n.position),
            yaw=b.yaw,
            pitch=b.pitch,
            roll=b.roll,
            slot=-1 if b.fixed else int(slots[id(b)]),
            time=0.0 if b.fixed else int(slots[id(b)]) * interval,
            level=b.level,
            path=b.source,
        )
        for b, n in zip(placed, nominal)
    ]


def _own_ids(scenario: Scenario, bricks: Sequence[str], launches: Sequence[Launch], motions: Sequence[Kinematic]) -> None:
    """Refuse a projectile or pusher whose id is a brick's or an earlier body's: the timeline,
    the verdicts and the replay name bodies by id, and a pusher called ``L01.1`` read as the
    brick ``L01.1`` touched by hand. A ScenarioError at the later one's ``id`` (at the impact or
    push itself when its id is the default one). Source: stackdsl's own."""
    seen = dict.fromkeys(bricks, "a brick of the structure")
    bodies: list[tuple[str, FieldPath, bool]] = [
        (launch.id, ("impacts", i), scenario.impacts[i].id is not None) for i, launch in enumerate(launches)
    ]
    bodies += [
        (m.id, ("actions", i, "push"), (push := scenario.actions[i].push) is not None and push.id is not None)
        for i, m in enumerate(motions)
        if isinstance(m, Push)
    ]
    for ident, path, written in bodies:
        if ident in seen:
            raise scenario.source.error(
                (*path, "id") if written else path,
                f"id {ident!r} already names {seen[ident]}: give this body an id of its own",
            )
        seen[ident] = "a projectile" if path[0] == "impacts" else "a pusher"


def _measurable(scenario: Scenario, end: float, bricks: int) -> None:
    """Refuse an expectation the run cannot measure: ``stands_until`` past the run's end (s), a
    ``toppled`` count or bound whose fewest bricks is beyond the scene's ``bricks``, a
    ScenarioError at it; warn of a ``toppled`` tolerance or bound that allows every count (it
    cannot fail)."""
    until = scenario.expect.stands_until
    if until is not None and until > end + 1e-9:
        raise scenario.source.error(
            ("expect", "stands_until"),
            f"{until:g} s is past the end of the run, {end:g} s (the last action or placement and timing.settle): nothing "
            f"after it is simulated; give a time up to {end:g} s, or a longer timing.settle",
        )
    toppled = scenario.expect.toppled
    if toppled is None or toppled.count == "all":
        return
    least, most = toppled.allows(bricks)
    if least > bricks:
        shown = toppled.count if toppled.op == "±" else f"'{toppled.text()}'"
        raise scenario.source.error(
            ("expect", "toppled"),
            f"{shown} toppled can never be measured: the scene has {bricks} brick{'s' * (bricks != 1)}",
        )
    if least <= 0 and most >= bricks:
        smaller = "a smaller tolerance" if toppled.op == "±" else "a bound that some count fails"
        warnings.warn(
            scenario.source.warning(
                ("expect", "toppled"),
                f"{toppled.text() if toppled.op != '±' else f'{toppled.count}±{toppled.tolerance}'} covers every count from "
                f"0 to the scene's {bricks} bricks: it cannot fail; give {smaller}",
            ),
            stacklevel=2,
        )


def _engine(scenario: Scenario, mode: str | None, backend: str | None = None) -> EngineSettings:
    chosen = mode or scenario.engine.mode
    engine = backend or scenario.engine.backend
    try:
        own = backend_named(engine)
    except UnknownBackend as exc:
        if backend is None:  # the file's own: say where
            raise scenario.source.error(("engine", "backend"), str(exc)) from None
        raise ValueError(str(exc)) from None
    if chosen not in own.settings.DEFAULTS:
        raise ValueError(f"unknown mode {chosen!r}; known: {', '.join(own.settings.DEFAULTS)}")
    given = scenario.engine.model_dump(exclude_none=True, exclude={"mode", "backend"})
    if backend is not None and backend != scenario.engine.backend:  # the file's backend's own settings do not apply
        given = {k: v for k, v in given.items() if k not in backend_named(scenario.engine.backend).own_fields}
    return settings(engine, mode=chosen, gravity=GRAVITY, **{**defaults(engine, chosen), **given})


def _asked(
    exc: ScenarioError, scenario: Scenario, mode: str | None, backend: str | None, check: Callable[[EngineSettings], None]
) -> ScenarioError:
    """``exc``, an engine's refusal, saying so when the engine or mode that refuses is the command
    line's (``mode``, ``backend`` over the file's own) and whether the file's own passes ``check``:
    ``'; raw is the mode the command line asks for, not the file's own (extension), which takes
    it'``. The error stays at the field to change: the command line has no line of the file."""
    file_backend: str = scenario.engine.backend
    file_mode: str = scenario.engine.mode
    asked: list[tuple[str, str, str]] = [("engine", backend, file_backend)] if backend and backend != file_backend else []
    asked += [("mode", mode, file_mode)] if mode and mode != file_mode else []
    if asked:
        try:
            check(_engine(scenario, None, None))
            verdict = "which takes it"
        except ScenarioError:
            verdict = "which refuses it too"
        exc.message += (
            f"; {' '.join(a[1] for a in asked)} is the {' and '.join(a[0] for a in asked)} the command line asks for, "
            f"not the file's own ({' '.join(a[2] for a in asked)}), {verdict}"
        )
    return exc


def _nothing_placed_on_pulled(
    scenario: Scenario,
    bricks: Sequence[LaidBrick],
    specs: Mapping[str, BrickSpec],
    places: Sequence[Place],
    motions: Sequence[Kinematic],
) -> None:
    """A ScenarioError at a pull's ``at`` when a brick is placed on the pulled brick once the
    pull has started: it lands on a brick on its way out (a part ``on:`` it, a level above it).
    A brick rests on another when its bottom lies within 1 mm of the other's top and their
    footprints overlap. Source: stackdsl's own."""
    pulls = [(i, m) for i, m in enumerate(motions) if isinstance(m, Remove)]
    if not pulls:  # the common case: nothing to compare
        return
    laid = {b.id: b for b in bricks}
    boxes = {b.id: b.corners(specs[b.type]) for b in bricks}
    for index, motion in pulls:
        if motion.id not in boxes:
            continue
        pulled = boxes[motion.id]
        top, under = float(pulled[:, 2].max()), MultiPoint(pulled[:, :2]).convex_hull
        for place in places:
            if place.step < motion.step or place.id not in boxes:
                continue
            corners = boxes[place.id]
            if (
                abs(float(corners[:, 2].min()) - top) < 0.001
                and MultiPoint(corners[:, :2]).convex_hull.intersection(under).area > 1e-8
            ):
                raise scenario.source.error(
                    ("actions", index, "remove", "at"),
                    f"{motion.id} is pulled out from {motion.time:g} s, and {place.id} is placed on it at {place.time:g} s "
                    f"(level {laid[place.id].level}): pull it once what rests on it is built, "
                    "or build nothing on it",
                )


def _common_step() -> float:
    """Seconds: the shortest time that is a whole number of every backend's default timestep in
    every mode (1/240 s, 1 ms, 2 ms, 4 ms, 10 ms: 0.1 s), so that a time on its grid runs on each
    engine ``stackdsl compare`` may ask for. Source: stackdsl's own."""
    steps = [Fraction(str(d["timestep"])).limit_denominator(100_000) for m in BACKEND_DEFAULTS.values() for d in m.values()]
    # of fractions in lowest terms: the numerators' least common multiple over the denominators' greatest divisor
    return math.lcm(*(f.numerator for f in steps)) / math.gcd(*(f.denominator for f in steps))


#: Seconds that every engine and mode's default timestep divides (:func:`_common_step`): what a
#: time refused as off one engine's grid is suggested a multiple of.
COMMON_STEP = _common_step()


def _steps(scenario: Scenario, path: FieldPath, seconds: float, dt: float, whose: str = "") -> int:
    """``seconds`` as a whole number of timesteps (``dt``, s), or a ScenarioError at ``path``:
    a time past the run's limit (:data:`MAX_SIMULATED_TIME`: the run would last at least that
    long, and a time of 1e306 s or more counts no whole number of steps), or one off the grid
    (also a positive duration shorter than one timestep); ``whose`` follows the step's length in
    the message (``", mujoco's in extension mode"``). Source: stackdsl's own."""
    if not seconds <= MAX_SIMULATED_TIME:
        raise scenario.source.error(
            path, f"the run would last at least {_seconds(seconds)} s; at most {MAX_SIMULATED_TIME:.0f} s are simulated"
        )
    steps = seconds / dt
    if abs(steps - round(steps)) > 1e-6 * max(1.0, steps) or (seconds > 0 and round(steps) == 0):
        such = f"{max(1, round(steps)) * dt:.6g} s"
        common = COMMON_STEP / dt
        if abs(common - round(common)) <= 1e-9 * common:  # this run's step divides every default's grid
            everywhere = f"{max(1, round(seconds / COMMON_STEP)) * COMMON_STEP:.6g} s"
            such = such if everywhere == such else f"{such}, or {everywhere}"
            such += f", a whole number of steps on every engine and mode (a multiple of {COMMON_STEP:g} s)"
        step = f"({dt * 1000:.4g} ms{whose})"
        if _written(scenario, path):
            raise scenario.source.error(
                path, f"{seconds:g} s is not a whole number of timesteps {step}; use a multiple such as {such}"
            )
        raise _at_default(
            scenario, path, f"the default {seconds:g} s is not a whole number of timesteps {step}: write {path[-1]}: {such}"
        )
    return round(steps)


def _written(scenario: Scenario, path: FieldPath) -> bool:
    """Does the file write ``path`` (or a sweep's grid give it)? Not: the field's default."""
    source = scenario.source
    return path in source.values or any(path[: len(into)] == into for into, _, _ in source.moved)


def _at_default(scenario: Scenario, path: FieldPath, message: str) -> ScenarioError:
    """A ScenarioError for the default of ``path``, a field the file does not write, named as
    ``path``: at its section's key when the section is written (``timing:``), else at the
    timestep that makes the default fail when it is written (``engine.timestep``), else at the
    file. Source: stackdsl's own."""
    source = scenario.source
    if path[:-1] in source.keys:
        error = source.error(path[:-1], message, at_key=True)
    elif ("engine", "timestep") in source.values:
        error = source.error(("engine", "timestep"), message)
    else:
        error = source.error((), message)
    error.field = format_path(path)
    return error


def _spec(scenario: Scenario, name: str) -> BrickSpec:
    bt = scenario.brick_type(name)
    mat = scenario.material(bt.material)
    size = np.array(bt.size)
    return BrickSpec(
        type=name,
        half_extents=tuple(size / 2),
        mass=float(np.prod(size) * mat.density),
        friction=mat.friction,
        restitution=mat.restitution,
    )


def _launch(
    scenario: Scenario,
    index: int,
    impact: Impact,
    bricks: list[LaidBrick],
    slots: np.ndarray,
    spec: BrickSpec,
    stepping: tuple[float, float | None],
    pulls: Mapping[str, tuple[int, Remove]],
) -> Launch:
    """A projectile aimed so that, falling under gravity as the engine steps it (``stepping``: the
    step, and the most a thrown body moves in a substep, None when steps are not split: see
    :func:`~stackdsl.compile.aim.stepped_fall`), its centre reaches the target point (``pulls``:
    the bricks the actions pull out, each with its pull's index and motion: out of the scene from
    its pull's start, a level's face is aimed among the bricks left). A throw at a level's side
    names the brick it is aimed at first in its ``aim``, then the level's other bricks there to
    aim at: the run aims at that brick as it lies when the projectile is thrown."""
    path = ("impacts", index)
    dt, split = stepping
    direction = np.array(impact.direction or _side(impact), dtype=np.float64)
    direction /= np.linalg.norm(direction)
    if impact.target.side is not None and float(direction @ np.array(_side(impact))) <= 1e-9:
        into = _side(impact)
        axis = "xyz"[int(np.argmax(np.abs(into)))]
        raise scenario.source.error(
            path + ("direction",),
            f"a throw at the {impact.target.side} side must fly into it, and [{', '.join(f'{v:g}' for v in impact.direction or ())}] "
            "does not: "
            f"give a direction with a {'-' if min(into) < 0 else '+'}{axis} part, or leave it out to throw straight in",
        )
    if isinstance(impact.at, AfterLevel):
        last = [int(k) for b, k in zip(bricks, slots) if b.level == impact.at.after_level]
        if not last:
            raise scenario.source.error(path + ("at",), not_built(impact.at.after_level, bricks))
        launch_time = (last[-1] + 1) * scenario.timing.interval
    else:
        launch_time = impact.at
    step = _steps(scenario, path + ("at",), launch_time, dt)
    flight = impact.distance / impact.speed
    aim: tuple[str, ...] = ()
    face: tuple[float, float, float] | None = None
    if impact.target.point:
        target = np.array(impact.target.point)
    else:
        per_slot = _steps(scenario, ("timing", "interval"), scenario.timing.interval, dt)
        placed = {b.id: (int(k) * per_slot, int(k) * scenario.timing.interval) for b, k in zip(bricks, slots)}
        thrown, arrival = (step, launch_time), (step + flight / dt, launch_time + flight)
        level, target = _face_point(scenario, index, impact, bricks, placed, pulls, thrown, arrival)
        aim = tuple(b.id for b in level)
        face = tuple(-np.array(_side(impact), dtype=np.float64))
    start = target - direction * (impact.distance + spec.half_extents[0])
    start[2] += stepped_fall(tuple(direction * impact.speed), flight, dt, GRAVITY, split, MAX_SUBSTEPS)
    yaw, pitch = heading(direction)
    return Launch(
        step=step,
        time=launch_time,
        id=impact.id or f"impact{index + 1}",
        brick=spec,
        position=tuple(start),
        yaw=yaw,
        pitch=pitch,
        velocity=tuple(direction * impact.speed),
        target=tuple(target),
        arrival=launch_time + flight,
        aim=aim,
        face=face,
    )


def _face_point(
    scenario: Scenario,
    index: int,
    impact: Impact,
    bricks: list[LaidBrick],
    placed: Mapping[str, tuple[int, float]],
    pulls: Mapping[str, tuple[int, Remove]],
    thrown: tuple[int, float],
    arrival: tuple[float, float],
) -> tuple[list[LaidBrick], np.ndarray]:
    """The level's bricks there to aim at, the one aimed at first, and the middle of the level's
    outer face on the target side (:func:`~stackdsl.compile.aim.outer_face`). Only the bricks in
    the scene when the projectile is thrown (``thrown``, in steps and in seconds; ``placed``: each
    brick's placing, the same) and still there when it arrives (``arrival``, the same) count: a
    brick placed later is not there to aim at, a brick whose pull (of ``pulls``) has started by
    then is out of the scene. A level none of whose bricks is placed yet is refused at the impact's ``at``, one
    with none left at its ``target.level``."""
    path: FieldPath = ("impacts", index, "target", "level")
    assert impact.target.level is not None, "a target without a point names a level"
    built = [b for b in bricks if b.level == impact.target.level]
    if not built:
        raise scenario.source.error(path, not_built(impact.target.level, bricks))
    there = [b for b in built if placed[b.id][0] <= thrown[0]]
    if not there:
        first = min(built, key=lambda b: placed[b.id])
        raise scenario.source.error(
            ("impacts", index, "at"),
            f"the projectile is thrown at {thrown[1]:.4g} s, before level {impact.target.level} is built: its first "
            f"brick, {first.id}, is placed at {placed[first.id][1]:.4g} s; nothing is there to hit; throw it once the "
            f"level is placed ('after level {impact.target.level}')",
        )
    arrival_step, arrival_time = arrival
    level = [b for b in there if b.id not in pulls or pulls[b.id][1].step > arrival_step + 1e-9]
    if not level:
        taken = ", ".join(f"{b.id} by actions[{pulls[b.id][0]}] from {pulls[b.id][1].time:g} s" for b in there)
        raise scenario.source.error(
            path,
            f"every brick of level {impact.target.level} is pulled out of the scene before the projectile arrives at "
            f"{arrival_time:.4g} s ({taken}): nothing is left there to hit; aim at a level that stays, or throw before the pulls",
        )
    outward: np.ndarray = -np.array(_side(impact), dtype=np.float64)
    poses = [Pose.from_euler(b.position, b.yaw, b.pitch, b.roll) for b in level]
    boxes = [Box(np.array(scenario.brick_type(b.type).size) / 2, 1.0) for b in level]
    first_aimed, point = outer_face(boxes, poses, outward)
    return [level[first_aimed], *(b for i, b in enumerate(level) if i != first_aimed)], point


def _side(impact: Impact) -> tuple[float, float, float]:
    """The direction into the target's side (the schema requires a side unless a direction is given)."""
    assert impact.target.side is not None
    return SIDES[impact.target.side]
