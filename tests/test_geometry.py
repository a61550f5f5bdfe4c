"""Contact areas (report 3.3.3) against closed-form areas."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from shapely.geometry import box

from stability import Box, Plane, Pose, combined_hull, contains, face_overlap, padded_hull

KAPLA = Box(np.array([0.06, 0.012, 0.004]), 0.0106)


def test_one_point_becomes_a_diamond_centred_on_it():
    poly = padded_hull(np.array([[0.1, 0.2]]), 0.001)
    assert poly.area == pytest.approx(2 * 0.001**2)  # diamond with half-diagonal pad
    assert poly.centroid.x == pytest.approx(0.1) and poly.centroid.y == pytest.approx(0.2)


def test_two_points_become_a_thin_rectangle_padded_on_both_sides():
    poly = padded_hull(np.array([[0.0, 0.0], [0.03, 0.04]]), 0.001)
    assert poly.area == pytest.approx(0.05 * 0.002)
    assert poly.centroid.x == pytest.approx(0.015)


def test_collinear_points_are_padded_like_two():
    poly = padded_hull(np.array([[0.0, 0.0], [0.01, 0.0], [0.02, 0.0]]), 0.001)
    assert poly.area == pytest.approx(0.02 * 0.002)


def test_four_points_give_their_convex_hull():
    pts = np.array([[0, 0], [0.024, 0], [0.024, 0.024], [0, 0.024], [0.012, 0.012]])
    assert padded_hull(pts, 0.001).area == pytest.approx(0.024**2)


def test_no_point_is_an_error():
    with pytest.raises(ValueError):
        padded_hull(np.zeros((0, 2)), 0.001)


def test_crossed_bricks_touch_over_a_width_by_width_square():
    lower = Pose.from_euler([0, 0, 0.004])
    upper = Pose.from_euler([0, 0, 0.012], yaw=90)
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert area.exact
    assert area.area == pytest.approx(0.024**2)
    assert area.height == pytest.approx(0.008)


def test_brick_at_45_degrees_gets_the_exact_octagon_not_four_points():
    # Two 120 x 24 strips crossing at 45 deg overlap in a rhombus of area w^2 / sin(45).
    lower = Pose.from_euler([0, 0, 0.004])
    upper = Pose.from_euler([0, 0, 0.012], yaw=45)
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert area.area == pytest.approx(0.024**2 / math.sin(math.radians(45)), rel=1e-6)


def test_overhanging_brick_touches_only_over_the_overlap():
    lower = Pose.from_euler([0, 0, 0.004])
    upper = Pose.from_euler([0.05, 0, 0.012])
    assert face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001).area == pytest.approx(0.07 * 0.024)


def test_brick_on_the_ground_touches_with_its_whole_bottom():
    area = face_overlap(KAPLA, Pose.from_euler([0.3, 0, 0.004], yaw=30), Plane(0.0), None, gap=0.001)
    assert area.area == pytest.approx(0.12 * 0.024)


def test_tilted_or_separated_faces_are_not_face_to_face():
    lower = Pose.from_euler([0, 0, 0.004])
    assert face_overlap(KAPLA, Pose.from_euler([0, 0, 0.012], roll=5), KAPLA, lower, gap=0.001) is None
    assert face_overlap(KAPLA, Pose.from_euler([0, 0, 0.015]), KAPLA, lower, gap=0.001) is None


def test_faces_tilted_together_touch_face_to_face():
    # A tall tower settles a degree or so out of level: a brick crossing a brick tilted
    # 1.5 degrees, lying on its top face, still touches it over the exact square.
    tilt = Rotation.from_euler("y", 1.5, degrees=True)
    lower = Pose(np.array([0, 0, 0.004]), tilt.as_quat())
    up = tilt.apply([0, 0, 1.0])
    upper = Pose(lower.position + 0.008 * up, (tilt * Rotation.from_euler("z", 90, degrees=True)).as_quat())
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert area is not None and area.exact
    assert area.area == pytest.approx(0.024**2 * math.cos(math.radians(1.5)), rel=1e-6)
    assert area.normal == pytest.approx(up)
    # the same brick tilted alone, on a level brick, meets it along an edge only
    alone = Pose(np.array([0, 0, 0.012]), Rotation.from_euler("y", 1.5, degrees=True).as_quat())
    assert face_overlap(KAPLA, alone, KAPLA, Pose.from_euler([0, 0, 0.004]), gap=0.001) is None


@pytest.mark.parametrize("degrees, face_to_face", [(1.0, False), (0.6, False), (0.2, True), (0.0, True)])
def test_a_brick_tilted_on_an_edge_touches_along_it_though_within_the_face_gap(degrees, face_to_face):
    """A KAPLA rising ``degrees`` to the right from the top left edge (x = -60 mm) of a level
    KAPLA, overlapping it by 40 mm: its underside is within the face gap (1 mm) of that top over
    the whole overlap (0.7 mm at 1 deg), but tilted against it by more than 0.5 deg it touches
    along the edge only; as little as a settled stack's faces (0.2 deg) it lies on the face."""
    lower = Pose.from_euler([0, 0, 0.004])
    tilt = Rotation.from_euler("y", -degrees, degrees=True)
    along, up = tilt.apply([1.0, 0, 0]), tilt.apply([0, 0, 1.0])
    edge = np.array([-0.06, 0, 0.008])  # its underside meets it there; its right end is 40 mm on
    upper = Pose(edge - 0.02 * along + 0.004 * up, tilt.as_quat())
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert (area is not None) is face_to_face
    if area is not None:
        assert area.area == pytest.approx(0.040 * 0.024, rel=0.01)


