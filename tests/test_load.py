"""Centre of mass above and mass above (report 3.3.5-3.3.6, eq. 1-11) on hand-built graphs."""

import numpy as np
import pytest
from shapely.geometry import Point, box

from stability import ContactArea, LoadNode, propagate, split_load, torque_split

UP = np.array([0.0, 0.0, 1.0])
GROUND = 0


def area(x0, y0, x1, y1, z=0.0):
    return ContactArea(box(x0, y0, x1, y1), z, UP, True)


def test_single_branch_equations_1_and_2():
    # Three bricks in a column, each shifted: COM above is the mass-weighted mean (eq. 1),
    # mass above the sum (eq. 2).
    m = [0.01, 0.02, 0.03]
    x = [0.0, 0.01, 0.03]
    nodes = {
        1: LoadNode(m[0], np.array([x[0], 0, 0.004]), {GROUND: area(-0.06, -0.01, 0.06, 0.01)}),
        2: LoadNode(m[1], np.array([x[1], 0, 0.012]), {1: area(-0.05, -0.01, 0.06, 0.01, 0.008)}),
        3: LoadNode(m[2], np.array([x[2], 0, 0.020]), {2: area(-0.03, -0.01, 0.07, 0.01, 0.016)}),
    }
    loads = propagate(nodes)
    assert loads[3].mass_above == pytest.approx(m[2])
    assert loads[2].com_above[0] == pytest.approx((m[1] * x[1] + m[2] * x[2]) / (m[1] + m[2]))
    assert loads[1].mass_above == pytest.approx(sum(m))
    assert loads[1].com_above[0] == pytest.approx(np.dot(m, x) / sum(m))
    assert loads[1].shares == {GROUND: pytest.approx(1.0)}


def test_split_branching_adds_every_brick_resting_on_one():
    nodes = {
        1: LoadNode(0.01, np.array([0, 0, 0.004]), {GROUND: area(-0.06, -0.06, 0.06, 0.06)}),
        2: LoadNode(0.01, np.array([-0.03, 0, 0.012]), {1: area(-0.05, -0.01, -0.01, 0.01, 0.008)}),
        3: LoadNode(0.02, np.array([0.03, 0, 0.012]), {1: area(0.01, -0.01, 0.05, 0.01, 0.008)}),
    }
    load = propagate(nodes)[1]
    assert load.mass_above == pytest.approx(0.04)
    assert load.com_above[0] == pytest.approx((0.01 * -0.03 + 0.02 * 0.03) / 0.04)


def test_merging_one_support_carries_all_when_the_com_lies_over_it_beyond_both_centres():
    # report 3.3.6, first case: the centre of mass over support 2, past its centre (0.03)
    supports = {1: area(-0.06, -0.01, -0.02, 0.01), 2: area(0.0, -0.01, 0.06, 0.01)}
    split = split_load(np.array([0.045, 0.0, 0.01]), 0.05, supports)
    assert split[2][0] == pytest.approx(0.05)
    assert split[1][0] == 0.0
    assert split[2][1][:2] == pytest.approx([0.045, 0.0])


@pytest.mark.parametrize("joint", [-0.06, 0.0, 0.0417])
def test_a_centre_over_a_joint_puts_half_on_each_side_whichever_side_it_lies(joint):
    # A wall's brick centred over the joint between two bricks below: its two contact areas
    # meet under its centre of mass. 0.01 mm either way must not move the load to one side.
    supports = {1: area(joint - 0.06, -0.012, joint, 0.012), 2: area(joint, -0.012, joint + 0.06, 0.012)}
    for dx in (-1e-5, 0.0, 1e-5):
        split = split_load(np.array([joint + dx, 0.0, 0.02]), 0.01, supports)
        assert split[1][0] == pytest.approx(0.005, abs=1e-5), dx
        assert split[2][0] == pytest.approx(0.005, abs=1e-5), dx


@pytest.mark.slow
@pytest.mark.parametrize(
    "supports",
    [
        {1: area(-0.06, -0.01, -0.02, 0.01), 2: area(0.0, -0.01, 0.06, 0.01)},
        {1: area(-0.06, -0.012, 0.0, 0.012), 2: area(0.0, -0.012, 0.02, 0.012), 3: area(0.02, -0.012, 0.06, 0.012)},
    ],
)
def test_shares_are_continuous_in_the_centre_of_mass(supports):
    # A centre of mass swept across the supports in 0.1 mm steps: no share jumps by more than
    # what the step itself moves it (the report's all-on-one rule jumped by the whole load).
    previous = None
    for x in np.arange(-0.059, 0.059, 1e-4):
        split = split_load(np.array([x, 0.0, 0.02]), 1.0, supports)
        shares = np.array([split[s][0] for s in supports])
        assert shares.sum() == pytest.approx(1.0)
        if previous is not None:
            assert np.abs(shares - previous).max() < 0.01, x
        previous = shares


