"""Every shipped scenario rerun under changes that should not matter, each outcome compared with
the scenario's golden snapshot as pytest compares it: docs/results/goldens.md.

    python docs/results/golden_robustness.py [OUT_DIR] [-j N]

Perturbations: a placement jitter of 10 micrometres (4 draws), the drop gap moved to 0.4 and
0.6 mm, the timestep +-1%, solver iterations +-10% (stackdsl.compile.perturb). Writes each
perturbed run's snapshot to OUT_DIR (default: a new temporary folder), prints a line per run
that does not match its golden and what differs, and a table of how many matched.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from multiprocessing import Pool
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CHANGES: list[tuple[str, tuple[str, float]]] = [
    *((f"jitter {k}", ("jitter", k)) for k in (1, 2, 3, 4)),
    ("drop gap 0.4 mm", ("gap", 0.0004)),
    ("drop gap 0.6 mm", ("gap", 0.0006)),
    ("timestep +1%", ("timestep", 1)),
    ("timestep -1%", ("timestep", -1)),
    ("iterations +10%", ("iterations", 1)),
    ("iterations -10%", ("iterations", -1)),
]


def run(task: tuple[str, str, tuple[str, float], str]) -> tuple[str, str, bool, list[str], list[str]]:
    """One perturbed run of a scenario, compared with its golden: (file, change, expectations
    held, lines outside tolerance, what chaos decided)."""
    import stackdsl
    from stackdsl.compile.perturb import Perturbation, perturb
    from stackdsl.verdicts.golden_compare import compare_golden
    from stackdsl.verdicts.snapshot import scenario_golden_path
    from stackdsl.verdicts.tolerances import tolerances_for

    file, name, (kind, value), out = task
    scenario = stackdsl.load_scenario(file)
    program = stackdsl.compile_scenario(scenario)
    if kind == "gap":
        program = program.model_copy(
            update={"actions": tuple(a.model_copy(update={"drop": value}) if a.kind == "place" else a for a in program.actions)}
        )
    else:
        program = perturb(program, Perturbation(kind, int(value)))  # type: ignore[arg-type]
    outcome = stackdsl.run_program(program)
    held = all(v.passed for v in stackdsl.evaluate(scenario.expect, outcome, program.collapse_threshold))
    data = outcome.golden()
    target = Path(out) / name.replace(" ", "_") / Path(file).relative_to(ROOT / "scenarios").with_suffix(".json")
    target.parent.mkdir(parents=True, exist_ok=True)
    target.write_text(json.dumps(data))
    stored = json.loads(scenario_golden_path(file).read_text())
    tolerances = tolerances_for(program, scenario, ROOT / "pyproject.toml")
    expect = scenario.expect
    compared = compare_golden(stored, data, tolerances, toppled=expect.toppled is not None, may_fall=expect.may_fall or ())
    return file, name, held, compared.lines(5), compared.chaos


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", nargs="?", help="folder for the perturbed snapshots (default: a new temporary one)")
    parser.add_argument("-j", type=int, default=2, help="processes (default 2)")
    args = parser.parse_args()
    out = args.out or tempfile.mkdtemp(prefix="stackdsl-goldens-")
    files = sorted(str(p) for p in (ROOT / "scenarios").rglob("*.yaml"))
    tasks = [(f, name, change, out) for f in files for name, change in CHANGES]
    matched: Counter[str] = Counter()
    total: Counter[str] = Counter()
    chaos: Counter[str] = Counter()
    with Pool(args.j) as pool:
        for file, name, held, lines, chaotic in pool.imap_unordered(run, tasks):
            total[name] += 1
            matched[name] += not lines
            chaos[name] += bool(chaotic)
            shown = Path(file).relative_to(ROOT)
            if lines or not held:
                print(f"{shown} under {name}: {'expectations held' if held else 'AN EXPECTATION FAILED'}", flush=True)
                for line in lines:
                    print(f"    {line}", flush=True)
    print("\n| change | runs | match their golden | with a difference chaos decided |\n|---|---:|---:|---:|")
    for name, _ in CHANGES:
        print(f"| {name} | {total[name]} | {matched[name]} | {chaos[name]} |")
    print(f"| all | {sum(total.values())} | {sum(matched.values())} | {sum(chaos.values())} |")
    print(f"\nsnapshots in {out}", file=sys.stderr)


if __name__ == "__main__":
    main()
