"""Load paths and the report's propagated loads: sufficient tests of rigid-block equilibrium,
never wrong when they say 'stands'."""

from __future__ import annotations

import numpy as np
import pytest
from shapely import MultiPoint
from shapely.geometry import box

from stability import ContactArea, ContactPolygon, LoadNode, RigidBlock, load_path, proven, solve_equilibrium, support_piece
from stability._load import propagate_fast
from stability._load_path import loads_balance, share_region
from stackdsl.bench.bench import Scene, program_for
from stackdsl.runtime.run import RunOptions, run_program

HALF = np.array([0.06, 0.012, 0.004])
UP = np.array([0.0, 0.0, 1.0])


def _overlap(a: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """Corners (4, 3) of the overlap of two axis-aligned brick footprints at b's top, or None."""
    x0, x1 = max(a[0] - HALF[0], b[0] - HALF[0]), min(a[0] + HALF[0], b[0] + HALF[0])
    y0, y1 = max(a[1] - HALF[1], b[1] - HALF[1]), min(a[1] + HALF[1], b[1] + HALF[1])
    if x1 - x0 < 1e-6 or y1 - y0 < 1e-6:
        return None
    z = b[2] + HALF[2]
    return np.array([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]])


def _random_stack(rng: np.random.Generator, levels: int) -> tuple[list[np.ndarray], list[ContactPolygon[int]]]:
    """Bricks along x, level by level, one or two a level, each over the level below."""
    centres: list[np.ndarray] = []
    contacts: list[ContactPolygon[int]] = []
    below: list[int] = []
    for level in range(levels):
        z = HALF[2] * (2 * level + 1)
        here = []
        for _ in range(int(rng.integers(1, 3))):
            anchor = centres[below[int(rng.integers(len(below)))]] if below else np.zeros(3)
            c = np.array([anchor[0] + rng.uniform(-0.07, 0.07), anchor[1] + rng.uniform(-0.02, 0.02), z])
            if any(abs(c[1] - centres[j][1]) < 2 * HALF[1] and abs(c[0] - centres[j][0]) < 2 * HALF[0] for j in here):
                continue  # the bricks of a level do not overlap
            k = len(centres)
            centres.append(c)
            here.append(k)
            if not below:
                ring = np.array([[c[0] - HALF[0], c[1] - HALF[1], 0], [c[0] + HALF[0], c[1] - HALF[1], 0]])
                ring = np.vstack([ring, ring[::-1] + [0, 2 * HALF[1], 0]])
                contacts.append(ContactPolygon(k, -1, ring, UP, 0.5))
            for j in below:
                overlap = _overlap(c, centres[j])
                if overlap is not None:
                    contacts.append(ContactPolygon(k, j, overlap, UP, 0.5))
        below = here
    return centres, contacts


def _all_proven(centres: list[np.ndarray], contacts: list[ContactPolygon[int]]) -> bool:
    paths: dict[int, object] = {}
    for k, c in enumerate(centres):
        pieces = [support_piece(p.points, paths.get(p.other), ground=p.other == -1) for p in contacts if p.body == k]
        paths[k] = load_path([p for p in pieces if p is not None])
        if not proven(c, paths[k]):  # type: ignore[arg-type]
            return False
    return True


@pytest.mark.slow
def test_a_proven_stack_stands_by_the_equilibrium_program() -> None:
    rng = np.random.default_rng(7)
    outcomes = {True: 0, False: 0}
    for _ in range(300):
        centres, contacts = _random_stack(rng, int(rng.integers(2, 6)))
        blocks = {k: RigidBlock(0.0106, c) for k, c in enumerate(centres)}
        stands = solve_equilibrium(blocks, contacts).stands
        if _all_proven(centres, contacts):
            assert stands, "a load path is a solution of the program: it cannot be wrong"
        outcomes[stands] += 1
    assert outcomes[True] > 50 and outcomes[False] > 50  # both kinds were drawn


def _loads_balance(centres: list[np.ndarray], contacts: list[ContactPolygon[int]]) -> bool:
    """The report's loads propagated down the stack, checked as forces."""
    nodes, regions = {}, {}
    for k, c in enumerate(centres):
        mine = [p for p in contacts if p.body == k]
        areas = {
            p.other: ContactArea(MultiPoint(p.points[:, :2].tolist()).convex_hull, float(p.points[0, 2]), UP, True) for p in mine
        }
        nodes[k] = LoadNode(0.0106, c, areas)
        regions[k] = {p.other: r for p in mine if (r := share_region([p.points])) is not None}
    return loads_balance(propagate_fast(nodes), regions)


@pytest.mark.slow
def test_stacks_the_propagated_loads_balance_stand_by_the_program_and_include_unproven_ones() -> None:
    rng = np.random.default_rng(11)
    balanced = {True: 0, False: 0}  # of the balanced stacks: proven by load paths or not
    for _ in range(300):
        centres, contacts = _random_stack(rng, int(rng.integers(2, 6)))
        if _loads_balance(centres, contacts):
            blocks = {k: RigidBlock(0.0106, c) for k, c in enumerate(centres)}
            assert solve_equilibrium(blocks, contacts).stands, "the loads are a solution of the program"
            balanced[_all_proven(centres, contacts)] += 1
    assert balanced[False] > 10 and balanced[True] > 10  # it proves stacks the load paths cannot


