"""Scenarios built in Python from the language's models, and written back as YAML: every shipped
scenario reads back from its ``to_yaml()`` to a scenario that compiles to the identical Program."""

from __future__ import annotations

from pathlib import Path

import pytest

from stackdsl import ScenarioError, compile_scenario, load_scenario, parse_scenario
from stackdsl.lang.models import BrickPlacement, Dominoes, Expect, Part, Pyramid, Scenario, Structure, Timing, Tower, Wall

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = sorted([*(ROOT / "scenarios").rglob("*.yaml"), *(ROOT / "sweeps").glob("*.yaml")])


@pytest.mark.parametrize("path", SHIPPED, ids=[str(p.relative_to(ROOT)) for p in SHIPPED])
def test_every_shipped_scenario_reads_back_from_its_yaml_to_the_same_program(path):
    scenario = load_scenario(path)
    again = parse_scenario(scenario.to_yaml(), f"{path.name} as written back")
    assert again.model_dump() == scenario.model_dump()
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


def test_a_built_composition_is_checked_as_a_file_is_when_compiled():
    towers = [Part(name="a", tower=Tower(levels=2)), Part(name="b", on="c", origin=(1, 0), tower=Tower(levels=2))]
    with pytest.raises(ScenarioError, match="'c' names no part before this one"):
        compile_scenario(Scenario(stackdsl=1, structure=Structure(parts=towers)))
    unnamed = [Part(tower=Tower(levels=2))]
    with pytest.raises(ScenarioError, match="needs a 'name'"):
        compile_scenario(Scenario(stackdsl=1, structure=Structure(parts=unnamed)))
    with pytest.raises(ScenarioError, match="unknown brick type 'oak'"):
        compile_scenario(Scenario(stackdsl=1, structure=Structure(tower=Tower(levels=2, brick="oak"))))


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