@pytest.mark.parametrize("degrees", [1.5, 40.0])
def test_the_corners_of_a_tilted_face_overlap_lie_on_the_faces(degrees):
    """A brick lying along another tilted by ``degrees`` about y: the overlap's corners lie on
    the lower brick's top face, not at the mean height (38 mm off it at the ends, at 40 deg)."""
    tilt = Rotation.from_euler("y", degrees, degrees=True)
    lower = Pose(np.array([0, 0, 0.1]), tilt.as_quat())
    up = tilt.apply([0, 0, 1.0])
    upper = Pose(lower.position + 0.008 * up, tilt.as_quat())
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert area is not None
    corners = area.corners()
    top = lower.position + 0.004 * up
    assert np.abs((corners - top) @ up).max() < 1e-9
    assert np.ptp(corners[:, 2]) == pytest.approx(0.12 * math.sin(math.radians(degrees)), rel=1e-6)


def test_combined_hull_spans_both_supports():
    from stability import ContactArea

    up = np.array([0, 0, 1.0])
    a = ContactArea(box(-0.06, -0.012, -0.036, 0.012), 0.008, up, True)
    b = ContactArea(box(0.036, -0.012, 0.06, 0.012), 0.008, up, True)
    assert combined_hull([a, b]).area == pytest.approx(0.12 * 0.024)


def test_a_point_on_the_edge_is_outside_exactly_critical_is_not_stable():
    square = box(0, 0, 1, 1)
    assert contains(square, (0.5, 0.5))
    assert not contains(square, (1.0, 0.5))
    assert not contains(square, (0.5, 0.5), margin=0.6)


@pytest.mark.parametrize("orientation", [np.zeros(4), np.array([0.0, 0.0, math.nan, 1.0]), np.zeros(3)])
def test_a_pose_whose_orientation_is_no_rotation_says_so_where_it_is_used(orientation):
    # a zero quaternion was a ZeroDivisionError; it is refused where the rotation is first
    # asked for, not where a pose is made (every body's, every step)
    pose = Pose(np.zeros(3), orientation)
    for use in (lambda: pose.rotation, pose.euler_degrees, lambda: KAPLA.corners(pose)):
        with pytest.raises(ValueError, match=r"Pose.orientation must be a quaternion \(x, y, z, w\) of non-zero"):
            use()


