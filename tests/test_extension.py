"""The stability extension's rules (report 3.3.1-3.3.7) on a fake engine, no simulation."""

from types import SimpleNamespace

import numpy as np
import pytest

from stability import Box, BrickState, FakeEngine, Plane, Pose, StabilityConfig, StabilityExtension
from stability._load import propagate_fast

KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
H = 0.008


def corners(x, y, hx, hy, z):
    return [[x - hx, y - hy, z], [x + hx, y - hy, z], [x + hx, y + hy, z], [x - hx, y + hy, z]]


class Scene:
    """Bricks laid flat along x, each resting face to face on the one below (or the ground)."""

    def __init__(self, config=None):
        self.engine = FakeEngine()
        self.ext = StabilityExtension(self.engine, config or StabilityConfig(rest_duration=0.0))
        self.engine.frozen.add(0)  # the ground is static
        self.ext.add_ground(0, Plane(0.0))
        self.n = 0
        self.time = 0.0

    def place(self, x, level, on=(0,), y=0.0, yaw=0.0):
        """Add a brick and run one update: returns the brick and the update's events."""
        body = self.brick(x, level, on, y, yaw)
        self.time += 0.1
        return body, self.ext.update(self.time)

    def brick(self, x, level, on=(0,), y=0.0, yaw=0.0):
        self.n += 1
        body = self.n
        z = (level - 0.5) * H
        self.engine.poses[body] = Pose.from_euler([x, y, z], yaw=yaw)
        self.ext.add_brick(body, KAPLA, f"b{body}")
        for other in on:
            self.engine.touch(body, other, corners(x, y, 0.012, 0.012, z - H / 2), normal=[0, 0, 1])
        return body


def test_brick_at_rest_over_its_support_is_frozen():
    s = Scene()
    b = s.brick(0.0, 1)
    events = s.ext.update(0.0)
    assert [(e.kind, e.label) for e in events] == [("freeze", "b1")]
    assert s.ext.state(b) is BrickState.FROZEN and b in s.engine.frozen
    assert s.ext.quiet


@pytest.mark.parametrize("model", ["report", "equilibrium"])
def test_a_brick_is_frozen_out_of_the_overlap_with_its_supports(model):
    # the engine's soft contacts let a brick at rest sink a little into its support;
    # frozen there, a tall tower's overlaps would add up
    s = Scene(StabilityConfig(rest_duration=0.0, model=model))
    b = s.brick(0.0, 1, on=())
    s.engine.touch(b, 0, corners(0.0, 0.0, 0.06, 0.012, -1e-4), normal=[0, 0, 1], distance=-1e-4)
    s.engine.poses[b] = Pose.from_euler([0.0, 0.0, H / 2 - 1e-4])
    assert [e.kind for e in s.ext.update(0.0)] == ["freeze"]
    assert s.engine.poses[b].position[2] == pytest.approx(H / 2, abs=1e-9)
    # a brick that only touches (no overlap) stays where it is
    c = s.brick(0.2, 1)
    s.ext.update(0.1)
    assert s.ext.state(c) is BrickState.FROZEN and s.engine.poses[c].position[2] == pytest.approx(H / 2, abs=1e-12)


def test_moving_brick_is_not_admitted():
    s = Scene()
    b = s.brick(0.0, 1)
    s.engine.velocities[b] = (np.array([0.05, 0, 0]), np.zeros(3))
    assert s.ext.update(0.0) == []
    s.engine.velocities[b] = (np.zeros(3), np.array([0, 0, 1.0]))
    assert s.ext.update(0.1) == []
    assert s.ext.state(b) is BrickState.ACTIVE


def test_rest_must_last_the_rest_duration():
    s = Scene(StabilityConfig(rest_duration=0.05))
    s.brick(0.0, 1)
    assert s.ext.update(0.00) == []
    assert s.ext.update(0.03) == []
    assert [e.kind for e in s.ext.update(0.05)] == ["freeze"]


def test_brick_whose_com_overhangs_its_support_is_not_admitted():
    s = Scene()
    base, _ = s.place(0.0, 1)
    top, events = s.place(0.065, 2, on=(base,))  # 65 mm over a 60 mm half-length: COM outside
    assert events == []
    assert s.ext.state(top) is BrickState.ACTIVE


def test_contacts_between_two_active_bricks_are_dropped():
    s = Scene()
    base = s.brick(0.0, 1)
    s.engine.velocities[base] = (np.array([0.1, 0, 0]), np.zeros(3))  # still moving: not in the stack
    top = s.brick(0.0, 2, on=(base,))
    s.ext.update(0.0)
    assert s.ext.state(top) is BrickState.ACTIVE


def test_frozen_pairs_report_no_contacts_but_the_graph_remembers_them():
    s = Scene()
    base, _ = s.place(0.0, 1)
    s.place(0.03, 2, on=(base,))
    assert s.engine.contact_points() == []  # everything static: the engine says nothing
    graph = s.ext.graph()
    assert [(e.upper, e.support) for e in graph.edges] == [("b1", "ground"), ("b2", "b1")]
    assert graph.node("b1").mass_above == pytest.approx(2 * KAPLA.mass)
    assert graph.node("b1").com_above[0] == pytest.approx(0.015)


def test_stack_test_wakes_the_failing_brick_and_everything_above():
    # A column leaning right by 35 mm a level: each brick lies over the one below, but
    # once the fourth arrives the COM above the second is beyond the first's edge.
    s = Scene()
    b1, _ = s.place(0.0, 1)
    b2, _ = s.place(0.035, 2, on=(b1,))
    b3, _ = s.place(0.07, 3, on=(b2,))
    assert all(s.ext.state(b) is BrickState.FROZEN for b in (b1, b2, b3))
    b4, events = s.place(0.105, 4, on=(b3,))
    # b4 is admitted (its COM lies over b3), then the stack test finds b2's COM above
    # at (35 + 70 + 105) / 3 = 70 mm > 60 mm, b1's edge: b2, b3 and b4 wake. b1's own
    # COM above, (0 + 35 + 70 + 105) / 4 = 52.5 mm, stays over the ground: it holds.
    assert [(e.kind, e.label) for e in events] == [("freeze", "b4"), ("wake", "b2"), ("wake", "b3"), ("wake", "b4")]
    assert "outside its support" in events[1].reason and events[2].reason == "rests on b2"
    assert s.ext.state(b1) is BrickState.FROZEN
    assert all(s.ext.state(b) is BrickState.ACTIVE for b in (b2, b3, b4))
    assert b2 not in s.engine.frozen


