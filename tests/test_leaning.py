"""Leaning bricks (report 3.4-3.5) and impacts (3.6) on hand-built contact graphs."""

import math

import numpy as np
import pytest
from shapely.geometry import box

from stability import (
    Box,
    BrickState,
    ContactPolygon,
    FakeEngine,
    Plane,
    Pose,
    StabilityConfig,
    StabilityExtension,
    breaks_loose,
    kinetic_energy,
    lean_polygon,
    leaning_stands,
    pair_friction,
    potential_energy,
)
from stability._impact import tipping_energy

L = 0.12
M = 0.0106
UP = np.array([0.0, 0.0, 1.0])
KAPLA = Box(np.array([0.06, 0.012, 0.004]), M)


def thin_ladder(angle_deg: float, mu1: float, mu2: float) -> bool:
    """A thin rod from the floor to a wall at ``angle_deg`` from vertical."""
    a = math.radians(angle_deg)
    axis = np.array([math.sin(a), 0.0, math.cos(a)])
    contacts = [
        ContactPolygon("rod", "floor", np.zeros((1, 3)), UP, mu1),
        ContactPolygon("rod", "wall", (L * axis)[None], np.array([-1.0, 0.0, 0.0]), mu2),
    ]
    return leaning_stands({"rod": (L / 2 * axis, M)}, contacts)


def thin_vee(angle_deg: float, mu: float) -> bool:
    """Two thin rods leaning tip to tip, the force between them horizontal."""
    a = math.radians(angle_deg)
    left, right = np.array([-math.sin(a), 0, 0.0]) * L, np.array([math.sin(a), 0, 0.0]) * L
    apex = np.array([0.0, 0.0, L * math.cos(a)])
    contacts = [
        ContactPolygon("A", "floor", left[None], UP, mu),
        ContactPolygon("B", "floor", right[None], UP, mu),
        ContactPolygon("A", "B", apex[None], np.array([-1.0, 0.0, 0.0]), mu),
    ]
    return leaning_stands({"A": ((left + apex) / 2, M), "B": ((right + apex) / 2, M)}, contacts)


@pytest.mark.parametrize("mu1, mu2", [(0.5, 0.5), (0.4, 0.2), (0.6, 0.0)])
def test_ladder_limit_is_tan_2mu1_over_1_minus_mu1mu2(mu1, mu2):
    limit = math.degrees(math.atan(2 * mu1 / (1 - mu1 * mu2)))
    assert thin_ladder(limit * 0.99, mu1, mu2)
    assert not thin_ladder(limit * 1.01, mu1, mu2)


@pytest.mark.parametrize("mu", [0.5, 0.3])
def test_inverted_v_limit_is_tan_2mu_for_thin_bricks(mu):
    limit = math.degrees(math.atan(2 * mu))
    assert thin_vee(limit * 0.99, mu)
    assert not thin_vee(limit * 1.01, mu)


def test_one_v_brick_alone_against_a_fixed_partner_is_a_ladder():
    # Why the two bricks of a V are balanced together: against a fixed partner one brick
    # would stand up to the ladder limit (53.1 deg at mu = 0.5), beyond the V's 45 deg.
    assert thin_ladder(50, 0.5, 0.5) and not thin_vee(50, 0.5)


def test_friction_of_a_pair_is_the_geometric_mean():
    assert pair_friction(0.5, 0.5) == pytest.approx(0.5)
    assert pair_friction(0.8, 0.2) == pytest.approx(0.4)
    assert pair_friction(0.0, 0.5) == 0.0  # a frictionless body makes a frictionless pair