def test_the_propagated_loads_fail_where_a_share_would_pull_or_leave_its_contact() -> None:
    """A single-file stack of n bricks shifted 13 mm a level: the bricks above brick 0 have
    their centre of mass n x 6.5 mm from its centre, inside its top face (60 mm) for n <= 9.
    With one support a brick, the loads are the only solution: 9 bricks stand, 10 fall."""
    shift = 0.013
    for n, balances in ((9, True), (10, False)):
        centres = [np.array([k * shift, 0.0, HALF[2] * (2 * k + 1)]) for k in range(n)]
        ground = np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0], [0.06, 0.012, 0], [-0.06, 0.012, 0]])
        contacts = [ContactPolygon(0, -1, ground, UP, 0.5)]
        contacts += [ContactPolygon(k, k - 1, _overlap(centres[k], centres[k - 1]), UP, 0.5) for k in range(1, n)]  # type: ignore[arg-type]
        assert _loads_balance(centres, contacts) is balances


def test_a_single_file_slant_stack_is_proven_while_each_brick_is_over_the_first_ones_path() -> None:
    """Shift s a level: the load path of brick k reaches from (k - 1) s - 60 mm to 60 mm, so the
    test proves brick k while (k - 1) s <= 60 mm; beyond, only the full program can tell."""
    shift = 0.013
    centres = [np.array([k * shift, 0.0, HALF[2] * (2 * k + 1)]) for k in range(8)]
    contacts = [ContactPolygon(0, -1, np.array([[-0.06, -0.012, 0], [0.06, -0.012, 0], [0.06, 0.012, 0]]), UP, 0.5)]
    contacts += [ContactPolygon(k, k - 1, _overlap(centres[k], centres[k - 1]), UP, 0.5) for k in range(1, 8)]  # type: ignore[arg-type]
    provable = [_all_proven(centres[: n + 1], contacts[: n + 1]) for n in range(8)]
    assert provable == [k * shift <= 0.06 for k in range(8)]


def test_proven_counts_the_edge_and_nothing_beyond() -> None:
    path = box(-0.06, -0.012, 0.06, 0.012)
    assert proven([0.06, 0.0, 0.0], path) and not proven([0.0601, 0.0, 0.0], path) and not proven([0, 0, 0], None)


def _count_solves(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    import stability._stack_test as extension

    calls: list[int] = []
    real = extension.solve_equilibrium

    def counting(*args, **kwargs):  # type: ignore[no-untyped-def]
        calls.append(len(args[0]))
        return real(*args, **kwargs)

    monkeypatch.setattr(extension, "solve_equilibrium", counting)
    return calls


def test_an_upright_tower_needs_no_equilibrium_program(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _count_solves(monkeypatch)
    outcome = run_program(
        program_for(Scene("upright", 12, 12, "tower: {levels: 12}", None), "extension equilibrium"), RunOptions()
    )
    assert outcome.collapse is None and calls == []


def test_a_slant_stack_falls_at_its_closed_form_without_an_equilibrium_program(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = _count_solves(monkeypatch)
    scene = Scene("single file", 13, 12, "tower: {levels: 12, bricks_per_layer: 1, turn: 0, shift: 13 mm}", 10)
    outcome = run_program(program_for(scene, "extension equilibrium"), RunOptions(stop_at_collapse=True))
    assert outcome.collapse is not None and outcome.collapse.level == 10
    # beyond brick 5 the upper bricks reach past the lower bricks' load paths, but the propagated
    # loads balance the stack until it falls, and then the nine bricks above the first turn out
    # about its end (stability._cut): no program is solved
    assert calls == []


def test_the_report_models_stack_test_propagates_nothing_while_every_brick_is_over_its_path(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import stability._stack_test as stack_test

    propagated: list[int] = []
    real = stack_test.propagate_fast

    def counting(nodes, memo=None):  # type: ignore[no-untyped-def]
        propagated.append(len(nodes))
        return real(nodes, memo)

    monkeypatch.setattr(stack_test, "propagate_fast", counting)
    tower = program_for(Scene("upright", 12, 12, "tower: {levels: 12}", None), "extension report")
    assert run_program(tower, RunOptions()).collapse is None
    assert propagated == []  # it was one propagation down the frozen stack at every freeze
    scene = Scene("single file", 13, 12, "tower: {levels: 12, bricks_per_layer: 1, turn: 0, shift: 13 mm}", 10)
    outcome = run_program(program_for(scene, "extension report"), RunOptions(stop_at_collapse=True))
    assert outcome.collapse is not None and outcome.collapse.level == 10
    assert propagated, "beyond the first bricks' load paths the report's rule is asked again"


def test_the_report_model_asks_no_equilibrium_program_when_a_part_provably_turns_out(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    calls = _count_solves(monkeypatch)
    scene = Scene("single file", 9, 16, "tower: {levels: 16, bricks_per_layer: 1, turn: 0, shift: 9 mm}", 14)
    outcome = run_program(program_for(scene, "extension report"), RunOptions(stop_at_collapse=True))
    assert outcome.collapse is not None and outcome.collapse.level == 14
    # the report's rule fails at the collapse, and the bricks above it turn out about its end
    # (stability._cut): that proof comes before the program, which it made unnecessary
    assert calls == []
