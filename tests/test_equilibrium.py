"""Rigid-block equilibrium as a linear program, against closed forms."""

import math

import numpy as np
import pytest

from stability import ContactPolygon, RigidBlock, WarmStart, solve_equilibrium

M = 0.0106
W = M * 9.81
L = 0.12
UP = np.array([0.0, 0.0, 1.0])


def rectangle(x0, x1, z, y=0.012):
    return np.array([[x0, -y, z], [x1, -y, z], [x1, y, z], [x0, y, z]])


def overhang(d):
    """A brick reaching d beyond the edge (x = 0) of the brick below it."""
    return solve_equilibrium(
        {"top": RigidBlock(M, np.array([d - L / 2, 0.0, 0.012]))},
        [ContactPolygon("top", "base", rectangle(-(L - d), 0.0, 0.008), UP, 0.5)],
    )


@pytest.mark.parametrize("d", [0.05, 0.0599])
def test_overhang_up_to_half_a_length_stands(d):
    result = overhang(d)
    assert result.stands and result.tension == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("d", [0.0601, 0.07, 0.09])
def test_overhang_beyond_half_needs_the_closed_form_tension(d):
    # Moments about the edge: W (d - L/2) = T (L - d).
    result = overhang(d)
    assert not result.stands
    assert result.tension == pytest.approx(W * (d - L / 2) / (L - d), rel=1e-6)
    assert result.tension_by_body["top"] == pytest.approx(result.tension)


@pytest.mark.parametrize("angle, stands", [(26.0, True), (26.5, True), (26.6, False), (30.0, False)])
def test_brick_on_a_slope_slides_at_tan_equal_mu(angle, stands):
    a = math.radians(angle)  # limit: atan(0.5) = 26.565 deg
    normal = np.array([-math.sin(a), 0.0, math.cos(a)])
    along = np.array([math.cos(a), 0.0, math.sin(a)])
    corners = np.array([sx * 0.06 * along + [0, sy * 0.012, 0] for sx in (-1, 1) for sy in (-1, 1)])
    result = solve_equilibrium({"b": RigidBlock(M, 0.004 * normal)}, [ContactPolygon("b", "slope", corners, normal, 0.5)])
    assert result.stands is stands


def test_the_full_program_is_the_equilibrium_rows_alone_and_its_forces_stay_in_the_friction_cone(monkeypatch):
    from stability import _equilibrium

    programs, solve = [], _equilibrium.solve

    def recorded(cost, a_eq, b_eq, **kwargs):
        programs.append({"A_eq": a_eq, **kwargs})
        return solve(cost, a_eq, b_eq, **kwargs)

    monkeypatch.setattr(_equilibrium, "solve", recorded)
    a = math.radians(26.0)  # on a slope steeper than level: the full program decides at once
    normal = np.array([-math.sin(a), 0.0, math.cos(a)])
    along = np.array([math.cos(a), 0.0, math.sin(a)])
    corners = np.array([sx * 0.06 * along + [0, sy * 0.012, 0] for sx in (-1, 1) for sy in (-1, 1)])
    result = solve_equilibrium({"b": RigidBlock(M, 0.004 * normal)}, [ContactPolygon("b", "slope", corners, normal, 0.5)])
    (program,) = programs
    assert program.get("a_ub") is None and program["A_eq"].shape == (6, 4 * 9)  # 4 vertices: a tension, 8 edges
    assert result.stands and result.forces[0].sum(axis=0) == pytest.approx([0.0, 0.0, W], abs=1e-9)
    pressing = result.forces[0] @ normal
    sliding = np.linalg.norm(result.forces[0] - np.outer(pressing, normal), axis=1)
    assert (pressing >= -1e-12).all() and (sliding <= 0.5 * pressing + 1e-9).all()


def test_forces_balance_the_weight():
    result = overhang(0.03)
    assert result.forces[0].sum(axis=0) == pytest.approx([0.0, 0.0, W], abs=1e-9)
    assert (result.forces[0][:, 2] >= -1e-12).all()


def test_a_single_point_cannot_hold_a_brick_even_with_glue():
    result = solve_equilibrium(
        {"b": RigidBlock(M, np.array([0.03, 0.0, 0.004]))}, [ContactPolygon("b", "g", np.zeros((1, 3)), UP, 0.5)]
    )
    assert not result.stands and result.tension == math.inf


