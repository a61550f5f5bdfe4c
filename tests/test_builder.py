"""Scenarios built in Python from the language's models, and written back as YAML: every shipped
scenario reads back from its ``to_yaml()`` to a scenario that compiles to the identical Program."""

from __future__ import annotations

import copy
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from stackdsl import ScenarioError, compile_scenario, load_scenario, parse_scenario
from stackdsl.lang.models import (
    BrickPlacement,
    BrickType,
    CardHouse,
    Dominoes,
    Expect,
    Impact,
    Material,
    Part,
    Pyramid,
    Scenario,
    Structure,
    Sweep,
    Timing,
    Tower,
    Wall,
)

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted([*(ROOT / "scenarios").rglob("*.yaml"), *(ROOT / "sweeps").glob("*.yaml")])


@pytest.mark.parametrize("path", SHIPPED, ids=[str(p.relative_to(ROOT)) for p in SHIPPED])
def test_every_shipped_scenario_reads_back_from_its_yaml_to_the_same_program(path):
    scenario = load_scenario(path)
    again = parse_scenario(scenario.to_yaml(), f"{path.name} as written back")
    assert again.model_dump() == scenario.model_dump()
    assert again == scenario
    assert compile_scenario(again).model_dump() == compile_scenario(scenario).model_dump()


def test_the_bridge_built_in_python_is_the_shipped_bridge():
    bridge = Scenario(
        stackdsl=1,
        name="bridge",
        structure=Structure(
            parts=[
                Part(name="left", origin=(-0.1, 0), tower=Tower(levels=6, yaw=90)),
                Part(name="right", origin=("100 mm", 0), tower=Tower(levels=6, yaw=90)),
                Part(
                    name="deck",
                    on=["left", "right"],
                    bricks=[BrickPlacement(at=(0, y, "4 mm")) for y in ("-48 mm", "48 mm")],
                ),
            ]
        ),
        expect=Expect(stands=True),
    )
    shipped = load_scenario(ROOT / "scenarios" / "bridge.yaml")
    assert compile_scenario(bridge).model_dump() == compile_scenario(shipped).model_dump()
    assert parse_scenario(bridge.to_yaml()).model_dump() == bridge.model_dump()


def test_a_built_scene_of_every_new_layout_round_trips():
    scene = Scenario(
        stackdsl=1,
        name="every layout",
        structure=Structure(
            parts={
                "bond": Part(wall=Wall(courses=3, bricks_per_course=2, laid="edge", joint="1 mm")),
                "steps": Part(origin=(0, 0.2), pyramid=Pyramid(base=3, yaw=10)),
                "row": Part(origin=(0.5, 0), dominoes=Dominoes(count=5, radius=-0.4)),
                "top": Part(on="steps.L03.1", bricks=[BrickPlacement(at=(0, 0, 0.004), yaw=90)]),
            }
        ),
        timing=Timing(interval=0.5),
        require=["bricks == 19 and gap < 1 mm"],
    )
    text = scene.to_yaml()
    assert "bond:\n    wall:" in text and "'on': steps.L03.1" in text
    assert parse_scenario(text).model_dump() == scene.model_dump()
    assert compile_scenario(parse_scenario(text)).model_dump() == compile_scenario(scene).model_dump()


def test_a_built_scenario_is_checked_as_a_file_is():
    with pytest.raises(ValueError, match="exactly one of"):
        Part(name="a", tower=Tower(levels=2), wall=Wall(courses=1, bricks_per_course=1))
    with pytest.raises(ValueError, match="greater than or equal to 1"):
        Dominoes(count=0)
    with pytest.raises(ValueError, match="'wall' is a key of the structure"):
        Structure(parts={"wall": Part(wall=Wall(courses=1, bricks_per_course=1))})