def test_the_stack_test_propagates_only_the_part_a_change_reaches_and_still_finds_a_failing_brick(monkeypatch):
    # The leaning column of the test above, and two straight ones 300 and 600 mm away. Once a
    # stack test has passed every brick, a brick frozen on a straight column is tested with the
    # loads of that column alone (the others' kept); the fourth brick on the leaning column is
    # tested on its column's loads, fails b2 there, and the whole stack is tested as before:
    # the same wakes.
    import stability._stack_test as stack_test

    s = Scene()
    b1, _ = s.place(0.0, 1)
    b2, _ = s.place(0.035, 2, on=(b1,))
    b3, _ = s.place(0.07, 3, on=(b2,))
    columns = []
    for x, height in ((0.3, 2), (0.6, 4)):
        columns.append([s.place(x, 1)[0]])
        for level in range(2, height + 1):
            columns[-1].append(s.place(x, level, on=(columns[-1][-1],))[0])
    assert s.ext._stack.unproven and s.ext._stack.changed == set()  # b3 leans: the loads are propagated, and kept
    whole = []
    monkeypatch.setattr(stack_test, "propagate_fast", lambda *a: whole.append(a) or propagate_fast(*a))
    top, events = s.place(0.3, 3, on=(columns[0][-1],))
    assert [(e.kind, e.label) for e in events] == [("freeze", f"b{top}")] and not whole
    assert s.ext._stack.kept[columns[0][0]][1] == pytest.approx(3 * KAPLA.mass)  # its column's load, propagated alone
    b4, events = s.place(0.105, 4, on=(b3,))
    woken = [("wake", f"b{b}") for b in (b2, b3, b4)]
    assert [(e.kind, e.label) for e in events] == [("freeze", f"b{b4}"), *woken]
    assert whole  # b2 failed in its part: the whole stack was tested


def test_a_contact_whose_points_push_both_ways_gets_the_deepest_points_normal():
    # a 3-level tower struck 100 times at its base: a brick driven into another touched it on two
    # sides, the engine's normals cancelled out, and its contact polygon had no points (an
    # internal error where the run should have gone on)
    from stability import ContactPoint

    s = Scene()
    b1, _ = s.place(0.0, 1)
    b2 = s.brick(0.3, 2, on=())  # not lying on b1 face to face: its contact is the engine's points, padded
    at = np.array([0.06, 0.0, H])
    points = [
        ContactPoint(b2, b1, at, np.array([0.0, 0.0, 1.0]), distance=-0.001),
        ContactPoint(b2, b1, at + [0.01, 0.0, 0.0], np.array([0.0, 0.0, -1.0]), distance=-0.002),
    ]
    (polygon,) = s.ext._areas.polygons(s.ext._stack.bodies[b2], {b1: points})
    assert polygon.normal.tolist() == [0.0, 0.0, -1.0] and np.isfinite(polygon.points).all() and len(polygon.points)


def test_wake_clears_the_woken_brick_from_its_supports():
    s = Scene()
    b1, _ = s.place(0.0, 1)
    b2, _ = s.place(0.0, 2, on=(b1,))
    assert [e.label for e in s.ext.wake(b2, 0.2, "test")] == ["b2"]
    assert s.ext.wake(b2, 0.3, "again") == []  # not frozen: nothing to wake
    assert [e.label for e in s.ext.wake(b1, 0.4, "test")] == ["b1"]  # b2 no longer rests on it


def test_a_woken_brick_is_not_refrozen_until_it_has_rested_again():
    s = Scene(StabilityConfig(rest_duration=0.05))
    b1 = s.brick(0.0, 1)
    s.ext.update(0.0)
    s.ext.update(0.05)
    s.ext.wake(b1, 0.06, "test")
    assert s.ext.update(0.07) == []  # at rest, but only since the wake
    assert [e.kind for e in s.ext.update(0.12)] == ["freeze"]


def test_co_supports_of_a_brick_that_gave_way_are_retested():
    # Contact areas are the hulls of hand-placed points (face overlap off), so each patch
    # is exactly as drawn. Two columns L, R (two bricks each) carry a beam B whose load
    # sits over R. R2's COM above leaves its 4 mm patch: R2 gives way, B wakes with it.
    # B now leans on L2 alone, whose COM above then lies outside its own patch: L2 wakes
    # too (the report's wake-up alone would leave L2 frozen, holding B up).
    engine = FakeEngine()
    ext = StabilityExtension(engine, StabilityConfig(rest_duration=0.0, face_gap=-1.0))
    engine.frozen.add(0)
    ext.add_ground(0, Plane(0.0))

    def brick(body, x, level, on, x0, x1):
        engine.poses[body] = Pose.from_euler([x, 0, (level - 0.5) * H])
        ext.add_brick(body, KAPLA, f"b{body}")
        z = (level - 1) * H
        engine.touch(body, on, [[x0, -0.01, z], [x1, -0.01, z], [x1, 0.01, z], [x0, 0.01, z]], normal=[0, 0, 1])
        ext.update(0.1 * body)
        return ext.state(body)

    assert brick(1, -0.05, 1, 0, -0.06, -0.04) is BrickState.FROZEN  # L1
    assert brick(2, 0.05, 1, 0, 0.04, 0.06) is BrickState.FROZEN  # R1
    assert brick(3, -0.05, 2, 1, -0.052, -0.048) is BrickState.FROZEN  # L2
    assert brick(4, 0.05, 2, 2, 0.048, 0.052) is BrickState.FROZEN  # R2
    engine.poses[5] = Pose.from_euler([0.03, 0, 2.5 * H])  # B, on L2 and R2
    ext.add_brick(5, KAPLA, "b5")
    for on, (x0, x1) in ((3, (-0.046, -0.042)), (4, (0.058, 0.062))):
        engine.touch(5, on, [[x0, -0.01, 2 * H], [x1, -0.01, 2 * H], [x1, 0.01, 2 * H], [x0, 0.01, 2 * H]], normal=[0, 0, 1])
    events = ext.update(1.0)
    # lever rule: R2 carries 0.71 of B at x = 60 mm -> COM above 53.7 mm, outside [48, 52]; and
    # rigid-block equilibrium agrees (with B's force anywhere on its patch, padded by 1 mm, R2
    # needs f (x - 53 mm) <= 3 mm for B's share f at x, and f >= 0.69 at x >= 57 mm)
    assert [(e.kind, e.label) for e in events] == [("freeze", "b5"), ("wake", "b4"), ("wake", "b5"), ("wake", "b3")]
    assert events[3].reason.startswith("centre of mass above")
    assert [ext.state(b) for b in (1, 2)] == [BrickState.FROZEN, BrickState.FROZEN]