def test_supports_take_any_force_and_free_blocks_push_each_other():
    # Two bricks, one on the other on the ground: both free, all compressive.
    blocks = {"a": RigidBlock(M, np.array([0, 0, 0.004])), "b": RigidBlock(M, np.array([0.03, 0, 0.012]))}
    contacts = [
        ContactPolygon("a", "ground", rectangle(-0.06, 0.06, 0.0), UP, 0.5),
        ContactPolygon("b", "a", rectangle(-0.03, 0.06, 0.008), UP, 0.5),
    ]
    result = solve_equilibrium(blocks, contacts)
    assert result.stands
    assert result.forces[0][:, 2].sum() == pytest.approx(2 * W)  # the ground carries both


def test_bad_input():
    with pytest.raises(ValueError):
        solve_equilibrium({"b": RigidBlock(M, np.zeros(3))}, [ContactPolygon("b", "g", np.zeros((0, 3)), UP, 0.5)])
    with pytest.raises(ValueError):
        solve_equilibrium({}, [], sides=2)


def test_a_block_that_touches_nothing_falls():
    # no contact at all: no program to solve, and the block is the whole collapse mechanism
    result = solve_equilibrium({"brick": RigidBlock(0.01, np.zeros(3))}, [])
    assert not result.stands and result.mechanism == {"brick": 1.0}
    assert solve_equilibrium({}, []).stands


@pytest.mark.slow
def test_the_margin_program_agrees_with_bisection_on_random_assemblies():
    # equilibrium_margin finds how far every centre of mass can move together in any direction;
    # a bisection on solve_equilibrium (the oracle's way) along eight directions bounds it
    from stability import equilibrium_margin
    from stackdsl import compile_scenario, parse_scenario
    from stackdsl.verdicts.assemblies import _DIRECTIONS, MAX_MARGIN, RESOLUTION, assembly
    from stackdsl.verdicts.oracle import structure

    def bisection(blocks, contacts):
        def stands(shift):
            return solve_equilibrium({n: RigidBlock(b.mass, b.com + shift) for n, b in blocks.items()}, contacts).stands

        best = MAX_MARGIN
        for u in _DIRECTIONS:
            if stands(u * best):
                continue
            low, high = 0.0, best
            while high - low > RESOLUTION:
                mid = (low + high) / 2
                low, high = (mid, high) if stands(u * mid) else (low, mid)
            best = high
        return best

    checked = 0
    for k in range(40):
        rng = np.random.default_rng(np.random.SeedSequence(3, spawn_key=(k,)))
        program = compile_scenario(parse_scenario(assembly(rng, f"assembly {k}")))
        if any(p.pitch or p.roll for p in program.placements):
            continue  # flat assemblies: the oracle's own contacts, no leaning brick
        blocks, contacts = structure(list(program.placements), program.fixtures, program.ground_friction)
        if not solve_equilibrium(blocks, contacts).stands:
            assert equilibrium_margin(blocks, contacts) is None
            continue
        margin, bisected = equilibrium_margin(blocks, contacts), bisection(blocks, contacts)
        # the margin is the least over every direction, so no more than along any of the eight;
        # and the polygon of shifts holds the hull of the eight reaches, whose edges are at
        # least cos(pi / 8) of the least of them from 0
        assert margin is not None and bisected * math.cos(math.pi / 8) - 2 * RESOLUTION <= margin <= bisected
        checked += 1
        if checked == 5:
            break
    assert checked == 5


def test_every_brick_of_a_toppling_tower_moves_in_its_mechanism_the_base_included():
    """Four bricks, each 40-50 mm past the one below: the tower topples about its base's edge,
    and the base moves least (about a quarter of the top's virtual velocity); it moves all the same."""
    blocks, contacts, centres = {}, [], [0.0, 0.04, 0.09, 0.14]
    for k, x in enumerate(centres):
        blocks[k] = RigidBlock(M, np.array([x, 0.0, 0.004 + 0.008 * k]))
        if k == 0:
            contacts.append(ContactPolygon(0, "ground", rectangle(-L / 2, L / 2, 0.0), UP, 0.5))
        else:
            low, high = x - L / 2, centres[k - 1] + L / 2
            contacts.append(ContactPolygon(k, k - 1, rectangle(low, high, 0.008 * k), UP, 0.5))
    result = solve_equilibrium(blocks, contacts)
    assert not result.stands
    assert result.mechanism[3] == pytest.approx(1.0) and 0.0 < result.mechanism[0] < 0.5
    assert result.moving() == {0, 1, 2, 3}


