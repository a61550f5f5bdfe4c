"""Static bodies out of every moving body's reach leave pybullet's world (the shelf) and come
back, under their ids, before anything could touch them: a run reads them as it would read
them in the world, a projectile hits a shelved brick as it hits one that stayed, and a tower
gives the same verdict and graph either way. Static bodies merged into one body the engine
moves (a group riding a dragged support) read where their boxes of it are."""

from __future__ import annotations

import os

import numpy as np
import pytest

from stability import Pose
from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.compile.compiler import _spec
from stackdsl.engines.pybullet.settings import PyBulletSettings
from stackdsl.engines.pybullet.world import RECENT, pybullet_world
from stackdsl.runtime.run import RunOptions

SETTINGS = PyBulletSettings(mode="extension", timestep=1 / 240, solver_iterations=50)
LEVELS = 30


def _column(world, spec, levels=LEVELS):
    """A column of frozen bricks, one a level, 8 mm apart; their ids, bottom first."""
    bricks = []
    for i in range(levels):
        body = world.create(spec, Pose.from_euler([0.0, 0.0, 0.004 + 0.008 * i]))
        world.set_frozen(body, True, spec.mass)
        bricks.append(body)
    return bricks


def _spec_of():
    return _spec(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n"), "kapla")


def test_buried_bricks_leave_the_world_and_read_as_they_were():
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0) as world:
        bricks = _column(world, spec)
        before = {b: world.pose(b) for b in bricks}
        world.step()
        shelved = world.shelved
        # the bricks frozen last and what lies within 5 cm of them stay; the rest leave
        assert not shelved & set(bricks[-RECENT:])
        assert set(bricks[:10]) <= shelved and len(shelved) < LEVELS - RECENT
        for b in bricks:
            assert world.pose(b).position.tolist() == before[b].position.tolist()
            assert world.speeds(b) == (0.0, 0.0)
        assert world.contact_points(sorted(shelved)) == []
        assert not any(world.touches(b) for b in shelved)  # static, touching only static bodies
        assert world.poses_of(bricks)[0][:, 2] == pytest.approx([0.004 + 0.008 * i for i in range(LEVELS)])


def test_what_lies_near_a_shelved_brick_is_found_as_if_it_had_stayed():
    """A hand about to pull a brick deep in a frozen column asks what lies within reach of it
    (a pull's proof: what it slides between). The brick and its neighbours are on the shelf:
    they come back to answer, as a column that stayed in the world answers, and leave again
    once nothing moving needs them."""
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0) as world:
        bricks = _column(world, spec)
        world.step()
        middle = bricks[5]
        assert {bricks[4], middle, bricks[6]} <= world.shelved
        near = {c.other for c in world.near(middle, 0.001)}
        assert near == {bricks[4], bricks[6]}
        assert middle not in world.shelved
        world.step()
        assert {bricks[4], middle, bricks[6]} <= world.shelved


def test_a_shelved_brick_comes_back_before_a_projectile_reaches_it():
    """A brick thrown at the bottom of a column whose bottom is shelved stops against it as
    against a column that stayed in the world (shelved for good, it would pass through), and
    the contact names the brick it hit."""
    spec = _spec_of()
    ends = {}
    for shelve in (True, False):
        with pybullet_world(SETTINGS, 0.5, 0.0, shelve=shelve) as world:
            bricks = _column(world, spec)
            world.step()
            assert bool(world.shelved) is shelve and (bricks[3] in world.shelved) is shelve
            thrown = world.create(spec, Pose.from_euler([0.0, 0.12, 0.028], yaw=90.0))
            world.throw(thrown, (0.0, -1.5, 0.0), None)
            touched = set()
            for _ in range(120):
                world.step()
                touched |= {c.other for c in world.contact_points([thrown])}
            assert bricks[3] not in world.shelved  # back in the world: the projectile reached it
            ends[shelve] = world.pose(thrown).position
            assert ends[shelve][1] > 0.012 + 0.06 - 0.002  # it stopped at the column's side
            assert touched & set(bricks[1:5])
    # the same hit; not bitwise (pybullet orders a re-created body last), within 2 mm after the bounce
    assert np.allclose(ends[True], ends[False], atol=0.002)


def test_a_woken_shelved_brick_comes_back_and_falls():
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0) as world:
        bricks = _column(world, spec)
        world.step()
        low = bricks[2]
        assert low in world.shelved
        lifted = Pose.from_euler([0.2, 0.0, 0.05])
        world.move(low, lifted, spec.mass)  # back in the world, moving
        assert low not in world.shelved
        for _ in range(60):
            world.step()
        assert world.pose(low).position[2] < 0.01  # fell onto the ground