@pytest.mark.parametrize("a, b", [(-0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (math.nan, 0.5), (0.5, math.inf)])
def test_friction_of_a_pair_refuses_a_coefficient_no_material_has(a, b):
    # (-0.5, 0.5) was Python's own "math domain error"; (-0.5, -0.5) a coefficient of 0.5
    with pytest.raises(ValueError, match=r"pair_friction takes two finite friction coefficients >= 0"):
        pair_friction(a, b)


def test_lean_polygon_is_padded_across_the_normal():
    # Two points along a vertical edge on a wall facing -x: the polygon lies in the wall.
    points = np.array([[0.0, -0.012, 0.1], [0.0, 0.012, 0.1]])
    poly = lean_polygon(points, np.array([-1.0, 0.0, 0.0]), pad=0.001)
    assert np.allclose(poly[:, 0], 0.0)
    span_y, span_z = np.ptp(poly[:, 1]), np.ptp(poly[:, 2])
    assert span_y == pytest.approx(0.024) and span_z == pytest.approx(0.002)


def test_impact_energies_report_3_6():
    assert kinetic_energy(0.0106, 2.0) == pytest.approx(0.0212)
    assert potential_energy(0.1, 0.05, 0.01, gravity=10.0) == pytest.approx(0.04)
    assert potential_energy(0.1, 0.0, 0.01) == 0.0
    assert breaks_loose(0.05, 0.04) and not breaks_loose(0.04, 0.04)
    for mass in (-1.0, 0.0, float("nan")):
        with pytest.raises(ValueError, match="mass"):
            kinetic_energy(mass, 2.0)


# The rules inside the extension, on a fake engine ----------------------------------------
class Scene:
    def __init__(self, **config):
        self.engine = FakeEngine()
        self.ext = StabilityExtension(self.engine, StabilityConfig(rest_duration=0.0, **{"contact_pad": 1e-5, **config}))
        self.engine.frozen.add(0)
        self.ext.add_ground(0, Plane(0.0))

    def leaner(self, body, angle_deg, x_foot=0.0, lean=+1):
        """A KAPLA brick with its foot edge at x_foot, leaning toward +x (lean=+1) or -x."""
        a = math.radians(angle_deg)
        axis = np.array([lean * math.sin(a), 0.0, math.cos(a)])
        foot = np.array([x_foot, 0.0, 0.0])
        self.engine.poses[body] = Pose.from_euler(foot + L / 2 * axis, yaw=0 if lean > 0 else 180, pitch=angle_deg - 90)
        self.ext.add_brick(body, KAPLA, f"b{body}")
        self.engine.touch(body, 0, [foot + [0, -0.012, 0], foot + [0, 0.012, 0]], normal=UP)
        return foot + L * axis  # the top end


def wall_scene(angle_deg: float, **config) -> tuple[Scene, int]:
    s = Scene(**config)
    top = None
    s.engine.frozen.add(9)
    s.engine.poses[9] = Pose.from_euler([0.2, 0.0, 0.1])
    s.ext.add_ground(9, Box(np.array([0.01, 0.1, 0.1]), 1.0), "wall")
    top = s.leaner(1, angle_deg)
    s.engine.touch(1, 9, [top + [0, -0.012, 0], top + [0, 0.012, 0]], normal=[-1, 0, 0])
    return s, 1


def test_brick_leaning_on_a_wall_is_admitted_only_inside_the_ladder_limit():
    limit = math.degrees(math.atan(2 * 0.5 / (1 - 0.25)))
    s, b = wall_scene(limit - 1)
    events = s.ext.update(0.0)
    assert [(e.kind, e.reason) for e in events] == [("freeze", "leaning on ground, wall")]
    s, b = wall_scene(limit + 1)
    assert s.ext.update(0.0) == [] and s.ext.state(b) is BrickState.ACTIVE


def test_v_pair_is_admitted_together_and_wakes_together():
    s = Scene()
    top_a = s.leaner(1, 30, x_foot=-L * math.sin(math.radians(30)))
    s.leaner(2, 30, x_foot=L * math.sin(math.radians(30)), lean=-1)
    s.engine.touch(1, 2, [top_a + [0, -0.012, 0], top_a + [0, 0.012, 0]], normal=[-1, 0, 0])
    events = s.ext.update(0.0)
    assert [(e.kind, e.label) for e in events] == [("freeze", "b1"), ("freeze", "b2")]
    assert (
        events[0].reason == "leaning on ground, b2" and events[1].reason == "leaning on ground, b1"
    )  # its foot on the ground too
    assert [e.label for e in s.ext.wake(2, 0.1, "test")] == ["b2", "b1"]


def test_v_beyond_its_limit_is_not_admitted():
    s = Scene()
    top_a = s.leaner(1, 50, x_foot=-L * math.sin(math.radians(50)))
    s.leaner(2, 50, x_foot=L * math.sin(math.radians(50)), lean=-1)
    s.engine.touch(1, 2, [top_a + [0, -0.012, 0], top_a + [0, 0.012, 0]], normal=[-1, 0, 0])
    assert s.ext.update(0.0) == []


def test_leaning_on_a_moving_brick_is_not_admitted():
    s = Scene()
    top_a = s.leaner(1, 30, x_foot=-L * math.sin(math.radians(30)))
    s.leaner(2, 30, x_foot=L * math.sin(math.radians(30)), lean=-1)
    s.engine.touch(1, 2, [top_a + [0, -0.012, 0], top_a + [0, 0.012, 0]], normal=[-1, 0, 0])
    s.engine.velocities[2] = (np.array([0.05, 0, 0]), np.zeros(3))
    assert s.ext.update(0.0) == []


def test_more_than_two_leaning_contacts_are_beyond_the_reports_model():
    """The report's rules refuse a brick on three bodies; the debris rule's equilibrium, which
    counts any number, admits it."""
    s, b = wall_scene(40, debris=False)
    s.engine.frozen.add(8)
    s.engine.poses[8] = Pose.from_euler([0.03, 0.1, 0.1])
    s.ext.add_ground(8, Box(np.array([0.01, 0.1, 0.1]), 1.0), "post")
    s.engine.touch(b, 8, [[0.03, 0.0, 0.05]], normal=[0, -1, 0])
    assert s.ext.update(0.0) == []
    s2, b2 = wall_scene(40, max_leaning_bodies=3)
    s2.engine.frozen.add(8)
    s2.engine.poses[8] = Pose.from_euler([0.03, 0.1, 0.1])
    s2.ext.add_ground(8, Box(np.array([0.01, 0.1, 0.1]), 1.0), "post")
    s2.engine.touch(b2, 8, [[0.03, 0.0, 0.05]], normal=[0, -1, 0])
    assert [e.kind for e in s2.ext.update(0.0)] == ["freeze"]
    s3, b3 = wall_scene(40)
    s3.engine.frozen.add(8)
    s3.engine.poses[8] = Pose.from_euler([0.03, 0.1, 0.1])
    s3.ext.add_ground(8, Box(np.array([0.01, 0.1, 0.1]), 1.0), "post")
    s3.engine.touch(b3, 8, [[0.03, 0.0, 0.05]], normal=[0, -1, 0])
    assert [(e.kind, e.label) for e in s3.ext.update(0.0)] == [("freeze", "b1")]  # debris on: by equilibrium


def test_leaning_rule_off_leaves_the_brick_to_the_engine():
    """With neither the leaning rule nor the debris rule, a leaning brick is never frozen; the
    debris rule alone admits it (within the ladder's limit) and refuses it beyond."""
    s, _b = wall_scene(40, leaning=False, debris=False)
    assert s.ext.update(0.0) == []
    limit = math.degrees(math.atan(2 * 0.5 / (1 - 0.25)))
    for angle, frozen in ((limit - 1, True), (limit + 1, False)):
        s, b = wall_scene(angle, leaning=False)
        s.ext.update(0.0)
        assert (s.ext.state(b) is BrickState.FROZEN) is frozen


def test_contacts_at_different_heights_are_not_admitted_by_the_basic_test():
    # Report 3.5: a brick with one end on the ground and the other on a step 8 mm high is
    # leaning, even though its COM lies over the hull of its two contacts.
    s = Scene(leaning=False, debris=False)
    s.engine.frozen.add(7)
    s.engine.poses[7] = Pose.from_euler([0.1, 0.0, 0.004])
    s.ext.add_ground(7, Box(np.array([0.06, 0.06, 0.004]), 1.0), "step")
    s.engine.poses[1] = Pose.from_euler([0.0, 0.0, 0.008], pitch=-3.8)
    s.ext.add_brick(1, KAPLA, "plank")
    s.engine.touch(1, 0, [[-0.06, -0.012, 0.0], [-0.06, 0.012, 0.0]], normal=UP)
    s.engine.touch(1, 7, [[0.055, -0.012, 0.008], [0.055, 0.012, 0.008]], normal=UP)
    assert s.ext.update(0.0) == []
    flat = Scene(leaning=False, debris=False, lean_height=0.01)  # the same brick with a looser threshold
    flat.engine.frozen.add(7)
    flat.engine.poses[7] = s.engine.poses[7]
    flat.ext.add_ground(7, Box(np.array([0.06, 0.06, 0.004]), 1.0), "step")
    flat.engine.poses[1] = s.engine.poses[1]
    flat.ext.add_brick(1, KAPLA, "plank")
    flat.engine.contacts = list(s.engine.contacts)
    assert [e.kind for e in flat.ext.update(0.0)] == ["freeze"]


def impact_scene(speed: float, lowered: bool = False, spin: float = 0.0) -> tuple[Scene, list]:
    """A frozen column of two bricks; a projectile about to hit the top one at ``speed`` (with
    ``lowered``, a brick a hand sets down there), rolling about its length at ``spin`` rad/s."""
    s = Scene()
    for body, z in ((1, 0.004), (2, 0.012)):
        s.engine.poses[body] = Pose.from_euler([0.0, 0.0, z])
        s.ext.add_brick(body, KAPLA, f"b{body}")
        s.engine.touch(body, body - 1, [[-0.06, -0.012, z - 0.004], [0.06, 0.012, z - 0.004]], normal=UP)
        s.ext.update(0.1 * body)
    s.engine.poses[5] = Pose.from_euler([0.2, 0.0, 0.012])
    s.ext.add_brick(5, KAPLA, "hammer")
    s.engine.velocities[5] = (np.array([-speed, 0.0, 0.0]), np.array([spin, 0.0, 0.0]))
    s.engine.touch(5, 2, [[0.06, 0.0, 0.012]], normal=[1, 0, 0])
    if lowered:
        s.ext.lowering({5})
    return s, s.ext.update(1.0)


def test_an_impact_above_the_potential_energy_wakes_the_hit_brick():
    # The top brick's COM is 4 mm above its contact: PE = m g 0.004 = 0.42 mJ; KE at
    # 1 m/s = 5.3 mJ.
    s, events = impact_scene(1.0)
    assert [(e.kind, e.label, e.source) for e in events] == [("wake", "b2", "hammer")]
    assert "impact of hammer at 1.00 m/s: 5.3 mJ against 0.416 mJ" in events[0].reason
    # a brick rolling about its length: the spin, counted about its largest moment of inertia, is
    # most of the energy, and the words say it (a new user read 9.8 mJ at 0.21 m/s as a mistake)
    _, events = impact_scene(0.2, spin=38.0)
    assert "impact of hammer at 0.20 m/s and 38 rad/s: 9.7" in events[0].reason, events[0].reason
    assert s.ext.state(1) is BrickState.FROZEN


def test_an_impact_below_the_potential_energy_is_held():
    s, events = impact_scene(0.2)  # KE = 0.21 mJ
    assert [(e.kind, e.label) for e in events] == [("impact", "b2")]
    assert events[0].reason.startswith("held") and s.ext.state(2) is BrickState.FROZEN
    assert s.ext.update(1.01) == []  # the same approach is judged once


def test_a_brick_a_hand_sets_down_is_no_blow_until_it_lets_go():
    # the hammer of the scene above at 1 m/s, as a brick a hand lowers onto its place: the hand
    # stops it there, so the rule weighs no blow; let go of, the same approach wakes b2
    s, events = impact_scene(1.0, lowered=True)
    assert events == [] and s.ext.state(2) is BrickState.FROZEN
    s.ext.lowering(set())
    assert [(e.kind, e.label) for e in s.ext.update(1.01)] == [("wake", "b2")]


def domino_scene(speed: float, lintel: bool, across: bool = False, **config) -> tuple[Scene, list]:
    """A frozen KAPLA domino on end (8 mm along x, 24 along y, centre of mass 60 mm up); with
    ``lintel``, a second one at x = 100 mm and a flat KAPLA lying across their tops. A hammer
    about to strike the first one's -x face, heading +x, at ``speed`` (with ``across``, its -y
    face, heading +y)."""
    s = Scene(**config)
    feet = (0.0, 0.1) if lintel else (0.0,)
    for body, x in enumerate(feet, start=1):
        s.engine.poses[body] = Pose.from_euler([x, 0.0, 0.06], pitch=90)
        s.ext.add_brick(body, KAPLA, f"d{body}")
        s.engine.touch(body, 0, [[x - 0.004, -0.012, 0.0], [x + 0.004, 0.012, 0.0]], normal=UP)
    if lintel:
        s.engine.poses[3] = Pose.from_euler([0.05, 0.0, 0.124])
        s.ext.add_brick(3, KAPLA, "lintel")
        for leg, x in ((1, 0.0), (2, 0.1)):
            s.engine.touch(3, leg, [[x - 0.004, -0.012, 0.12], [x + 0.004, 0.012, 0.12]], normal=UP)
    s.ext.update(0.1)
    assert all(s.ext.state(b) is BrickState.FROZEN for b in range(1, len(feet) + 1 + lintel))
    s.ext.add_brick(5, KAPLA, "hammer")
    if across:
        s.engine.poses[5] = Pose.from_euler([0.0, -0.075, 0.1], yaw=90)
        s.engine.velocities[5] = (np.array([0.0, speed, 0.0]), np.zeros(3))
        s.engine.touch(5, 1, [[0.0, -0.012, 0.1]], normal=[0, -1, 0])
    else:
        s.engine.poses[5] = Pose.from_euler([-0.07, 0.0, 0.1])
        s.engine.velocities[5] = (np.array([speed, 0.0, 0.0]), np.zeros(3))
        s.engine.touch(5, 1, [[-0.004, 0.0, 0.1]], normal=[-1, 0, 0])
    return s, s.ext.update(1.0)


def test_a_blow_that_tips_a_lone_domino_over_wakes_it_though_it_could_not_lift_it():
    # KE at 0.3 m/s: 0.48 mJ. Lifting the domino's centre of mass 60 mm: 6.24 mJ (the report's
    # barrier); tipping it over the edge of its 8 mm foot: m g (sqrt(4^2 + 60^2) - 60) mm = 0.0138 mJ
    _, events = domino_scene(0.3, lintel=False)
    tip = M * 9.81 * (math.hypot(0.004, 0.06) - 0.06)
    assert [(e.kind, e.label, e.source) for e in events] == [("wake", "d1", "hammer")]
    assert f"0.477 mJ against {tip * 1000:.3g} mJ" in events[0].reason
    _, lifted = domino_scene(0.3, lintel=False, impact_energy="lift")  # the report's rule held it
    assert [(e.kind, e.label) for e in lifted] == [("impact", "d1")] and "against 6.24 mJ" in lifted[0].reason


def test_a_part_that_rests_on_a_brick_outside_it_is_tipped_over_its_whole_footprint():
    # the lintel lies on both dominoes: along the lintel the first post, with the lintel's share
    # above it, turns only over the far post's edge (braced: held); across it the part's support
    # polygon is still 24 mm wide, and a blow that tips it wakes it (12.7 mJ to lift the post
    # and its share held a 1 m/s KAPLA, 6.4 mJ, where the engines alone topple it)
    s, events = domino_scene(0.3, lintel=True)
    assert [(e.kind, e.label) for e in events] == [("impact", "d1")] and events[0].reason.startswith("held")
    assert s.ext.state(3) is BrickState.FROZEN
    s, events = domino_scene(0.3, lintel=True, across=True)
    assert ("wake", "d1") in [(e.kind, e.label) for e in events], [(e.kind, e.label, e.reason) for e in events]
    assert s.ext.state(3) is BrickState.ACTIVE  # the lintel rests on it


def _pusher(s: Scene, at: list[float]) -> None:
    """A 20 x 10 x 6 mm pusher (body 7) at ``at`` (m), guided by a hand at 50 mm/s from t = 0.2 s."""
    s.engine.poses[7] = Pose.from_euler(at)
    s.ext.add_brick(7, Box(np.array([0.01, 0.005, 0.003]), 0.001), "pusher")
    s.ext.guide(7, 0.2, "a pusher", 0.05)


def test_a_brick_a_hand_drives_into_a_frozen_one_breaks_it_loose():
    """A pusher drives a loose brick at 50 mm/s (0.013 mJ) into another lying on the ground: by
    its own energy the blow was held (0.42 mJ to lift the other), and the 100 kg hand pushed
    the first brick into the ground and under the second. Driven by a hand, it wakes it; one
    that only slides along a frozen brick (a brick riding on a pulled one) does not."""
    s = Scene()
    for body, y in ((1, -0.026), (2, 0.0)):
        s.engine.poses[body] = Pose.from_euler([0.0, y, 0.004])
        s.ext.add_brick(body, KAPLA, "AB"[body - 1])
        s.engine.touch(body, 0, [[-0.06, y - 0.012, 0.0], [0.06, y + 0.012, 0.0]], normal=UP)
    s.ext.update(0.1)
    _pusher(s, [0.0, -0.05, 0.004])
    s.engine.velocities[7] = (np.array([0.0, 0.05, 0.0]), np.zeros(3))
    s.engine.touch(7, 1, [[0.0, -0.038, 0.004]], normal=[0, -1, 0])  # the pusher on A
    s.ext.update(0.2)
    assert s.ext.state(1) is BrickState.ACTIVE
    s.engine.velocities[1] = (np.array([0.0, 0.05, 0.0]), np.zeros(3))
    s.engine.touch(1, 2, [[0.0, -0.012, 0.004]], normal=[0, -1, 0])  # A's face on B's
    events = s.ext.update(0.21)
    woken = [e for e in events if e.kind == "wake" and e.label == "B"]
    assert woken and "driven into it by a hand" in woken[0].reason
    # the same brick sliding along B's top face, not into it: nothing
    t = Scene()
    t.engine.poses[2] = Pose.from_euler([0.0, 0.0, 0.004])
    t.ext.add_brick(2, KAPLA, "B")
    t.engine.touch(2, 0, [[-0.06, -0.012, 0.0], [0.06, 0.012, 0.0]], normal=UP)
    t.ext.update(0.1)
    t.engine.poses[1] = Pose.from_euler([0.0, 0.0, 0.012])
    t.ext.add_brick(1, KAPLA, "A")
    _pusher(t, [0.0, -0.03, 0.012])
    t.engine.touch(7, 1, [[0.0, -0.012, 0.012]], normal=[0, -1, 0])
    t.ext.update(0.2)
    t.engine.velocities[1] = (np.array([0.0, 0.05, 0.0]), np.zeros(3))
    t.engine.touch(1, 2, [[-0.06, -0.012, 0.008], [0.06, 0.012, 0.008]], normal=UP)
    assert [e for e in t.ext.update(0.21) if e.label == "B" and e.kind == "wake"] == []


def test_impact_rule_off():
    s = Scene(impacts=False)
    s.engine.poses[1] = Pose.from_euler([0.0, 0.0, 0.004])
    s.ext.add_brick(1, KAPLA, "b1")
    s.engine.touch(1, 0, [[-0.06, -0.012, 0.0], [0.06, 0.012, 0.0]], normal=UP)
    s.ext.update(0.0)
    s.engine.poses[5] = Pose.from_euler([0.2, 0.0, 0.004])
    s.ext.add_brick(5, KAPLA, "hammer")
    s.engine.velocities[5] = (np.array([-5.0, 0.0, 0.0]), np.zeros(3))
    s.engine.touch(5, 1, [[0.06, 0.0, 0.004]], normal=[1, 0, 0])
    assert s.ext.update(1.0) == []


def slope_scene(model: str, angle: float) -> Scene:
    """A brick lying on a fixed ramp tilted ``angle`` deg, inside the 30 deg support angle."""
    a = math.radians(angle)
    s = Scene(model=model)
    s.engine.frozen.add(7)
    s.engine.poses[7] = Pose.from_euler([0.0, 0.0, -0.05], pitch=-angle)
    s.ext.add_ground(7, Box(np.array([0.2, 0.1, 0.05]), 1.0), "ramp")
    normal = np.array([math.sin(a), 0.0, math.cos(a)])
    along = np.array([math.cos(a), 0.0, -math.sin(a)])
    s.engine.poses[1] = Pose(0.004 * normal, Pose.from_euler([0, 0, 0], pitch=-angle).orientation)
    s.ext.add_brick(1, KAPLA, "b1")
    corners = [sx * 0.06 * along + [0, sy * 0.012, 0] for sx in (-1, 1) for sy in (-1, 1)]
    s.engine.touch(1, 7, corners, normal=normal)
    return s


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("angle", [10.0, 20.0, 26.0, 27.0, 28.0])
def test_a_brick_on_a_slope_is_frozen_only_within_its_friction_angle(model, angle):
    """tan(a) <= mu (0.5: 26.57 deg) in both models: the report's basic test needs no friction on
    level faces, and a support steeper than its friction angle is decided with friction."""
    assert bool(slope_scene(model, angle).ext.update(0.0)) is (math.tan(math.radians(angle)) <= 0.5)


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("angle", [27.0, 28.0])
def test_a_brick_in_a_groove_of_two_slopes_steeper_than_its_friction_angle_is_frozen(model, angle):
    """Each face alone is beyond the friction angle; the two push against each other, so the
    brick (its long axis along the groove) stays. Source: statics of a block in a V-groove."""
    s = Scene(model=model)
    a = math.radians(angle)
    s.engine.poses[1] = Pose.from_euler([0.0, 0.0, 0.0])  # long axis along x; the groove's faces slope across y
    s.ext.add_brick(1, KAPLA, "b1")
    for body, side in ((7, 1.0), (8, -1.0)):
        s.engine.frozen.add(body)
        s.engine.poses[body] = Pose.from_euler([0.0, side * 0.02, -0.02], roll=side * angle)
        s.ext.add_ground(body, Box(np.array([0.1, 0.02, 0.01]), 1.0), f"face{body}")
        normal = np.array([0.0, -side * math.sin(a), math.cos(a)])
        edge = [0.0, side * 0.012, -0.004]
        s.engine.touch(1, body, [np.add(edge, [x, 0.0, 0.0]) for x in (-0.06, 0.06)], normal=normal)
    events = s.ext.update(0.0)
    assert [e.kind for e in events] == ["freeze"], events


def test_equilibrium_model_wakes_the_mechanism_only():
    # A column leaning right by 35 mm a level on a base brick: with the fourth brick on,
    # the three upper bricks tip over the base's edge (their COM is at 70 mm, the edge at
    # 60 mm); the base stays frozen.
    s = Scene(model="equilibrium")
    for body, x in ((1, 0.0), (2, 0.035), (3, 0.07), (4, 0.105)):
        z = (body - 0.5) * 0.008
        s.engine.poses[body] = Pose.from_euler([x, 0.0, z])
        s.ext.add_brick(body, KAPLA, f"b{body}")
        s.engine.touch(body, body - 1, [[x - 0.01, 0.0, z - 0.004]], normal=UP)  # areas come from the faces
        events = s.ext.update(0.1 * body)
    assert events[0].kind == "freeze" and events[0].label == "b4"
    woken = [e.label for e in events if e.kind == "wake"]
    assert sorted(woken) == ["b2", "b3", "b4"] and s.ext.state(1) is BrickState.FROZEN
    assert "collapse mechanism" in next(e.reason for e in events if e.label == "b2")


def test_unknown_model_is_refused():
    with pytest.raises(ValueError, match="unknown stability model"):
        StabilityConfig(model="physics")


@pytest.mark.parametrize(
    "field, value, said",
    [
        ("rest_speed", -1.0, "rest_speed must be a finite speed >= 0 in m/s"),
        ("rest_angular_speed", math.nan, "rest_angular_speed must be a finite angular speed >= 0"),
        ("rest_duration", math.inf, "rest_duration must be a finite duration >= 0"),
        ("contact_pad", 0.0, "contact_pad must be a finite length > 0"),
        ("support_angle", 200.0, "support_angle must be an angle from 0 to 90 degrees"),
        ("support_angle", -1.0, "support_angle must be an angle from 0 to 90 degrees"),
        ("face_gap", math.nan, "face_gap must be a finite length"),
        ("com_margin", -0.001, "com_margin must be a finite length >= 0"),
        ("lean_height", -0.001, "lean_height must be a finite length >= 0"),
        ("gravity", 0.0, "gravity must be a finite acceleration > 0"),
        ("max_leaning_bodies", 0, "max_leaning_bodies must be at least 1"),
    ],
)
def test_a_threshold_out_of_its_physical_range_is_refused(field, value, said):
    with pytest.raises(ValueError, match=f"StabilityConfig.{said}"):
        StabilityConfig(**{field: value})


def test_a_threshold_that_is_no_number_is_refused_by_type():
    with pytest.raises(TypeError, match=r"StabilityConfig.rest_speed must be a number"):
        StabilityConfig(rest_speed="5 mm/s")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"StabilityConfig.max_leaning_bodies must be a whole number"):
        StabilityConfig(max_leaning_bodies=2.5)  # type: ignore[arg-type]