def leaning_ladder(shift_mm: float) -> tuple[dict[str, RigidBlock], list[ContactPolygon[str]]]:
    """A brick 36 deg from horizontal, its foot on a step brick and its top against a wall, both
    at mu 0.5, in a vertical plane 49.5 deg from x, its centre of mass moved ``shift_mm`` mm
    towards the wall: the foot needs its friction between two edges of an eight-sided pyramid.
    Its foot normal, as an engine reported it, is off vertical by 8e-6."""
    mm = 1e-3
    wall_normal = np.array([0.64974, -0.76016, 0.0])
    foot_normal = np.array([7.74e-6, -2.78e-6, 1.0]) / np.linalg.norm([7.74e-6, -2.78e-6, 1.0])
    wall = [[337.205, -58.374, 77.348], [337.205, -58.374, 79.348], [355.449, -42.78, 79.342], [355.449, -42.78, 77.342]]
    foot = [[400.998, -133.031, 8.0], [399.698, -131.51, 8.0], [417.942, -115.917, 8.0], [419.241, -117.437, 8.0]]
    contacts = [
        ContactPolygon("ladder", "wall", np.array(wall) * mm, wall_normal, 0.5),
        ContactPolygon("ladder", "step", np.array(foot) * mm, foot_normal, 0.5),
    ]
    com = np.array([379.419, -89.304, 46.406]) * mm - shift_mm * mm * wall_normal
    return {"ladder": RigidBlock(M, com)}, contacts


@pytest.mark.parametrize("shift_mm", [0.0, 1.5, 3.0, 5.0])
def test_a_ladder_whose_foot_normal_an_engine_tilted_is_judged_on_the_cone(shift_mm):
    # The leaning ladder stands on the cone as it is and 1.5 mm nearer the wall; 3 mm on it
    # falls. The eight-sided program called it fallen as it was (0.32 mN of tension).
    ladder, contacts = leaning_ladder(shift_mm)
    result = solve_equilibrium(ladder, contacts)
    cone = solve_equilibrium(ladder, contacts, sides=64)  # near the cone itself
    assert result.stands is cone.stands is (shift_mm < 2.0)


@pytest.mark.parametrize(("shift_mm", "fine"), [(0.0, False), (3.0, True), (8.0, False)])
def test_a_verdict_alone_skips_the_fine_pyramid_when_the_pyramid_around_the_cone_fails(monkeypatch, shift_mm, fine):
    # The leaning ladder: standing (no fine program needed), just fallen (the eight-sided pyramid
    # around the cone still holds it: the 32-sided program decides), and well fallen (the
    # pyramid around the cone fails it too, and so must the cone: no 32-sided program). The
    # verdict and its mechanism are the cone's every time.
    from stability import _equilibrium
    from stability._equilibrium import FINE_SIDES

    ladder, contacts = leaning_ladder(shift_mm)
    cone = solve_equilibrium(ladder, contacts, sides=64)  # near the cone itself
    sides: list[int] = []
    program = _equilibrium._solve
    monkeypatch.setattr(_equilibrium, "_solve", lambda *a, **k: sides.append(a[2]) or program(*a, **k))
    decided = solve_equilibrium(ladder, contacts, decide=True)
    assert decided.stands is cone.stands is (shift_mm < 2.0)
    assert decided.moving() == cone.moving()
    assert (FINE_SIDES in sides) is fine, sides
    if not decided.stands:
        assert 0.0 < decided.tension <= solve_equilibrium(ladder, contacts).tension  # a lower bound of the cone's


def slope(angle, mu):
    """A brick on a slope of ``angle`` degrees whose contact has friction ``mu``."""
    a = math.radians(angle)
    normal = np.array([-math.sin(a), 0.0, math.cos(a)])
    along = np.array([math.cos(a), 0.0, math.sin(a)])
    corners = np.array([sx * 0.06 * along + [0, sy * 0.012, 0] for sx in (-1, 1) for sy in (-1, 1)])
    return {"b": RigidBlock(M, 0.004 * normal)}, corners, normal


