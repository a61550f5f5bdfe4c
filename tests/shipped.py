"""The project's own scenario files and goldens, as its tests read them: never what a user keeps
in the clone beside them (the README's five-minute tour writes ``my_scenarios/tower.yaml`` and
its golden ``golden/my_scenarios/tower.json``; a user's sweep, or a test of theirs using the
``golden`` fixture, leaves goldens there that are no scenario's outcome)."""

from pathlib import Path

from stackdsl.verdicts.snapshot import scenario_golden_path

ROOT = Path(__file__).resolve().parents[1]


def shipped_goldens(root: Path = ROOT) -> list[Path]:
    """The golden snapshot of each scenario file below ``root/scenarios`` that has one, where the
    pytest plugin keeps it, in the order of the files; no other file of ``root/golden``."""
    found = (scenario_golden_path(p) for p in sorted((root / "scenarios").rglob("*")) if p.suffix in (".yaml", ".yml"))
    return [g for g in found if g.is_file()]