def test_a_refused_brick_is_asked_again_only_when_something_changed(monkeypatch):
    s = Scene()
    s.brick(0.0, 1)
    s.ext.update(0.0)  # b1 frozen on the ground
    b = s.brick(0.065, 2, on=(1,))  # centre of mass 65 mm out, beyond b1's end: refused
    asked = []
    real = s.ext._admission.basic
    monkeypatch.setattr(s.ext._admission, "basic", lambda *a: asked.append(a[0].body) or real(*a))
    for k in range(5):
        assert s.ext.update(0.1 * (k + 1)) == []
    assert asked == [b]  # once: nothing changed since
    s.engine.poses[b] = Pose.from_euler([0.0652, 0.0, 1.5 * H])  # it crept 0.2 mm
    s.ext.update(0.6)
    assert asked == [b, b]
    s.brick(0.3, 1)  # another brick freezes: the stack changed
    s.ext.update(0.7)
    s.ext.update(0.8)
    assert asked.count(b) == 3


def _overhanging() -> tuple[Scene, int]:
    """A scene with a rest duration of 50 ms, b1 frozen on the ground and b2 lying on it with its
    centre of mass beyond b1's end (refused once asked), not yet seen by an update."""
    s = Scene(StabilityConfig(rest_duration=0.05))
    s.brick(0.0, 1)
    s.ext.update(0.0)
    s.ext.update(0.1)  # b1 frozen on the ground
    return s, s.brick(0.065, 2, on=(1,))


def test_a_refused_brick_waits_a_rest_duration_on_the_same_stack(monkeypatch):
    s, b = _overhanging()
    asked = []
    real = s.ext._admission.basic
    monkeypatch.setattr(s.ext._admission, "basic", lambda *a: asked.append(a[0].body) or real(*a))
    s.ext.update(1.0)
    s.ext.update(1.06)  # at rest for the rest duration: asked, refused
    assert asked == [b]
    for t, x in ((1.07, 0.0652), (1.08, 0.0654)):  # it creeps, but on the same stack it waits
        s.engine.poses[b] = Pose.from_euler([x, 0.0, 1.5 * H])
        s.ext.update(t)
    assert asked == [b]
    s.engine.poses[b] = Pose.from_euler([0.0656, 0.0, 1.5 * H])
    s.ext.update(1.12)  # a rest duration after the refusal
    assert asked == [b, b]


def test_a_refused_brick_waits_out_a_lone_brick_elsewhere_but_not_a_change_under_it(monkeypatch):
    s, b = _overhanging()
    lone = s.brick(0.5, 1)  # on the ground alone, touching nothing b touches
    asked = []
    real = s.ext._admission.basic
    monkeypatch.setattr(s.ext._admission, "basic", lambda *a: asked.append(a[0].body) or real(*a))
    s.ext.update(1.0)
    on_b1 = s.brick(-0.03, 2, on=(1,))  # at rest from 1.03 on: frozen at 1.08, on b1
    s.ext.update(1.03)
    version = s.ext._stack.version
    s.ext.update(1.06)  # at rest for the rest duration: b asked and refused, then the lone brick frozen
    assert asked == [b, lone] and lone in s.engine.frozen and s.ext._stack.version > version
    s.ext.update(1.07)
    assert asked == [b, lone]  # the stack changed far from b: b waits its rest duration all the same
    s.ext.update(1.08)
    assert on_b1 in s.engine.frozen and asked.count(b) == 1
    s.ext.update(1.09)
    assert asked.count(b) == 2  # b1, which b lies on, carries more: asked again within the rest duration


def test_a_refused_brick_waiting_out_a_lone_change_is_asked_once_a_brick_it_touches_rests(monkeypatch):
    s, b = _overhanging()
    m = s.brick(-0.065, 2, on=(1,))  # refused too, and still moving when b is first asked
    s.engine.touch(b, m, [[0.0, 0.0, 1.5 * H]], normal=[1, 0, 0])
    s.engine.velocities[m] = (np.array([0.05, 0.0, 0.0]), np.zeros(3))
    lone = s.brick(0.5, 1)
    asked = []
    real = s.ext._admit
    monkeypatch.setattr(s.ext, "_admit", lambda rec, *a: asked.append(rec.body) or real(rec, *a))
    s.ext.update(1.0)
    del s.engine.velocities[m]  # at rest from 1.03 on: rested at 1.08
    s.ext.update(1.03)
    s.ext.update(1.06)  # b asked and refused while m moved; then the lone brick frozen
    assert asked == [b, lone] and lone in s.engine.frozen
    s.ext.update(1.07)
    assert asked == [b, lone]  # the lone brick changed nothing b depends on: it waits
    s.ext.update(1.08)
    assert asked == [b, lone, m, b]  # m has rested: b asked again, after m, within its rest duration


