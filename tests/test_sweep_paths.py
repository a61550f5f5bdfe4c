"""Field paths a user writes, in a grid key (``sweep.grid``) or a condition (``require:``): a
path the file cannot take is one ScenarioError at the key or the condition, never a Python
error, whatever node the path runs into (a number, a list, a distribution, a part by name, an
action of another kind); a path it can take sets or reads the field it names.

Source: stackdsl's own.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stackdsl import ScenarioError, compile_scenario, parse_scenario
from stackdsl.compile.require import DERIVED, quantities, scene, unreadable
from stackdsl.lang.field_kinds import whole_of

SHAKE = "actions:\n  - shake: {amplitude: 5 mm, frequency: 2 Hz, duration: 1 s, at: after level 3}\n"
SCENES = {
    "tower": "stackdsl: 1\nstructure: {tower: {levels: 3}}\n" + SHAKE,
    "list": (
        "stackdsl: 1\nstructure:\n  - {name: left, tower: {levels: 3}}\n  - {name: right, tower: {levels: 3}, origin: [0.3, 0]}\n"
    ),
    "map": "stackdsl: 1\nstructure:\n  left: {tower: {levels: 3}}\n  right: {tower: {levels: 2}, origin: [0.3, 0]}\n",
    "random": (
        "stackdsl: 1\nstructure: {tower: {levels: {choice: [3, 4]}, bricks_per_layer: 1, turn: 0,"
        " shift: {uniform: [-20 mm, 20 mm], per: layer}}}\n"
    ),
    "bricks": "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n    - {id: b, at: [0, 0, 12 mm]}\n",
}
WORDS = [
    "structure", "tower", "levels", "shift", "shifts", "spacing", "left", "right", "middle", "wall", "courses",
    "bricks", "at", "yaw", "id", "name", "actions", "shake", "remove", "amplitude", "speed", "timing", "interval",
    "choice", "uniform", "parts", "foo", "0", "1", "2", "7",
]  # fmt: skip
VALUES = ["2", "5 mm", "0.5 s", "{levels: 2}", "[1, 2]", "x", "null", "true", "[]", "{}"]


@st.composite
def paths(draw: st.DrawFn) -> str:
    """A dotted path of 1 to 6 words, each index written as ``.0`` or ``[0]``."""
    words = draw(st.lists(st.sampled_from(WORDS), min_size=1, max_size=6))
    out = words[0]
    for word in words[1:]:
        out += f"[{word}]" if word.isdigit() and draw(st.booleans()) else f".{word}"
    return out


def _with_grid(scene: str, key: str, values: str) -> str:
    return scene + f'sweep:\n  samples: 1\n  grid: {{"{key}": [{values}]}}\n'


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(sorted(SCENES)), paths(), st.sampled_from(VALUES))
def test_any_grid_key_is_taken_or_refused_at_the_key(name, key, value):
    text = _with_grid(SCENES[name], key, value)
    try:
        scenario = parse_scenario(text, "g.yaml")
        template = scenario.template
        assert all(whole_of(path) is None for path, _, _ in template.grid), key  # one field, never a section
        for c in range(template.cells):
            compile_scenario(template.scenario(c, 0))
            template.parameters(c, 0)
    except ScenarioError as exc:
        assert exc.file == "g.yaml" and exc.line is not None, str(exc)


@pytest.mark.parametrize(
    "scene, key, says",
    [
        (
            "list",
            "structure.middle.tower.levels",
            "structure is a list with no item named 'middle'; its items are named left, right",
        ),
        ("list", "structure.tower.levels", "no item named 'tower'"),
        ("map", "structure.middle.tower.levels", "structure has no part named 'middle' (its parts: left, right)"),
        ("tower", "structure.left.tower.levels", "structure has no part named 'left' (it is a tower, not parts)"),
        ("tower", "structure.tower.levels.foo", "structure.tower.levels is 3, which has no field 'foo'"),
        ("tower", "structure.tower.levels[0]", "this file has no item 0 in structure.tower.levels (it is 3)"),
        ("tower", "actions[0].shake.amplitude.foo", "actions[0].shake.amplitude is '5 mm', which has no field 'foo'"),
        ("tower", "actions[0].remove.speed", "actions[0] is a shake, not a remove"),
        ("tower", "structure.wall.courses", "structure is a tower, not a wall"),
        ("list", "structure.left.wall.courses", "structure[0] is a tower, not a wall"),
        ("random", "structure.tower.levels.choice", "structure.tower.levels is a distribution; the grid may replace it whole"),
    ],
)
def test_a_grid_key_the_file_cannot_take_is_refused_at_the_key(scene, key, says):
    with pytest.raises(ScenarioError) as err:
        parse_scenario(_with_grid(SCENES[scene], key, "2"), "g.yaml")
    key_line = _with_grid(SCENES[scene], key, "2").splitlines().index(f'  grid: {{"{key}": [2]}}') + 1
    assert (err.value.field, err.value.line, err.value.column) == (f"sweep.grid.{key}", key_line, 10)
    assert says in err.value.message


def test_a_grid_key_names_a_material_or_a_brick_type_by_its_name():
    """A material's or a brick type's name was read as a field of it: 'brick_types has no field 'long''."""
    text = """stackdsl: 1