def test_the_edges_of_the_ranges_are_taken():
    # a negative face gap turns exact face areas off (the tests of engines' contact points use it)
    config = StabilityConfig(rest_speed=0, rest_duration=0.0, support_angle=90.0, face_gap=-1.0, com_margin=0.0)
    assert config.face_gap == -1.0 and config.support_angle == 90.0


def test_the_tipping_barrier_of_a_blow_is_housners_about_the_edge_its_line_passes_outside():
    """A counterweighted cantilever (two KAPLAs, 21.2 g, their centre of mass 3 mm inside a
    table's edge at x = 0 and 8 mm above it), struck straight down on its tip 75 mm out: the
    blow turns it over the edge, m g (sqrt(3^2 + 8^2) - 8) mm = 0.113 mJ, not 1.66 mJ to lift
    it. Struck inside the table's edge, or by a blow whose line meets the table inside it, it
    is pressed on its base: lifting it is the barrier."""
    table = box(-0.1, -0.012, 0.0, 0.012)
    mass, com, base, down = 2 * M, np.array([-0.003, 0.0, 0.048]), 0.04, np.array([0.0, 0.0, -1.0])
    housner = mass * 9.81 * (math.hypot(0.003, 0.008) - 0.008)
    lift = potential_energy(mass, 0.048, base)
    assert lift == pytest.approx(1.66e-3, abs=1e-5) and housner == pytest.approx(0.113e-3, abs=1e-6)
    for tip in ([0.075, 0.0, 0.048], [0.075, 0.01, 0.048], [0.001, -0.012, 0.044]):  # off its axis too
        assert tipping_energy(mass, com, table, base, down, point=np.array(tip)) == pytest.approx(housner)
    for inside in ([-0.05, 0.0, 0.048], [0.0, 0.0, 0.048], [-0.003, 0.0, 0.056]):  # on the edge: no moment
        assert tipping_energy(mass, com, table, base, down, point=np.array(inside)) == pytest.approx(lift)
    # 45 degrees down and out: struck 8 mm above the base, the line meets it 8 mm further out
    slant = np.array([1.0, 0.0, -1.0]) / math.sqrt(2.0)
    assert tipping_energy(mass, com, table, base, slant, point=np.array([-0.005, 0.0, 0.048])) == pytest.approx(housner)
    assert tipping_energy(mass, com, table, base, slant, point=np.array([-0.02, 0.0, 0.048])) == pytest.approx(lift)
    # up and in, under the overhang, past the edge: it turns the overhang up, over the far edge
    up = np.array([0.0, 0.0, 1.0])
    far = mass * 9.81 * (math.hypot(0.097, 0.008) - 0.008)
    assert tipping_energy(mass, com, table, base, up, point=np.array([0.075, 0.0, 0.04])) == pytest.approx(far)


