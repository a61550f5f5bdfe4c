"""Frozen piles and the stack test: parts of the rigid-block problem, the watched bricks a pile
leans on, and a brick equilibrium held against the report's rule."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from stability._equilibrium import ContactPolygon, RigidBlock, connected_part, solve_equilibrium
from stackdsl import compile_scenario, parse_scenario
from stackdsl.bench.dominoes import domino_row
from stackdsl.runtime.run import run_program

UP = np.array([0.0, 0.0, 1.0])
BRICK = np.array([[-0.06, -0.012, 0.0], [0.06, -0.012, 0.0], [0.06, 0.012, 0.0], [-0.06, 0.012, 0.0]])


def _on(body: str, other: str, points: np.ndarray, z: float) -> ContactPolygon[str]:
    return ContactPolygon(body, other, points + [0.0, 0.0, z], UP, 0.5)


def test_each_part_of_a_rigid_block_problem_stands_or_falls_on_its_own():
    """Two stacks that touch only the ground: the whole stands exactly when each part does, and
    the part of a brick is its stack alone."""
    mass = 0.0106
    blocks = {
        "a": RigidBlock(mass, np.array([0.0, 0.0, 0.004])),
        "b": RigidBlock(mass, np.array([0.0, 0.0, 0.012])),
        "c": RigidBlock(mass, np.array([1.0, 0.0, 0.004])),
        "d": RigidBlock(mass, np.array([1.1, 0.0, 0.012])),  # its centre of mass 40 mm past c's end
    }
    contacts = [
        _on("a", "ground", BRICK, 0.0),
        _on("b", "a", BRICK, 0.008),
        _on("c", "ground", BRICK + [1.0, 0.0, 0.0], 0.0),
        _on("d", "c", np.array([[1.04, -0.012, 0], [1.06, -0.012, 0], [1.06, 0.012, 0], [1.04, 0.012, 0]]), 0.008),
    ]
    left, left_contacts = connected_part(blocks, contacts, {"b"})
    right, right_contacts = connected_part(blocks, contacts, {"c"})
    assert sorted(left) == ["a", "b"] and sorted(right) == ["c", "d"]
    assert len(left_contacts) == 2 and len(right_contacts) == 2
    assert solve_equilibrium(left, left_contacts).stands
    falls = solve_equilibrium(right, right_contacts)
    assert not falls.stands and falls.moving() <= right.keys()
    assert not solve_equilibrium(blocks, contacts).stands
    assert connected_part(blocks, contacts, {"ground"}) == ({}, [])  # a support is no part


@pytest.mark.slow
@pytest.mark.parametrize("setting", ["extension equilibrium", "extension report"])
def test_a_pile_frozen_leaning_on_a_watched_brick_is_not_woken_at_the_step_it_froze(setting):
    """The debris rule freezes the settled part of a pile leaning on a brick that still moves,
    as on a fixed support, and the stack watches that brick. The stack test must solve the
    pile on the same support: without it the equilibrium model woke 8 of 30 fallen dominoes at
    the very step they froze (63 wakes instead of 30)."""
    program = compile_scenario(parse_scenario(domino_row(30, setting), "dominoes.yaml"))
    outcome = run_program(program)
    frozen_at: dict[str, float] = {}
    churn = []
    for event in outcome.events:
        if event.kind == "freeze":
            frozen_at[event.brick] = event.time
        elif event.kind == "wake" and frozen_at.get(event.brick) == event.time:
            churn.append((event.brick, event.detail))
    assert len(outcome.toppled) == 30
    assert churn == []
    assert sum(e.kind == "wake" for e in outcome.events) == 30  # each domino once, by the chain


@pytest.mark.slow
def test_on_mujoco_a_fallen_domino_row_is_frozen_once_and_not_solved_again(monkeypatch):
    """On MuJoCo a fallen domino that one behind it leaned on before its pile froze fails the
    report's centre-of-mass rule; rigid-block equilibrium holds it. The rule used to wake its
    part (up to 105 bricks) or, once the pile's watched support was in the program, ask
    equilibrium of the growing part at every freeze of the row (171 programs). Now the rule
    wakes nothing (a freeze under a pile's edge that fails is undone alone), equilibrium is
    asked a few times (as the row's piles freeze: twice or four times, by when the blows are
    seen), and each domino is woken once by the chain's blows. (A watched edge
    domino that settles a millimetre may still wake the fallen row behind it, once: the pile
    leaned on it as on a fixed support.)"""
    pytest.importorskip("mujoco")
    from stability import _stack_test

    asked: list[int] = []
    solve = _stack_test.solve_equilibrium
    monkeypatch.setattr(_stack_test, "solve_equilibrium", lambda *a, **k: asked.append(len(a[0])) or solve(*a, **k))
    program = compile_scenario(parse_scenario(domino_row(120, "MuJoCo extension"), "dominoes.yaml"))
    outcome = run_program(program)
    wakes = [e.detail for e in outcome.events if e.kind == "wake"]
    assert len(outcome.toppled) == 120
    assert [w for w in wakes if "outside its support" in w and "not frozen after all" not in w] == []
    assert len(asked) <= 4, asked
    # d002 to d120 by the chain's blows, d001 by the pusher; one of them, at most, again by a
    # watched edge domino that settles (this machine's MuJoCo: d019 by d020 at 0.03 m/s)
    blows = Counter(e.brick for e in outcome.events if e.kind == "wake" and e.detail.startswith("impact of"))
    assert set(blows) == {f"d{i:03d}" for i in range(2, 121)}
    assert sum(blows.values()) - len(blows) <= 1, blows


ROW_50 = """stackdsl: 1
engine: {backend: mujoco}
brick_types: {finger: {size: [20 mm, 10 mm, 10 mm]}}
structure: {dominoes: {count: 20, spacing: 50 mm}}
timing: {interval: 0.1 s, settle: 3 s}
actions:
  - push: {target: {brick: D01, offset: [0, 0, 55 mm]}, direction: +x, speed: 1 m/s, distance: 15 mm, at: after level 1, pusher: finger}