materials: {soft: {density: 400 kg/m^3}}
brick_types: {long: {size: [150 mm, 24 mm, 8 mm], material: soft}}
structure: {tower: {levels: 2, brick: long}}
sweep:
  samples: 1
  grid: {brick_types.long.size: [[150 mm, 24 mm, 8 mm], [140 mm, 24 mm, 8 mm]], materials.soft.density: [400 kg/m^3, 500]}
"""
    template = parse_scenario(text, "g.yaml").template
    last = template.scenario(3, 0)
    assert last.brick_types["long"].size == pytest.approx((0.14, 0.024, 0.008)) and last.materials["soft"].density == 500
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text.replace("materials.soft.density", "materials.soft.densty"), "g.yaml")
    assert "materials.soft has no field 'densty'; it has: density, friction, restitution" in err.value.message


@pytest.mark.parametrize(
    "scene, key, what, such_as",
    [
        ("tower", "structure", "the whole structure section", "structure.tower.levels"),
        ("tower", "structure.tower", "a whole tower", "structure.tower.levels"),
        ("tower", "actions.0", "a whole action", "actions.0.shake.amplitude"),
        ("tower", "actions[0]", "a whole action", "actions[0].shake.amplitude"),
        ("tower", "actions[0].shake", "a whole shake", "actions[0].shake.amplitude"),
        ("tower", "actions", "the whole actions section", "actions.0.shake.amplitude"),
        ("tower", "timing", "the whole timing section", "timing.interval"),
        ("tower", "materials.pine", "a whole material", "materials.pine.density"),
        ("map", "structure.right", "a whole part", "structure.right.origin"),
        ("map", "structure.left", "a whole part", "structure.left.tower.levels"),
        ("list", "structure.right", "a whole part", "structure.right.origin"),
        ("list", "structure[1]", "a whole part", "structure[1].origin"),
        ("bricks", "structure.bricks", "the whole list of bricks", "structure.bricks.0.at"),
        ("bricks", "structure.bricks.1", "a whole brick", "structure.bricks.1.at"),
    ],
)
def test_a_grid_key_naming_a_whole_section_item_or_list_is_refused_at_the_key(scene, key, what, such_as):
    """A grid key names one field: a whole section, part, action or list was taken, its cells
    whole scenes labelled by all of their text. The field suggested is one a grid takes."""
    text = _with_grid(SCENES[scene], key, "{}")
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "g.yaml")
    key_line = text.splitlines().index(f'  grid: {{"{key}": [{{}}]}}') + 1
    assert (err.value.field, err.value.line, err.value.column) == (f"sweep.grid.{key}", key_line, 10)
    assert f"the grid names {key!r}, but that is {what}, not one field" in err.value.message
    assert f"such as {such_as!r}" in err.value.message
    ends = {"levels": "2", "at": "[0, 0, 4 mm]", "amplitude": "2 mm", "density": "400 kg/m^3", "origin": "[0.3, 0]"}
    value = ends.get(such_as.rsplit(".", 1)[-1], "1")
    template = parse_scenario(_with_grid(SCENES[scene], such_as, value), "g.yaml").template
    assert [key for _, key, _ in template.grid] == [such_as]


def test_a_grid_may_give_one_field_whole_whatever_its_form():
    """Numbers, quantities, words, lists of numbers, and the values a file writes as a mapping (a
    target, a moment after a level) are single fields: a grid varies them."""
    text = """stackdsl: 1
