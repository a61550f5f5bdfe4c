"""The ``stackdsl`` command: check, compare, compile, run, bench, schema.

Exit status: 0 when everything holds, 1 when an expectation fails (or a run reaches its
``--timeout``), 2 on bad input or a usage error (nothing is simulated then), 3 on an internal
error (one line on stderr; ``--debug`` shows the traceback), 130 on Ctrl-C, 141 when the
output pipe closes early. No Python traceback reaches stderr without ``--debug`` (or
``STACKDSL_TRACEBACK=1``).
Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import signal
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Any, NoReturn

from ._artefacts import folder_name
from ._check import TIMEOUT, CheckResult, ScenarioErrors, discover, prepare, run_checks, run_guarded, select, stopped_by, tabulate
from ._cli_args import jobs_type, timeout_type
from ._cli_bench import add_bench
from ._cli_draw import add_commands, add_record_options
from ._cli_sweep import add_sweep
from ._compiler import BACKEND_DEFAULTS, MODE_DEFAULTS, compile_scenario
from ._errors import ScenarioError
from ._expect import describe, evaluate
from ._jsonschema import json_schema
from ._loader import load_scenario
from ._program import format_program
from ._progress import Lines, is_live
from ._report import HEADER, failure_lines, json_document, junit_xml, row, run_command, summary, version

MODELS = ["report", "equilibrium"]

EXIT_STATUS = """\
exit status:
  0    every expectation held
  1    an expectation failed, or a run reached its --timeout
  2    bad input: a scenario file, a path or an option (nothing is simulated then)
  3    internal error: a bug, out of memory, a worker died (one line; --debug shows the traceback)
  130  interrupted (Ctrl-C)
  141  the output pipe was closed early (as by | head); nothing more is printed"""

#: Ends the one line of an internal error.
HINT = " (run with --debug for the traceback)"

#: Exit statuses (see :data:`EXIT_STATUS`).
OK, FAILED, BAD_INPUT, INTERNAL, INTERRUPTED, BROKEN_PIPE = 0, 1, 2, 3, 130, 141


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``stackdsl`` console script; returns the exit status
    (argparse's usage errors exit 2 through SystemExit).

    Without ``--debug`` nothing Python prints as a traceback reaches stderr: not the
    exceptions caught here, and not the "Exception ignored in" reports of objects torn down
    half-built by Ctrl-C (kept quiet until exit when called as the command, with no ``argv``).
    """
    command = argv is None
    argv = sys.argv[1:] if argv is None else argv
    debug = "--debug" in argv or os.environ.get("STACKDSL_TRACEBACK", "") not in ("", "0")
    # SIGTERM unwinds like Ctrl-C, so that workers are stopped on the way out (main thread only).
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminated) if main_thread else None
    interrupt = signal.getsignal(signal.SIGINT) if main_thread else None
    hook, variable = sys.unraisablehook, os.environ.get("STACKDSL_TRACEBACK")
    interrupted = False
    if debug:
        os.environ["STACKDSL_TRACEBACK"] = "1"  # for the workers
    else:
        sys.unraisablehook = _ignore
    try:
        args = _parser().parse_args(argv)
        args.debug = debug
        status = int(args.func(args))
        sys.stdout.flush()
        return status
    except ScenarioErrors as exc:
        for err in exc.errors:
            print(err, file=sys.stderr)
        return BAD_INPUT
    except ScenarioError as exc:
        print(exc, file=sys.stderr)
        return BAD_INPUT
    except BrokenPipeError:
        # The reader went away (``| head``): stop quietly, and let nothing flush into the
        # closed pipe at exit.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return BROKEN_PIPE
    except KeyboardInterrupt:
        interrupted = True
        if main_thread:  # a second Ctrl-C while this line is printed must not show a traceback
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("stackdsl: interrupted", file=sys.stderr)
        return INTERRUPTED
    except Exception as exc:
        if debug:
            traceback.print_exc()
        message = (str(exc).splitlines() or [""])[0] or "(no message)"
        print(f"stackdsl: internal error: {type(exc).__name__}: {message}{'' if debug else HINT}", file=sys.stderr)
        return INTERNAL
    finally:
        if main_thread:
            signal.signal(signal.SIGTERM, previous)
            signal.signal(signal.SIGINT, interrupt)
        if not command:
            if interrupted or sys.exc_info()[0] is not None:
                gc.collect()  # what an interrupted run left half-built goes now, quietly
            sys.unraisablehook = hook
            if variable is None:
                os.environ.pop("STACKDSL_TRACEBACK", None)
            else:
                os.environ["STACKDSL_TRACEBACK"] = variable


