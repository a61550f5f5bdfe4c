"""stackdsl.runtime.catch: the bound on how fast a part placed off its support tips, and when a
brick placed on it catches it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from shapely.geometry import box as rectangle

from stability import Box, Pose
from stackdsl.runtime.catch import about, caught, edge_of, tipped

KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)
UNDER = rectangle(-0.06, -0.012, 0.06, 0.012)  # the top face of a KAPLA brick at the origin, 8 mm up
G = 9.81


def _arm(out: float) -> list[tuple[Box, Pose]]:
    """A KAPLA brick lying on :data:`UNDER` along x, its centre of mass ``out`` m past the edge."""
    return [(KAPLA, Pose(np.array([0.06 + out, 0.0, 0.012])))]


def _turned(part_out: float, t: float) -> float:
    """The angle (rad) a KAPLA brick placed ``part_out`` m past the edge has turned after ``t`` s,
    integrated: I theta'' = M g (d cos theta + h sin theta), about the fixed edge."""
    edge = edge_of(UNDER, np.array([0.06 + part_out, 0.0, 0.012]), 0.008)
    assert edge is not None
    part = about(_arm(part_out), edge)

    def rate(_: float, y: np.ndarray) -> list[float]:
        theta, spin = y
        return [spin, part.mass * G * (part.out * math.cos(theta) + part.up * math.sin(theta)) / part.inertia]

    return float(solve_ivp(rate, (0.0, t), [0.0, 0.0], rtol=1e-10, atol=1e-12).y[0, -1])


@pytest.mark.parametrize("out", [0.0002, 0.001, 0.005])
@pytest.mark.parametrize("t", [0.05, 0.1, 0.2])
def test_the_bound_is_never_below_the_turn_integrated_and_close_to_it_early(out, t):
    edge = edge_of(UNDER, np.array([0.06 + out, 0.0, 0.012]), 0.008)
    assert edge is not None and np.allclose(edge.out, [1, 0, 0]) and np.allclose(edge.at, [0.06, 0, 0.008])
    bound, _ = tipped(about(_arm(out), edge), t, G)
    turned = _turned(out, t)
    assert turned <= bound and bound < 1.2 * turned  # within 20% while the angle is small


def test_a_brick_about_its_edge_has_the_parallel_axis_inertia_and_its_far_corner_as_reach():
    edge = edge_of(UNDER, np.array([0.061, 0.0, 0.012]), 0.008)
    assert edge is not None
    part = about(_arm(0.001), edge)
    a, c = 0.06, 0.004  # half length, half thickness: turning about the y axis
    assert part.inertia == pytest.approx(KAPLA.mass * ((a * a + c * c) / 3 + 0.001**2 + 0.004**2))
    assert (part.out, part.up) == pytest.approx((0.001, 0.004))
    assert part.reach == pytest.approx(math.hypot(0.121 - 0.06, 0.008))


def test_a_centre_of_mass_inside_has_no_edge_to_tip_over():
    assert edge_of(UNDER, np.array([0.059, 0.0, 0.012]), 0.008) is None


@pytest.mark.parametrize(
    "out, late, held",
    [
        (0.001, 0.1, True),  # turned 2.4 deg by then, its far end 2.5 mm down: caught
        (0.001, 0.13, False),  # its far end past the 4 mm threshold at the bound
        (0.003, 0.05, True),
        (0.003, 0.1, False),
        (0.0002, 0.2, True),
        (0.0002, 1.0, False),  # a single file's next brick, a second later
    ],
)
def test_a_counterweight_catches_the_part_only_in_time(out, late, held):
    weight = (KAPLA, Pose(np.array([0.03, 0.0, 0.020])))
    assert caught(_arm(out), [*_arm(out), weight], UNDER, 0.008, late, 0.004, G) is held


def test_a_brick_that_leaves_the_centre_of_mass_outside_catches_nothing():
    further = (KAPLA, Pose(np.array([0.09, 0.0, 0.020])))  # a step further out: a staircase
    assert not caught(_arm(0.001), [*_arm(0.001), further], UNDER, 0.008, 0.01, 0.004, G)
    light = (Box(np.array([0.06, 0.012, 0.004]), 0.001), Pose(np.array([0.03, 0.0, 0.020])))  # too light to bring it in
    assert not caught(_arm(0.003), [*_arm(0.003), light], UNDER, 0.008, 0.01, 0.004, G)