def test_a_quaternion_of_another_length_is_still_its_rotation():
    turned = Pose.from_euler(np.zeros(3), yaw=90)
    assert np.allclose(Pose(np.zeros(3), 3.0 * turned.orientation).rotation, turned.rotation)


@pytest.mark.parametrize(
    "half, mass, said",
    [
        ([0.06, 0.0, 0.004], 0.0106, "half_extents must be 3 finite positive lengths"),
        ([0.06, -0.012, 0.004], 0.0106, "half_extents must be 3 finite positive lengths"),
        ([0.06, 0.012], 0.0106, "half_extents must be 3 finite positive lengths"),
        ([0.06, math.inf, 0.004], 0.0106, "half_extents must be 3 finite positive lengths"),
        ([0.06, 0.012, 0.004], 0.0, "mass must be a finite positive number of kg"),
        ([0.06, 0.012, 0.004], -1.0, "mass must be a finite positive number of kg"),
        ([0.06, 0.012, 0.004], math.nan, "mass must be a finite positive number of kg"),
    ],
)
def test_a_box_without_a_size_or_a_mass_is_refused(half, mass, said):
    with pytest.raises(ValueError, match=f"Box.{said}"):
        Box(np.array(half), mass)


@pytest.mark.parametrize("height", [math.nan, math.inf, -math.inf])
def test_a_plane_must_be_somewhere(height):
    with pytest.raises(ValueError, match=r"Plane.height must be a finite number of metres"):
        Plane(height)


def test_faces_are_found_once_and_give_the_same_overlaps():
    """A brick's bottom face meets each of its supports, and a support's top face each brick
    laid on it: with ``faces`` each face (and its horizontal projection) is found once and
    reused, and the overlaps are those found without it, to the bit."""
    made: dict = {}
    left, right = (Pose.from_euler([0.001, y, 0.004], yaw=0.2, pitch=0.1, roll=0.1) for y in (-0.048, 0.048))
    uppers = [Pose.from_euler([x, 0.001, 0.01195], yaw=90.3, pitch=0.1, roll=0.1) for x in (-0.048, 0.048)]
    pairs = [(u, s) for u in uppers for s in (left, right)]
    for upper, lower in pairs:
        plain = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
        reused = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001, faces=made)
        assert plain is not None and reused is not None
        assert reused.polygon.wkb == plain.polygon.wkb
        assert (reused.height, reused.depth, reused.normal.tolist()) == (plain.height, plain.depth, plain.normal.tolist())
    assert len(made) == 4  # two bottom faces and two top faces, for four overlaps
    kept = {k: (f, f.projection) for k, f in made.items()}
    assert all(p is not None for _, p in kept.values())  # each face's projection made, once
    face_overlap(KAPLA, uppers[0], KAPLA, left, gap=0.001, faces=made)
    assert all(made[k] is f and f.projection is p for k, (f, p) in kept.items()) and len(made) == 4  # nothing new made
    ground = face_overlap(
        KAPLA, Pose.from_euler([0.3, 0.1, 0.004], yaw=30, pitch=0.01, roll=0.01), Plane(0.0), None, gap=0.001, faces=made
    )
    assert ground is not None and len(made) == 5


def test_a_face_at_a_zero_coordinate_is_not_kept():
    """0.0 and -0.0 are one key: a face whose pose has a zero is found anew each time, so that
    no face found at one of them serves the other (their corners may differ in a zero's sign)."""
    made: dict = {}
    lower = Pose(np.array([-0.0, 0.0, 0.004]), np.array([0.0, 0.0, 0.0, 1.0]))
    upper = Pose(np.array([0.0, -0.0, 0.012]), np.array([-0.0, 0.0, 0.0, 1.0]))
    area = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001, faces=made)
    plain = face_overlap(KAPLA, upper, KAPLA, lower, gap=0.001)
    assert area is not None and plain is not None and area.polygon.wkb == plain.polygon.wkb
    assert made == {}


