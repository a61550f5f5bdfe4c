"""Program -> Outcome: run a program in a world, with or without the stability extension.

:func:`run_program` builds a world on the program's backend (:func:`world_for`: the world its
:class:`~stackdsl.engines.backend.Backend` opens, closed in all cases), a :class:`stackdsl.runtime.loop.StepLoop` over the program, and
attaches its subscribers: the substep control, the stability extension, the collapse
monitor and, when asked, a recorder. Bodies enter the engine when they are placed, in
program order, so creation order is a function of the scenario alone (pybullet is
bitwise repeatable only then; MuJoCo compiles its model again for each, keeping the state).

Collapse detection is the same in every mode: after the first structure brick leaves
its placed pose by more than the collapse threshold, nothing more is placed and the run
ends ``settle`` seconds later. In extension mode, while every brick is frozen nothing
can move, so the run jumps to the next action instead of stepping; and once a collapse is
decided, the bricks still moving become cheaper to step (rigid bodies on pybullet, half the cost a step),
unless the scene judges what stays after the collapse (the program's ``rigid`` rule).

Two guards keep a run finite (the compiler's work budget refuses the scenarios that
would take too long before anything runs, :mod:`stackdsl.compile.compiler`):

* a step is split into at most :data:`MAX_SUBSTEPS` substeps however fast a body moves
  (a ``substeps`` event says when the cap held);
* ``run_program(..., timeout=SECONDS)`` stops a run after that much wall time, cleanly:
  the outcome is built from what was simulated and :attr:`Outcome.stopped` says when.
  The clock is read once per :data:`CLOCK_EVERY` steps and at every action.

While a run lasts, the objects that existed before it (some 90,000 after the imports of
numpy, scipy, shapely and pydantic) are left out of Python's garbage collector
(:func:`gc.freeze`, undone by :func:`gc.unfreeze` when the run ends: what they leave as
garbage is collected after it). A full collection during a run scanned them all: 50 to 65 ms
of a 1.2 to 1.5 s run of a collapsing slant log cabin in extension mode, which makes more
objects than the raw one (timed ad hoc with :data:`gc.callbacks`).

Source: stackdsl's own.
"""

from __future__ import annotations

import gc
import time as _time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from numbers import Real

from ..compile.program import Program, require_program
from ..engines.protocol import EngineSettings, World
from ..engines.registry import backend
from .actions import Actions
from .collapse import CollapseMonitor
from .loop import CLOCK_EVERY, StepLoop, Subscriber
from .motion import PeakMotion
from .outcome import Outcome
from .placing import run_placed
from .subscribers import CheapDebris, SoftLanding, Stability, Substeps

__all__ = ["CLOCK_EVERY", "RunOptions", "run_in", "run_program"]


@dataclass(frozen=True)
class RunOptions:
    """How much of a scene the runtime simulates; each switch shows its saving in ``stackdsl bench``.

    Attributes:
        jump: in extension mode, jump to the next action while every brick is frozen
            (nothing can move) instead of stepping.
        lazy_bodies: bodies enter the engine when they are placed; False creates every
            brick at the start, parked far away and immovable; None (the default): the
            backend's best, measured (docs/results/mujoco.md): when placed on pybullet; at the
            start on MuJoCo, which compiles its model again for each new body (with its own
            sleeping too: the 60-level 4 stack takes 54 s parked against 134 s rebuilt).
        needed_rules: run only the stability rules the compiler chose for the scene;
            False runs leaning and impacts always.
        per_event: run the stack-wide test when the stack changes; False every step.
        stop_at_collapse: place nothing after the first collapse and end ``settle`` later.
        soft_landing: a placed brick is lowered onto its resting height and let go of there
            (:class:`stackdsl.runtime.subscribers.SoftLanding`); False drops it freely from its gap.
        cheap_debris: in extension mode, with ``stop_at_collapse`` and the program's ``rigid``
            rule on, the bricks that move once the collapse is decided become cheaper to step
            (:class:`stackdsl.runtime.subscribers.CheapDebris`): rigid bodies (maximal
            coordinates) on pybullet, contacts at MuJoCo's default impratio on MuJoCo.
        shelve: on pybullet, static bodies that nothing moving can reach leave the engine's world
            until something could (:class:`stackdsl.engines.pybullet.world.PyBulletWorld`); False
            keeps every body in it.
        settle: seconds the run goes on after the first collapse is decided (with
            ``stop_at_collapse``); None: the program's ``settle``. 0 ends the run at the
            decision, as a peer that only wants the collapse level does (``stackdsl bench``).

    Source: stackdsl's own (model only what a scene needs).
    """

    jump: bool = True
    lazy_bodies: bool | None = None
    needed_rules: bool = True
    per_event: bool = True
    stop_at_collapse: bool = True
    cheap_debris: bool = True
    soft_landing: bool = True
    shelve: bool = True
    settle: float | None = None