def test_a_negative_friction_is_refused_not_a_pyramid_turned_inside_out():
    # mu = -1 turned the pyramid's edges uphill: a brick on a 20 deg slope "stood" where mu = 0 slides
    blocks, corners, normal = slope(20.0, 0.0)
    assert not solve_equilibrium(blocks, [ContactPolygon("b", "slope", corners, normal, 0.0)]).stands
    for mu in (-1.0, -1e-9, math.nan, math.inf):
        with pytest.raises(ValueError, match=r"ContactPolygon.friction must be a finite friction coefficient >= 0"):
            ContactPolygon("b", "slope", corners, normal, mu)


@pytest.mark.parametrize("mass", [-0.0106, 0.0, math.nan, math.inf])
def test_a_block_without_a_positive_finite_mass_is_refused(mass):
    # a negative mass made the blocks "stand" on anything: gravity held them up
    with pytest.raises(ValueError, match=r"RigidBlock.mass must be a finite positive number of kg"):
        RigidBlock(mass, np.zeros(3))


@pytest.mark.parametrize("com", [np.zeros(2), np.array([0.0, math.nan, 0.0]), [[0.0, 0.0, 0.0]]])
def test_a_block_without_three_finite_coordinates_is_refused(com):
    with pytest.raises(ValueError, match=r"RigidBlock.com must be 3 finite coordinates"):
        RigidBlock(M, com)


@pytest.mark.parametrize("sides", [0, 1, 2])
def test_a_pyramid_of_fewer_than_three_sides_is_refused_everywhere(sides):
    from stability import equilibrium_margin, is_level

    blocks, corners, normal = slope(0.0, 0.5)
    contact = ContactPolygon("b", "ground", corners, normal, 0.5)
    for ask in (is_level, solve_equilibrium, equilibrium_margin):
        args = (contact,) if ask is is_level else (blocks, [contact])
        with pytest.raises(ValueError, match=rf"sides: the friction pyramid needs at least 3 sides, not {sides}"):
            ask(*args, sides=sides)  # type: ignore[operator]


@pytest.mark.parametrize("degrees", [30, 45, 50])
def test_the_friction_share_of_a_thin_ladder_is_its_closed_form(degrees):
    # a thin ladder at angle a from vertical on a floor and a wall of one coefficient mu s:
    # moments about the foot give tan a = 2 mu s / (1 - (mu s)^2) at the limit
    from stability import friction_share
    from stability._friction import FRICTION_STEP

    a, mu = math.radians(degrees), 0.5
    foot = np.array([[-L * math.sin(a), -0.01, 0.0], [-L * math.sin(a), 0.01, 0.0]])
    top = np.array([[0.0, -0.01, L * math.cos(a)], [0.0, 0.01, L * math.cos(a)]])
    contacts = [
        ContactPolygon("ladder", "floor", foot, UP, mu),
        ContactPolygon("ladder", "wall", top, np.array([-1.0, 0, 0]), mu),
    ]
    ladder = {"ladder": RigidBlock(M, np.array([-L * math.sin(a) / 2, 0.0, L * math.cos(a) / 2]))}
    t = math.tan(a)
    closed = (math.sqrt(1 + t * t) - 1) / t / mu
    share = friction_share(ladder, contacts)
    assert closed <= share <= closed + FRICTION_STEP
    assert solve_equilibrium(ladder, [ContactPolygon(c.body, c.other, c.points, c.normal, mu * share) for c in contacts]).stands


def turned_ladder(degrees, yaw):
    """A thin ladder ``degrees`` from vertical, turned ``yaw`` degrees about the vertical from
    the wall's normal, on a floor and against a wall of friction 0.5: its block and contacts."""
    a, turn = math.radians(degrees), math.radians(yaw)
    along, across = np.array([math.cos(turn), math.sin(turn), 0.0]), np.array([-math.sin(turn), math.cos(turn), 0.0])
    foot, top = -L * math.sin(a) * along, np.array([0.0, 0.0, L * math.cos(a)])
    contacts = [
        ContactPolygon("ladder", "floor", np.array([foot - 0.01 * across, foot + 0.01 * across]), UP, 0.5),
        ContactPolygon("ladder", "wall", np.array([top - 0.01 * across, top + 0.01 * across]), np.array([-1.0, 0, 0]), 0.5),
    ]
    return {"ladder": RigidBlock(M, (foot + top) / 2)}, contacts


