"""Composed structures: named parts placed part after part, ids prefixed, levels counted from the
ground across parts, ``on`` a part or a brick, and the checks before simulating over the whole."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stackdsl import compile_scenario
from stackdsl.compile.parts import arrange
from stackdsl.lang.errors import ScenarioError
from stackdsl.lang.loader import parse_scenario

BRIDGE_LIST = """stackdsl: 1
structure:
  - name: left
    tower: {levels: 4, yaw: 90}
    origin: [-100 mm, 0]
  - name: right
    tower: {levels: 4, yaw: 90}
    origin: [100 mm, 0]
  - name: deck
    on: [left, right]
    bricks:
      - {at: [0, -48 mm, 4 mm]}
      - {at: [0, 48 mm, 4 mm]}
"""

BRIDGE_MAP = """stackdsl: 1
structure:
  left: {tower: {levels: 4, yaw: 90}, origin: [-100 mm, 0]}
  right: {tower: {levels: 4, yaw: 90}, origin: [100 mm, 0]}
  deck:
    on: [left, right]
    bricks: [{at: [0, -48 mm, 4 mm]}, {at: [0, 48 mm, 4 mm]}]
"""


def laid(text: str):
    return arrange(parse_scenario(text, "p.yaml"))


def error(text: str) -> ScenarioError:
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(text, "p.yaml"))
    return err.value


def test_parts_are_placed_in_order_with_prefixed_ids_and_levels_counted_across_them():
    bricks = laid(BRIDGE_LIST)
    assert [b.id for b in bricks][:2] == ["left.L01.1", "left.L01.2"]
    assert [b.id for b in bricks][-3:] == ["right.L04.2", "deck.b001", "deck.b002"]
    deck = [b for b in bricks if b.id.startswith("deck.")]
    assert {b.level for b in deck} == {5}
    assert np.allclose([b.position[2] for b in deck], 4 * 0.008 + 0.004)  # on the towers' top, 32 mm
    left = [b for b in bricks if b.id.startswith("left.")]
    assert np.allclose(np.mean([b.position[:2] for b in left], axis=0), [-0.1, 0.0])


def test_a_map_of_parts_is_the_list_written_by_name():
    as_list, as_map = laid(BRIDGE_LIST), laid(BRIDGE_MAP)
    assert [(b.id, b.level, b.type) for b in as_list] == [(b.id, b.level, b.type) for b in as_map]
    assert np.allclose([b.position for b in as_list], [b.position for b in as_map])


def test_a_part_on_a_brick_stands_on_its_top_centred_on_it_unless_given_an_origin():
    text = """stackdsl: 1
structure:
  - {name: base, tower: {levels: 3, origin: [0.2, 0]}}
  - {name: cap, on: base.L03.1, bricks: [{at: [0, 0, 4 mm], yaw: 90}]}
  - {name: far, on: base.L03.2, origin: [0.2, 0.03], bricks: [{at: [0, 0, 4 mm]}]}