class DroppingEngine(FakeEngine):
    """Forgets every contact of a body whose mass changes until the next step, as pybullet does."""

    def set_frozen(self, body, frozen, mass, at=None):
        super().set_frozen(body, frozen, mass, at)
        self.contacts = [c for c in self.contacts if body not in (c.body, c.other)]


def test_a_steps_contacts_are_read_in_full_before_a_freeze_drops_some():
    from shapely.geometry import box

    from stability._geometry import ContactArea

    s = Scene()
    s.engine = DroppingEngine(frozen={0})
    s.ext = StabilityExtension(s.engine, StabilityConfig(rest_duration=0.0))
    s.ext.add_ground(0, Plane(0.0))
    s.brick(0.0, 1)
    s.brick(0.0, 2, on=(1,))
    stack = s.ext._stack
    book = stack.contacts([1, 2], now=[1])  # b2's contacts are read when first needed
    assert sorted(book) == [1]
    area = ContactArea(box(-0.06, -0.012, 0.06, 0.012), 0.0, np.array([0.0, 0.0, 1.0]), exact=False)
    stack.freeze(stack.bodies[1], {0: area}, area, [])
    assert s.engine.contact_points([2]) == []  # the engine forgot b2's contacts with b1
    assert {c.other for c in book[2]} == {1}  # read before the freeze


def test_the_profile_rows_of_the_bench_name_functions_that_exist():
    """``stackdsl bench height`` finds each part of the profile by file and function name: a
    rename must not leave a row that silently reads 0 s."""
    import ast
    from pathlib import Path

    from stackdsl.bench.cost import PARTS

    root = Path(__file__).resolve().parents[1]
    for label, where in PARTS.items():
        for file, function in where:
            (path,) = [p for p in (root / "stability" / file, root / "stackdsl" / file) if p.exists()]
            names = {n.name for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.FunctionDef)}
            assert function in names, label


@pytest.mark.slow
def test_the_sampled_profile_of_a_tower_splits_its_steps_from_the_rest():
    from stackdsl.bench.cost import PHYSICS, format_profiles, profile_tower

    profile = profile_tower("extension report", 8)
    # sixteen bricks, each frozen as it lands, two or three steps after it is placed (before a placed
    # brick froze where it lands, each took a dozen steps or more to come to rest)
    assert 16 * 2 <= profile.steps <= 16 * 4, profile.steps
    assert 0 < profile.parts[PHYSICS] < profile.total
    assert 0 < profile.parts["stability extension, all of it"] < profile.total
    physics, rest = profile.per_step
    assert physics > 0 and rest > 0
    assert abs((physics + rest) * profile.steps - profile.wall) < 1e-9
    table = format_profiles([profile])
    assert "| per step: the engine's step |" in table and f"| physics steps taken | {profile.steps} |" in table


def test_a_debris_pile_is_held_by_equilibrium_until_something_else_rests_on_it():
    from stability._stack import Record

    rec = Record(1, "b1", KAPLA, BrickState.FROZEN, 1, 0.5, pile=frozenset({1, 2}), objects_above={2})
    assert rec.held_by_pile()
    rec.objects_above.add(5)  # a brick from outside the pile came to rest on it
    assert not rec.held_by_pile()
    assert not Record(3, "b3", KAPLA, BrickState.FROZEN, 3, 0.5, objects_above={2}).held_by_pile()


@pytest.mark.parametrize("speed, at_rest", [(0.006, True), (0.009, False)])
def test_a_fallen_pile_is_at_rest_when_its_kinetic_energy_is_under_that_at_the_rest_thresholds(speed, at_rest):
    """Two fallen bricks, one at rest and one whose rest clock has only just started: the
    pile is at rest as a whole while its kinetic energy is at most what both would carry at
    the rest thresholds (5 mm/s and 0.05 rad/s: the second may move at up to 7.5 mm/s)."""
    s = Scene(StabilityConfig(rest_duration=0.05))
    b1, b2 = s.brick(0.0, 1), s.brick(0.03, 2, on=(1,))
    stack = s.ext._stack
    for body, since in ((b1, 0.5), (b2, 1.0)):
        stack.bodies[body].clock.fallen, stack.bodies[body].clock.since = True, since
    s.engine.velocities[b2] = (np.array([speed, 0.0, 0.0]), np.zeros(3))
    contacts = stack.contacts([b1, b2], now=[b1, b2])
    pile = s.ext._debris._pile(stack.bodies[b1], contacts, 1.0)
    assert [r.body for r in pile] == ([b1, b2] if at_rest else [])
    s.engine.velocities[b2] = (np.array([0.0, 0.0, 0.0]), np.zeros(3))
    stack.bodies[b2].clock.fallen = False  # a placed brick is not taken along before it is at rest
    contacts = stack.contacts([b1, b2], now=[b1, b2])  # another step's (a step's pile is gathered once)
    assert s.ext._debris._pile(stack.bodies[b1], contacts, 1.0) == []


def test_a_contact_polygon_between_tilted_faces_lies_on_them():
    """The equilibrium program's polygon for a brick lying face to face on a fixed brick tilted
    30 deg: its vertices on the support's top face (they were at its mean height)."""
    from scipy.spatial.transform import Rotation

    s = Scene()
    tilt = Rotation.from_euler("y", 30, degrees=True)
    up = tilt.apply([0, 0, 1.0])
    support = Pose(np.array([0.0, 0.0, 0.1]), tilt.as_quat())
    s.engine.poses[7], s.engine.frozen = support, s.engine.frozen | {7}
    s.ext.add_ground(7, KAPLA, "ramp")
    body = s.brick(0.0, 1, on=())
    s.engine.poses[body] = Pose(support.position + 0.008 * up, tilt.as_quat())
    s.engine.touch(body, 7, [support.position + 0.004 * up], normal=up)
    points = [c for c in s.engine.contacts if c.body == body]
    (polygon,) = s.ext._areas.polygons(s.ext._stack.bodies[body], {7: points})
    assert len(polygon.points) == 4
    assert np.abs((polygon.points - (support.position + 0.004 * up)) @ up).max() < 1e-9