@pytest.mark.parametrize(("degrees", "yaw"), [(30, 20), (40, 35), (50, 20)])
def test_the_friction_share_is_the_fine_pyramids_least_where_eight_sides_need_more(degrees, yaw):
    # a ladder turned about the vertical against a wall needs its wall friction between the
    # eight-sided pyramid's edges: the coarse pyramid fails where the 32-sided one stands, and the
    # share is the fine pyramid's least, found here by trying every step from 0
    from stability import friction_share
    from stability._equilibrium import FINE_SIDES, _solve
    from stability._friction import COARSE_SIDES, FRICTION_STEP

    ladder, contacts = turned_ladder(degrees, yaw)

    def scaled(share):
        return [ContactPolygon(c.body, c.other, c.points, c.normal, c.friction * share) for c in contacts]

    least = next(k * FRICTION_STEP for k in range(65) if _solve(ladder, scaled(k * FRICTION_STEP), FINE_SIDES, 9.81).stands)
    assert friction_share(ladder, contacts) == least
    assert not _solve(ladder, scaled(least), COARSE_SIDES, 9.81).stands


def test_the_friction_shares_programs_start_from_the_last_basis_and_find_the_same_share(monkeypatch):
    # the bisection's programs differ only in their friction coefficients: each starts from the
    # basis the last one of its pyramid ended on, in fewer simplex iterations, to the same share
    import stability._friction as friction
    from stability import _lp, friction_share

    ladder, contacts = turned_ladder(40, 35)
    iterations = [0]
    solve = _lp.LinearProgram.solve

    def counted(self, warm=None):
        solution = solve(self, warm)
        iterations[0] += solution.iterations
        return solution

    monkeypatch.setattr(_lp.LinearProgram, "solve", counted)
    warm_share, warm_iterations = friction_share(ladder, contacts), iterations[0]

    class Cold:  # a warm start that never keeps a basis
        shape = basis = None

        def __setattr__(self, name, value):
            pass

    monkeypatch.setattr(friction, "WarmStart", Cold)
    iterations[0] = 0
    assert friction_share(ladder, contacts) == warm_share
    assert warm_iterations < iterations[0]


def test_a_brick_on_a_level_face_needs_no_friction():
    from stability import friction_share

    assert (
        friction_share(
            {"top": RigidBlock(M, np.array([0.0, 0.0, 0.012]))},
            [ContactPolygon("top", "base", rectangle(-0.06, 0.06, 0.008), UP, 0.5)],
        )
        == 0.0
    )


def test_a_brick_on_a_face_tilted_by_an_engines_noise_needs_no_friction_beside_a_side_contact():
    """A brick on a face tilted 0.03 deg (an engine's noise on a level face: is_level's
    LEVEL_TILT) and touching a wall with its side: vertical forces on the level contact hold it,
    so it needs no friction. The side contact made the share's first program the full one,
    whose frictionless pyramid at the tilted face cannot cancel the normal's sideways part: a
    settled Jenga tower's certificate read "needing 2% of each friction coefficient"."""
    from scipy.spatial.transform import Rotation

    from stability import friction_share

    turn = Rotation.from_euler("x", 5e-4)
    brick = {"top": RigidBlock(M, turn.apply([0.0, 0.0, 0.004]))}
    face = ContactPolygon("top", "base", turn.apply(rectangle(-0.06, 0.06, 0.0)), turn.apply(UP), 0.5)
    wall = ContactPolygon(
        "top", "wall", np.array([[-0.06, 0.012, 0.0], [0.06, 0.012, 0.0], [0.0, 0.012, 0.008]]), np.array([0.0, -1.0, 0.0]), 0.5
    )
    assert friction_share(brick, [face, wall]) == 0.0


def three_levels_tied(spread=0.0255, levels=3):
    """Jenga-like levels of three 75 x 25 x 15 mm blocks, each level across the one under it,
    the lowest on a support: blocks by name, and every crossing as a contact square."""
    blocks, contacts, below = {}, [], [(f"support{i}", np.array([0.0, s, -0.0075])) for i, s in enumerate((-spread, 0.0, spread))]
    for k in range(levels):
        here = []
        for i, s in enumerate((-spread, 0.0, spread)):
            centre = np.array([s, 0.0, 0.0075 + 0.015 * k]) if k % 2 == 0 else np.array([0.0, s, 0.0075 + 0.015 * k])
            name = f"L{k}.{i}"
            blocks[name] = RigidBlock(0.02, centre)
            for other, at in below:
                x, y = (centre[0], at[1]) if k % 2 == 0 else (at[0], centre[1])
                square = np.array(
                    [
                        [x + dx, y + dy, 0.015 * k]
                        for dx, dy in ((-0.0125, -0.0125), (0.0125, -0.0125), (0.0125, 0.0125), (-0.0125, 0.0125))
                    ]
                )
                contacts.append(ContactPolygon(name, other, square, UP, 0.4))
            here.append((name, centre))
        below = here
    return blocks, contacts