expect: {toppled: all}
"""


def test_a_pile_whose_freeze_changes_a_held_dominos_load_is_asked_of_equilibrium():
    """A fallen domino frozen leaning on its neighbours, which equilibrium held though the
    report's centre-of-mass rule fails it, has its load changed when the pile beyond it
    freezes. The debris rule's check of the stack under that pile asked the rule alone, so
    every later pile of the row was refused: on MuJoCo 13 of these 20 dominoes stayed in the
    engine, at rest, from 3.4 s to the run's end at 5 s. It now asks equilibrium, as the stack
    test does, and each domino ends frozen soon after the chain has passed."""
    pytest.importorskip("mujoco")
    outcome = run_program(compile_scenario(parse_scenario(ROW_50, "row.yaml")))
    last = {e.brick: e for e in outcome.events if e.brick.startswith("D") and e.kind in ("freeze", "wake")}
    assert len(outcome.toppled) == 20
    assert sorted(b for b, e in last.items() if e.kind != "freeze") == []
    assert max(e.time for e in last.values()) < 3.5


def _pile_on_a_stack(frozen_overhang: float = 0.0):
    """A stack of two frozen bricks (1 on the ground 0, 2 on 1, shifted ``frozen_overhang`` m
    along x) and a pile of three resting on it (3 on 2, 4 on 3, 5 on 4 with its centre of
    mass 40 mm past 4's end): the debris rule, its fake stack and the pile's polygons."""
    from types import SimpleNamespace

    from stability._debris import Debris

    mass, level = 0.0106, 0.008
    x = {1: 0.0, 2: frozen_overhang, 3: frozen_overhang, 4: frozen_overhang, 5: frozen_overhang + 0.1}
    com = {b: np.array([x[b], 0.0, level * (b - 0.5)]) for b in x}
    rec = {b: SimpleNamespace(body=b, box=SimpleNamespace(mass=mass), com=com[b]) for b in x}

    def under(body: int, other: int) -> ContactPolygon[int]:
        below = x.get(other, x[body])  # the ground: under the whole brick
        lo, hi = max(x[body], below) - 0.06, min(x[body], below) + 0.06
        square = np.array([[lo, -0.012, 0.0], [hi, -0.012, 0.0], [hi, 0.012, 0.0], [lo, 0.012, 0.0]])
        return _on(body, other, square, level * (body - 1))

    remembered = [under(1, 0), under(2, 1)]
    stack = SimpleNamespace(
        config=SimpleNamespace(model="equilibrium", gravity=9.81),
        frozen={1: rec[1], 2: rec[2]},
        in_order=lambda: [rec[1], rec[2]],
        pose=lambda r: SimpleNamespace(position=r.com),
        engine=SimpleNamespace(pose=lambda body: SimpleNamespace(position=com[body])),
        frozen_contacts=lambda blocks: [c for c in remembered if c.other in blocks or c.other == 0],
    )
    debris = Debris(stack, None, None)  # the program of a pile with the stack needs no areas nor admission
    return debris, [rec[3], rec[4], rec[5]], {3: [under(3, 2)], 4: [under(4, 3)], 5: [under(5, 4)]}


def test_a_pile_solved_with_the_frozen_stack_is_trimmed_of_the_bricks_its_mechanism_moves():
    """The debris rule's program of a pile with every frozen brick free too: a pile whose top
    brick overhangs is solved again without it, and the part that stands is frozen with its
    contacts; a brick the pile's collapse would move among the frozen ones, or fewer than two
    left, leave the pile to the rule that solves it against the frozen bricks as supports."""
    debris, pile, polygons = _pile_on_a_stack()
    found = debris._with_stack(pile, polygons)
    assert found is not None
    kept, kept_polygons = found
    assert [m.body for m in kept] == [3, 4]
    assert sorted(kept_polygons) == [3, 4] and all(c.other != 5 for cs in kept_polygons.values() for c in cs)

    leaning, pile, polygons = _pile_on_a_stack(frozen_overhang=0.07)  # the frozen brick 2 tips off 1 with it
    assert leaning._with_stack(pile, polygons) is None
    debris, pile, polygons = _pile_on_a_stack()
    assert debris._with_stack(pile[:1], {3: polygons[3]}) is None  # one brick on a stack of two: solved alone


PYRAMID_PULLED = """stackdsl: 1
structure: {pyramid: {base: 3, joint: 1 mm}}
timing: {interval: 0.5 s, settle: 1 s}
actions:
  - remove: {brick: L01.3, at: after level 3, speed: 30 mm/s, direction: +x}
expect: {stands: true}
"""


def test_a_pair_frozen_as_a_pile_names_what_the_pair_touches_as_the_pair():
    """A flat pyramid of 3 with 1 mm joints, its end base brick pulled out outward: L02.2 over it
    tilts onto L01.2 with L03.1 on it, and the debris rule freezes the two together. L03.1 also
    lies on L02.1, 1 mm from L02.2. The asker's event used to read "leaning on L01.2, L02.1",
    naming as its own a body only its partner touches; a pair from the debris rule now says what
    the two touch together, as a larger pile does."""
    outcome = run_program(compile_scenario(parse_scenario(PYRAMID_PULLED, "pyramid.yaml")))
    late = [e for e in outcome.events if e.kind == "freeze" and e.time > 3.5 and e.brick in ("L02.2", "L03.1")]
    assert outcome.collapse is None and late, outcome.events
    reasons = {e.brick: e.detail for e in late}
    assert "one of 2 touching bricks frozen together; together they touch L01.2, L02.1" in reasons["L02.2"], reasons
    assert "leaning on" not in reasons["L02.2"], reasons


@pytest.mark.slow  # a 12-level tower's fall (the suite's budget: its scenario runs in it already)
def test_a_settling_heap_is_searched_once_a_step_whichever_brick_asks(monkeypatch):
    """The bricks of a heap at rest ask the debris rule in turn, in the same step, on the same
    stack: the heap, and the part of it that has settled, are the same from any of them, and
    are gathered once (the 18-level Jenga tower's fallen top searched its heap 111 times, once
    for each brick refused; 33 searches now), with the same verdicts."""
    from stability import _debris

    searched: list[tuple[float, int, frozenset[int]]] = []
    part = _debris.Debris._settled_part

    def counted(self, rec, contacts, time):  # type: ignore[no-untyped-def]
        reached, found = part(self, rec, contacts, time)
        searched.append((time, self.stack.version, frozenset(reached)))
        return reached, found

    monkeypatch.setattr(_debris.Debris, "_settled_part", counted)
    outcome = run_program(compile_scenario(parse_scenario(open("scenarios/jenga_falls.yaml").read(), "jenga_falls.yaml")))
    assert outcome.collapse is not None and outcome.collapse.level == 12
    # the heap was asked of more than once while part of it still moved (4 or 6 times: how the
    # heap settles moves with round-off, OpenBLAS's AVX-512 kernels against its Haswell ones)
    assert len(searched) > 3
    reached = Counter((time, version, brick) for time, version, bricks in searched for brick in bricks)
    assert max(reached.values()) == 1, [k for k, n in reached.items() if n > 1][:5]


def test_a_pile_refused_again_and_again_waits_twice_as_long_each_time(monkeypatch):
    """The same bricks refused by the debris rule k times in a row are asked again only
    2 ** (k - 1) rest durations after the last refusal (at most 16), not every rest duration: a
    creeping pile of 40 fallen bricks was solved 19 times in 1 s. Other bricks are not kept
    waiting, and a pile that is frozen starts again from one rest duration."""
    from types import SimpleNamespace

    from stability import _debris

    config = SimpleNamespace(rest_duration=0.05, model="equilibrium")
    stack = SimpleNamespace(version=1, config=config, attempt=lambda m, contacts, time: (m.body, time))
    bricks = [SimpleNamespace(body=b, clock=SimpleNamespace(since=0.0, fallen=True), failed=None) for b in (3, 4, 5)]
    pile = list(bricks)
    stands = [False]
    solved: list[float] = []

    def admissible(self, group, polygons, earlier):  # type: ignore[no-untyped-def]
        solved.append(round(now[0], 3))
        return (group, polygons, {}, []) if stands[0] else ([], {}, {}, [])

    monkeypatch.setattr(_debris.Debris, "_pile", lambda self, rec, contacts, time: list(pile))
    monkeypatch.setattr(_debris.Debris, "_with_stack", lambda self, group, polygons: None)
    monkeypatch.setattr(_debris.Debris, "_earlier", lambda self, group, contacts: [])
    monkeypatch.setattr(_debris.Debris, "_admissible", admissible)
    areas = SimpleNamespace(polygons=lambda m, around, skip: [], around=lambda m, contacts: {})
    debris = _debris.Debris(stack, areas, None)  # type: ignore[arg-type]
    now = [0.0]
    for step in range(0, 3001, 5):  # 3 s of steps of 5 ms, a new rest clock each step: a creeping pile
        now[0] = step / 1000
        for b in pile:
            b.clock.since = now[0]
        debris.admit(pile[0], {}, now[0])
    assert solved == [0.0, 0.05, 0.15, 0.35, 0.75, 1.55, 2.35], solved  # 1, 2, 4, 8, 16, 16 rest durations

    solved.clear()
    pile = bricks[:2]  # another pile: asked at once
    now[0] = 2.4
    debris.admit(pile[0], {}, now[0])
    assert solved == [2.4]

    debris.admission = SimpleNamespace(freeze_group=lambda *a, **k: [])  # type: ignore[assignment]
    pile, stands[0] = list(bricks), True
    stack.ordered = lambda held: list(held)
    stack.bodies = {}
    for t in (3.2, 3.25):  # frozen at 3.2 (16 rest durations after 2.35 have passed): no longer waiting
        now[0] = t
        debris.admit(pile[0], {}, t)
    assert solved[1:] == [3.2, 3.25]