brick_types: {long: {size: [150 mm, 24 mm, 8 mm]}}
structure: {tower: {levels: 3, brick: long}}
timing: {settle: 0.5 s}
impacts:
  - {target: {level: 3, side: +x}, direction: [-1, 0, 0], speed: 1 m/s, at: after level 3}
actions:
  - push: {target: {brick: L01.1}, direction: [0, 1, 0], at: 5 s}
sweep:
  samples: 1
  grid:
    brick_types.long.size: [[150 mm, 24 mm, 8 mm], [140 mm, 24 mm, 8 mm]]
    impacts.0.target: [{level: 3, side: +x}, {point: [0, 0, 20 mm]}]
    actions[0].push.at: [5 s, {after_level: 3}]
    structure.tower.brick: [long, kapla]
"""
    template = parse_scenario(text, "g.yaml").template
    assert template.cells == 16
    last = template.scenario(15, 0)
    assert last.impacts[0].target.point == (0.0, 0.0, 0.02)
    assert last.actions[0].push is not None and last.actions[0].push.at.after_level == 3
    assert last.structure.tower is not None and last.structure.tower.brick == "kapla"
    assert template.scenario(0, 0).brick_types["long"].size == (0.15, 0.024, 0.008)
    assert template.label(15) == (
        "brick_types.long.size = [140 mm, 24 mm, 8 mm], impacts.0.target = {point: [0, 0, 20 mm]}, "
        "actions[0].push.at = {after_level: 3}, structure.tower.brick = kapla"
    )
    compile_scenario(last)


@pytest.mark.parametrize(
    "scene, key",
    [
        ("list", "structure.left.tower.levels"),
        ("list", "structure.0.tower.levels"),
        ("list", "structure[1].tower.levels"),
        ("map", "structure.left.tower.levels"),
    ],
)
def test_a_part_is_named_in_a_grid_key_by_its_name_or_in_a_list_its_index(scene, key):
    template = parse_scenario(_with_grid(SCENES[scene], key, "4, 5"), "g.yaml").template
    part = 1 if "[1]" in key else 0
    other = 1 - part
    levels = [[p.tower.levels for p in _parts(template.scenario(c, 0))] for c in range(template.cells)]
    assert [ls[part] for ls in levels] == [4, 5]
    assert len({ls[other] for ls in levels}) == 1  # the other part is left as written
    assert template.values(1) == {key.replace("[1]", ".1"): 5.0}


def _parts(scenario):
    parts = scenario.structure.parts
    return list(parts.values()) if isinstance(parts, dict) else parts


@pytest.mark.parametrize(
    "scene, first, second, says",
    [
        ("list", "structure.left.tower.levels", "structure[0].tower.levels", "the same field as"),
        ("bricks", "structure.bricks.1.at", "structure.bricks[1].at[2]", "a field inside"),
        ("bricks", "structure.bricks.1.at.2", "structure.bricks[1].at", "a field around"),
    ],
)
def test_two_grid_keys_for_one_field_are_refused(scene, first, second, says):
    text = SCENES[scene] + f'sweep:\n  samples: 1\n  grid:\n    "{first}": [4 mm]\n    "{second}": [5 mm]\n'
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "g.yaml")
    assert err.value.field == f"sweep.grid.{second}" and f"{says} '{first}'" in err.value.message


@pytest.mark.slow
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(sorted(SCENES)), paths())
def test_a_condition_reads_a_number_or_says_why_its_name_reads_none(name, path):
    """The name of a condition either reads a number of the first draw (and is among what
    conditions read), or may in another draw (a file with distributions), or is refused with
    why; the file is refused at the condition, never with a Python error."""
    text = SCENES[name] + "sweep: {samples: 2}\n"
    scenario = parse_scenario(text, "r.yaml")
    name_as_read = path.replace("[", ".").replace("]", "")
    why = unreadable(scene(scenario), name_as_read, scenario.template, isinstance(scenario.structure.parts, list))
    values = quantities(scenario, set())
    if name_as_read in values:
        assert why is None
    elif why is None and not scenario.template.distributions:
        raise AssertionError(f"{name_as_read} reads nothing, yet is not refused")
    condition = f"{path} > 0 or levels > 0"  # holds at the first draw whenever the name is taken
    try:
        compile_scenario(parse_scenario(text + f"require: ['{condition}']\n", "r.yaml"))
    except ScenarioError as exc:
        assert exc.field == "require[0]" and "nan" not in exc.message, str(exc)
        assert path not in DERIVED


STACK = """stackdsl: 1
structure: {tower: {levels: 6, bricks_per_layer: 1, turn: 0, shift: {uniform: [-40 mm, 40 mm], per: layer}}}
sweep: {samples: 5}
"""


@pytest.mark.parametrize(
    "condition, says",
    [
        (
            "structure.tower.shifts.7.0 > 0",
            "no such field 'structure.tower.shifts.7.0': structure.tower.shifts has items 0 to 4, no item 7",
        ),
        ("structure.tower.shifts.0 > 0", "structure.tower.shifts.0 has items 0 (along x) and 1 (along y), not one number"),
        ("structure.tower.levels.0 > 0", "structure.tower.levels is a number, with no item 0"),
        ("structure.tower.brick > 0", "structure.tower.brick is 'kapla', not a number"),
        ("structure.wall.courses > 0", "structure is a tower, not a wall"),
        ("structure.left.tower.levels > 0", "structure has no field 'left'; it has: tower"),
        # a shift drawn per layer is its shifts: the name written for it says where they are
        ("structure.tower.shift.0 > 0", "structure.tower.shift is drawn per layer, into structure.tower.shifts"),
        ("structure.tower.shift.5 > 0", "read level 2's shift on level 1 as structure.tower.shifts.0.0 (along x)"),
        ("structure.tower.shift > 0", "samples.csv's structure.tower.shift"),
    ],
)
def test_a_condition_on_a_field_the_scene_has_not_is_refused_at_it(condition, says):
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(STACK + f"require: ['{condition}']\n", "r.yaml"))
    assert (err.value.field, err.value.line) == ("require[0]", 4)
    assert says in err.value.message and "draws" not in err.value.message


def test_a_per_layer_shift_is_read_from_its_shifts():
    scenario = parse_scenario(STACK + "require: ['structure.tower.shifts.0.0 > 10 mm']\n", "r.yaml")
    for k in range(5):
        program = compile_scenario(scenario.template.scenario(0, k))
        bricks = sorted(program.placements, key=lambda p: p.position[2])
        assert bricks[1].position[0] - bricks[0].position[0] > 0.01  # level 2 on level 1, as drawn


def test_a_part_of_a_list_is_read_by_its_name_or_its_index():
    text = "stackdsl: 1\nstructure:\n  - {name: left, tower: {levels: {choice: [2, 3, 4]}}}\nsweep: {samples: 4}\n"
    for name in ("structure.0.tower.levels", "structure.left.tower.levels"):
        template = parse_scenario(text + f"require: ['{name} >= 3']\n", "r.yaml").template
        drawn = [compile_scenario(template.scenario(0, k)) for k in range(4)]
        assert all(p.levels >= 3 for p in drawn)


@pytest.mark.slow
def test_a_division_by_zero_is_said_as_such():
    with pytest.raises(ScenarioError) as err:
        parse_scenario(STACK + "require: ['1 / (2 - 2) > 0']\n", "r.yaml")
    assert err.value.field == "require[0]" and "at character 5: divides by zero" in err.value.message
    with pytest.raises(ScenarioError) as err:  # a field that is 0 in every draw
        compile_scenario(parse_scenario(STACK + "require: ['1 / structure.tower.turn > 0']\n", "r.yaml"))
    assert "it divides by zero in every one of them" in err.value.message


def test_a_name_no_draw_has_is_said_as_such_not_as_nan():
    text = STACK.replace("levels: 6,", "levels: {choice: [3, 4]},")
    with pytest.raises(ScenarioError) as err:
        compile_scenario(parse_scenario(text + "require: ['structure.tower.shifts.5.0 > 0']\n", "r.yaml"))
    assert "no draw of the scene has structure.tower.shifts.5.0" in err.value.message
    assert "nan" not in err.value.message and not math.isnan(0.0)


def test_a_grid_cell_is_labelled_as_the_file_writes_its_values():
    """Cell labels printed Python's reprs: radius = None, interleave = True, target =
    {'point': [0, 0, '4 mm']}; they are the file's spelling: null, true, {point: [0, 0, 4 mm]}."""
    text = """stackdsl: 1
structure:
  - {name: a, tower: {levels: 2}}
  - {name: b, tower: {levels: 2}, origin: [300 mm, 0]}
actions:
  - push: {target: {brick: a.L01.1}, direction: [0, 1, 0], at: after level 4}
sweep:
  samples: 1
  grid:
    structure.b.interleave: [true, false]
    actions.0.push.target: [{point: [0, -30 mm, 4 mm]}, {brick: b.L01.1, offset: [0, 0, 2 mm]}]
    collapse_threshold: [null, 4 mm]
expect: {p_stands: ">= 0.5"}
"""
    template = parse_scenario(text, "g.yaml").template
    assert template.label(0) == (
        "structure.b.interleave = true, actions.0.push.target = {point: [0, -30 mm, 4 mm]}, collapse_threshold = null"
    )
    assert template.label(7) == (
        "structure.b.interleave = false, actions.0.push.target = {brick: b.L01.1, offset: [0, 0, 2 mm]}, "
        "collapse_threshold = 4 mm"
    )