@pytest.mark.parametrize("run", [(0.1, 0.0), (0.3, 0.0), (0.0, 0.35), (0.25, -0.25), (0.39, 0.0), (0.41, 0.0)])
def test_forces_along_a_tilted_gravity_prove_only_what_the_full_program_proves(run):
    """Tied levels under a tilted gravity: forces parallel to it (stability.balanced_tilted) hold
    them up to their friction, 0.4 (the levels tip only past 37.5 / 22.5 = 1.7 as a block), and
    wherever they do the full program (solve_equilibrium with sideways) stands too: the parallel
    forces are among its forces. Past the friction coefficient no contact can carry them."""
    from stability import balanced_tilted

    blocks, contacts = three_levels_tied()
    found = balanced_tilted(blocks, contacts, run)
    assert found is (math.hypot(*run) < 0.4)
    if found:
        assert solve_equilibrium(blocks, contacts, sideways=(9.81 * run[0], 9.81 * run[1]), quick=False).stands


def test_a_tilted_gravity_tips_a_post_past_its_half_width_over_its_height_and_not_before():
    """A post 8 mm wide on the ground with its centre 60 mm up and 2 mm off its middle stands
    tilted by a run under 2 / 60 towards the near edge, 6 / 60 towards the far one and 12 / 60
    along, as the report's tipping test with a tilted gravity says, on parallel forces as in the
    full program; upright it stands whatever the friction."""
    from stability import balanced_tilted

    post = {"post": RigidBlock(M, np.array([0.002, 0.0, 0.06]))}
    foot = [ContactPolygon("post", "ground", rectangle(-0.004, 0.004, 0.0), UP, 0.5)]
    cases = [((0.032, 0.0), True), ((0.035, 0.0), False), ((-0.099, 0.0), True), ((-0.101, 0.0), False)]
    for run, stands in [*cases, ((0.0, 0.199), True), ((0.0, 0.201), False)]:
        assert balanced_tilted(post, foot, run) is stands, run
        assert solve_equilibrium(post, foot, sideways=(9.81 * run[0], 9.81 * run[1]), quick=False).stands is stands
    assert balanced_tilted(post, [ContactPolygon("post", "ground", rectangle(-0.004, 0.004, 0.0), UP, 0.0)], (0.0, 0.0))


def _ladders():
    """Twenty turned ladders as the free blocks of one program: each needs its wall friction
    between the eight-sided pyramid's edges, or more friction than there is."""
    blocks, contacts = {}, []
    for i, (degrees, yaw) in enumerate((d, y) for d in (30, 38, 40, 44, 50) for y in (10, 20, 35, 50)):
        ladder, theirs = turned_ladder(degrees, yaw)
        blocks[f"l{i}"] = ladder["ladder"]
        contacts += [ContactPolygon(f"l{i}", c.other, c.points, c.normal, c.friction) for c in theirs]
    return blocks, contacts


def test_the_fine_pyramid_starts_from_the_coarse_ones_optimum_and_finds_the_same(monkeypatch):
    # the 32-sided program is solved by columns from the eight-sided one's edges and basis: the
    # same least tension and collapse mechanism as the whole program from scratch, in a fraction
    # of its simplex iterations
    from stability import _lp
    from stability._equilibrium import FINE_SIDES, _solve

    blocks, contacts = _ladders()
    coarse = WarmStart()
    eight = _solve(blocks, contacts, 8, 9.81, warm=coarse)
    pivots = []
    solve = _lp.LinearProgram.solve
    monkeypatch.setattr(_lp.LinearProgram, "solve", lambda self, warm=None: pivots.append(solve(self, warm)) or pivots[-1])
    started = _solve(blocks, contacts, FINE_SIDES, 9.81, start=(8, coarse))
    from_start = sum(p.iterations for p in pivots)
    pivots.clear()
    whole = _solve(blocks, contacts, FINE_SIDES, 9.81)
    assert not eight.stands and eight.tension > started.tension > 0
    assert started.tension == pytest.approx(whole.tension, rel=1e-9)
    assert started.moving() == whole.moving() and len(whole.moving()) > 1
    assert from_start < 0.3 * sum(p.iterations for p in pivots)