@pytest.mark.parametrize("x", [-0.02, 0.0, 0.015, 0.029])
def test_merging_two_supports_is_the_lever_rule(x):
    # A beam on two narrow supports at -0.03 and +0.03: the share of the right one is
    # m (x - x_left) / (x_right - x_left), and the shares sum to the load.
    supports = {1: area(-0.031, -0.01, -0.029, 0.01), 2: area(0.029, -0.01, 0.031, 0.01)}
    split = split_load(np.array([x, 0.0, 0.01]), 1.0, supports)
    assert split[2][0] == pytest.approx((x + 0.03) / 0.06, abs=1e-9)
    assert split[1][0] + split[2][0] == pytest.approx(1.0)


def test_torque_split_equations_4_to_9_with_a_vertical_offset():
    # Heights do not matter: only horizontal lever arms enter (gravity is vertical).
    com, pivot, at = np.array([0.02, 0.0, 0.5]), np.array([0.0, 0.0, 0.0]), np.array([0.08, 0.0, -0.3])
    assert torque_split(com, 2.0, at, pivot) == pytest.approx(2.0 * 0.02 / 0.08)


def test_two_supports_shares_pass_through_the_centre_of_mass():
    # The shares' resultant passes through the centre of mass above (moment balance),
    # also when the COM is off the line joining the two contact-area centres.
    supports = {1: area(-0.06, -0.012, -0.036, 0.012), 2: area(0.036, -0.012, 0.06, 0.012)}
    com = np.array([0.01, 0.005, 0.02])
    split = split_load(com, 1.0, supports)
    resultant = sum(m * p[:2] for m, p in split.values())
    assert sum(m for m, _ in split.values()) == pytest.approx(1.0)
    assert resultant == pytest.approx(com[:2])


def test_more_than_two_supports_take_equal_shares():
    """The report's rule, where equal shares at points of the contacts balance the load: its
    centre of mass over none of them, within reach of their points' mean."""
    supports = {k: area(x - 0.005, -0.01, x + 0.005, 0.01) for k, x in [(1, -0.05), (2, 0.01), (3, 0.05)]}
    split = split_load(np.array([0.0, 0.0, 0.02]), 0.3, supports)
    assert [split[k][0] for k in (1, 2, 3)] == pytest.approx([0.1, 0.1, 0.1])


def test_four_stack_loads_stay_centred():
    # Level 2 rests on two level-1 bricks: each carries half of it at its own centre line.
    l1 = {1: -0.048, 2: 0.048}
    nodes = {b: LoadNode(0.01, np.array([x, 0, 0.004]), {GROUND: area(x - 0.012, -0.06, x + 0.012, 0.06)}) for b, x in l1.items()}
    nodes[3] = LoadNode(
        0.01, np.array([0, 0.048, 0.012]), {b: area(x - 0.012, 0.036, x + 0.012, 0.06, 0.008) for b, x in l1.items()}
    )
    loads = propagate(nodes)
    assert loads[3].shares == {1: pytest.approx(0.5), 2: pytest.approx(0.5)}
    assert loads[2].mass_above == pytest.approx(0.015)
    assert loads[2].com_above[0] == pytest.approx(0.048)


@pytest.mark.parametrize("x", [-0.2, -0.05, 0.0, 0.03, 0.2])
@pytest.mark.parametrize("y", [-0.1, 0.0, 0.02, 0.1])
def test_two_supports_shares_always_sum_to_the_load(x, y):
    """Wherever the centre of mass lies (over the supports, between them, off their line, beyond
    both: a failing brick), the shares pass on the whole load, no more: a fallen brick on the
    ground and a brick read shares of 1.0 each."""
    supports = {1: area(-0.06, -0.012, -0.05, 0.012), 2: area(0.05, -0.03, 0.06, -0.02)}
    shares = split_load(np.array([x, y, 0.1]), 0.5, supports)
    assert sum(m for m, _ in shares.values()) == pytest.approx(0.5)
    assert all(0.0 <= m <= 0.5 for m, _ in shares.values())


@pytest.mark.parametrize("x", [0.0286, -0.05, 0.11, 0.021])
def test_more_than_two_supports_share_a_load_in_moment_balance(x):
    """A plank on three piers (contacts 40 mm long at -120, 0 and 120 mm), its load's centre of
    mass at ``x``: equal thirds at points inside the contacts put the resultant at 20 mm at most
    from the middle, so a load 28.6 mm out read a third each, out of balance. The shares sum to
    the load, none is negative, and their resultant passes through the centre of mass."""
    supports = {k: area(c - 0.02, -0.012, c + 0.02, 0.012) for k, c in [(1, -0.12), (2, 0.0), (3, 0.12)]}
    split = split_load(np.array([x, 0.0, 0.1]), 0.6, supports)
    masses = np.array([split[k][0] for k in (1, 2, 3)])
    points = np.array([split[k][1] for k in (1, 2, 3)])
    assert masses.sum() == pytest.approx(0.6) and (masses >= 0).all()
    assert (masses @ points[:, :2]) / 0.6 == pytest.approx([x, 0.0], abs=1e-9)
    for k in (1, 2, 3):  # each share acts where its support touches
        assert supports[k].polygon.buffer(1e-9).contains(Point(points[k - 1][:2]))