def run_program(
    program: Program,
    options: RunOptions = RunOptions(),
    *,
    timeout: float | None = None,
    subscribers: tuple[Subscriber, ...] = (),
) -> Outcome:
    """Run a compiled program and report what happened.

    Args:
        program: a compiled program.
        options: how much of the scene to simulate.
        timeout: seconds of wall time after which the run stops (checked every
            :data:`CLOCK_EVERY` steps and at every action, and by each linear program of the
            end's proof that a structure stands); the outcome then covers the
            simulated time so far and :attr:`Outcome.stopped` says where it stopped.
            None: no limit.
        subscribers: more subscribers for the step loop (a recorder), after the run's own.

    Raises:
        ValueError: a negative or not-a-number timeout (:func:`check_timeout`).
        TypeError: ``program`` is not a :class:`Program` (a Scenario or a file name: the
            message says how to compile it), or a timeout that is not a number.
        pybullet.error: the engine failed (not expected for a compiled program).
        ImportError: the program's engine is an optional extra that is not installed.
    """
    require_program(program, "run_program")
    check_timeout(timeout)
    engine = backend(program.engine.backend)
    if engine.prepare is not None:
        engine.prepare()  # a process's one-off import, not this run's wall time
    start = _time.perf_counter()
    if not engine.dynamics and not subscribers:  # nothing to step: placed and solved
        return run_placed(program, timeout=timeout, started=start)
    with _older_objects_left_alone(), world_for(program, shelve=options.shelve) as world:
        loop = run_in(world, program, options, timeout=timeout, started=start, subscribers=subscribers)
        built = outcome(loop, 0.0)  # its wall time counts the final brick graph too: it is part of the run
        return built.model_copy(update={"wall_time": _time.perf_counter() - start})


def check_timeout(timeout: float | None) -> None:
    """Refuse a wall-clock limit no run can keep: ``timeout`` must be None (no limit) or a
    number of seconds >= 0 (0: the run stops at its first check).

    Raises:
        TypeError: ``timeout`` is not a number (a string, a bool).
        ValueError: ``timeout`` is negative or not a number (NaN).
    """
    if timeout is None:
        return
    if isinstance(timeout, bool) or not isinstance(timeout, Real):
        raise TypeError(f"timeout must be a number of seconds >= 0 or None, not {timeout!r}")
    if not timeout >= 0:
        raise ValueError(f"timeout must be a number of seconds >= 0 or None, not {timeout!r}")