"""
    bricks = {b.id: b for b in laid(text)}
    under = bricks["base.L03.1"]
    assert np.allclose(bricks["cap.b001"].position, [under.position[0], under.position[1], 0.028])
    assert bricks["cap.b001"].level == 4
    assert np.allclose(bricks["far.b001"].position, [0.2, 0.03, 0.028])


def test_a_part_turns_about_its_origin():
    text = "stackdsl: 1\nstructure:\n  - {name: w, yaw: 90, origin: [1, 0], wall: {courses: 1, bricks_per_course: 3}}\n"
    bricks = laid(text)
    assert np.allclose([b.position[0] for b in bricks], 1.0)
    assert np.allclose(sorted(b.position[1] for b in bricks), [-0.12, 0.0, 0.12])
    assert {round(b.yaw) for b in bricks} == {90}


def test_a_card_house_on_a_tower_counts_its_levels_on_from_the_tower():
    text = (
        "stackdsl: 1\nstructure:\n  - {name: t, tower: {levels: 2, bricks_per_layer: 3, spacing: 40 mm}}\n"
        "  - {name: c, on: t, card_house: {levels: 1}}\n"
    )
    bricks = laid(text)
    house = [b for b in bricks if b.id.startswith("c.")]
    assert {b.level for b in house} == {3}
    bottoms = [b.position[2] - 0.06 * math.cos(math.radians(20)) - 0.004 * math.sin(math.radians(20)) for b in house]
    assert np.allclose(bottoms, 0.016)
    compile_scenario(parse_scenario(text, "p.yaml"))  # nothing overlaps, nothing floats


@pytest.mark.parametrize(
    "text, field, line, words",
    [
        (  # two towers in one place: the later part is to be moved
            "stackdsl: 1\nstructure:\n  - {name: a, tower: {levels: 2}}\n  - {name: b, origin: [10 mm, 0], tower: {levels: 2}}\n",
            "structure[1].origin",
            4,
            "reaches",
        ),
        (  # a part with nothing under it
            "stackdsl: 1\nstructure:\n  a: {tower: {levels: 2}}\n  b: {origin: [1, 0], pyramid: {base: 2}, on: a.L02.1}\n",
            "structure.b.origin",
            4,
            "rests on nothing",
        ),
        (  # a brick by hand with nothing under it
            "stackdsl: 1\nstructure:\n  a: {tower: {levels: 2}}\n  b: {origin: [1, 0], bricks: [{at: [0, 0, 50 mm]}]}\n",
            "structure.b.bricks[0].at",
            4,
            "rests on nothing",
        ),
        (
            "stackdsl: 1\nstructure:\n  - {name: a, tower: {levels: 2}}\n  - {name: b, on: a.L09.1, tower: {levels: 2}}\n",
            "structure[1].on",
            4,
            "a.L01.1 to a.L02.2",
        ),
    ],
)
def test_problems_of_a_composition_point_at_the_part_to_change(text, field, line, words):
    err = error(text)
    assert (err.field, err.line) == (field, line), str(err)
    assert words in err.message


@pytest.mark.parametrize(
    "text, field, words",
    [
        ("  - {tower: {levels: 2}}\n", "structure[0]", "needs a 'name'"),
        ("  - {name: a, tower: {levels: 2}}\n  - {name: a, on: a, tower: {levels: 2}}\n", "structure[1].name", "already"),
        (
            "  - {name: a, on: b, tower: {levels: 2}}\n  - {name: b, tower: {levels: 2}}\n",
            "structure[0].on",
            "written after this one",
        ),
        ("  - {name: a.b, tower: {levels: 2}}\n", "structure[0].name", "letters, digits"),
        ("  - {name: a, tower: {levels: 2}, wall: {courses: 1, bricks_per_course: 1}}\n", "structure[0]", "exactly one"),
        ("  - {name: a, towr: {levels: 2}}\n", "structure[0].towr", "did you mean 'tower'"),
        ("  - {name: a, tower: {levels: 2, brick: oak}}\n", "structure[0].tower.brick", "unknown brick type"),
        ("  - {name: a, bricks: [{at: [0, 0, 4 mm], fixed: true}]}\n", "structure", "nothing to build"),
        ("  - {name: a, bricks: [{at: [0, 0, 4 mm], together: true}]}\n", "structure[0].bricks[0].together", "no brick before"),
        ("  - {name: tower, bricks: [{at: [0, 0, 4 mm]}]}\n", "structure[0]", "another name"),
    ],
)
def test_bad_parts_are_refused_where_written(text, field, words):
    with pytest.raises(ScenarioError) as err:
        parse_scenario("stackdsl: 1\nstructure:\n" + text, "p.yaml")
    assert err.value.field == field and err.value.line is not None, str(err.value)
    assert words in err.value.message


def test_a_typo_of_a_single_layout_is_not_taken_for_a_part():
    with pytest.raises(ScenarioError, match="did you mean 'tower'"):
        parse_scenario("stackdsl: 1\nstructure: {towr: {levels: 3}}\n", "p.yaml")


def test_compile_shows_each_part_with_its_support_ids_and_levels():
    from stackdsl import format_program

    text = format_program(compile_scenario(parse_scenario(BRIDGE_MAP, "p.yaml")))
    assert "part   left       tower      on ground: 8 bricks, left.L01.1 to left.L04.2, levels 1-4" in text
    assert "part   deck       bricks     on left, right: 2 bricks, deck.b001 to deck.b002, level 5" in text
    assert "place  deck.b002  level   5" in text
    single = format_program(compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", "t.yaml")))
    assert "part " not in single


def test_interleaved_parts_rise_level_by_level_together():
    text = BRIDGE_LIST.replace("  - name: right\n", "  - name: right\n    interleave: true\n")
    ids = [b.id for b in laid(text)]
    assert ids[:6] == ["left.L01.1", "left.L01.2", "right.L01.1", "right.L01.2", "left.L02.1", "left.L02.2"]
    assert ids[-2:] == ["deck.b001", "deck.b002"]  # the deck is not interleaved: after both
    assert sorted(ids) == sorted(b.id for b in laid(BRIDGE_LIST))
    program = compile_scenario(parse_scenario(text, "p.yaml"))
    times = {a.id: a.time for a in program.placements}
    assert times["right.L01.1"] < times["left.L02.1"]
    with pytest.raises(ScenarioError, match="no part before it to interleave with"):
        parse_scenario(BRIDGE_LIST.replace("  - name: left\n", "  - name: left\n    interleave: true\n"), "p.yaml")


def test_a_sweep_grid_and_a_distribution_reach_into_parts():
    text = BRIDGE_MAP + "sweep: {samples: 2, grid: {structure.right.origin.0: [0.1, 0.12], structure.left.tower.levels: [4]}}\n"
    template = parse_scenario(
        text.replace("levels: 4, yaw: 90}, origin: [100 mm", "levels: 4, yaw: {choice: [90, 270]}}, origin: [100 mm"), "p.yaml"
    ).template
    assert template.cells == 2
    assert [template.scenario(c, 0).structure.parts["right"].origin[0] for c in range(2)] == [0.1, 0.12]
    assert {template.scenario(0, k).structure.parts["right"].tower.yaw for k in range(8)} == {90.0, 270.0}
    with pytest.raises(ScenarioError, match="has no field 'levls'"):
        parse_scenario(BRIDGE_MAP + "sweep: {samples: 1, grid: {structure.left.tower.levls: [2]}}\n", "p.yaml")


PER_LAYER_PARTS = """stackdsl: 1
seed: 3
structure:
  left: {tower: {levels: 5, bricks_per_layer: 1, turn: 0, shift: {uniform: [-20 mm, 20 mm], per: layer}, yaw_jitter: {uniform: [-2, 2], per: brick}}}
  right: {origin: [300 mm, 0], tower: {levels: 3, bricks_per_layer: 1, turn: 0, shift: [{uniform: [-5 mm, 5 mm], per: layer}, 0]}}