def test_a_horizontal_blow_tips_the_part_over_the_edge_ahead_along_it_as_before():
    """A domino's 8 mm foot, its centre of mass 60 mm up: 4 mm to the edge ahead whatever the
    height struck, and a heading a hair off the axis never opens the 12 mm side; a trilithon
    post braced along its lintel (its part's polygon reaches the far post, 74 mm ahead) is not
    tipped sideways by a blow 1e-4 off the lintel's line."""
    foot, com = box(-0.004, -0.012, 0.004, 0.012), np.array([0.0, 0.0, 0.06])
    domino = M * 9.81 * (math.hypot(0.004, 0.06) - 0.06)
    for heading in ([1.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1e-7, 0.0], [1.0, -1e-4, 0.0]):
        for point in (None, np.array([-0.004, 0.0, 0.1]), np.array([-0.004, 0.0, 0.01])):
            assert tipping_energy(M, com, foot, 0.0, np.array(heading), point=point) == pytest.approx(domino, rel=1e-6)
    span, post = box(-0.004, -0.012, 0.104, 0.012), np.array([0.03, 0.0, 0.07])
    along = 2 * M * 9.81 * (math.hypot(0.074, 0.07) - 0.07)
    hit = np.array([-0.004, 0.0, 0.1])
    assert tipping_energy(2 * M, post, span, 0.0, np.array([1.0, 1e-4, 0.0]), point=hit) == pytest.approx(along, rel=1e-6)
    across = 2 * M * 9.81 * (math.hypot(0.012, 0.07) - 0.07)
    assert tipping_energy(2 * M, post, span, 0.0, np.array([0.0, 1.0, 0.0]), point=hit) == pytest.approx(across)
    # a blow 30 degrees off the axis turns the domino over the same edge: 4 mm across it
    oblique = np.array([math.cos(math.radians(30)), math.sin(math.radians(30)), 0.0])
    assert tipping_energy(M, com, foot, 0.0, oblique, point=hit) == pytest.approx(domino)


