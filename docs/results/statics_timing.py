"""The statics backend against each shipped scenario's own engine: verdict and wall time.

    python docs/results/statics_timing.py [ROUNDS]

For each scenario under scenarios/: compiled for the statics backend (``backend="statics"``,
as ``--backend statics`` does); a scene statics refuses (it needs motion) is listed with the
field and the reason. Each other is run with ``run_program`` on statics and on its own engine
and mode (the file's ``engine:``), ROUNDS times each (default 3), in turn; the table gives the
median wall seconds of each and the collapse level (or "stands"). Output: markdown
(docs/results/statics.md).
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

from stackdsl import ScenarioError, compile_scenario, load_scenario, run_program

ROOT = Path(__file__).resolve().parents[2]


def main(rounds: int) -> None:
    rows, refused = [], []
    for path in sorted((ROOT / "scenarios").rglob("*.yaml")):
        name = str(path.relative_to(ROOT / "scenarios"))
        scenario = load_scenario(path)
        try:
            statics = compile_scenario(scenario, backend="statics")
        except ScenarioError as exc:
            refused.append(f"| {name} | {exc.field} | {exc.message.split(': ', 1)[1].split(';')[0]} |")
            continue
        own = compile_scenario(scenario)
        walls: dict[str, list[float]] = {"statics": [], "own": []}
        said = {}
        for _ in range(rounds):
            for key, program in (("statics", statics), ("own", own)):
                start = time.perf_counter()
                outcome = run_program(program)
                walls[key].append(time.perf_counter() - start)
                said[key] = "stands" if outcome.collapse is None else f"collapse {outcome.collapse.level}"
        same = "yes" if said["statics"] == said["own"] else "**no**"
        engine = f"{own.engine.backend} {own.engine.mode}"
        rows.append(
            f"| {name} | {engine} | {said['own']} | {statistics.median(walls['own']):.3f} | {said['statics']} "
            f"| {statistics.median(walls['statics']):.3f} | {same} |"
        )
        print(rows[-1], file=sys.stderr, flush=True)
    print("| scenario | its engine | its verdict | its wall (s) | statics | statics wall (s) | same |")
    print("|---|---|---|---:|---|---:|---|")
    print("\n".join(rows))
    print("\nRefused by statics (they need motion):\n")
    print("| scenario | field | why |")
    print("|---|---|---|")
    print("\n".join(refused))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