sweep: {samples: 4}
"""


@pytest.mark.parametrize("form", ["map", "list"])
def test_a_towers_per_layer_and_per_brick_draws_work_inside_a_part(form):
    """A part's tower takes ``per: layer`` on its shift and ``per: brick`` on its yaw jitter as the
    structure's own tower does (it was refused: "'per: layer' is not allowed here")."""
    text = PER_LAYER_PARTS
    if form == "list":
        text = text.replace("  left: {", "  - {name: left, ").replace("  right: {", "  - {name: right, ")
    t = parse_scenario(text, "p.yaml").template
    names = ("left", "right") if form == "map" else (0, 1)
    samples = [t.scenario(0, k).structure.parts for k in range(3)]
    left = [p[names[0]].tower for p in samples]  # type: ignore[index]
    right = [p[names[1]].tower for p in samples]  # type: ignore[index]
    assert all(len(tw.shifts) == 4 and len(tw.yaw_jitter) == 5 for tw in left)
    assert all(abs(x) <= 0.020 and y == 0 for tw in left for x, y in tw.shifts)
    assert len({tuple(tw.shifts) for tw in left}) == 3  # a new walk each sample
    assert len({x for x, _ in left[0].shifts}) == 4  # a draw a layer, not one a sample
    assert all(len(tw.shifts) == 2 and all(abs(x) <= 0.005 and y == 0 for x, y in tw.shifts) for tw in right)
    assert t.scenario(0, 1).structure.parts[names[0]].tower.shifts == left[1].shifts  # type: ignore[index]  # a function of (seed, k)
    label = "structure.left.tower.shift [m]"  # a list's part by its name too, as require: names it
    assert t.parameters(0, 0)[label] == pytest.approx([x for x, _ in left[0].shifts])


def test_a_part_on_itself_is_told_so():
    """'on' naming the part it is written in says so, not that the part comes after itself."""
    text = "stackdsl: 1\nstructure:\n  - {name: left, on: left, tower: {levels: 2}}\n"
    with pytest.raises(ScenarioError, match="'left' names this part itself") as err:
        parse_scenario(text, "self.yaml")
    assert (err.value.field, err.value.line) == ("structure[0].on", 3)