def test_contact_area_corners_lie_on_the_tilted_plane_through_its_height():
    normal = np.array([-0.6, 0.0, 0.8])
    area = face_overlap(KAPLA, Pose.from_euler([0, 0, 0.012]), KAPLA, Pose.from_euler([0, 0, 0.004]), gap=0.001)
    assert area is not None
    tilted = type(area)(area.polygon, 0.008, normal, True)
    corners = tilted.corners()
    ring = np.asarray(area.polygon.exterior.coords)[:-1]
    assert corners.shape == (len(ring), 3)
    assert corners[:, :2].tolist() == ring.tolist()
    # on the plane through (centre, 0.008) with that normal: n . (p - c) = 0
    centre = np.array([*ring.mean(axis=0), 0.008])
    assert np.abs((corners - centre) @ normal).max() < 1e-15


def _same(a, b) -> bool:
    """Two shapely geometries of one type with the same coordinates, bit for bit, in order."""
    import shapely

    return a.geom_type == b.geom_type and np.array_equal(shapely.get_coordinates(a), shapely.get_coordinates(b))


def test_hull_xy_is_the_multipoints_hull_bit_for_bit() -> None:
    """The ring-made hull is the multipoint's, coordinates and order, for 3 to 8 points, rounded,
    repeated or collinear ones, and for one or two points."""
    import shapely

    from stability import hull_xy

    rng = np.random.default_rng(7)
    for i in range(3000):
        xy = rng.normal(size=(int(rng.integers(1, 9)), 2)) * 0.03
        if i % 3 == 0:
            xy = np.round(xy, 3)
        if i % 5 == 0 and len(xy) > 1:
            xy[1] = xy[0]
        if i % 7 == 0:
            xy[:, 1] = 0.5 * xy[:, 0]
        assert _same(hull_xy(xy), shapely.convex_hull(shapely.multipoints(xy))), xy


@pytest.mark.slow
def test_hull_of_union_is_the_union_hull_bit_for_bit() -> None:
    """Without the union where the polygons lie apart, with it where they overlap or touch: the
    same hull, coordinates and order, as the union's, for polygons, lines and points."""
    import shapely

    from stability._geometry import _apart, hull_of_union

    rng = np.random.default_rng(11)
    apart = 0
    for i in range(3000):
        parts = []
        for _ in range(int(rng.integers(1, 4))):
            c, kind = rng.normal(size=2) * 0.03, rng.random()
            if kind < 0.15:
                parts.append(shapely.points(c))
            elif kind < 0.3:
                parts.append(shapely.linestrings(rng.normal(size=(2, 2)) * 0.01 + c))
            else:
                pts = rng.normal(size=(int(rng.integers(3, 8)), 2)) * 0.01 + c
                parts.append(shapely.convex_hull(shapely.multipoints(np.round(pts, 3) if i % 3 == 0 else pts)))
        hull = hull_of_union(parts)
        assert _same(hull, shapely.union_all(parts).convex_hull), parts
        polygons = all(p.geom_type == "Polygon" for p in parts)
        apart += polygons and len(parts) > 1 and _apart(shapely.bounds(parts).tolist())
    assert apart > 100  # the hull without the union was found often


def test_proven_counts_the_path_edge() -> None:
    """A centre of mass on the load path's edge or corner is over it; just beyond, not."""
    from stability._load_path import proven

    path = box(-0.06, -0.012, 0.06, 0.012)
    assert proven([0.06, 0.0, 0.004], path) and proven([0.06, 0.012], path) and proven([0.0, -0.012], path)
    assert not proven([0.0600001, 0.0], path) and not proven([0.0, 0.0], None)