@pytest.mark.parametrize("bad", ["3", "007", "1e3", "0", "-1", ".", "-", "..", "2001-01-01", "a.", "ground"])
def test_a_brick_id_that_reads_as_a_level_or_the_ground_is_refused_as_in_a_file(bad):
    """A file's 'expect' reads '3' and '007' as levels, '.' as nothing, and 'ground' is the ground's
    id in the timeline: the models refuse such an id of a brick, an impact or a pusher."""
    with pytest.raises(ValidationError, match=r"pattern|names the ground"):
        BrickPlacement(id=bad, at=(0, 0, 0.004))
    with pytest.raises(ValidationError, match=r"pattern|names the ground"):
        Impact(id=bad, target={"level": 1, "side": "+x"}, speed=1, at=1)
    head = "stackdsl: 1\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n"
    with pytest.raises(ScenarioError) as err:
        parse_scenario(head + f"    - {{id: '{bad}', at: [0, 0, 12 mm]}}\n", "ids.yaml")
    assert (err.value.line, err.value.column, err.value.field) == (5, 12, "structure.bricks[1].id")
    assert "an ASCII letter or '_' first" in err.value.message or "names the ground" in err.value.message
    assert BrickPlacement(id="_" + bad.strip("."), at=(0, 0, 0.004)).id  # with a '_' first it is an id


def test_a_name_the_loader_reads_as_a_merge_key_is_refused_by_the_models():
    """'<<' as a material's, a brick type's or a grid field's name was accepted in Python, and
    to_yaml wrote a file the loader refused (its merge key): builder and loader now agree."""
    tower = Structure(tower=Tower(levels=2))
    for build in (
        lambda: Scenario(stackdsl=1, materials={"<<": Material(density=500, friction=0.5)}, structure=tower),
        lambda: Scenario(stackdsl=1, brick_types={"<<": BrickType(size=(0.1, 0.02, 0.01))}, structure=tower),
        lambda: Sweep(samples=2, grid={"<<": [1, 2]}),
    ):
        with pytest.raises(ValidationError, match="'<<' is YAML's merge key"):
            build()
    odd = Scenario(
        stackdsl=1,
        materials={"< <": Material(density=500, friction=0.5)},
        brick_types={"<": BrickType(size=(0.1, 0.02, 0.01), material="< <")},
        structure=Structure(tower=Tower(levels=2, brick="<")),
    )
    assert parse_scenario(odd.to_yaml()) == odd  # a name like it is written and read back


def _readme_bridge() -> Scenario:
    """The README's bridge, as the README builds it (no name)."""
    towers = [Part(name=n, origin=(x, 0), tower=Tower(levels=6, yaw=90)) for n, x in (("left", "-100 mm"), ("right", "100 mm"))]
    deck = Part(name="deck", on=["left", "right"], bricks=[{"at": (0, y, "4 mm")} for y in ("-48 mm", "48 mm")])
    return Scenario(stackdsl=1, structure=Structure(parts=[*towers, deck]), expect={"stands": True})


UNNAMED = {
    "tower": lambda: Scenario(stackdsl=1, structure=Structure(tower=Tower(levels=3))),
    "README bridge": _readme_bridge,
    "card house and timing": lambda: Scenario(
        stackdsl=1, structure=Structure(card_house=CardHouse(levels=2)), timing=Timing(interval=0.5), expect={"stands": True}
    ),
    "map of layouts with an action": lambda: Scenario(
        stackdsl=1,
        structure=Structure(
            parts={
                "stack": Part(tower=Tower(levels=4)),
                "steps": Part(origin=(0, 0.3), pyramid=Pyramid(base=3)),
                "row": Part(origin=(0.5, 0), dominoes=Dominoes(count=4)),
            }
        ),
        actions=[{"remove": {"brick": "stack.L02.2", "at": "after level 4", "speed": "20 mm/s"}}],
    ),
}


@pytest.mark.parametrize("build", UNNAMED.values(), ids=UNNAMED.keys())
def test_a_built_scenario_without_a_name_reads_back_from_its_yaml_to_the_same_program(build):
    """A scenario read from text of no file was named '<scenario>' (the stem of its stand-in file
    name) and a built one None: the two compiled to Programs of different names, and to_yaml()
    wrote 'name: <scenario>' back. Text of no file keeps no name, as a built scenario does."""
    built = build()
    text = built.to_yaml()
    assert "name:" not in text.split("structure:")[0]
    again = parse_scenario(text)
    assert again.name is None and again.model_dump() == built.model_dump()
    assert compile_scenario(again) == compile_scenario(built)
    assert compile_scenario(again).model_dump() == compile_scenario(built).model_dump()
    assert again.to_yaml() == text
    assert parse_scenario(text, "from a file.yaml").name == "from a file"  # a file still names it by its stem