def test_a_part_on_parts_of_unequal_height_is_warned_of_the_one_it_does_not_reach():
    """A deck 'on: [left, right]' over towers of 5 and 3 levels sits on the left one's top and
    16 mm above the right one's: it rests on one of the two it was written to rest on."""
    import warnings

    from stackdsl.lang.errors import ScenarioWarning

    text = (
        "stackdsl: 1\nstructure:\n"
        "  - {name: left, tower: {levels: LEFT, yaw: 90}, origin: [-100 mm, 0]}\n"
        "  - {name: right, tower: {levels: 3, yaw: 90}, origin: [100 mm, 0]}\n"
        "  - {name: deck, on: [left, right], bricks: [{at: [0, -48 mm, 4 mm]}, {at: [0, 48 mm, 4 mm]}]}\n"
    )
    with pytest.warns(
        ScenarioWarning, match=r"u.yaml:5:22: warning: structure\[2\].on: .* does not reach 'right' \(16 mm lower\)"
    ):
        arrange(parse_scenario(text.replace("LEFT", "5"), "u.yaml"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", ScenarioWarning)
        arrange(parse_scenario(text.replace("LEFT", "3"), "e.yaml"))


def test_a_part_on_parts_stands_over_their_origin_unless_its_own_is_given():
    """``on: post`` puts a part over the post wherever the post stands; on a list of parts, over
    the middle of their origins; a given origin is where it stands."""

    def centre(text: str, part: str) -> tuple[float, float]:
        program = compile_scenario(parse_scenario("stackdsl: 1\nstructure:\n" + text, "p.yaml"))
        xy = np.array([p.position[:2] for p in program.placements if p.id.startswith(part + ".")])
        return tuple(np.round(xy.mean(axis=0) * 1000, 3) + 0.0)

    post = "  - {name: post, tower: {levels: 3}, origin: [-350 mm, 20 mm]}\n"
    assert centre(post + "  - {name: top, on: post, tower: {levels: 2}}\n", "top") == (-350.0, 20.0)
    assert centre(post + "  - {name: top, on: post, origin: [-340 mm, 20 mm], tower: {levels: 2}}\n", "top") == (-340.0, 20.0)
    two = (
        "  - {name: left, tower: {levels: 3}, origin: [-100 mm, 30 mm]}\n"
        "  - {name: right, tower: {levels: 3}, origin: [100 mm, 30 mm]}\n"
        "  - {name: deck, on: [left, right], bricks: [{at: [0, 48 mm, 4 mm]}]}\n"
    )
    assert centre(two, "deck") == (0.0, 78.0)  # 48 mm from the middle of the two origins


def test_the_keys_a_structure_allows_are_those_a_file_may_write():
    """'parts' is the Python models' field; a file writes the list or map itself, so the keys
    listed beside an unknown one leave it out (a file writing 'parts:' is refused)."""
    with pytest.raises(ScenarioError) as err:
        parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}, origin: [1, 0]}\n", "o.yaml")
    assert "allowed: bricks, card_house, dominoes, pyramid, tower, wall" in err.value.message, err.value.message


def test_a_part_on_fixed_bricks_stands_on_their_top_as_on_the_ground():
    """A fixed table is a support: ``on:`` a part of fixed bricks alone puts the part on their
    highest top, its first level 1 as on the ground (it was built on the ground, under the table,
    while ``compile`` said "on table"); ``on:`` a fixed brick by id puts it on that brick's top
    (it was refused as "part 'a' has no brick 'a.w'"). A part's fixtures are not its top when it
    has other bricks."""
    text = """stackdsl: 1
brick_types: {slab: {size: [300 mm, 300 mm, 20 mm]}, post: {size: [24 mm, 24 mm, 300 mm]}}
structure:
  - {name: table, bricks: [{id: top, at: [400 mm, 0, 150 mm], brick: slab, fixed: true}]}
  - {name: t, on: table, tower: {levels: 2}, origin: [400 mm, 0]}
  - {name: a, bricks: [{id: w, at: [0, 0, 30 mm], brick: slab, fixed: true}, {at: [-300 mm, 0, 4 mm]}, {id: p, at: [-300 mm, 150 mm, 150 mm], brick: post, fixed: true}]}
  - {name: b, on: a.w, bricks: [{at: [0, 0, 4 mm]}]}
  - {name: c, on: a, origin: [-300 mm, 0], bricks: [{at: [0, 0, 4 mm], yaw: 90}]}
"""
    bricks = {b.id: b for b in laid(text)}
    tower = [b for b in bricks.values() if b.id.startswith("t.")]
    assert {b.level for b in tower} == {1, 2}
    assert np.allclose(min(b.position[2] for b in tower), 0.160 + 0.004)  # on the table's top, 160 mm
    assert np.allclose(bricks["b.b001"].position, [0.0, 0.0, 0.040 + 0.004]) and bricks["b.b001"].level == 1
    # c is on a's standing brick (8 mm top, level 1), not on its fixed slab (40 mm) or post (300 mm)
    assert np.isclose(bricks["c.b001"].position[2], 0.008 + 0.004) and bricks["c.b001"].level == 2
    program = compile_scenario(parse_scenario(text, "p.yaml"))  # nothing overlaps, nothing floats
    parts = {p.name: p for p in program.parts}
    assert (parts["t"].on, parts["t"].levels) == ("table", (1, 2))