def _rectangle(x0: float, x1: float, z: float) -> list[list[float]]:
    """The corners of a KAPLA-wide contact from x0 to x1 (m) at height z."""
    return [[x0, -0.012, z], [x1, -0.012, z], [x1, 0.012, z], [x0, 0.012, z]]


def cantilever_scene(speed: float, at_x: float = 0.075) -> tuple[Scene, list]:
    """A KAPLA A sticking 80 mm out over a fixed table's edge (x = 0, top z = 40 mm), a KAPLA B
    on its back end (their centre of mass 3 mm inside the edge, 8 mm above it); a 10 mm pine
    cube about to land on A's top at ``at_x``, straight down at ``speed``."""
    s = Scene()
    s.engine.frozen.add(9)
    s.engine.poses[9] = Pose.from_euler([-0.1, 0.0, 0.02])
    s.ext.add_ground(9, Box(np.array([0.1, 0.05, 0.02]), 1.0), "table")
    s.engine.poses[1] = Pose.from_euler([0.02, 0.0, 0.044])
    s.ext.add_brick(1, KAPLA, "A")
    s.engine.touch(1, 9, _rectangle(-0.04, 0.0, 0.04), normal=UP)
    s.engine.poses[2] = Pose.from_euler([-0.026, 0.0, 0.052])
    s.ext.add_brick(2, KAPLA, "B")
    s.engine.touch(2, 1, _rectangle(-0.04, 0.034, 0.048), normal=UP)
    s.ext.update(0.1)
    assert s.ext.state(1) is BrickState.FROZEN and s.ext.state(2) is BrickState.FROZEN
    s.engine.poses[5] = Pose.from_euler([at_x, 0.0, 0.0535])
    s.ext.add_brick(5, Box(np.array([0.005, 0.005, 0.005]), 0.00046), "pebble")
    s.engine.velocities[5] = (np.array([0.0, 0.0, -speed]), np.zeros(3))
    s.engine.touch(5, 1, [[at_x, 0.0, 0.048]], normal=UP)
    return s, s.ext.update(1.0)