def test_a_pose_read_once_between_steps_follows_every_move():
    """The world keeps a pose it read until the next step; a step, and every call that puts a
    body somewhere (a freeze raised out of its support, a move, a guide), reads it anew."""
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        body = world.create(spec, Pose.from_euler([0.0, 0.0, 0.05]))
        assert world.pose(body).position[2] == pytest.approx(0.05)
        world.step()
        assert world.pose(body).position[2] < 0.05  # falling: read after the step
        assert world.pose_floats(body)[0] == tuple(world.pose(body).position.tolist())
        world.move(body, Pose.from_euler([0.1, 0.0, 0.02]), spec.mass)
        assert world.pose(body).position.tolist() == pytest.approx([0.1, 0.0, 0.02])
        world.set_frozen(body, True, spec.mass, Pose.from_euler([0.1, 0.0, 0.03]))
        assert world.pose(body).position.tolist() == pytest.approx([0.1, 0.0, 0.03])
        world.guide(body, Pose.from_euler([0.1, 0.0, 0.03]), (0.1, 0.0, 0.0))
        world.step()
        assert world.pose(body).position[0] > 0.1  # driven along its path: read after the step


@pytest.mark.slow
def test_a_tower_gives_the_same_verdict_and_graph_shelved_or_not():
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: {LEVELS}}}}}\n"
    program = compile_scenario(parse_scenario(text, "tower.yaml"))
    shelved, kept = run_program(program), run_program(program, RunOptions(shelve=False))
    assert shelved.collapse is None and kept.collapse is None
    a, b = shelved.final_graph, kept.final_graph
    assert [n.id for n in a.nodes] == [n.id for n in b.nodes]
    for m, n in zip(a.nodes, b.nodes, strict=True):
        assert m.state == n.state
        assert np.allclose(m.position_mm, n.position_mm, atol=0.2)
    assert {(e.upper, e.support) for e in a.edges} == {(e.upper, e.support) for e in b.edges}


@pytest.mark.slow
def test_a_kept_client_simulates_as_a_new_one(monkeypatch):
    """A run on the client the last run left (emptied) gives the outcome, bitwise, that it
    gives on a new client; a run that raises disconnects its client instead of keeping it."""
    import json

    import stackdsl.engines.pybullet.client as client_module

    def outcome(text):
        o = run_program(compile_scenario(parse_scenario(text, "s.yaml")))
        return json.dumps(
            o.model_dump(mode="json", exclude={"wall_time", "engine_time", "after_collapse", "certificate_time"}), sort_keys=True
        )

    cabin = "stackdsl: 1\nstructure: {tower: {levels: 8, spacing: 96 mm, shift: 9.5 mm}}\n"
    impact = open("scenarios/impact_top.yaml").read()
    client_module._SPARE.clear()
    new = outcome(cabin)
    (kept,) = [c for _, c in client_module._SPARE]
    outcome(impact)  # on the kept client: its bodies, substeps and timestep
    assert [c for _, c in client_module._SPARE] == [kept]
    kept.setPhysicsEngineParameter(numSubSteps=4, fixedTimeStep=0.01)  # as a run that ended while something was fast
    assert outcome(cabin) == new
    with pytest.raises(RuntimeError), client_module.direct_client() as client:
        assert client is kept
        raise RuntimeError("a run that fails")
    assert client_module._SPARE == []


def test_a_new_client_has_no_renderer_plugin_and_simulates_as_one_that_has():
    """A new client unloads pybullet's TinyRenderer plugin (it builds a visual shape for every
    body; stackdsl renders nothing through pybullet): loading it by name then finds no such
    file (-1). The physics does not read it: a run gives the same outcome, bitwise, on a client
    with the plugin loaded."""
    import json

    import pybullet
    from pybullet_utils.bullet_client import BulletClient

    import stackdsl.engines.pybullet.client as client_module

    def outcome():
        o = run_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 6, shift: 9 mm}}\n", "s.yaml")))
        return json.dumps(
            o.model_dump(mode="json", exclude={"wall_time", "engine_time", "after_collapse", "certificate_time"}), sort_keys=True
        )

    client_module._SPARE.clear()
    without = outcome()
    (kept,) = [c for _, c in client_module._SPARE]
    with client_module.quiet_c_output():  # pybullet warns that it cannot open a file of that name
        assert kept.loadPlugin(client_module.RENDERER) == -1
        rendering = BulletClient(connection_mode=pybullet.DIRECT)
    assert rendering.loadPlugin(client_module.RENDERER) >= 0  # a new client's, loaded: its id
    client_module._SPARE[:] = [(os.getpid(), rendering)]
    assert outcome() == without
    client_module._SPARE.clear()
    for client in (kept, rendering):
        client.disconnect()