def test_a_built_composition_is_refused_when_built_at_the_field_its_file_names():
    """The checks between parts and of names (an 'on' that names no part before, two parts named
    alike, an unknown brick type) ran only when a built scenario was compiled; they refuse it when
    it is built, at the field a file's error names, and a file's error is unchanged."""
    towers = [Part(name="a", tower=Tower(levels=2)), Part(name="b", on="c", origin=(1, 0), tower=Tower(levels=2))]
    twins = [Part(name="a", tower=Tower(levels=2)), Part(name="a", origin=(1, 0), tower=Tower(levels=2))]
    cases = [
        (Structure(parts=towers), ("structure", 1, "on"), "'c' names no part before this one", "c"),
        (Structure(parts=twins), ("structure", 1, "name"), "there is already a part named 'a'", "a"),
        (
            Structure(parts={"a": Part(tower=Tower(levels=2)), "b": Part(on=["a", "zz"], origin=(1, 0), tower=Tower(levels=2))}),
            ("structure", "b", "on", 1),
            "'zz' names no part before this one",
            "zz",
        ),
        (Structure(parts=[Part(tower=Tower(levels=2))]), ("structure", 0), "needs a 'name'", None),
        (Structure(tower=Tower(levels=2, brick="oak")), ("structure", "tower", "brick"), "unknown brick type 'oak'", "oak"),
    ]
    for structure, loc, message, refused_value in cases:
        with pytest.raises(ValidationError) as refused:
            Scenario(stackdsl=1, structure=structure)
        (error,) = refused.value.errors()
        assert error["loc"] == loc and message in error["msg"]
        if refused_value is not None:
            assert error["input"] == refused_value
    written = "stackdsl: 1\nstructure:\n  - {name: a, tower: {levels: 2}}\n  - {name: a, tower: {levels: 2}, origin: [1, 0]}\n"
    with pytest.raises(ScenarioError) as from_file:
        parse_scenario(written, "twins.yaml")
    assert str(from_file.value).splitlines()[0] == "twins.yaml:4:12: structure[1].name: there is already a part named 'a'"
    forward = "stackdsl: 1\nstructure:\n  - {name: deck, on: [left, right], bricks: [{at: [0, 0, 4 mm]}]}\n  - {name: left, tower: {levels: 2}}\n  - {name: right, tower: {levels: 2}, origin: [1, 0]}\n"
    with pytest.raises(ScenarioError) as two:
        parse_scenario(forward, "forward.yaml")
    assert [(e.field, e.line, e.column, e.message.split(" names")[0]) for e in (two.value, *two.value.others)] == [
        ("structure[0].on[0]", 3, 23, "'left'"),
        ("structure[0].on[1]", 3, 29, "'right'"),
    ]  # both said, each at its name


def test_a_scenario_made_without_validation_is_still_checked_when_compiled():
    unchecked = Scenario.model_construct(
        stackdsl=1, structure=Structure.model_construct(parts=[Part(name="a", on="c", tower=Tower(levels=2))])
    )
    with pytest.raises(ScenarioError, match="'c' names no part before this one"):
        compile_scenario(unchecked)


def test_a_length_far_from_plausible_is_written_back_with_its_unit_and_reads_back_silently():
    """to_yaml wrote SI numbers bare: a tower 1 km away read back as '1000 is read as 1000 m; did
    you mean 1000 mm?'. Such a length is written '1000.0 m'; plausible ones stay bare."""
    import warnings

    from stackdsl.lang.models import Scenario, Structure, Tower

    built = Scenario(stackdsl=1, structure=Structure(tower=Tower(levels=2, origin=(1000, 0), spacing=0.1)))
    text = built.to_yaml()
    assert "origin: [1000.0 m, 0.0]" in text and "spacing: 0.1\n" in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        again = parse_scenario(text, "built.yaml")
    assert again.structure.tower is not None and again.structure.tower.origin == (1000.0, 0.0)


