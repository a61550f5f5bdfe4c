"""The summary of a changed golden snapshot: what differs, named by its key, and nothing else."""

import copy
import json
import random
import re
from pathlib import Path

import pytest

from stackdsl.verdicts.snapshot import dumps, summarize

ROOT = Path(__file__).resolve().parents[1]

STAIR = {
    "scenario": "single-file staircase 13 mm",
    "mode": "extension",
    "levels_placed": 2,
    "collapse": None,
    "certificate": {"verdict": "stands", "kind": "equilibrium", "bricks": [], "margin_mm": 1.5},
    "collapse_graph": None,
    "final_graph": {
        "L01.1": {
            "level": 1,
            "state": "frozen",
            "position_mm": [0.0, 0.0, 4.0],
            "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0],
            "com_above_mm": [52.0, 0.0, 36.0],
            "mass_above_g": 21.2,
            "rests_on": {"ground": {"area_mm2": 2880.0, "load_share": 1.0}},
        },
        "L02.1": {
            "level": 2,
            "state": "frozen",
            "position_mm": [13.0, 0.0, 12.0],
            "quaternion_xyzw": [0.0, 0.0, 0.0, 1.0],
            "com_above_mm": [13.0, 0.0, 12.0],
            "mass_above_g": 10.6,
            "rests_on": {"L01.1": {"area_mm2": 576.0, "load_share": 1.0}},
        },
    },
}


def changed(**edits):
    """STAIR with ``edits`` applied: ``path=value``, the path's keys joined by ``__``."""
    data = copy.deepcopy(STAIR)
    for path, value in edits.items():
        *keys, last = path.split("__")
        place = data
        for key in keys:
            place = place[key]
        place[last] = value
    return data


def no_change_shown_as_a_change(lines: list[str]) -> None:
    for line in lines:
        for left, right in re.findall(r"(\S+) -> (\S+)", line):
            assert left != right, line


def test_a_changed_margin_is_named_by_its_key_with_both_values():
    lines = summarize(dumps(STAIR), dumps(changed(certificate__margin_mm=0.1)))
    assert lines == ["certificate.margin_mm: 1.5 -> 0.1"]


def test_a_changed_contact_area_names_the_support_and_no_unchanged_support():
    new = changed()
    new["final_graph"]["L02.1"]["rests_on"]["L01.1"]["area_mm2"] = 540.2
    assert summarize(dumps(STAIR), dumps(new)) == ["final_graph L02.1: rests on L01.1: area 576.0 -> 540.2 mm^2"]
    new["final_graph"]["L02.1"]["rests_on"] = {
        "L01.1": {"area_mm2": 300.0, "load_share": 0.6},
        "ground": {"area_mm2": 2.0, "load_share": 0.4},
    }
    (line,) = summarize(dumps(STAIR), dumps(new))
    assert "rests on L01.1: area 576.0 -> 300.0 mm^2, load share 1.0 -> 0.6" in line
    assert "now rests on ground (area 2.0 mm^2, load share 0.4)" in line


def test_a_moved_staircase_names_each_change_once():
    new = changed(certificate__margin_mm=0.1)
    brick = new["final_graph"]["L02.1"]
    brick["position_mm"] = [13.3, 0.0, 12.0]
    brick["com_above_mm"] = [13.3, 0.0, 12.0]
    brick["rests_on"]["L01.1"]["area_mm2"] = 559.7
    new["final_graph"]["L01.1"]["com_above_mm"] = [52.2, 0.0, 36.0]
    lines = summarize(dumps(STAIR), dumps(new))
    assert lines == [
        "certificate.margin_mm: 1.5 -> 0.1",
        "final_graph L01.1: com_above_mm x 52.0 -> 52.2",
        "final_graph L02.1: x 13.0 -> 13.3 mm; rests on L01.1: area 576.0 -> 559.7 mm^2; com_above_mm x 13.0 -> 13.3",
    ]


def test_a_long_value_is_cut_around_its_difference_not_before_it():
    old = changed(certificate__kind="x" * 80 + "one")
    new = changed(certificate__kind="x" * 80 + "two")
    (line,) = summarize(dumps(old), dumps(new))
    assert line.startswith("certificate.kind: ") and 'one"' in line and 'two"' in line
    no_change_shown_as_a_change([line])


def test_lists_say_what_came_and_went_or_which_elements_changed():
    old = changed(certificate__bricks=["L02.1", "L03.1", "L04.1"])
    new = changed(certificate__bricks=["L03.1", "L04.1", "L05.1"])
    assert summarize(dumps(old), dumps(new)) == ["certificate.bricks: added L05.1; removed L02.1"]
    cell = {"grid": {"structure.tower.shift": "13 mm"}, "collapse_levels": [10, 10, 11, 10]}
    moved = {"grid": cell["grid"], "collapse_levels": [10, 9, 11, 10]}
    assert summarize(dumps({"cell 0": cell}), dumps({"cell 0": moved})) == ["cell 0.collapse_levels[1]: 10 -> 9"]


def leaves(data, path=()):
    """Every number and string of a JSON value, with the keys and indices to it."""
    if isinstance(data, dict):
        for key, value in data.items():
            yield from leaves(value, (*path, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            yield from leaves(value, (*path, i))
    elif isinstance(data, (int, float, str)) and not isinstance(data, bool):
        yield path, data


@pytest.mark.slow
@pytest.mark.parametrize("name", ["four_stack", "jenga_falls", "slope_slides"])
def test_any_one_value_changed_in_a_shipped_golden_is_the_one_thing_named(name):
    stored = json.loads((ROOT / "golden" / "scenarios" / f"{name}.json").read_text())
    found = list(leaves(stored))
    for path, value in random.Random(name).sample(found, min(60, len(found))):
        new = copy.deepcopy(stored)
        place = new
        for key in path[:-1]:
            place = place[key]
        place[path[-1]] = value + "z" if isinstance(value, str) else round(value + 7.3, 1)
        lines = summarize(dumps(stored), dumps(new))
        assert len(lines) == 1, (path, lines)
        (line,) = lines
        assert line.startswith(path[0]), (path, line)
        if path[0] in ("final_graph", "collapse_graph") and len(path) > 2 and path[2] != "quaternion_xyzw":
            assert line.count(" -> ") == 1, (path, line)  # that value alone
        no_change_shown_as_a_change(lines)