@pytest.mark.parametrize("tilt", [0.0, 10.0, 32.0, 44.0])
@pytest.mark.parametrize("yaw", [0.0, 90.0])
def test_a_brick_lying_on_a_tilted_face_is_found_on_it_from_the_poses(tilt, yaw):
    """A brick lying face to face on a fixed ramp, along or across the slope: its bottom face
    reaches below the ramp's top corner by the tilt (12.7 mm across a 24 mm face at 32 deg), and it
    is still found lying on the ramp, and on nothing when lifted 2 mm off it. A brick refused
    admission is carried on what it is found on: a column on a 32 deg ramp was built on to level 8."""
    s = Scene()
    ramp = Pose.from_euler([0.0, 0.0, 0.0], pitch=-tilt)
    up = ramp.rotation[:, 2]
    s.engine.poses[7], s.engine.frozen = ramp, s.engine.frozen | {7}
    s.ext.add_ground(7, Box(np.array([0.2, 0.1, 0.01]), 1.0), "ramp")
    body = s.brick(0.0, 1, on=())
    turned = Pose.from_euler([0.0, 0.0, 0.0], yaw=yaw, pitch=-tilt if yaw == 0.0 else 0.0, roll=-tilt if yaw else 0.0)
    areas, rec = s.ext._areas, s.ext._stack.bodies[body]
    for lift, found in ((0.0, [7]), (0.002, [])):
        pose = Pose(ramp.position + (0.014 + lift) * up, turned.orientation)
        assert list(areas.lying_on(rec, pose)) == found
        assert list(areas.lying_on(rec, pose, active=True)) == found


def test_the_report_rule_wakes_nothing_that_rigid_block_equilibrium_holds():
    # The same columns and beam, B's load over R2's inner edge: the lever rule puts R2's share at
    # the middle of B's patch (56 mm) and finds R2's centre of mass above 0.55 mm outside its own
    # patch [48, 52] mm; but B may push anywhere on its patch, at 54 mm R2 holds (f (x - 52 mm)
    # = 0.755 x 2 mm <= 2 mm), so the program holds the stack and nothing wakes.
    engine = FakeEngine()
    ext = StabilityExtension(engine, StabilityConfig(rest_duration=0.0, face_gap=-1.0))
    engine.frozen.add(0)
    ext.add_ground(0, Plane(0.0))
    for body, x, level, on, (x0, x1) in (
        (1, -0.05, 1, 0, (-0.06, -0.04)),
        (2, 0.05, 1, 0, (0.04, 0.06)),
        (3, -0.05, 2, 1, (-0.052, -0.048)),
        (4, 0.05, 2, 2, (0.048, 0.052)),
    ):
        engine.poses[body] = Pose.from_euler([x, 0, (level - 0.5) * H])
        ext.add_brick(body, KAPLA, f"b{body}")
        z = (level - 1) * H
        engine.touch(body, on, [[x0, -0.01, z], [x1, -0.01, z], [x1, 0.01, z], [x0, 0.01, z]], normal=[0, 0, 1])
        ext.update(0.1 * body)
    engine.poses[5] = Pose.from_euler([0.03, 0, 2.5 * H])
    ext.add_brick(5, KAPLA, "b5")
    for on, (x0, x1) in ((3, (-0.046, -0.042)), (4, (0.054, 0.058))):
        engine.touch(5, on, [[x0, -0.01, 2 * H], [x1, -0.01, 2 * H], [x1, 0.01, 2 * H], [x0, 0.01, 2 * H]], normal=[0, 0, 1])
    events = ext.update(1.0)
    assert [(e.kind, e.label) for e in events] == [("freeze", "b5")]
    assert all(ext.state(b) is BrickState.FROZEN for b in range(1, 6))


def test_bricks_frozen_on_an_active_brick_wake_once_it_has_moved_away():
    # the edge of a settled pile: a frozen brick leans on an active one, which the stack watches
    s = Scene()
    frozen = s.brick(0.0, 1)
    s.ext.update(0.0)
    edge = s.brick(0.2, 1)
    stack = s.ext._stack
    stack.watch(stack.bodies[edge], {frozen})
    start = s.engine.poses[edge]
    s.engine.poses[edge] = Pose(start.position + [0.0005, 0.0, 0.0], start.orientation)  # half a contact pad
    assert stack.moved_away(1.0, 0.001) == [] and s.ext.state(frozen) is BrickState.FROZEN
    s.engine.poses[edge] = Pose(start.position + [0.0015, 0.0, 0.0], start.orientation)
    woken = stack.moved_away(1.1, 0.001)
    assert [w.event.label for w in woken] == ["b1"] and "b2, which it leaned on, moved 1.5 mm" in woken[0].event.reason
    assert s.ext.state(frozen) is BrickState.ACTIVE and not stack.watched
    # a watched brick that is frozen itself is a support like any other: no longer watched
    stack.watch(stack.bodies[frozen], {edge})
    s.ext.update(1.2)
    assert s.ext.state(frozen) is BrickState.FROZEN
    stack.moved_away(1.3, 0.001)
    assert frozen not in stack.watched