def test_two_supports_with_one_centre_split_the_load():
    # two bricks crossed at one centre carry a third: no line joins the two centres
    supports = {1: area(-0.06, -0.012, 0.06, 0.012), 2: area(-0.012, -0.06, 0.012, 0.06)}
    split = split_load(np.array([0.005, 0.003, 0.01]), 0.04, supports)
    assert sum(m for m, _ in split.values()) == pytest.approx(0.04)
    resultant = sum(m * p[:2] for m, p in split.values()) / 0.04
    assert resultant == pytest.approx([0.005, 0.003])


def _random_dag(rng, n):
    """Nodes 0..n-1 in a random order, each resting on up to three others (mostly later ones: out of
    order), with now and then a cycle."""
    order = rng.permutation(n).tolist()
    above = {b: [] for b in order}
    for a in order:
        for s in rng.choice(n, size=min(n, int(rng.integers(0, 4))), replace=False).tolist():
            if s != a and (a < s or rng.random() < 0.02):
                above[s].append(a)
    return above


def test_the_loads_order_is_graphlibs_node_for_node():
    # the loads are summed in this order: the same order, so the same sums to the bit
    import graphlib

    from stability._load import _static_order

    rng, cycles = np.random.default_rng(7), 0
    for _ in range(400):
        above = _random_dag(rng, int(rng.integers(1, 25)))
        try:
            expected = list(graphlib.TopologicalSorter(above).static_order())
        except graphlib.CycleError:
            cycles += 1
            with pytest.raises(graphlib.CycleError):
                _static_order(above)
            continue
        assert _static_order(above) == expected
    assert cycles > 0  # the cycles were tried too


def test_a_memo_of_splits_gives_the_loads_without_it_and_splits_a_changed_node_again():
    from stability._load import propagate_fast

    nodes = {
        1: LoadNode(0.01, np.array([0, 0, 0.004]), {GROUND: area(-0.06, -0.06, 0.06, 0.06)}),
        2: LoadNode(0.01, np.array([-0.03, 0, 0.012]), {1: area(-0.05, -0.01, -0.01, 0.01, 0.008)}),
        3: LoadNode(0.02, np.array([0.03, 0, 0.012]), {1: area(0.01, -0.01, 0.05, 0.01, 0.008)}),
    }
    memo: dict = {}
    assert propagate_fast(nodes, memo) == propagate_fast(nodes)
    assert propagate_fast(nodes, memo) == propagate_fast(nodes)  # from the memo
    moved = {**nodes, 3: LoadNode(0.02, np.array([0.04, 0, 0.012]), nodes[3].supports)}
    assert propagate_fast(moved, memo) == propagate_fast(moved)  # brick 3 and the load on 1 split again
    assert propagate_fast(moved, memo)[1] != propagate_fast(nodes)[1]


def wall(levels, heavier=0.0):
    """A stepped wall of 120 mm bricks, each on halves of the two under it, every level after the
    one under it (bodies 1, 2... the first level, 101, 102... the second); the first brick of the
    second level ``heavier`` kg heavier, its centre of mass 10 mm along for each 10 g."""
    nodes, below = {}, []
    for level in range(levels):
        count = levels - level
        row = []
        for i in range(count):
            b = 100 * level + i + 1
            x = 0.12 * i + 0.06 * level
            z = 0.004 + 0.008 * level
            if not below:
                supports = {GROUND: area(x - 0.06, -0.012, x + 0.06, 0.012)}
            else:
                supports = {
                    s: area(max(x - 0.06, sx - 0.06), -0.012, min(x + 0.06, sx + 0.06), 0.012, z - 0.004)
                    for s, sx in below
                    if abs(sx - x) < 0.12
                }
            extra = heavier if b == 101 else 0.0
            nodes[b] = LoadNode(0.01 + 0.001 * i + extra, np.array([x + extra, 0.0, z]), supports)
            row.append((b, x))
        below = row
    return nodes


def test_a_part_propagated_alone_gives_the_whole_propagation_bit_for_bit():
    from stability._load import propagate_fast, propagate_part

    before = wall(5)
    kept = propagate_fast(before)
    after = wall(5, heavier=0.01)  # brick 101 changed: its load and those of the bricks under it change
    part, todo = set(), [101]
    while todo:
        b = todo.pop()
        if b in after and b not in part:
            part.add(b)
            todo += after[b].supports
    order = {b: i for i, b in enumerate(after)}
    uppers = {s: [a for a, n in after.items() if s in n.supports] for s in after}
    whole = propagate_fast(after)
    found = propagate_part(after, part, kept, uppers.__getitem__, order.__getitem__)
    assert found is not None and found.keys() == part and len(part) < len(after)
    assert all(found[b] == whole[b] for b in part)
    assert any(found[b] != kept[b] for b in part)  # a real change, not the kept loads again
    # a brick resting on the part with no kept load, or a part out of its supports' order: no answer
    assert propagate_part(after, part, {}, uppers.__getitem__, order.__getitem__) is None
    backwards = {b: -i for b, i in order.items()}
    assert propagate_part(after, part, kept, uppers.__getitem__, backwards.__getitem__) is None
