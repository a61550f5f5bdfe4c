"""The ``stackdsl`` command: check, compile, run, schema.

Exit status: 0 when everything holds, 1 when an expectation fails, 2 on bad input
(nothing is simulated then). Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from ._bench import SETTINGS, format_solve_times, run_matrix, savings, scenes, solve_times, write_outputs
from ._check import ScenarioErrors, check, compare
from ._compiler import MODE_DEFAULTS, compile_scenario
from ._errors import ScenarioError
from ._expect import describe, evaluate
from ._hard import format_hard, format_limits, format_wall, leaning_limits, thrown_at_wall
from ._loader import load_scenario
from ._program import format_program
from ._runtime import run_program
from ._schema import Scenario

MODELS = ["report", "equilibrium"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``stackdsl`` console script; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except ScenarioErrors as exc:
        for err in exc.errors:
            print(err, file=sys.stderr)
        return 2
    except ScenarioError as exc:
        print(exc, file=sys.stderr)
        return 2


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="stackdsl", description="Declarative stacking scenarios for pybullet.")
    sub = parser.add_subparsers(required=True, metavar="COMMAND")
    modes = list(MODE_DEFAULTS)

    many = argparse.ArgumentParser(add_help=False)
    many.add_argument("paths", nargs="+", metavar="PATH")
    many.add_argument("--model", choices=MODELS, help="override every scenario's stability model")
    many.add_argument("-j", "--jobs", type=int, default=None, help="worker processes (default: one per core)")
    one = argparse.ArgumentParser(add_help=False)
    one.add_argument("file")
    one.add_argument("--mode", choices=modes, help="override the scenario's engine mode")
    one.add_argument("--model", choices=MODELS, help="override the scenario's stability model")
    one.add_argument("--json", action="store_true", help="print JSON instead of text")

    p = sub.add_parser("check", parents=[many], help="run scenario files or folders and check their expectations")
    p.add_argument("--mode", choices=modes, help="override every scenario's engine mode")
    p.set_defaults(func=_check)

    p = sub.add_parser("compare", parents=[many], help="run scenario files or folders in every mode and print one table")
    p.add_argument("--modes", default=",".join(modes), help=f"comma-separated (default: {','.join(modes)})")
    p.set_defaults(func=_compare)

    p = sub.add_parser("compile", parents=[one], help="print the program a scenario compiles to")
    p.set_defaults(func=_compile)

    p = sub.add_parser("run", parents=[one], help="run one scenario and print its timeline and outcome")
    p.set_defaults(func=_run)

    p = sub.add_parser("bench", help="speed against error: every engine setting on the same scenes (long)")
    p.add_argument("--out", default="docs/bench", help="folder for bench.csv, bench.md and the plots")
    p.add_argument("--settings", default=",".join(SETTINGS), help="comma-separated, of: " + ", ".join(SETTINGS))
    p.add_argument("--families", default="slant log cabin,single file,upright", help="comma-separated scene families")
    p.add_argument("--repeats", type=int, default=3, help="runs per cell (median), for cells faster than --repeat-below")
    p.add_argument("--repeat-below", type=float, default=30.0, help="seconds; slower cells run once")
    p.add_argument("--quick", action="store_true", help="one small cell per setting (a smoke test)")
    p.add_argument("-j", "--jobs", type=int, default=2)
    p.set_defaults(func=_bench)
    bench = p.add_subparsers(metavar="BENCHMARK")
    q = bench.add_parser("solve", help="equilibrium solve time for towers of 10 to 100 bricks")
    q.add_argument("--sizes", default="10,25,50,100", help="bricks per tower, comma-separated")
    q.add_argument("--repeats", type=int, default=5)
    q.set_defaults(func=_bench_solve)
    q = bench.add_parser(
        "hard", help="the hard cases in extension and raw mode, a brick thrown at a wall, the leaning limits swept"
    )
    q.add_argument("folder", nargs="?", default="scenarios/hard")
    q.add_argument("-j", "--jobs", type=int, default=None, help="worker processes (default: one per core)")
    q.set_defaults(func=_bench_hard)

    p = sub.add_parser("schema", help="print the JSON Schema of scenario files (for editors)")
    p.set_defaults(func=_schema)
    return parser


def _check(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    results = []
    checks = check(args.paths, mode=args.mode, jobs=args.jobs, model=args.model)  # raises on bad input: nothing printed yet
    print(f"{'':4}  {'scenario':<40} {'mode':<9}  {'expected':<18} {'measured':<32} {'simulated':>9} {'wall':>8}")
    for r in checks:
        results.append(r)
        status = "PASS" if r.passed else "FAIL"
        print(
            f"{status:<4}  {_short(r.file):<40} {_mode(r):<9}  {r.expected:<18} {r.measured:<32} "
            f"{r.simulated_time:>7.1f} s {r.wall_time:>6.1f} s",
            flush=True,
        )
    failed = sum(not r.passed for r in results)
    wall = time.perf_counter() - start
    print(f"{len(results)} scenarios: {len(results) - failed} passed, {failed} failed ({wall:.1f} s wall)")
    return 1 if failed else 0


def _compare(args: argparse.Namespace) -> int:
    modes = tuple(m.strip() for m in args.modes.split(",") if m.strip())
    unknown = [m for m in modes if m not in MODE_DEFAULTS]
    if unknown or not modes:
        raise ScenarioError(f"unknown mode {', '.join(unknown) or '(none)'}; known: {', '.join(MODE_DEFAULTS)}", file="--modes")
    start = time.perf_counter()
    table = compare(args.paths, modes, jobs=args.jobs, model=args.model)
    width = max([len("scenario"), *(len(Path(f).stem) for f in table)])
    print(f"{'scenario':<{width}} {'expected':<18} " + " ".join(f"{m:<29}" for m in modes).rstrip())
    for file, row in table.items():
        first = next(iter(row.values()))
        cells = [
            f"{'PASS' if r.passed else 'FAIL'} {describe(r.collapse_level):<13} {r.wall_time:>7.1f} s"
            for r in (row[m] for m in modes)
        ]
        print(f"{Path(file).stem:<{width}} {first.expected:<18} " + " ".join(f"{c:<29}" for c in cells).rstrip())
    print(f"{len(table)} scenarios x {len(modes)} modes ({time.perf_counter() - start:.1f} s wall)")
    return 0


def _mode(r) -> str:
    """The mode, with the stability model when the extension ran with the equilibrium one."""
    return "ext/equil" if r.mode == "extension" and r.model == "equilibrium" else r.mode


def _short(file: str) -> str:
    return file if len(file) <= 40 else "..." + file[-37:]


def _compile(args: argparse.Namespace) -> int:
    program = compile_scenario(load_scenario(args.file), args.mode, args.model)
    print(program.model_dump_json(indent=2) if args.json else format_program(program))
    return 0


def _run(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.file)
    program = compile_scenario(scenario, args.mode, args.model)
    outcome = run_program(program)
    verdicts = evaluate(scenario.expect, outcome, program.collapse_threshold)
    if args.json:
        print(outcome.model_dump_json(indent=2))
    else:
        for e in outcome.events:
            level = "" if e.level is None else f"level {e.level}"
            print(f"t={e.time:9.3f} s  {e.kind:<8} {e.brick:<10} {level:<9} {e.detail}")
        print(
            f"{Path(args.file).name}: {describe(outcome.collapse.level if outcome.collapse else None)} "
            f"({outcome.levels_placed} levels placed), {outcome.simulated_time:.1f} s simulated, "
            f"{outcome.wall_time:.2f} s wall, {outcome.steps} steps ({outcome.steps_skipped} skipped)"
        )
        for v in verdicts:
            print(f"{'PASS' if v.passed else 'FAIL'}  expected {v.expected}, measured {v.measured}")
    return 0 if all(v.passed for v in verdicts) else 1


def _bench(args: argparse.Namespace) -> int:
    settings = [x.strip() for x in args.settings.split(",") if x.strip()]
    families = {x.strip() for x in args.families.split(",") if x.strip()}
    unknown = [x for x in settings if x not in SETTINGS]
    if unknown:
        raise ScenarioError(f"unknown setting {', '.join(unknown)}; known: {', '.join(SETTINGS)}", file="--settings")
    chosen = [sc for sc in scenes(args.quick) if sc.family in families or args.quick]
    start = time.perf_counter()
    print(f"stackdsl bench: {len(chosen)} scenes x {len(settings)} settings, {args.jobs} workers", flush=True)

    def progress(c):
        print(
            f"  {c.setting:<22} {c.family:<16} {c.parameter:>5g}: collapse {c.collapse_level} (closed form {c.closed_form}), {c.wall:.2f} s",
            flush=True,
        )

    cells = run_matrix(settings, chosen, args.repeats, args.repeat_below, args.jobs, progress)
    saved = [] if args.quick else savings(args.repeats)
    targets = write_outputs(cells, saved, Path(args.out))
    print((Path(args.out) / "bench.md").read_text())
    print(f"targets: {targets}")
    print(
        f"wrote {args.out}/bench.csv, bench.md, wall_vs_error.png, wall_vs_height.png ({time.perf_counter() - start:.0f} s wall)"
    )
    return 0


def _bench_solve(args: argparse.Namespace) -> int:
    sizes = tuple(int(x) for x in args.sizes.split(","))
    print(format_solve_times(solve_times(sizes, args.repeats)))
    return 0


def _bench_hard(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    print(format_hard(args.folder, args.jobs), end="\n\n", flush=True)
    print(format_wall(thrown_at_wall()), end="\n\n", flush=True)
    print(format_limits(leaning_limits()), end="\n\n")
    print(f"({time.perf_counter() - start:.0f} s wall)")
    return 0


def _schema(args: argparse.Namespace) -> int:
    print(json.dumps(Scenario.model_json_schema(), indent=2))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