def test_a_brick_frozen_resting_on_an_active_one_is_never_its_support():
    # frozen on a settled pile's edge, b2 rests on b1; b1, frozen later, must not rest on b2 (the two
    # would carry each other: a cycle in the load tree)
    s = Scene()
    b1 = s.brick(0.0, 1, on=())
    b2 = s.brick(0.0, 2, on=())
    stack = s.ext._stack
    rec1, rec2 = stack.bodies[b1], stack.bodies[b2]
    s.engine.touch(b1, b2, corners(0.0, 0.0, 0.012, 0.012, H), normal=[0, 0, 1])  # as b1 sees it: lying on b2
    areas = s.ext._areas
    assert list(areas.supports(rec1, s.engine.contact_points([b1]), stack_only=False)) == []  # b2 is active, higher
    rec2.rests_on = {b1: None}
    rec2.state = BrickState.FROZEN
    assert list(areas.supports(rec1, s.engine.contact_points([b1]), stack_only=True)) == []
    rec2.rests_on = {}
    assert list(areas.supports(rec1, s.engine.contact_points([b1]), stack_only=True)) == [b2]


def test_a_woken_brick_says_whether_it_rested_on_the_one_woken_or_lay_in_its_pile():
    """The bricks of a pile wake together (the debris rule links them both ways); a brick woken
    so did not rest on the one whose wake woke it, and says so; one that rests on it says that."""
    s = Scene()
    a, _ = s.place(0.0, 1)
    b, _ = s.place(0.2, 1)
    s.place(0.0, 2, on=(a,))
    stack = s.ext._stack
    ra, rb = stack.bodies[a], stack.bodies[b]
    ra.objects_above.add(b)  # as Admission.freeze_group links the members of a pile
    rb.objects_above.add(a)
    events = s.ext.wake(a, 1.0, "moved by hand")
    reasons = {e.label: e.reason for e in events}
    assert reasons == {"b1": "moved by hand", "b2": "was frozen in one pile with b1", "b3": "rests on b1"}


def test_the_impact_rule_sees_a_blow_by_the_path_of_the_impactors_closest_point():
    """A toppling domino's top edge, 3 mm behind the next domino's face and coming at it down and
    forward at 45 deg, reaches it within the look-ahead; a brick thrown level 8 mm above a
    brick's top, closing on its edge, passes over it; a point moving away reaches nothing."""
    from stability._engine import ContactPoint
    from stability._impact import _reaches

    domino = Box(np.array([0.004, 0.012, 0.06]), 0.0106)  # on end, its faces facing -x and +x
    at = Pose.from_euler([0.0, 0.0, 0.06])
    window, pad = 1.5 / 240, 0.001
    edge = ContactPoint(1, 2, np.array([-0.004, 0.0, 0.1]), np.array([-1.0, 0.0, 0.0]), distance=0.003)
    centre = np.array([-0.05, 0.0, 0.06])  # the toppling domino's centre of mass, behind and below its top edge
    spin = np.zeros(3)
    assert _reaches(edge, np.array([0.6, 0.0, -0.6]), spin, centre, domino, at, window, pad)
    assert not _reaches(edge, np.array([-0.6, 0.0, -0.6]), spin, centre, domino, at, window, pad)
    # the same point carried by the spin about the toppling domino's foot, its centre at rest
    foot = np.array([-0.096, 0.0, 0.0])
    omega = np.array([0.0, 8.0, 0.0])  # rad/s about +y: the top moves towards +x and down
    assert _reaches(edge, np.zeros(3), omega, foot, domino, at, window, pad)
    # a thrown brick 8 mm above a flat brick's top, 5 mm out from its edge, heading in at 1 m/s
    flat, below = KAPLA, Pose.from_euler([0.0, 0.0, 0.004])
    over = ContactPoint(1, 2, np.array([0.06, 0.0, 0.008]), np.array([0.53, 0.0, 0.85]), distance=np.hypot(0.005, 0.008))
    assert not _reaches(over, np.array([-1.0, 0.0, 0.0]), spin, np.array([0.1, 0.0, 0.02]), flat, below, window, pad)
    level = ContactPoint(1, 2, np.array([0.06, 0.0, 0.004]), np.array([1.0, 0.0, 0.0]), distance=0.005)
    assert _reaches(level, np.array([-1.0, 0.0, 0.0]), spin, np.array([0.1, 0.0, 0.004]), flat, below, window, pad)


def _under_a_piles_edge_failing_the_rule(monkeypatch: pytest.MonkeyPatch) -> tuple[Scene, int, int]:
    """A brick that came to rest in this update under the edge of a pile frozen leaning on it
    while it still moved, and the report's rule made to fail it: (scene, brick, pile)."""
    from shapely.geometry import box as rect

    from stability._geometry import ContactArea

    s = Scene()
    stack = s.ext._stack
    edge = s.brick(0.2, 1)
    s.engine.velocities[edge] = (np.array([0.05, 0.0, 0.0]), np.zeros(3))  # still moving
    pile = s.brick(0.25, 2, on=(edge,))
    up = np.array([0.0, 0.0, 1.0])
    on_edge = ContactArea(rect(0.238, -0.012, 0.262, 0.012), H, up, exact=True)
    leaning = ContactArea(rect(0.238, -0.012, 0.36, 0.012), H, up, exact=False)  # with what else it leans on
    stack.bodies[pile].clock.fallen = True  # a pile of bricks that fell (the debris rule's)
    stack.freeze(stack.bodies[pile], {edge: on_edge}, leaning, [])
    stack.watch(stack.bodies[edge], {pile})
    s.engine.velocities.pop(edge)
    failing = stack.bodies[edge]
    holds = s.ext._tests.areas.holds
    monkeypatch.setattr(s.ext._tests.areas, "holds", lambda main, point: main is not failing.main_contact and holds(main, point))
    return s, edge, pile