def test_the_kept_client_is_disconnected_at_exit_while_pybullet_is_loaded():
    """At the interpreter's very end pybullet's module may be gone before a kept client's
    ``__del__`` runs (an ignored exception on stderr, seen in test workers): an exit handler
    disconnects it first."""
    import stackdsl.engines.pybullet.client as client_module

    run_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n", "s.yaml")))
    (kept,) = [c for _, c in client_module._SPARE]
    assert kept.isConnected()
    client_module._disconnect_spare()
    assert client_module._SPARE == [] and not kept.isConnected()


def test_merged_bricks_move_as_one_body_and_come_apart_where_they_are():
    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        base, middle, top = _column(world, spec, 3)
        world.set_frozen(base, False, spec.mass)
        assert world.merge([middle, top])
        assert not world.merge([middle, base])  # merged already, or moving
        for k in range(48):  # a hand slides the base out: friction carries what rests on it
            world.guide(base, Pose.from_euler([0.05 * k / 240, 0.0, 0.004]), (0.05, 0.0, 0.0), hold=False)
            world.step()
        moved = {b: world.pose(b).position - np.array([0.0, 0.0, 0.004 + 0.008 * i]) for i, b in enumerate((base, middle, top))}
        assert moved[middle][0] > 0.005  # carried along
        gap = world.pose(top).position - world.pose(middle).position
        assert float(np.linalg.norm(gap)) == pytest.approx(0.008, abs=1e-9)  # rigid: one body
        turn = world.pose(top).orientation @ world.pose(middle).orientation
        assert abs(float(turn)) == pytest.approx(1.0, abs=1e-12)
        (v_middle, spin), (v_top, spin_top) = world.velocity(middle), world.velocity(top)
        assert spin_top.tolist() == spin.tolist() and v_middle[0] > 0.0
        assert (v_top - v_middle).tolist() == pytest.approx(np.cross(spin, gap).tolist(), abs=1e-12)
        seen = {(c.body, c.other) for c in world.contact_points([base])}
        assert seen == {(base, world.ground), (base, middle)}  # named by the brick touched, never the merged body
        assert {c.other for c in world.contact_points([middle])} == {base}
        assert world.touches(base) and world.touches(middle)  # the merged body's points named by the part nearest
        assert not world.touches(top) and world.contact_points([top]) == []
        flying = world.create(spec, Pose.from_euler([0.3, 0.0, 0.5]), spec.mass)
        world.step()
        assert not world.touches(flying) and world.contact_points([flying]) == []
        world.move(flying, Pose.from_euler([0.0, 0.2, 0.004]), spec.mass)
        world.step()
        assert world.touches(flying) and world.contact_points([flying])
        there, rode = world.pose(top).position, world.velocity(top)
        world.unmerge([middle, top])
        assert world.pose(top).position.tolist() == pytest.approx(there.tolist(), abs=1e-12)
        assert world.speeds(top) == (0.0, 0.0)  # frozen
        world.set_frozen(top, False, spec.mass)  # woken in the same step: it moves on as it rode
        assert np.concatenate(world.velocity(top)).tolist() == pytest.approx(np.concatenate(rode).tolist(), abs=1e-6)
        world.step()
        world.set_frozen(middle, False, spec.mass)  # a step later: from rest
        assert world.speeds(middle) == (0.0, 0.0)
        assert world.pose(top).position[2] == pytest.approx(there[2], abs=2e-4)  # it rests where it rode to


def test_the_turns_of_driven_and_merged_bodies_are_exact_for_every_angle():
    """A guided body is driven back by the turn from where it is to its path, a merged box is
    turned by its body's turn: both in double precision, a turn of 1e-6 rad included (pybullet's
    own quaternion calls round to single precision and read a turn under 0.04 deg as none)."""
    from scipy.spatial.transform import Rotation

    from stackdsl.engines.pybullet.world import _product, _turn

    rng = np.random.default_rng(7)
    for k in range(200):
        now = Rotation.random(random_state=rng)
        to = Rotation.from_rotvec(rng.normal(size=3) * 10.0 ** rng.uniform(-6, 0.4)) * now
        sign = 1.0 if k % 2 else -1.0  # either quaternion of a turn
        q_now, q_to = tuple(sign * now.as_quat()), tuple(to.as_quat())
        assert _turn(q_now, q_to) == pytest.approx((to * now.inv()).as_rotvec().tolist(), rel=1e-9, abs=1e-15)
        product = np.array(_product(q_now, q_to))
        expected = (now * to).as_quat()
        assert min(np.abs(product - expected).max(), np.abs(product + expected).max()) < 1e-15