@contextmanager
def _older_objects_left_alone() -> Iterator[None]:
    """The garbage collector's passes look only at objects made inside the block (module docstring).
    A caller that froze objects itself (:func:`gc.freeze` before forking workers) keeps its own
    arrangement: nothing is frozen here, so nothing of it is unfrozen at the end."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


@contextmanager
def world_for(program: Program, *, shelve: bool = True) -> Iterator[World]:
    """A new world for ``program``: on its backend's engine, closed on exit; ``shelve``: see
    :attr:`RunOptions.shelve`.

    Raises:
        ImportError: an engine that is an optional extra, not installed.
    """
    engine = program.engine
    opened = backend(engine.backend).world
    with opened(
        engine, program.ground_friction, program.ground_restitution, shelve=shelve, movable_ground=program.shakes
    ) as world:
        yield world


def run_in(
    world: World,
    program: Program,
    options: RunOptions = RunOptions(),
    *,
    timeout: float | None = None,
    started: float | None = None,
    subscribers: tuple[Subscriber, ...] = (),
) -> StepLoop:
    """Run ``program`` in ``world`` (a real or a fake one) and return the finished loop;
    :func:`outcome` reads it. ``timeout`` and ``started``: as :class:`StepLoop`'s.

    Raises:
        TypeError: ``program`` is not a :class:`Program` (as :func:`run_program`), or
            ``timeout`` is not a number.
        ValueError: a negative or not-a-number ``timeout``.
    """
    require_program(program, "run_in")
    check_timeout(timeout)
    config = program.stability
    if not options.needed_rules:
        config = replace(config, leaning=True, impacts=True)
    config = replace(config, per_event=options.per_event)
    acting = program.engine.mode == "extension"
    stability = Stability(world, program, config, acting)
    rest = (program.stability.rest_speed, program.stability.rest_angular_speed, program.stability.rest_duration)
    monitor = CollapseMonitor(
        program.collapse_threshold,
        program.settle if options.settle is None else options.settle,
        stability.graph,
        stability.extension.certificate,
        stability.proved,
        *rest,
        near_ties=lambda: stability.near_ties,
    )
    hand = stability.extension.lowering if acting else None
    own: list[Subscriber] = [SoftLanding(program.engine.gravity, hand)] if options.soft_landing else []
    substeps = Substeps(program.collapse_threshold, acting) if program.engine.ccd else None
    own += [substeps] if substeps is not None else []
    # finer steps while a pull lasts: pybullet's friction at 240 Hz drags what the pulled brick
    # carries (compile.program.PULL_STEP); MuJoCo's guided brick, its velocity set once a step, then
    # slips under what it carries (a brick lying on it stayed put where it rode 40 mm along)
    split_pulls = acting and backend(program.engine.backend).split_pulls
    own += [Actions(stability, substeps, split_pulls, monitor.past_threshold_besides)] if program.kinematic else []
    after: list[Subscriber] = []
    rigid = any(r.name == "rigid" and r.on for r in program.rules)
    if acting and rigid and options.cheap_debris and world.cheap_debris and options.settle != 0.0:  # 0: nothing falls on
        after.append(CheapDebris(world.make_debris))
    after += [PeakMotion()] if program.watch_motion else []
    loop = StepLoop(
        world,
        program,
        [*own, stability, monitor, *after, *subscribers],
        jump=options.jump,
        stop_at_collapse=options.stop_at_collapse,
        lazy_bodies=options.lazy_bodies if options.lazy_bodies is not None else _lazy(program.engine),
        timeout=timeout,
        started=started,
    )
    loop.run()
    return loop


def _round_mm(metres: float) -> float:
    return round(metres * 1000, 3) + 0.0


def _lazy(engine: EngineSettings) -> bool:
    return engine.enters_when_placed


def outcome(loop: StepLoop, wall_time: float) -> Outcome:
    """What a finished loop of :func:`run_in` produced (:class:`Outcome`); ``wall_time``: the
    seconds it took, reported as :attr:`Outcome.wall_time`. Source: stackdsl's own.

    >>> from stackdsl import FakeWorld, compile_scenario, parse_scenario
    >>> program = compile_scenario(parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\n"))
    >>> outcome(run_in(FakeWorld(), program), 0.0).levels_placed
    2

    Raises:
        ValueError: ``loop`` was not made by :func:`run_in` (it has no collapse monitor or
            stability extension among its subscribers).
    """
    monitor = next((s for s in loop.subscribers if isinstance(s, CollapseMonitor)), None)
    stability = next((s for s in loop.subscribers if isinstance(s, Stability)), None)
    if monitor is None or stability is None:
        raise ValueError("outcome() reads a loop made by run_in(): this one has no collapse monitor or stability extension")
    structure = loop.structure
    placed = structure.placed
    motion = next((s for s in loop.subscribers if isinstance(s, PeakMotion)), None)
    # a run stopped at the step its collapse was decided in has that step's graph already
    final_graph = monitor.collapse_graph if monitor.graph_step == loop.step else None
    final_graph = final_graph or stability.graph(loop)
    ended = _time.perf_counter()
    return Outcome(
        scenario=loop.program.name,
        mode=loop.program.engine.mode,
        backend=loop.program.engine.backend,
        collapse=monitor.collapse,
        events=tuple(loop.events),
        final_graph=final_graph,
        collapse_graph=monitor.collapse_graph,
        displacement={r.id: float(d) for r, d in zip(placed, structure.displacements(placed))},
        drift=monitor.drift,
        kinetic_energy=structure.kinetic_energy(),
        levels_placed=max((a.level for a in loop.program.placements if a.id in structure.records), default=0),  # pulled out too
        bricks_placed=len(placed),
        unplaced=tuple(a.id for a in loop.program.placements if a.id not in structure.records),
        simulated_time=loop.now,
        wall_time=wall_time,
        steps=loop.step - loop.skipped,
        steps_skipped=loop.skipped,
        engine_time=loop.engine_time,
        after_collapse=0.0 if loop.stop_clock is None else ended - loop.stop_clock,
        certificate=monitor.certificate,
        certificate_time=monitor.certify_time,
        toppled=tuple(r.id for r in structure.toppled()),
        peak_tilt=None if motion is None else motion.tilt,
        peak_slip=None if motion is None else motion.slip,
        removed=tuple(r.id for r in structure.removed),
        stopped=loop.stopped,
        not_run=loop.not_run,
        collapse_threshold_mm=_round_mm(loop.program.collapse_threshold),
        margin=monitor.margin if loop.stopped is None else None,
    )