def test_a_freeze_under_a_piles_edge_that_fails_the_stack_test_is_undone_alone(monkeypatch):
    """A brick frozen this step, under the edge of a pile frozen leaning on it while it moved:
    when the report's rule fails it, its freeze is undone (it stays active, watched) and the
    pile stays frozen; the pile woke with it before (43 dominoes of a fallen row, to freeze
    again). Bricks frozen on it in the same step are no such pile: they wake with it."""
    s, edge, pile = _under_a_piles_edge_failing_the_rule(monkeypatch)
    stack = s.ext._stack
    from stability import _stack_test

    asked = []  # statics is asked first, and here says it does not stand either
    monkeypatch.setattr(_stack_test, "solve_equilibrium", lambda *a, **k: asked.append(a) or SimpleNamespace(stands=False))
    events = s.ext.update(1.0)
    assert len(asked) == 1
    assert [(e.kind, e.label) for e in events] == [("freeze", "b1"), ("wake", "b1")]
    assert "not frozen after all" in events[1].reason
    assert s.ext.state(edge) is BrickState.ACTIVE and s.ext.state(pile) is BrickState.FROZEN
    assert pile in stack.watched[edge][1]  # it wakes the pile if it moves away
    monkeypatch.undo()
    # a column frozen in one step on a brick that then fails: all of it wakes
    s = Scene()
    b1, _ = s.place(0.0, 1)
    b2 = s.brick(0.035, 2, on=(b1,))
    b3 = s.brick(0.07, 3, on=(b2,))
    b4 = s.brick(0.105, 4, on=(b3,))
    events = s.ext.update(1.0)
    assert [(e.kind, e.label) for e in events][-3:] == [("wake", "b2"), ("wake", "b3"), ("wake", "b4")]
    assert all(s.ext.state(b) is BrickState.ACTIVE for b in (b2, b3, b4))


def test_a_freeze_under_a_piles_edge_that_statics_holds_is_kept(monkeypatch):
    """The same brick under a pile's edge, failing the report's rule where rigid-block
    equilibrium holds it (the rule puts a share at its contact area's centre, beyond the
    brick's own support): it stays frozen, as the rule's other failures do. A fallen domino row
    on the report's model woke such a brick at the very step it froze."""
    s, edge, pile = _under_a_piles_edge_failing_the_rule(monkeypatch)
    events = s.ext.update(1.0)
    assert [(e.kind, e.label) for e in events] == [("freeze", "b1")]
    assert s.ext.state(edge) is BrickState.FROZEN and s.ext.state(pile) is BrickState.FROZEN


def test_the_graph_of_a_heap_of_active_bricks_looks_at_each_box_once(monkeypatch):
    # what each active brick lies on face to face is found among the boxes near it: looking at
    # every other body's box for each brick cost 20 s for the graph of a fallen 500-level tower
    s = Scene()
    n = 60
    lower = [s.brick(0.2 * i, 1, on=()) for i in range(n)]  # no contact points: faces alone tell
    upper = [s.brick(0.2 * i + 0.03, 2, on=()) for i in range(n)]
    calls = 0
    corners = Box.corners

    def counted(self, pose):
        nonlocal calls
        calls += 1
        return corners(self, pose)

    monkeypatch.setattr(Box, "corners", counted)
    graph = s.ext.graph()
    rests = {(e.upper, e.support) for e in graph.edges}
    assert rests == {(f"b{u}", f"b{b}") for u, b in zip(upper, lower)} | {(f"b{b}", "ground") for b in lower}
    assert calls < 10 * 2 * n  # a few a brick, not one for each pair (2n * 2n = 14400)


JENGA = """\
stackdsl: 1
materials: {maple: {density: 700 kg/m^3, friction: 0.4}}
brick_types: {jenga: {size: [75 mm, 25 mm, 15 mm], material: maple}}
ground: {material: maple}
structure: {tower: {levels: 5, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}
timing: {interval: 0.5 s, settle: 1 s}
actions: [{remove: {brick: L02.2, at: after level 5, speed: 150 mm/s}}]
expect: {stands: true}
"""


def test_a_brick_woken_and_frozen_again_before_its_supports_rests_on_all_of_them():
    """A pull wakes the bricks above it; those that freeze again before a brick under them does
    rest on it once it freezes too: each brick of a Jenga tower rests on every brick of the level
    below that is still there (three, or two over the pulled one), whichever froze first, and the
    load is shared among them (a third each), not piled on the middle one."""
    from stackdsl import compile_scenario, parse_scenario, run_program

    graph = run_program(compile_scenario(parse_scenario(JENGA))).golden()["final_graph"]
    for brick, fields in graph.items():
        level = fields["level"]
        if level == 1:
            continue
        below = {b for b, f in graph.items() if f["level"] == level - 1}
        assert set(fields["rests_on"]) == below, brick
        shares = [s["load_share"] for s in fields["rests_on"].values()]
        assert max(shares) - min(shares) < 0.1, (brick, shares)


def test_a_brick_tilted_on_its_supports_edge_is_not_frozen_at_the_turning_point_of_a_rock():
    """At rest is face to face on its support: a brick on one support, tilted to it by 0.5 to
    10 deg, touches it along an edge only, as at the still top of a rock; it is refused (and
    asked again once it lies flat)."""
    s = Scene()
    base, _ = s.place(0.0, 1)
    top = s.n + 1
    s.n = top
    s.engine.poses[top] = Pose.from_euler([0.0595, 0.0, 1.5 * H + 0.0005], pitch=-1.5)  # its far end lifted
    s.ext.add_brick(top, KAPLA, f"b{top}")
    s.engine.touch(top, base, [[0.06, -0.012, H], [0.06, 0.012, H]], normal=[0, 0, 1])
    assert s.ext.update(1.0) == [] and s.ext.state(top) is BrickState.ACTIVE
    s.engine.poses[top] = Pose.from_euler([0.0595, 0.0, 1.5 * H])  # it came down flat on its face
    s.engine.touch(top, base, corners(0.03, 0.0, 0.03, 0.012, H), normal=[0, 0, 1])
    assert [e.kind for e in s.ext.update(1.1)] == ["freeze"]