@pytest.mark.parametrize("speed", [1.0, 2.0])
def test_a_blow_straight_down_on_a_cantilevers_tip_tips_it_over_the_table_edge(speed):
    # 0.23 mJ at 1 m/s against 0.113 mJ to turn the pair over the edge; lifting it takes 1.66 mJ,
    # which held it where every tuned engine topples it
    s, events = cantilever_scene(speed)
    housner = 2 * M * 9.81 * (math.hypot(0.003, 0.008) - 0.008)
    assert [(e.kind, e.label) for e in events] == [("wake", "A"), ("wake", "B")]
    assert f"against {housner * 1000:.3g} mJ" in events[0].reason
    assert s.ext.state(1) is BrickState.ACTIVE


def test_a_gentle_tap_on_the_tip_or_a_blow_down_inside_the_table_is_held():
    s, events = cantilever_scene(0.2)  # 0.0092 mJ
    assert [(e.kind, e.label) for e in events] == [("impact", "A")] and "against 0.113 mJ" in events[0].reason
    # the least any part tips for, found once for the stack as it is: the pair over the table's
    # edge, below which no blow needs a part under the struck one weighed
    housner = 2 * M * 9.81 * (math.hypot(0.003, 0.008) - 0.008)
    assert s.ext._impacts._least_tip() == pytest.approx(housner, rel=1e-3)
    _, events = cantilever_scene(2.0, at_x=-0.02)  # over the table: pressed on it, lifting is the barrier
    assert [(e.kind, e.label) for e in events] == [("impact", "A")] and "0.92 mJ against 1.66 mJ" in events[0].reason


