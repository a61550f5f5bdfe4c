"""The statics backend against each shipped scenario's own engine: verdict and wall time.

    python docs/results/statics_timing.py [ROUNDS]

For each scenario under scenarios/: compiled for the statics backend (``backend="statics"``,
as ``--backend statics`` does); a scene statics refuses (it needs motion) is listed with the
field and the reason. Each other is run with ``run_program`` on its own engine and mode (the
file's ``engine:``) ROUNDS times (default 3) and on statics max(ROUNDS, 5) times (it is cheap),
in one process after the imports (a first run of each warms nothing: the scenes run in file
order); the table gives the median wall and CPU (``time.process_time``) milliseconds of each,
the collapse level (or "stands"), how statics proved it and the wall milliseconds of its
certificate of a stand (its margin and friction share: :attr:`Outcome.certificate_time`). Then the same for towers of 10, 30, 100
and 200 levels (``structure: {tower: {levels: N}}``, two bricks a level, on the default engine),
and the cost of the imports alone (a fresh interpreter importing stackdsl's runtime, median of
ROUNDS). Output: markdown (docs/results/statics.md).
"""

from __future__ import annotations

import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

from stackdsl import ScenarioError, compile_scenario, load_scenario, parse_scenario, run_program
from stackdsl.lang.schema import Scenario

ROOT = Path(__file__).resolve().parents[2]
IMPORTS = "from stackdsl import compile_scenario, load_scenario, run_program"


def said(outcome) -> str:  # type: ignore[no-untyped-def]
    return "stands" if outcome.collapse is None else f"collapse {outcome.collapse.level}"


def proof(outcome) -> str:  # type: ignore[no-untyped-def]
    certificate = outcome.certificate
    if certificate is None:
        return "none"
    if certificate.kind == "no equilibrium":
        return "no equilibrium (program)"
    return "load paths" if "load path" in certificate.detail else "program"


def timed(program, rounds: int) -> tuple[float, float, object]:  # type: ignore[no-untyped-def]
    walls, cpus, outcome = [], [], None
    for _ in range(rounds):
        start, cpu = time.perf_counter(), time.process_time()
        outcome = run_program(program)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    return statistics.median(walls) * 1000, statistics.median(cpus) * 1000, outcome


def row(name: str, scenario: Scenario, rounds: int) -> str:
    statics = compile_scenario(scenario, backend="statics")
    own = compile_scenario(scenario)
    own_ms, own_cpu, own_outcome = timed(own, rounds)
    statics_ms, statics_cpu, statics_outcome = timed(statics, max(rounds, 5))
    same = "yes" if said(statics_outcome) == said(own_outcome) else "**no**"
    engine = f"{own.engine.backend} {own.engine.mode}"
    return (
        f"| {name} | {len(statics.placements)} | {engine} | {said(own_outcome)} | {own_ms:.0f} | {own_cpu:.0f} "
        f"| {said(statics_outcome)} | {statics_ms:.1f} | {statics_cpu:.1f} | {statics_outcome.certificate_time * 1000:.1f} "
        f"| {proof(statics_outcome)} | {same} |"
    )


def main(rounds: int) -> None:
    head = (
        "| {} | bricks | its engine | its verdict | its wall (ms) | its CPU (ms) | statics | statics wall (ms) "
        "| statics CPU (ms) | of which certificate (ms) | proved by | same |"
    )
    rule = "|---|---:|---|---|---:|---:|---|---:|---:|---:|---|---|"
    rows, refused, towers = [], [], []
    for path in sorted((ROOT / "scenarios").rglob("*.yaml")):
        name = str(path.relative_to(ROOT / "scenarios"))
        scenario = load_scenario(path)
        try:
            compile_scenario(scenario, backend="statics")
        except ScenarioError as exc:
            refused.append(f"| {name} | {exc.field} | {exc.message.split(': ', 1)[1].split(';')[0]} |")
            continue
        rows.append(row(name, scenario, rounds))
        print(rows[-1], file=sys.stderr, flush=True)
    for levels in (10, 30, 100, 200):
        towers.append(
            row(f"tower of {levels}", parse_scenario(f"stackdsl: 1\nstructure: {{tower: {{levels: {levels}}}}}\n"), rounds)
        )
        print(towers[-1], file=sys.stderr, flush=True)
    imports, import_cpus = [], []
    for _ in range(rounds):
        start, before = time.perf_counter(), resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", IMPORTS], check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        imports.append(time.perf_counter() - start)
        import_cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
    print(head.format("scenario"))
    print(rule)
    print("\n".join(rows))
    print("\nTowers (`structure: {tower: {levels: N}}`):\n")
    print(head.format("tower"))
    print(rule)
    print("\n".join(towers))
    print(
        f"\nImports (a fresh interpreter running `{IMPORTS}`): {statistics.median(imports) * 1000:.0f} ms wall, "
        f"{statistics.median(import_cpus) * 1000:.0f} ms CPU, median of {rounds}."
    )
    print("\nRefused by statics (they need motion):\n")
    print("| scenario | field | why |")
    print("|---|---|---|")
    print("\n".join(refused))


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3)