@pytest.mark.parametrize(
    "names, says", [("[x, a]", "sample 0 of grid cell 0 (structure.0.name = x): "), ("[a, x]", "with structure.0.name = x: ")]
)
def test_an_error_a_grid_value_makes_at_another_field_names_the_grid_value(names, says):
    """A grid renaming a part breaks the 'on' of a later part: the error is at that 'on', and says
    which grid value made it (it said nothing of the grid); the file's own error does not."""
    text = f"""stackdsl: 1
structure:
  - {{name: a, tower: {{levels: 2}}}}
  - {{name: c, on: a, bricks: [{{at: [0, 0, 4 mm]}}]}}
sweep: {{samples: 1, grid: {{structure.0.name: {names}}}}}
expect: {{p_stands: ">= 0.5"}}
"""
    with pytest.raises(ScenarioError) as err:
        parse_scenario(text, "g.yaml")
    assert (err.value.field, err.value.line) == ("structure[1].on", 4)
    assert err.value.message.startswith(says + "'a' names no part before this one")
    own = text.replace("{name: c, on: a,", "{name: c, on: a, yaw: 1 km,")
    with pytest.raises(ScenarioError) as err:
        parse_scenario(own, "g.yaml")
    assert err.value.field == "structure[1].yaw" and err.value.message.startswith("expected an angle")