def test_the_boxes_of_a_merged_body_read_together_are_each_boxs_own_arithmetic_to_the_bit():
    """The boxes of a merged body are read all at once each step (the collapse monitor reads
    every brick riding a shaken ground); each reads what its own arithmetic gives, to the bit:
    the merged body's matrix times its arm, Hamilton's product of the turns in floats, and
    v + w x r. A product of the matrix and the arms' rows as one array rounds differently."""
    from scipy.spatial.transform import Rotation

    from stackdsl.engines.pybullet.world import _product

    spec = _spec_of()
    rng = np.random.default_rng(11)
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        bricks = _column(world, spec, 6)
        for body in bricks[1:]:  # each box turned its own way about the vertical, off the centre line
            turned = Rotation.from_euler("z", rng.uniform(-1.0, 1.0)).as_quat()
            place = world.pose(body).position + np.array([*rng.uniform(-0.01, 0.01, size=2), 0.0])
            world.move(body, Pose(place, turned), 0.0)
        assert world.merge(bricks[1:])
        group = world._merged[bricks[1]][0]
        world.set_frozen(bricks[0], False, spec.mass)
        for k in range(30):  # the base slides and turns out from under the group: it tips and spins
            world.guide(bricks[0], Pose.from_euler([0.2 * k / 240, 0.0, 0.004], yaw=1.2 * k), (0.2, 0.0, 0.0), hold=False)
            world.step()
            read = {b: (world.pose_floats(b), world.velocity_floats(b)) for b in reversed(bricks[1:])}
            (x, y, z), turn = world.pose_floats(group)
            (vx, vy, vz), (wx, wy, wz) = world.velocity_floats(group)
            matrix = world._matrix(turn)
            for index, body in enumerate(bricks[1:]):
                part = world._frames[group]
                rx, ry, rz = (matrix @ part.arms[index]).tolist()
                own = ((x + rx, y + ry, z + rz), _product(turn, part.turns[index]))
                moves = ((vx + wy * rz - wz * ry, vy + wz * rx - wx * rz, vz + wx * ry - wy * rx), (wx, wy, wz))
                assert read[body] == (own, moves)
        assert abs(wx) + abs(wy) + abs(wz) > 0.0  # it turned: the arms' products were tested


def test_the_bricks_of_a_merged_body_are_measured_from_its_one_pose_as_each_brick_alone():
    """The collapse monitor measures the bricks one merged body moves from that body's one pose
    (``Structure.displacements``, the world's ``merged_groups``): each as far from where it was
    placed as its own pose says (``Structure.displacement``, brick by brick), as the merged body
    tips and spins, in the ground's frame when the ground has moved, and anew after the bricks
    were parted, moved and merged again."""
    from scipy.spatial.transform import Rotation

    from stackdsl.runtime.bricks import BrickRecord, Structure

    spec = _spec_of()
    rng = np.random.default_rng(5)
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        structure = Structure(world)
        bricks = _column(world, spec, 17)
        for i, body in enumerate(bricks):
            placed = world.pose(body)
            structure.add(BrickRecord(f"b{i}", body, spec, i + 1, placed, placed))
        records = list(structure.records.values())

        def check() -> None:
            merged = structure.displacements(records)
            alone = [structure.displacement(r) for r in records]  # in floats, pose by pose
            assert merged.tolist() == pytest.approx(alone, abs=1e-12)

        for body in bricks[1:]:  # turned and off the centre line: placed where they are not now
            turned = Rotation.from_euler("z", rng.uniform(-0.3, 0.3)).as_quat()
            world.move(body, Pose(world.pose(body).position + np.array([*rng.uniform(-0.005, 0.005, size=2), 0.0]), turned), 0.0)
        assert world.merged_groups() == {}
        assert world.merge(bricks[1:])
        assert list(world.merged_groups().values()) == [tuple(bricks[1:])]
        world.set_frozen(bricks[0], False, spec.mass)
        for k in range(30):  # the base slides and turns out from under the merged body: it tips and spins
            world.guide(bricks[0], Pose.from_euler([0.2 * k / 240, 0.0, 0.004], yaw=1.2 * k), (0.2, 0.0, 0.0), hold=False)
            world.step()
            structure.offset = (0.001 * k, -0.0005 * k, 0.0)
            check()
        assert structure.displacements(records).max() > 0.01  # it moved: the merged body's pose was read
        world.unmerge(bricks[1:])
        assert world.merged_groups() == {}
        for body in bricks[1:9]:  # parted: some of them moved on their own, then merged again
            world.move(body, Pose(world.pose(body).position + np.array([0.003, 0.0, 0.0])), 0.0)
        assert world.merge(bricks[1:])
        check()