def test_a_blow_straight_down_on_a_flat_brick_is_weighed_against_lifting_it():
    for speed, kind in ((0.2, "impact"), (1.0, "wake")):  # 0.21 and 5.3 mJ, struck 10 mm in from its end
        s = Scene()
        s.engine.poses[1] = Pose.from_euler([0.0, 0.0, 0.004])
        s.ext.add_brick(1, KAPLA, "b1")
        s.engine.touch(1, 0, _rectangle(-0.06, 0.06, 0.0), normal=UP)
        s.ext.update(0.1)
        s.engine.poses[5] = Pose.from_euler([0.05, 0.0, 0.012])
        s.ext.add_brick(5, KAPLA, "hammer")
        s.engine.velocities[5] = (np.array([0.0, 0.0, -speed]), np.zeros(3))
        s.engine.touch(5, 1, [[0.05, 0.0, 0.008]], normal=UP)
        events = s.ext.update(1.0 + speed)
        assert [(e.kind, e.label) for e in events] == [(kind, "b1")] and "against 0.416 mJ" in events[0].reason


def flush_stack_scene(speed: float) -> tuple[Scene, list]:
    """Three KAPLAs lying flush on each other on a fixed table (top z = 40 mm), their common
    centre of mass 2 mm inside its edge (x = 0); a 10 mm pine cube about to land straight down
    on the top one's tip, 54 mm past the edge, at ``speed``."""
    s = Scene()
    s.engine.frozen.add(9)
    s.engine.poses[9] = Pose.from_euler([-0.1, 0.0, 0.02])
    s.ext.add_ground(9, Box(np.array([0.1, 0.05, 0.02]), 1.0), "table")
    for body, below, z in ((1, 9, 0.044), (2, 1, 0.052), (3, 2, 0.060)):
        s.engine.poses[body] = Pose.from_euler([-0.002, 0.0, z])
        s.ext.add_brick(body, KAPLA, "ABC"[body - 1])
        s.engine.touch(body, below, _rectangle(-0.062, 0.0 if below == 9 else 0.058, z - 0.004), normal=UP)
        s.ext.update(0.1 * body)
    assert all(s.ext.state(b) is BrickState.FROZEN for b in (1, 2, 3))
    s.engine.poses[5] = Pose.from_euler([0.052, 0.0, 0.0695])
    s.ext.add_brick(5, Box(np.array([0.005, 0.005, 0.005]), 0.00046), "pebble")
    s.engine.velocities[5] = (np.array([0.0, 0.0, -speed]), np.zeros(3))
    s.engine.touch(5, 3, [[0.052, 0.0, 0.064]], normal=UP)
    return s, s.ext.update(1.0)


def test_a_blow_on_a_flush_stacks_top_is_passed_down_to_the_part_that_tips_over_the_table_edge():
    """The top brick C lies flush on B, so the blow's line meets C's support inside and lifting
    C (0.416 mJ) is its barrier, and B with C on it 1.66 mJ; but the blow is passed down to A,
    and A with B and C on it turns over the table's edge for 3 m g (sqrt(2^2 + 12^2) - 12) mm."""
    housner = 3 * M * 9.81 * (math.hypot(0.002, 0.012) - 0.012)
    assert housner == pytest.approx(0.052e-3, abs=1e-6)
    s, events = flush_stack_scene(1.0)  # 0.23 mJ: under the top brick's 0.416 mJ, above the stack's
    assert [(e.kind, e.label) for e in events] == [("wake", "A"), ("wake", "B"), ("wake", "C")]
    assert f"on C: 0.23 mJ against {housner * 1000:.3g} mJ to turn A and what it carries" in events[0].reason
    assert all(s.ext.state(b) is BrickState.ACTIVE for b in (1, 2, 3))
    s, events = flush_stack_scene(0.3)  # 0.0207 mJ: a gentle tap is held
    assert [(e.kind, e.label) for e in events] == [("impact", "C")], events
    assert events[0].reason.startswith("held") and s.ext.state(1) is BrickState.FROZEN