def test_deciding_asks_the_wider_pyramid_from_the_coarse_basis_and_decides_as_from_scratch(monkeypatch):
    # with decide, the pyramid around the cone starts from the eight-sided program's basis (by the
    # primal simplex): whether the blocks stand and the tension are those of the programs solved
    # from scratch
    import stability._equilibrium as equilibrium
    from stability._equilibrium import FINE_SIDES, _solve

    blocks, contacts = _ladders()
    wider = [ContactPolygon(c.body, c.other, c.points, c.normal, c.friction / math.cos(math.pi / 8)) for c in contacts]
    for part in (["l2", "l6"], list(blocks)):  # ladders that stand on the cone, and all of them
        some = {k: blocks[k] for k in part}
        theirs = [c for c in contacts if c.body in some]
        decided = solve_equilibrium(some, theirs, decide=True)
        around = _solve(some, [c for c in wider if c.body in some], 8, 9.81)
        fine = _solve(some, theirs, FINE_SIDES, 9.81)
        assert decided.stands == fine.stands
        assert decided.tension == pytest.approx(fine.tension if around.stands else around.tension, rel=1e-9, abs=1e-12)
    calls = []
    real = equilibrium._solve
    monkeypatch.setattr(equilibrium, "_solve", lambda *a, **k: calls.append(k) or real(*a, **k))
    solve_equilibrium(blocks, contacts, decide=True)
    assert [k.get("primal", False) for k in calls][:2] == [False, True] and calls[1]["warm"].basis is not None
    calls.clear()
    solve_equilibrium(blocks, contacts)  # without decide: the fine program, by columns from the coarse basis
    assert len(calls) == 2 and calls[1]["start"] == (8, calls[0]["warm"])


def _one_contacts_generators(contact, blocks, sides, along=None):
    """The pyramid's edges of one contact, worked out alone: the reference for all at once."""
    normal = np.asarray(contact.normal, dtype=float)
    normal = normal / np.linalg.norm(normal)
    down = np.array([0.0, 0.0, -1.0])
    first = down - (down @ normal) * normal
    held = next((blocks[k] for k in (contact.body, contact.other) if k in blocks), None)
    toward = along if along is not None else None if held is None else held.com - np.asarray(contact.points).mean(axis=0)
    if np.linalg.norm(first) < 1e-3 and toward is not None:
        first = toward - (toward @ normal) * normal
    if np.linalg.norm(first) < 1e-6:
        axis = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        first = axis - (axis @ normal) * normal
    first = first / np.linalg.norm(first)
    angles = 2 * np.pi * np.arange(sides) / sides
    tangents = np.cos(angles)[:, None] * first + np.sin(angles)[:, None] * np.cross(normal, first)
    return np.vstack([-normal, normal + contact.friction * tangents])


@pytest.mark.parametrize("along", [None, (0.3, -0.2, 0.0)])
def test_every_contacts_pyramid_at_once_is_each_ones_to_the_last_bit(along):
    # level, nearly level, tilted, vertical and downward contacts, some between two supports: the
    # edges of all at once are those of each worked out alone, bit for bit (the programs, and so
    # the goldens, do not move)
    from stability._equilibrium import _generators, _vertices

    rng = np.random.default_rng(5)
    normals = [(0, 0, 1.0), (1e-5, -2e-5, 1.0), (1.0, 0, 0), (0, 0, -1.0), (0.3, 0.1, 0.9), tuple(rng.normal(size=3))]
    blocks = {"a": RigidBlock(M, rng.normal(size=3) * 0.02), "b": RigidBlock(M, rng.normal(size=3) * 0.02)}
    contacts = []
    for k in range(60):
        body, other = (("a", "ground"), ("b", "a"), ("wall", "ground"))[k % 3]
        points = rng.normal(size=(int(rng.integers(1, 9)), 3)) * 0.01
        contacts.append(ContactPolygon(body, other, points, np.array(normals[k % len(normals)]), float(rng.uniform(0, 1))))
    points, owner = _vertices(contacts)
    way = None if along is None else np.array(along)
    for sides in (8, 32):
        together = _generators(contacts, blocks, sides, points, owner, way)
        alone = np.stack([_one_contacts_generators(c, blocks, sides, way) for c in contacts])
        assert np.array_equal(together, alone)