@pytest.mark.parametrize(("x", "decided"), [(0.0595, True), (0.0598, True), (0.0585, False), (0.0605, False)])
def test_a_near_tie_is_frozen_by_statics_as_it_lands(x, decided):
    """A brick that lands face to face with its centre of mass inside its support's edge by
    less than the engine's contact margin (here 1 mm) is frozen at once by statics on its
    placed geometry, before any rest duration, and the event says so (proved); clear of the tie,
    or outside the edge, it waits for the rest test as ever."""
    s = Scene(StabilityConfig(rest_duration=0.05))
    base = s.brick(0.0, 1)
    s.ext.update(0.0)
    s.ext.update(0.06)
    assert s.ext.state(base) is BrickState.FROZEN
    top = s.n + 1
    s.n = top
    s.engine.poses[top] = Pose.from_euler([x, 0.0, 1.5 * H + 0.0005])  # in the air still: its drop gap
    s.ext.add_brick(top, KAPLA, f"b{top}", near_tie=0.001)
    s.engine.touch(top, base, corners((x + 0.06 - 0.06) / 2, 0.0, (0.12 - x) / 2, 0.012, H), normal=[0, 0, 1])
    assert s.ext.update(0.07) == []  # not landed yet
    s.engine.poses[top] = Pose.from_euler([x, 0.0, 1.5 * H])  # lowered onto its place
    events = s.ext.update(0.08)
    if decided:
        (freeze,) = events
        assert freeze.kind == "freeze" and freeze.proved and "by exact statics on its placed geometry" in freeze.reason
        assert f"{(0.06 - x) * 1000:.2f} mm inside its support's edge" in freeze.reason
    else:
        assert events == [] and s.ext.state(top) is BrickState.ACTIVE


def _clearance_scene():
    """A brick frozen at the origin and a moving one 0.3 m along x; the impact rule's bound."""
    from stability._impact import _Clearances

    s = Scene()
    frozen = s.brick(0.0, 1)
    s.ext.update(0.0)
    assert s.ext.state(frozen) is BrickState.FROZEN
    moving = s.brick(0.3, 1, on=())
    stack = s.ext._stack
    return s, stack, _Clearances(stack), stack.bodies[moving]


def test_a_body_far_from_every_frozen_box_is_measured_once_until_it_moves_near(monkeypatch):
    s, stack, clearances, rec = _clearance_scene()
    assert clearances.near([rec], [0.01]) == [False]
    measured = []
    gaps = type(stack).frozen_gaps
    monkeypatch.setattr(type(stack), "frozen_gaps", lambda self, *a: measured.append(1) or gaps(self, *a))
    s.engine.poses[rec.body] = Pose.from_euler([0.29, 0.0, H / 2])  # 10 mm nearer: far still
    assert clearances.near([rec], [0.01]) == [False] and measured == []  # the kept gap answers
    s.engine.poses[rec.body] = Pose.from_euler([0.125, 0.0, H / 2])  # 5 mm from the frozen brick's end
    assert clearances.near([rec], [0.01]) == [True] and measured == [1]
    s.engine.poses[rec.body] = Pose.from_euler([0.127, 0.0, H / 2])  # 2 mm on: near still, by the kept gap
    assert clearances.near([rec], [0.01]) == [True] and measured == [1]
    s.engine.poses[rec.body] = Pose.from_euler([0.14, 0.0, H / 2])  # 20 mm off: measured again, and not near
    assert clearances.near([rec], [0.01]) == [False] and measured == [1, 1]


def test_a_body_turning_near_a_frozen_box_is_measured_again():
    s, _, clearances, rec = _clearance_scene()
    s.engine.poses[rec.body] = Pose.from_euler([0.0, 0.08, H / 2])  # beside it, 56 mm off in y
    assert clearances.near([rec], [0.01]) == [False]
    s.engine.poses[rec.body] = Pose.from_euler([0.0, 0.08, H / 2], yaw=90)  # its end turned to 8 mm off
    assert clearances.near([rec], [0.01]) == [True]


def test_a_box_joining_the_frozen_ones_voids_every_kept_gap():
    s, stack, clearances, rec = _clearance_scene()
    assert clearances.near([rec], [0.01]) == [False]
    beside = s.brick(0.425, 1)  # 5 mm past the moving brick's end, on the ground
    s.ext.update(0.1)
    assert s.ext.state(beside) is BrickState.FROZEN
    assert clearances.near([rec], [0.01]) == [True]
    stack.wake(beside, 0.2, "a test")
    assert clearances.near([rec], [0.01]) == [True]  # near by its kept gap: the engine is asked, and finds nothing


def test_a_body_id_taken_again_is_measured_afresh():
    """A body the scene took away, its id given to a longer brick at the same pose: the kept gap
    was the first one's and is not used."""
    s, stack, clearances, rec = _clearance_scene()
    assert clearances.near([rec], [0.01]) == [False]  # 0.3 m along x: 180 mm from the frozen brick's end
    stack.forget(rec.body)
    s.ext.add_brick(rec.body, Box(np.array([0.25, 0.012, 0.004]), 0.05), "long")  # reaches to 50 mm along x
    assert clearances.near([stack.bodies[rec.body]], [0.01]) == [True]


def test_a_pushers_shadow_of_a_brick_is_found_again_where_it_froze_again():
    """What a pusher's path is measured against (the frozen brick's extent across the path) is
    kept for the pose the brick froze at, and found again once it froze somewhere else."""
    s = Scene()
    b = s.brick(0.0, 1)
    s.ext.update(0.0)
    stack = s.ext._stack
    axes, along = s.ext._across(99, np.array([0.05, 0.0, 0.0]))  # a pusher's path along +x
    assert along.tolist() == [1.0, 0.0]
    before = s.ext._shadow(stack.bodies[b], axes)
    assert s.ext._shadow(stack.bodies[b], axes) is before  # kept
    stack.wake(b, 0.1, "a test")
    s.engine.poses[b] = Pose.from_euler([0.0, 0.03, H / 2])  # 30 mm across the path
    s.ext.update(0.2)
    assert s.ext.state(b) is BrickState.FROZEN
    after = s.ext._shadow(stack.bodies[b], axes)
    moved = [abs(now - then) for then, now in zip(before[0], after[0], strict=True)]
    assert moved == pytest.approx([0.03, 0.03])  # its extent along the level axis across the path
