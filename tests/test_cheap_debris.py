"""Fallen bricks settle as cheaper bodies once a collapse is decided: pybullet re-creates them
as rigid bodies under the same ids, MuJoCo drops its contacts' impratio; the verdict and the
collapse graph are those of the run without, and a scene that judges what stays after a
collapse keeps its bodies as they were."""

from __future__ import annotations

import pytest

from stability import Pose
from stackdsl import compile_scenario, parse_scenario
from stackdsl.compile.compiler import _spec
from stackdsl.engines.pybullet.settings import PyBulletSettings
from stackdsl.engines.pybullet.world import pybullet_world
from stackdsl.runtime.collapse import CollapseMonitor
from stackdsl.runtime.run import RunOptions, run_in
from stackdsl.runtime.subscribers import CheapDebris

SINGLE_FILE = "stackdsl: 1\nstructure: {tower: {levels: 12, bricks_per_layer: 1, turn: 0, shift: 13 mm}}\n"


def test_the_world_re_creates_a_moving_multibody_as_a_rigid_body_under_its_id():
    spec = _spec(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n"), "kapla")
    settings = PyBulletSettings(mode="extension", timestep=1 / 240, solver_iterations=50)
    with pybullet_world(settings, 0.5, 0.0) as world:
        moving = world.create(spec, Pose.from_euler([0.0, 0.0, 0.2], yaw=0.3))
        frozen = world.create(spec, Pose.from_euler([0.5, 0.0, 0.004]))
        world.set_frozen(frozen, True, spec.mass)
        thrown = world.create(spec, Pose.from_euler([-0.5, 0.0, 0.2]), projectile=True)
        world.throw(moving, (0.1, 0.0, 0.0), None)
        world.step()
        pose, (linear, angular) = world.pose(moving), world.velocity(moving)
        assert world.make_debris([moving, frozen, thrown]) == [moving]  # neither the frozen nor the rigid one
        assert world.pose(moving).position == pytest.approx(pose.position)
        assert world.pose(moving).orientation == pytest.approx(pose.orientation)
        assert world.velocity(moving)[0] == pytest.approx(linear) and world.velocity(moving)[1] == pytest.approx(angular)
        assert world.make_debris([moving]) == []  # rigid now
        for _ in range(240):
            world.step()
        assert world.pose(moving).position[2] == pytest.approx(0.004, abs=2e-4)  # it landed on the ground
        assert world.speeds(moving)[0] < 1e-3
        world.set_frozen(frozen, False, spec.mass)
        assert world.make_debris([frozen]) == [frozen]  # woken, it moves again


def _run(text: str, options: RunOptions | None = None):
    options = options or RunOptions()
    program = compile_scenario(parse_scenario(text, "slant.yaml"))
    with pybullet_world(program.engine, program.ground_friction, program.ground_restitution) as world:
        loop = run_in(world, program, options)
    rigid = [s for s in loop.subscribers if isinstance(s, CheapDebris)]
    return loop, rigid[0] if rigid else None


def test_fallen_bricks_become_rigid_when_the_collapse_is_decided_and_the_verdict_is_unchanged():
    rigid_loop, rigid = _run(SINGLE_FILE)
    loop, none = _run(SINGLE_FILE, RunOptions(cheap_debris=False))
    assert none is None and rigid is not None and rigid.made
    collapse = next(s for s in rigid_loop.subscribers if isinstance(s, CollapseMonitor))
    before = next(s for s in loop.subscribers if isinstance(s, CollapseMonitor))
    assert collapse.collapse == before.collapse and collapse.collapse.level == 10
    assert collapse.collapse_graph == before.collapse_graph
    decided = collapse.collapse.decided
    assert [e for e in rigid_loop.events if e.time <= decided] == [e for e in loop.events if e.time <= decided]
    last: dict[str, str] = {}  # each brick's last freeze or wake by the decision
    for e in rigid_loop.events:
        if e.time <= decided and e.kind in ("place", "freeze", "wake"):
            last[e.brick] = e.kind
    moving = {name for name, kind in last.items() if kind != "freeze"}
    records = {r.body: r.id for r in rigid_loop.structure.records.values()}
    assert {records[b] for b in rigid.made} == moving and len(moving) >= 3


@pytest.mark.slow
def test_a_scene_judged_after_its_collapse_keeps_its_multibodies():
    impact = "impacts: [{target: {level: 12, side: +x}, speed: 3, at: after level 12}]\n"
    tower = "stackdsl: 1\nstructure: {tower: {levels: 12}}\n" + impact
    _, rigid = _run(tower + "expect: {stays: 1-10}\n")
    assert rigid is None
    _, rigid = _run(tower)
    assert rigid is not None
    _, unused = _run(SINGLE_FILE, RunOptions(stop_at_collapse=False))
    assert unused is not None and unused.made is None  # placing goes on after the collapse: no settle yet


def test_on_mujoco_the_debris_settles_at_the_default_impratio_and_the_verdict_is_unchanged():
    """A single-file stack (13 mm shifts) falls at the same level either way; the
    moving bricks are made cheaper when the collapse is decided, and only then."""
    pytest.importorskip("mujoco")
    from stackdsl.engines.mujoco.world import MuJoCoWorld
    from stackdsl.runtime.run import world_for

    program = compile_scenario(parse_scenario(SINGLE_FILE + "engine: {backend: mujoco}\n", "slant.yaml"))
    outcomes = {}
    for cheap in (True, False):
        with world_for(program) as world:
            assert isinstance(world, MuJoCoWorld) and world._ready()[0].opt.impratio == 10.0
            loop = run_in(world, program, RunOptions(cheap_debris=cheap))
            made = [s.made for s in loop.subscribers if isinstance(s, CheapDebris)]
            assert world._ready()[0].opt.impratio == (1.0 if cheap else 10.0)
        assert bool(made) == cheap and (not cheap or len(made[0]) >= 3)
        outcomes[cheap] = next(s for s in loop.subscribers if isinstance(s, CollapseMonitor)).collapse
    assert outcomes[True] is not None and outcomes[True].level == outcomes[False].level == 10


def test_the_bricks_of_a_ride_that_tips_over_fall_as_debris_and_the_verdict_holds():
    """The second pull of ``scenarios/jenga_falls.yaml`` leaves levels 6-12 on one block at its
    edge, and statics proved that they fall without the pulled block: their ride on it ends
    (its proof fails as it tips, or the pull ends), and its bricks wake falling
    (``StabilityEvent.falling``). They are made debris as they wake (pybullet's
    rigid bodies: a falling column of 40 costs about half a step), although the scene judges what
    stays after the collapse and the rigid rule is off; the collapse and levels 1-3 hold."""
    from pathlib import Path

    from stackdsl import evaluate
    from stackdsl.runtime.run import outcome

    path = Path(__file__).resolve().parents[1] / "scenarios" / "jenga_falls.yaml"
    scenario = parse_scenario(path.read_text(), "jenga_falls.yaml")
    program = compile_scenario(scenario)
    made: list[int] = []
    with pybullet_world(program.engine, program.ground_friction, program.ground_restitution) as world:
        make = world.make_debris

        def recorded(bodies):
            done = make(bodies)
            made.extend(done)
            return done

        world.make_debris = recorded  # type: ignore[method-assign]
        loop = run_in(world, program, RunOptions())
    assert not any(isinstance(s, CheapDebris) for s in loop.subscribers)  # the rigid rule is off
    ended = {e.time for e in loop.events if e.kind == "wake" and e.detail.startswith("rode the pull")}
    tipped = {e.brick for e in loop.events if e.kind == "wake" and e.time in ended}  # with what rests on each
    records = {r.body: r.id for r in loop.structure.records.values()}
    assert len(tipped) >= 15 and {records[b] for b in made} == tipped
    verdicts = evaluate(scenario.expect, outcome(loop, 0.0), program.collapse_threshold)
    assert [v.name for v in verdicts] == ["collapse", "stays"] and all(v.passed for v in verdicts), verdicts