def test_mean_is_numpys_to_the_bit():
    """_mean sums as numpy's mean does (pairwise, in blocks of eight and halves beyond 128), so
    that an admission's overlap and a face overlap's heights keep numpy's bits."""
    from stability._geometry import _mean

    rng = np.random.default_rng(5)
    for n in [*range(1, 40), 127, 128, 129, 255, 300, 1000]:
        values = (rng.normal(0.0, 1.0, n) * 10.0 ** rng.integers(-6, 6, n)).tolist()
        assert _mean(values) == float(np.mean(values)), n


def test_box_bounds_are_the_corners_least_and_greatest():
    """The bounding box in floats (the impact rule's bound) against scipy's corners, on 200 random poses."""
    from stability._geometry import box_bounds, corners_of

    rng = np.random.default_rng(7)
    halves, positions = rng.uniform(0.004, 0.06, (200, 3)), rng.normal(size=(200, 3))
    quaternions = Rotation.random(200, random_state=8).as_quat() * rng.uniform(0.5, 2.0, (200, 1))  # not all unit
    corners = corners_of(halves, positions, quaternions / np.linalg.norm(quaternions, axis=1, keepdims=True))
    for i in range(200):
        low, high = box_bounds(halves[i], positions[i].tolist(), quaternions[i].tolist())
        assert low == pytest.approx(corners[i].min(axis=0).tolist(), abs=1e-12)
        assert high == pytest.approx(corners[i].max(axis=0).tolist(), abs=1e-12)


def test_moved_at_most_bounds_every_corner_and_is_tight_for_a_pure_shift_or_turn():
    """The impact rule's and the watch's bound on how far a body's points moved, against scipy's
    corners on 300 random pairs of poses, small turns (a step's) and large ones; a shift alone and
    a turn alone about the centre reach it (it is no looser than it must be)."""
    from stability._geometry import corners_of, moved_at_most

    rng = np.random.default_rng(11)
    halves = rng.uniform(0.004, 0.06, (300, 3))
    positions, shifts = rng.normal(size=(300, 3)), rng.normal(scale=0.01, size=(300, 3))
    first = Rotation.random(300, random_state=12)
    angles = np.concatenate([rng.uniform(0.0, 0.02, 150), rng.uniform(0.0, math.pi, 150)])
    axes = rng.normal(size=(300, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    turned = Rotation.from_rotvec(axes * angles[:, None]) * first
    before = corners_of(halves, positions, first.as_quat())
    after = corners_of(halves, positions + shifts, turned.as_quat())
    for i in range(300):
        reach = float(np.linalg.norm(halves[i]))
        bound = moved_at_most(
            positions[i].tolist(),
            first[i].as_quat().tolist(),
            (positions[i] + shifts[i]).tolist(),
            turned[i].as_quat().tolist(),
            reach,
        )
        assert float(np.linalg.norm(after[i] - before[i], axis=1).max()) <= bound + 1e-12
    quaternion = first[0].as_quat().tolist()
    assert moved_at_most((0, 0, 0), quaternion, (0.003, 0.004, 0.0), quaternion, 0.06) == pytest.approx(0.005, abs=1e-15)
    half = np.array([0.06, 0.012, 0.004])
    turn = Rotation.from_rotvec([0.0, 0.0, 0.3])  # about z: the corners in the xy plane move on their circle
    moved = np.linalg.norm(
        corners_of(half[None], np.zeros((1, 3)), turn.as_quat()[None])[0]
        - corners_of(half[None], np.zeros((1, 3)), np.array([[0, 0, 0, 1.0]]))[0],
        axis=1,
    ).max()
    bound = moved_at_most((0, 0, 0), (0, 0, 0, 1), (0, 0, 0), turn.as_quat().tolist(), float(np.hypot(0.06, 0.012)))
    assert moved <= bound <= moved * 1.004  # a chord against its arc: 2 sin(0.15) / 0.3 = 0.9963