def _ignore(unraisable: Any) -> None:
    """An ``sys.unraisablehook`` that prints nothing."""


def _terminated(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


class _Parser(argparse.ArgumentParser):
    """argparse's parser with a usage error on one line: what is wrong and where the help is
    (argparse prints the whole usage first); the subcommands' parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(BAD_INPUT, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    raw = argparse.RawDescriptionHelpFormatter
    parser = _Parser(
        prog="stackdsl",
        description="Declarative stacking scenarios for pybullet.",
        epilog=EXIT_STATUS,
        formatter_class=raw,
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
    debug_help = "on an internal error, print the traceback (also STACKDSL_TRACEBACK=1)"
    parser.add_argument("--debug", action="store_true", help=debug_help)
    sub = parser.add_subparsers(required=True, metavar="COMMAND")
    modes = list(MODE_DEFAULTS)
    common = _Parser(add_help=False)  # --debug after the command too
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=debug_help)
    guarded = _Parser(add_help=False)
    guarded.add_argument(
        "--timeout",
        type=timeout_type,
        default=TIMEOUT,
        metavar="SECONDS",
        help=f"wall seconds a scenario may run before it is stopped and fails (default: {TIMEOUT:g}); "
        "worker processes may also map at most 4 GiB each",
    )

    many = _Parser(add_help=False, parents=[common, guarded])
    many.add_argument("paths", nargs="+", metavar="PATH", help="scenario files, or folders searched for *.yaml")
    many.add_argument("--model", choices=MODELS, help="override every scenario's stability model")
    many.add_argument(
        "--backend",
        metavar="ENGINE",
        help=f"override every scenario's engine: {' or '.join(BACKEND_DEFAULTS)} (compare: several, comma-separated)",
    )
    many.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="auto",
        help="runs at the same time, this process included: 1 to the number of cores, or auto (default: one per "
        "core). Work estimated cheaper than starting a worker runs in this process whatever -j says",
    )
    many.add_argument(
        "-k",
        metavar="PATTERN",
        dest="pattern",
        help="only the scenarios whose file path or name contains PATTERN (plain text, case-insensitive)",
    )
    many.add_argument("--json", action="store_true", help="print one JSON document of every result instead of the table")
    one = _Parser(add_help=False, parents=[common])
    one.add_argument("file")
    one.add_argument("--mode", choices=modes, help="override the scenario's engine mode")
    one.add_argument("--model", choices=MODELS, help="override the scenario's stability model")
    one.add_argument("--backend", choices=list(BACKEND_DEFAULTS), help="override the scenario's engine")

    p = sub.add_parser(
        "check",
        parents=[many],
        help="run scenario files or folders and check their expectations",
        description="Run scenario files or folders and check their expectations: a row per scenario as it "
        "finishes (under a progress line on a terminal), what moved under each FAIL, then a summary.",
        epilog=EXIT_STATUS,
        formatter_class=raw,
    )
    p.add_argument("--mode", choices=modes, help="override every scenario's engine mode")
    p.add_argument("-x", "--exitfirst", action="store_true", help="stop after the first failure (runs not started are cancelled)")
    p.add_argument("--junit-xml", metavar="FILE", help="also write JUnit XML to FILE: one testcase per scenario")
    p.add_argument(
        "--report",
        metavar="DIR",
        help="also record every run and write DIR/index.html: a row per scenario (failures first) with a picture at "
        "the collapse or the end, the timeline, a clip and a brick-graph plot, then a summary (made if missing)",
    )
    p.set_defaults(func=_check)

    p = sub.add_parser(
        "compare",
        parents=[many],
        help="run scenario files or folders in every mode and print one table",
        description="Run scenario files or folders in every mode, in one run, and print one table.",
        epilog=EXIT_STATUS.replace(
            "  0    every expectation held\n  1    an expectation failed, or a run reached its --timeout\n",
            "  0    the table was printed\n",
        )
        + "\n\nFAIL cells are results, not errors: compare exits 0 once its table is printed.",
        formatter_class=raw,
    )
    p.add_argument("--modes", default=",".join(modes), help=f"comma-separated (default: {','.join(modes)})")
    p.set_defaults(func=_compare)

    one_status = EXIT_STATUS.replace(
        "  0    every expectation held\n  1    an expectation failed, or a run reached its --timeout\n", "  0    done\n"
    )
    p = sub.add_parser(
        "compile", parents=[one], help="print the program a scenario compiles to", epilog=one_status, formatter_class=raw
    )
    p.add_argument("--json", action="store_true", help="print the Program as JSON")
    p.set_defaults(func=_compile)

    p = sub.add_parser(
        "run",
        parents=[one, guarded],
        help="run one scenario and print its timeline and outcome",
        epilog=EXIT_STATUS + "\n\nWith --json too, the exit status is 1 when an expectation failed.",
        formatter_class=raw,
    )
    p.add_argument(
        "--json", action="store_true", help="print the whole Outcome as JSON (exit 1 still means a failed expectation)"
    )
    add_record_options(p)
    p.set_defaults(func=_run)

    add_commands(sub, [one, guarded], one_status)
    add_sweep(
        sub,
        [common, guarded],
        EXIT_STATUS.replace("  0    every expectation held", "  0    every statistical expectation held (PASS)").replace(
            "  1    an expectation failed, or a run reached its --timeout",
            "  1    an expectation failed or was inconclusive, or a run reached its --timeout",
        ),
        jobs_type,
        MODELS,
        modes,
    )

    add_bench(sub, [common], one_status, modes)

    p = sub.add_parser(
        "schema",
        parents=[common],
        help="print the JSON Schema of scenario files (for editors)",
        epilog=one_status,
        formatter_class=raw,
    )
    p.set_defaults(func=_print_schema)
    return parser


def _check(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    if args.junit_xml and not Path(args.junit_xml).parent.is_dir():
        raise ScenarioError("no such folder for the JUnit XML file", file=args.junit_xml)
    if args.report is not None and not args.report.strip():
        raise ScenarioError("give the folder for the report", file="--report")
    report = Path(args.report) if args.report else None
    if report is not None and report.exists() and not report.is_dir():
        raise ScenarioError("the report must go to a folder, and this is a file", file=args.report)
    backends = _backends(args.backend, several=False)
    prepared = select(
        prepare(discover(args.paths), args.mode, model=args.model, backends=backends), args.pattern
    )  # bad input raises here
    folders = None
    if report is not None:
        try:
            report.mkdir(parents=True, exist_ok=True)
            probe = report / ".stackdsl-write-test"
            probe.touch()
            probe.unlink()
        except OSError as exc:
            raise ScenarioError(f"cannot write the report there: {exc.strerror or exc}", file=args.report) from None
        taken: set[str] = set()
        base = os.path.commonpath([path.resolve().parent for path, *_ in prepared])  # names relative to it
        folders = [str(report / folder_name(os.path.relpath(path.resolve(), base), taken=taken)) for path, *_ in prepared]
    results: list[CheckResult] = []
    commands: list[str] = []
    stream = sys.stderr if args.json else sys.stdout  # with --json only the progress line, on a terminal
    with Lines(len(prepared), "check", file=stream, live=is_live(stream)) as lines:
        if not args.json:
            lines.line(HEADER)
        runs = run_checks(prepared, args.jobs, timeout=args.timeout, folders=folders)
        try:
            for r in runs:
                results.append(r)
                commands.append(run_command(r.file, args.mode, args.model, args.backend))
                if not args.json:
                    lines.line(row(r))
                    if not r.passed:
                        for text in failure_lines(r, commands[-1]):
                            lines.line(text)
                lines.advance()
                if args.exitfirst and not r.passed:
                    break
        finally:
            runs.close()  # cancels what has not started and stops the workers
    wall = time.perf_counter() - start
    # rows came as runs finished; the reports list them in file order, so that they diff from run to run
    order = {str(p.path): i for i, p in enumerate(prepared)}
    pairs = sorted(zip(results, commands, strict=True), key=lambda pair: order.get(pair[0].file, len(order)))
    results, commands = [r for r, _ in pairs], [c for _, c in pairs]
    if args.junit_xml:
        ran = {r.file for r in results}
        junit_xml(results, commands, [str(p.path) for p in prepared if str(p.path) not in ran], wall, args.junit_xml)
    if report is not None:
        from ._htmlreport import remove_stale_folders, write_report

        page = write_report(results, report, total=len(prepared), wall=wall, commands=commands, argv=sys.argv[1:] or ["check"])
        stale = remove_stale_folders(report, {Path(f).name for f in folders or []})
        if stale:
            print(f"report: removed {stale} folders of an earlier report in {report}", file=stream)
        drawn = [r for r in results if r.draw_error]
        print(f"report: {page}" + (f" ({len(drawn)} runs not fully drawn: {drawn[0].draw_error})" if drawn else ""), file=stream)
    if args.json:
        print(json.dumps(json_document("check", results, commands, len(prepared), wall), indent=2))
    else:
        print(summary(results, len(prepared), wall))
    if _internal_errors(results, args.debug):
        return INTERNAL
    refused = [r for r in results if r.bad_input]
    for r in refused:  # a sweep's sample the language refuses: bad input, found once it was drawn
        print(r.bad_input, file=sys.stderr)
    if refused:
        return BAD_INPUT
    return FAILED if any(not r.passed for r in results) else OK


def _internal_errors(results: list[CheckResult], debug: bool) -> bool:
    """Say on stderr, in one line, that runs hit internal errors (their tracebacks before it
    with ``debug``); False when none did."""
    errors = [r for r in results if r.error]
    if not errors:
        return False
    sys.stdout.flush()
    if debug:
        for r in errors:
            print(f"stackdsl: {r.file} ({r.mode}): {r.error}", file=sys.stderr)
            print(r.traceback or "(no traceback: the worker process died)", file=sys.stderr)
    many = f" (and {len(errors) - 1} more)" if len(errors) > 1 else ""
    first = errors[0]
    print(f"stackdsl: {first.error} in {first.file} ({first.mode}){many}{'' if debug else HINT}", file=sys.stderr)
    return True


def _compare(args: argparse.Namespace) -> int:
    modes = tuple(m.strip() for m in args.modes.split(",") if m.strip())
    unknown = [m for m in modes if m not in MODE_DEFAULTS]
    if unknown or not modes:
        raise ScenarioError(f"unknown mode {', '.join(unknown) or '(none)'}; known: {', '.join(MODE_DEFAULTS)}", file="--modes")
    backends = _backends(args.backend, several=True)
    if len(backends) > 1:
        modes = tuple(f"{b} {m}" for b in backends for m in modes)
    start = time.perf_counter()
    plain = tuple(dict.fromkeys(m.split()[-1] for m in modes))
    prepared = select(prepare(discover(args.paths), modes=plain, model=args.model, backends=backends), args.pattern)
    done: list[CheckResult] = []
    live = is_live(sys.stdout)
    # On a terminal a progress line; elsewhere a line per finished cell on stderr, so that
    # stdout holds the table (or the JSON) alone.
    with Lines(len(prepared), "compare", file=sys.stdout if live else sys.stderr, live=live) as lines:

        def each(r: CheckResult) -> None:
            done.append(r)
            lines.advance()
            if not live:
                lines.line(
                    f"[{len(done)}/{len(prepared)}] {Path(r.file).stem} {r.mode}: "
                    f"{'PASS' if r.passed else 'FAIL'} {r.error or r.stopped or describe(r.collapse_level)} ({r.wall_time:.1f} s)"
                )

        table = tabulate(prepared, modes, run_checks(prepared, args.jobs, timeout=args.timeout), each)
    wall = time.perf_counter() - start
    if args.json:
        commands = [run_command(r.file, r.mode, args.model, r.backend if args.backend else None) for r in done]
        print(json.dumps(json_document("compare", done, commands, len(prepared), wall), indent=2))
        return INTERNAL if _internal_errors(done, args.debug) else OK
    width = max([len("scenario"), *(len(Path(f).stem) for f in table)])
    print(f"{'scenario':<{width}} {'expected':<18} " + " ".join(f"{m:<29}" for m in modes).rstrip())
    for file, cells in table.items():
        first = next(iter(cells.values()))
        texts = [f"{'PASS' if r.passed else 'FAIL'} {_cell(r):<13} {r.wall_time:>7.1f} s" for r in (cells[m] for m in modes)]
        print(f"{Path(file).stem:<{width}} {first.expected:<18} " + " ".join(f"{c:<29}" for c in texts).rstrip())
    print(f"{len(table)} scenarios x {len(modes)} modes ({wall:.1f} s wall)")
    return INTERNAL if _internal_errors(done, args.debug) else OK


def _backends(given: str | None, several: bool) -> tuple[str | None, ...]:
    """The backends ``--backend`` names: one (or, with ``several``, a comma-separated list);
    (None,): each scenario's own.

    Raises:
        ScenarioError: an unknown backend, or several where one is expected.
    """
    if given is None:
        return (None,)
    names = tuple(dict.fromkeys(b.strip() for b in given.split(",") if b.strip()))
    unknown = [b for b in names if b not in BACKEND_DEFAULTS]
    if unknown or not names or (len(names) > 1 and not several):
        what = "one of" if not several else "one or more of"
        raise ScenarioError(f"unknown backend {given!r}: give {what} {', '.join(BACKEND_DEFAULTS)}", file="--backend")
    return names


def _cell(r: CheckResult) -> str:
    """What compare's table shows of a result: the collapse level, or what went wrong."""
    if r.error:
        return "out of memory" if "out of memory" in r.error else "internal error"
    return "timeout" if r.stopped else describe(r.collapse_level)


def _compile(args: argparse.Namespace) -> int:
    program = compile_scenario(load_scenario(args.file), args.mode, args.model, args.backend)
    print(program.model_dump_json(indent=2) if args.json else format_program(program))
    return OK


def _run(args: argparse.Namespace) -> int:
    scenario = load_scenario(args.file)
    program = compile_scenario(scenario, args.mode, args.model, args.backend)
    if args.rate is not None and not args.record:
        raise ScenarioError("--rate is the recording's: give --record OUT.npz too", file="--rate")
    if args.record:
        record = Path(args.record)
        if record.suffix.lower() != ".npz":
            raise ScenarioError("a trajectory file must end in .npz", file=args.record)
        if not record.parent.is_dir() or record.is_dir():
            raise ScenarioError(
                "no such folder for the trajectory file" if not record.parent.is_dir() else "a folder", file=args.record
            )
        from ._recorder import RATE, record_program

        outcome, trajectory = record_program(program, args.rate or RATE, source=args.file, timeout=args.timeout)
        trajectory.save(record)
        print(
            f"wrote {record}: {len(trajectory.times)} frames of {len(trajectory.ids)} bodies",
            file=sys.stderr if args.json else sys.stdout,
        )
    else:
        outcome = run_guarded(program, args.timeout)
    stopped = stopped_by(outcome)
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
            f"{outcome.wall_time:.2f} s wall ({outcome.engine_time:.2f} s in the engine's steps"
            + (f", {outcome.after_collapse:.2f} s after the collapse" if outcome.collapse else "")
            + f"), {outcome.steps} steps ({outcome.steps_skipped} skipped)"
        )
        for v in verdicts:
            print(f"{'PASS' if v.passed else 'FAIL'}  expected {v.expected}, measured {v.measured}")
        if stopped and all(v.passed for v in verdicts):  # no verdict says it
            print(f"FAIL  {stopped}")
    return OK if all(v.passed for v in verdicts) and not stopped else FAILED


def _print_schema(args: argparse.Namespace) -> int:
    print(json.dumps(json_schema(), indent=2))
    return OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