def test_a_random_scenario_built_as_plain_data_reads_as_its_yaml_does():
    """Distributions are a file's; in Python a random scene is its plain data, which
    parse_scenario reads as it reads the same YAML: the same draws, sample for sample."""
    import yaml

    data = {
        "stackdsl": 1,
        "seed": 3,
        "structure": {
            "tower": {"levels": 4, "bricks_per_layer": 1, "turn": 0, "shift": {"uniform": ["-5 mm", "5 mm"], "per": "layer"}}
        },
        "timing": {"placement_error": "1 mm"},
        "sweep": {"samples": 3, "grid": {"timing.interval": ["1 s", "2 s"]}},
    }
    built, written = parse_scenario(data), parse_scenario(yaml.safe_dump(data))
    assert built.template is not None and written.template is not None
    for cell, k in [(0, 0), (0, 2), (1, 1)]:
        assert compile_scenario(built.template.scenario(cell, k)) == compile_scenario(written.template.scenario(cell, k))
    assert compile_scenario(built.template.scenario(0, 0)) != compile_scenario(built.template.scenario(0, 1))
    with pytest.raises(TypeError, match="plain data"):
        parse_scenario({"stackdsl": 1, "structure": {"tower": {"levels": object()}}})


#: Names the language takes that YAML may read as something else: numbers with an exponent and no
#: point (a number to the loader, as YAML 1.2 reads them), YAML 1.1's numbers, flags and null.
LOOK_ALIKES = ["1e3", "1E3", "-1e3", "12e03", "1e-3", "1e+3", "0e0", "010", "0x1f", "0o17", "1_000", "-5", "3.5"]
LOOK_ALIKES += ["true", "False", "yes", "No", "on", "OFF", "y", "n", "null", "Null", "NaN", "inf", "-.inf", ".nan", "_"]


def _exponent(parts: tuple[str, str, str, str, str]) -> str:
    sign, digits, e, esign, exponent = parts
    return f"{sign}{digits}{e}{esign}{exponent}"


NAMES = st.one_of(
    st.sampled_from(LOOK_ALIKES),
    st.tuples(
        st.sampled_from(["", "-"]),
        st.from_regex(r"[0-9][0-9_]{0,5}", fullmatch=True),
        st.sampled_from("eE"),
        st.sampled_from(["", "-", "+"]),
        st.from_regex(r"[0-9]{1,3}", fullmatch=True),
    ).map(_exponent),
    st.integers(-(10**12), 10**12).map(str),
    st.from_regex(r"[A-Za-z0-9_-]{1,40}", fullmatch=True),
)
LABELS = st.one_of(st.sampled_from(LOOK_ALIKES), NAMES, st.text(min_size=1, max_size=60))
#: Part names and brick ids start with a letter or '_' (``expect`` reads 3 as a level): the same
#: look-alikes behind a '_' where they do not, so that few examples are refused.
IDS = NAMES.map(lambda n: n if n[:1].isalpha() or n[:1] == "_" else f"_{n}")


@pytest.mark.slow  # 3-5 s: in .ci/nightly's slow part
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(
    name=LABELS,
    description=st.one_of(LABELS, st.text(max_size=200)),
    part=IDS,
    brick=IDS,
    material=NAMES,
    kind=NAMES,
    choice=NAMES,
)
@example(
    name="a\x85b\u2028c", description="d\u2029e\nf\x85", part="_1e3", brick="Null", material="1E3", kind="12e03", choice="1e-3"
)
def test_to_yaml_quotes_every_text_the_loader_would_read_as_something_else(
    name, description, part, brick, material, kind, choice
):
    """A part, brick id, brick type or material named 1e3 was written bare and read back as the
    number 1000.0; a name with U+0085 (a YAML line break) came back with a space."""
    assume(part != "top" and kind != "kapla" and material != "pine" and choice != kind)
    data = {
        "stackdsl": 1,
        "name": name,
        "description": description,
        "materials": {material: {"density": 460, "friction": 0.5}},
        "brick_types": {t: {"size": [0.12, 0.024, 0.008], "material": material} for t in (kind, choice)},
        "structure": {
            part: {"tower": {"levels": 2, "brick": kind}},
            "top": {"on": part, "bricks": [{"at": [0, 0, 0.004], "id": brick, "brick": choice}]},
        },
    }
    drawn = copy.deepcopy(data)  # a random file is written as its data, distributions and all
    drawn["structure"][part]["tower"]["brick"] = {"choice": [kind, choice]}
    for written in (data, drawn):
        try:
            scenario = parse_scenario(written)
        except ScenarioError:
            assume(False)  # a name the language refuses (a control character, too long)
        again = parse_scenario(scenario.to_yaml())
        assert again == scenario
        assert (again.name, again.description) == (name, description)
        assert again.model_dump() == scenario.model_dump()