def _merged_column(world, spec, levels=9):
    """A column of ``levels`` frozen bricks (:func:`_column`), each a structure brick placed where
    it is, all but the bottom one merged into one body: the structure and the bricks, bottom first."""
    from stackdsl.runtime.bricks import BrickRecord, Structure

    structure = Structure(world)
    bricks = _column(world, spec, levels)
    for i, body in enumerate(bricks):
        placed = world.pose(body)
        structure.add(BrickRecord(f"b{i}", body, spec, i + 1, placed, placed))
    assert world.merge(bricks[1:])
    return structure, bricks


def test_the_monitor_measures_a_merged_body_s_bricks_from_its_pose_and_skips_them_while_its_bound_holds(monkeypatch):
    """``Structure.measure`` of the bricks one merged body moves (a ride): the same bricks, at the
    same displacements, as measured brick by brick (``Structure.displacement``), the pending ones
    and every one past the threshold, in the order placed, as the merged body slides, tips and
    spins off its base; while the bound from its last measure keeps every one within the
    threshold, they are not measured at all."""
    from stackdsl.runtime.bricks import Structure

    spec, threshold = _spec_of(), 0.004
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        structure, bricks = _merged_column(world, spec)
        world.set_frozen(bricks[0], False, spec.mass)
        measured = []
        rigidly = Structure._rigidly
        monkeypatch.setattr(Structure, "_rigidly", lambda self, *args: measured.append(1) or rigidly(self, *args))
        skipped = watched_any = 0
        for k in range(90):  # the base slides slowly, dragging it, then fast and turning, out from under it
            speed = 0.02 if k < 40 else 0.4
            x = 0.02 * min(k, 40) / 240 + 0.4 * max(k - 40, 0) / 240
            world.guide(bricks[0], Pose.from_euler([x, 0.0, 0.004], yaw=max(k - 40, 0)), (speed, 0.0, 0.0), hold=False)
            world.step()
            pending = ("b5",) if k > 70 else ()
            before = len(measured)
            watched, moved = structure.measure(dict.fromkeys(pending), threshold)
            skipped += len(measured) == before
            exact = {r.id: structure.displacement(r) for r in structure.placed}
            expected = [r.id for r in structure.placed if exact[r.id] > threshold or r.id in pending]
            assert [r.id for r in watched] == expected
            assert moved.tolist() == pytest.approx([exact[i] for i in expected], abs=1e-12)
            watched_any += len(expected) > 1
        assert skipped >= 10 and watched_any >= 10  # the bound held for a while; then they were past the threshold


@pytest.mark.parametrize("degrees, within", [(0.01, True), (3.0, False)])
def test_a_merged_body_turned_in_place_is_measured_again_when_its_turn_may_carry_a_corner_out(degrees, within):
    """The bound that skips a merged body's bricks (``Structure._within``) takes the chord its
    turn sweeps at its farthest corner: eight bricks riding one body, turned about the first one's
    centre, which does not move; turned 3 deg, a corner 86 mm from it may have moved 4.5 mm, past
    the 4 mm threshold (about this axis the top corners move 3.2 mm: the bound is not exact)."""
    from scipy.spatial.transform import Rotation

    spec = _spec_of()
    with pybullet_world(SETTINGS, 0.5, 0.0, shelve=False) as world:
        structure, bricks = _merged_column(world, spec)
        (key,) = world.merged_groups()
        riders = [structure.records[f"b{i}"] for i in range(1, 9)]
        assert structure.measure({}, 0.004)[0] == []  # measured once, all in place
        (x, y, z), turn = world.pose_floats(bricks[1])
        turned = tuple((Rotation.from_euler("x", degrees, degrees=True) * Rotation.from_quat(turn)).as_quat().tolist())
        read = world.pose_floats
        world.pose_floats = lambda body: ((x, y, z), turned) if body == bricks[1] else read(body)  # type: ignore[method-assign]
        assert structure._within(key, riders, 0.004) is within
