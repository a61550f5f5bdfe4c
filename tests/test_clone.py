"""A user's files in the clone are theirs: the README's five-minute tour writes
``my_scenarios/tower.yaml`` and, through the pytest plugin, ``golden/my_scenarios/tower.json``;
a sweep of theirs there, or a test of theirs using the ``golden`` fixture, writes goldens that
are no scenario's outcome. The project's own tests read the goldens of its shipped scenarios
only (``tests/shipped.py``), so that none of these makes them fail."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from shipped import ROOT, shipped_goldens


def test_the_projects_goldens_are_its_scenarios_and_no_users(tmp_path):
    (tmp_path / "pyproject.toml").write_text("[project]\nname = 'a clone'\n")
    for scenario in ("scenarios/a.yaml", "scenarios/hard/b.yml", "scenarios/c.yaml", "my_scenarios/tower.yaml"):
        (tmp_path / scenario).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / scenario).write_text("stackdsl: 1\n")
    goldens = ["scenarios/a.json", "scenarios/hard/b.json", "my_scenarios/tower.json", "my_scenarios/walk.json"]
    goldens += ["my_scenarios/test_mine/test_it.json", "notes/readme.json"]  # a user's golden fixture's; anything
    for golden in goldens:
        (tmp_path / "golden" / golden).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / "golden" / golden).write_text("{}")  # a sweep's or a test's golden is no scenario outcome
    assert shipped_goldens(tmp_path) == [tmp_path / "golden" / "scenarios" / g for g in ("a.json", "hard/b.json")]


def test_the_tests_still_read_the_golden_of_every_shipped_scenario():
    scenarios = [p for p in (ROOT / "scenarios").rglob("*") if p.suffix in (".yaml", ".yml")]
    assert len(shipped_goldens()) == len(scenarios) >= 30