def test_a_scenario_read_back_from_its_yaml_equals_it():
    """parse_scenario(s.to_yaml()) == s was False with every field, the YAML and the Program equal:
    pydantic's equality compared the source maps (file name, lines, positions) too."""
    built = Scenario(stackdsl=1, name="t", structure=Structure(tower=Tower(levels=3)), expect=Expect(stands=True))
    assert parse_scenario(built.to_yaml()) == built
    assert parse_scenario(built.to_yaml(), "other.yaml") == built  # where it was read from is no part of it
    assert parse_scenario(built.to_yaml().replace("levels: 3", "levels: 4")) != built
    shipped = load_scenario(ROOT / "sweeps" / "required_to_stand.yaml")  # a sweep: its file data and sample too
    again = parse_scenario(shipped.to_yaml(), "elsewhere.yaml")
    assert again == shipped and again != shipped.template.scenario(0, 1)


@pytest.mark.parametrize("text", ["a\x00b", "a\x07b", "\x1b[31mred", "a\ufffeb"])
def test_the_builder_refuses_a_character_the_loader_refuses(text):
    # Scenario(name="a\x00b") was built, and its to_yaml() refused by the loader
    with pytest.raises(ValidationError, match=r"U\+[0-9A-F]{4}.* is not allowed in a value") as err:
        Scenario(stackdsl=1, name=text, structure={"tower": {"levels": 2}})
    assert err.value.errors()[0]["loc"] == ("name",)
    with pytest.raises(ValidationError, match="is not allowed in a value") as err:
        Scenario(stackdsl=1, materials={text: {"density": 500}}, structure={"tower": {"levels": 2}})
    with pytest.raises(ValidationError, match="is not allowed in a value"):
        Scenario(stackdsl=1, structure={"tower": {"levels": 2}}, xfail={"reason": text})


@given(st.text(max_size=8))
@settings(max_examples=200, deadline=None)
def test_what_the_builder_accepts_the_loader_reads_back(text):
    try:
        built = Scenario(stackdsl=1, name=text or "x", description=text, structure={"tower": {"levels": 2}})
    except ValidationError:
        return
    again = parse_scenario(built.to_yaml())
    assert (again.name, again.description) == (built.name, built.description)


def test_a_grid_key_the_loader_refuses_is_refused_by_the_models():
    """Found by the grammar fuzzer (tests/test_grammar_fuzz.py): Sweep(grid={'L01.1': [...]}) was
    accepted in Python, and its to_yaml() was a file the loader refused ('no field L01')."""
    for key in ("L01.1", "timing.placement_eror", "expect.stands", "seed"):
        with pytest.raises(ValidationError, match=r"the grid names|the grid varies the scene"):
            Sweep(samples=2, grid={key: [1, 2]})
        with pytest.raises(ScenarioError) as err:
            parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nsweep:\n  grid: {{'{key}': [1, 2]}}\n", "g.yaml")
        assert (err.value.line, err.value.field) == (4, f"sweep.grid.{key}")  # the loader's position, unchanged
    built = Scenario(
        stackdsl=1, structure=Structure(tower=Tower(levels=2)), sweep=Sweep(samples=2, grid={"timing.settle": [0.2, 0.3]})
    )
    assert parse_scenario(built.to_yaml()).template is not None  # a grid of a field: written and read back