def test_a_blow_on_a_tall_columns_top_brick_moves_that_brick_alone():
    """A column of 20 KAPLAs on the ground struck on the top one's side across it at 0.5 m/s
    (1.3 mJ): the top one is lifted for 0.416 mJ; the column under it, passed the blow, would
    need 20 m g (sqrt(12^2 + 80^2) - 80) mm = 1.86 mJ to turn over, and stays frozen."""
    s = Scene()
    for body in range(1, 21):
        z = 0.008 * body - 0.004
        s.engine.poses[body] = Pose.from_euler([0.0, 0.0, z])
        s.ext.add_brick(body, KAPLA, f"b{body}")
        s.engine.touch(body, body - 1, _rectangle(-0.06, 0.06, z - 0.004), normal=UP)
        s.ext.update(0.1 * body)
    s.engine.poses[30] = Pose.from_euler([0.0, 0.03, 0.156], yaw=90)
    s.ext.add_brick(30, KAPLA, "hammer")
    s.engine.velocities[30] = (np.array([0.0, -0.5, 0.0]), np.zeros(3))
    s.engine.touch(30, 20, [[0.0, 0.012, 0.156]], normal=[0, 1, 0])
    events = s.ext.update(3.0)
    assert [(e.kind, e.label) for e in events] == [("wake", "b20")], events
    assert "1.32 mJ against 0.416 mJ" in events[0].reason and "to turn" not in events[0].reason
    assert s.ext.state(19) is BrickState.FROZEN


def post_scene(model: str, post_friction: float) -> Scene:
    """A frozen post (60 x 100 x 120 mm, two bricks' mass) on the ground, and a KAPLA brick
    leaning on its -x face at 30 deg from vertical, foot on the ground (pair 0.5). The leaner
    pushes the post with H = W/2 sin a / (cos a + mu_w sin a) = 0.28 W; the post slides when the
    ground's pair friction holds less: sqrt(0.5 f) (2 W + mu_w H) < 0.28 W, f < 0.08."""
    s = Scene(model=model)
    s.engine.poses[9] = Pose.from_euler([0.09, 0.0, 0.06])
    s.ext.add_brick(9, Box(np.array([0.03, 0.05, 0.06]), 2 * M), "post", friction=post_friction)
    s.engine.touch(9, 0, [[x, y, 0.0] for x in (0.06, 0.12) for y in (-0.05, 0.05)], normal=UP)
    assert [e.kind for e in s.ext.update(0.0)] == ["freeze"]
    top = s.leaner(1, 30)
    s.engine.touch(1, 9, [top + [0, -0.012, 0], top + [0, 0.012, 0]], normal=[-1, 0, 0])
    return s


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("post_friction, stands", [(0.01, False), (0.5, True)])
def test_a_brick_leaning_on_a_frozen_one_that_cannot_take_its_push_wakes_it(model, post_friction, stands):
    """The leaning test holds the post as a wall; frozen with the leaner, the post is held only
    by its friction on the ground, which rigid-block equilibrium of the two weighs in both
    models: the report's centre-of-mass test sees no sideways push."""
    s = post_scene(model, post_friction)
    events = s.ext.update(0.1)
    assert ("freeze", "b1") in [(e.kind, e.label) for e in events]
    assert (s.ext.state(9) is BrickState.FROZEN) is stands
    if not stands:
        assert "collapse mechanism" in next(e.reason for e in events if e.kind == "wake" and e.label == "post")


def vee_scene(model: str, leg_friction: float) -> Scene:
    """A frozen V of two KAPLA bricks, 25 deg from vertical, on the ground (pair sqrt(0.5 f)),
    and a flat KAPLA (mass W) laid across its apex. Thin-V statics: each foot needs
    H/N = tan a (W/2 + P/2) / (W + P/2) with P the load on the apex: 0.233 alone, 0.311 with
    the flat."""
    s = Scene(model=model)
    a = math.radians(25)
    top = s.leaner(1, 25, x_foot=-L * math.sin(a))
    s.leaner(2, 25, x_foot=L * math.sin(a), lean=-1)
    for b in (1, 2):
        s.ext._stack.bodies[b].friction = leg_friction
    s.engine.touch(1, 2, [top + [0, -0.012, 0], top + [0, 0.012, 0]], normal=[-1, 0, 0])
    assert [e.kind for e in s.ext.update(0.0)] == ["freeze", "freeze"]
    s.engine.poses[3] = Pose.from_euler([0.0, 0.0, top[2] + 0.004])
    s.ext.add_brick(3, KAPLA, "flat")
    for leg, x in ((1, -0.001), (2, 0.001)):
        s.engine.touch(3, leg, [[x, -0.012, top[2]], [x, 0.012, top[2]]], normal=UP)
    return s


@pytest.mark.parametrize("model", ["report", "equilibrium"])
@pytest.mark.parametrize("pair, stands", [(0.28, False), (0.5, True)])
def test_a_load_laid_on_a_v_wakes_it_when_its_feet_cannot_hold_the_push(model, pair, stands):
    """The flat rests on level contacts, but its load goes down through leaning bricks: it is
    frozen only when rigid-block equilibrium with friction holds the V under it."""
    s = vee_scene(model, pair * pair / 0.5)
    events = s.ext.update(0.1)
    assert [(e.kind, e.label) for e in events][:1] == [("freeze", "flat")]
    assert all((s.ext.state(b) is BrickState.FROZEN) is stands for b in (1, 2, 3))


def test_a_slanted_stack_on_level_contacts_keeps_the_reports_fast_test(monkeypatch):
    """Bricks stepping out 35 mm a level: the top one is off the lower bricks' load paths but over
    its own level support, so nothing leans and no program is solved (the report's loads decide)."""
    import stability._stack_test as stack_test

    def refuse(*args, **kwargs):
        raise AssertionError("no rigid-block program on level contacts")

    monkeypatch.setattr(stack_test, "solve_equilibrium", refuse)
    s = Scene()
    for body, x in ((1, 0.0), (2, 0.035), (3, 0.07)):
        z = (body - 0.5) * 0.008
        s.engine.poses[body] = Pose.from_euler([x, 0.0, z])
        s.ext.add_brick(body, KAPLA, f"b{body}")
        s.engine.touch(body, body - 1, [[x - 0.01, 0.0, z - 0.004]], normal=UP)  # areas come from the faces
        assert [e.kind for e in s.ext.update(0.1 * body)] == ["freeze"]
    stack = s.ext._stack
    assert stack.unproven == {3} and not stack.leaning and not any(r.leans for r in stack.bodies.values())
