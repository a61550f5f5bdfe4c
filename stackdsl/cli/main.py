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
import contextlib
import gc
import json
import os
import signal
import sys
import threading
import traceback
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from ..engines.registry import backend, names
from ..lang.errors import ScenarioError, ScenarioErrors, one_line, warnings_as_lines
from ..util.extras import installed, missing
from .args import (
    BAD_INPUT,
    BROKEN_PIPE,
    CHECK_STATUS,
    COMMANDS,
    EXIT_STATUS,
    FAILED,
    HINT,
    INTERNAL,
    INTERRUPTED,
    OK,
    add_engine_overrides,
    add_seed,
    command_of,
    exit_status,
    jobs_type,
    perturb_type,
    refused,
    timeout_type,
)
from .progress import EVERY
from .sample import add_sample_options, scenario_of

if TYPE_CHECKING:
    from ..compile.program import Program
    from ..runtime.outcome import Outcome
    from ..verdicts.expect import Verdict

MODELS = ["report", "equilibrium"]
#: The engines (:mod:`stackdsl.engines.registry`, which loads none of them for their names) and
#: their modes, as the options offer them: the modes written here, so that ``--help`` loads no
#: engine settings (their protocol loads the stability package); a test keeps them the settings'.
BACKENDS = names()
MODES = ["raw", "tuned", "extension"]


def _need_backends(option: object) -> None:
    """Nothing when each engine ``--backend`` names (comma-separated) is known and installed.

    Raises:
        ScenarioError: at ``--backend``, an engine whose optional extra is not installed (an
            unknown name is the command's own to refuse, with its choices).
    """
    for name in (b.strip() for b in str(option or "").split(",") if b.strip() in BACKENDS):
        extra = backend(name).extra
        if extra is not None and not installed(extra):
            raise ScenarioError(missing(extra), file="--backend")


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``stackdsl`` console script; returns the exit status
    (argparse's usage errors exit 2 through SystemExit).

    Without ``--debug`` nothing Python prints as a traceback reaches stderr: not the
    exceptions caught here, and not the "Exception ignored in" reports of objects torn down
    half-built by Ctrl-C (kept quiet until exit when called as the command, with no ``argv``).

    A standard error closed before the command began (``2>&-``) is the null device for its
    length: the command runs as with it open, its messages unseen. A pipe that closes early,
    on standard output or standard error, wherever it is met (an error's message included),
    is exit 141.
    """
    command = argv is None
    if sys.stdout is None:  # standard output closed before the command began (``>&-``): as a closed pipe
        return BROKEN_PIPE
    _fill_closed_descriptors()
    closed = sys.stderr is None
    if closed:
        sys.stderr = open(os.devnull, "w", encoding="utf-8")  # closed below, or with the process
    try:
        return _main(sys.argv[1:] if argv is None else argv, command)
    except BrokenPipeError:
        return _pipe_closed(command)
    finally:
        if closed and not command:
            sys.stderr.close()
            sys.stderr = None


def _plotting_environment() -> None:
    """Refuse, as bad input (exit 2), an ``MPLBACKEND`` in the environment that matplotlib does
    not know: matplotlib reads it when first imported and raises ValueError, which a drawing met
    as an internal error (exit 3). stackdsl draws to files with Agg whatever it names; it is
    read only when set, importing matplotlib then (about 0.2 s).

    Raises:
        ScenarioError: naming ``MPLBACKEND``, its value and what to do.
    """
    value = os.environ.get("MPLBACKEND")
    if value is None or "matplotlib" in sys.modules:
        return
    try:
        import matplotlib  # noqa: F401  (reads MPLBACKEND)
    except ValueError:
        for name in [m for m in sys.modules if m == "matplotlib" or m.startswith("matplotlib.")]:
            del sys.modules[name]  # half-imported: a later import would not read it again
        raise ScenarioError(
            f"{value[:60]!r} in the environment is not a backend matplotlib knows: unset MPLBACKEND or give one "
            "matplotlib knows, such as Agg (stackdsl draws its pictures to files with Agg whatever it names)",
            file="MPLBACKEND",
        ) from None


def _fill_closed_descriptors() -> None:
    """Put the null device on whichever of descriptors 0, 1 and 2 is closed, so that no file
    the command opens lands on one of them and takes what the engines print there."""
    for fd in (0, 1, 2):
        try:
            os.fstat(fd)
        except OSError:
            null = os.open(os.devnull, os.O_RDWR)
            if null != fd:
                os.dup2(null, fd)
                os.close(null)


def _pipe_closed(command: bool) -> int:
    """The reader went away (``| head``): stop quietly, and let nothing more be written into
    the closed pipe, at exit either (as the command: standard output and standard error both
    go to the null device then)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    for stream in (sys.stdout, sys.stderr) if command else (sys.stdout,):
        with contextlib.suppress(OSError, ValueError, AttributeError):
            os.dup2(devnull, stream.fileno())
    os.close(devnull)
    return BROKEN_PIPE


def _main(argv: list[str], command: bool) -> int:
    """:func:`main` once the standard streams are in place."""
    debug = "--debug" in argv or os.environ.get("STACKDSL_TRACEBACK", "") not in ("", "0")
    # SIGTERM unwinds like Ctrl-C, so that workers are stopped on the way out (main thread only).
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminated) if main_thread else None
    interrupt = signal.getsignal(signal.SIGINT) if main_thread else None
    pressed: list[int] = []  # Ctrl-C: noted, then raised as KeyboardInterrupt

    def ctrl_c(signum: int, frame: Any) -> None:
        pressed.append(signum)
        raise KeyboardInterrupt

    if main_thread and interrupt is signal.default_int_handler:
        signal.signal(signal.SIGINT, ctrl_c)
    hook, variable = sys.unraisablehook, os.environ.get("STACKDSL_TRACEBACK")
    interrupted = False
    if debug:
        os.environ["STACKDSL_TRACEBACK"] = "1"  # for the workers
    else:
        sys.unraisablehook = _ignore
    _RUNNING.set()
    try:
        return _command(argv, command, debug)
    except BrokenPipeError:
        return _pipe_closed(command)
    except Exception as exc:
        status = _said_error(exc, debug, command_of(argv))
        if status is not None:
            return status
        if not pressed:
            return _internal(exc, debug)
        # Ctrl-C inside a C extension's import or call comes out as that call's error
        # (an ImportError, a SystemError): it was the interrupt all the same
        interrupted = True
        _say_interrupted(main_thread)
        return INTERRUPTED
    except KeyboardInterrupt:
        interrupted = True
        _say_interrupted(main_thread)
        return INTERRUPTED
    finally:
        _RUNNING.clear()
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


def _command(argv: list[str], command: bool, debug: bool) -> int:
    """Parse ``argv`` and run its command, warnings as lines; its exit status."""
    args = _parser(argv).parse_args(argv)
    args.debug = debug
    _plotting_environment()
    _need_backends(getattr(args, "backend", None))
    if command and command_of(argv) in _IN_PROCESS:  # the main process does the work: give it the workers' limit
        from ..batch.guard import limit_memory

        limit_memory()
    with warnings_as_lines():
        status = int(args.func(args))
    sys.stdout.flush()
    return status


def _said_error(exc: Exception, debug: bool, command: str | None = None) -> int | None:
    """Say an error a command's user can act on, on standard error, and return its exit status:
    bad input (the scenario's errors, a path the OS refused), running out of memory (with what to
    give ``command`` instead), and an OS error that is neither (an internal one); None for any
    other error."""
    if isinstance(exc, ScenarioErrors):
        for err in exc.errors:
            print(err, file=sys.stderr)
        if exc.summary:
            print(exc.summary, file=sys.stderr)
        return BAD_INPUT
    if isinstance(exc, ScenarioError):
        print(exc, file=sys.stderr)
        return BAD_INPUT
    if isinstance(exc, OSError):
        line = refused(exc)
        if line is None:
            return _internal(exc, debug)
        print(line, file=sys.stderr)
        return BAD_INPUT
    if isinstance(exc, MemoryError):
        from ..batch.guard import MEMORY_LIMIT

        drawing = command in _DRAWING
        hint = "give a smaller --size, fewer frames, or a smaller file" if drawing else "give a smaller scene"
        print(
            f"stackdsl: out of memory: this command may use {MEMORY_LIMIT >> 30} GiB of address space ({hint})", file=sys.stderr
        )
        return INTERNAL
    return None


def _say_interrupted(main_thread: bool) -> None:
    """Say that Ctrl-C ended the command; a second Ctrl-C meanwhile must not show a traceback."""
    if main_thread:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    print("stackdsl: interrupted", file=sys.stderr)


def _internal(exc: BaseException, debug: bool) -> int:
    """Say an internal error in one line (the traceback with ``debug``); its exit status."""
    if debug:
        traceback.print_exception(exc)
    message = (str(exc).splitlines() or [""])[0] or "(no message)"
    where = "".join(f" ({one_line(note)})" for note in getattr(exc, "__notes__", ()) if note.startswith("while "))
    print(f"stackdsl: internal error: {type(exc).__name__}: {message}{where}{'' if debug else HINT}", file=sys.stderr)
    return INTERNAL


class _Version(argparse.Action):
    """``--version``: the installed version, read only when asked (importlib.metadata takes 20 ms)."""

    def __call__(self, parser: argparse.ArgumentParser, *args: Any) -> NoReturn:
        from .._version import version

        print(f"{parser.prog} {version()}")  # on standard output, as argparse's own version action
        parser.exit()


def _ignore(unraisable: Any) -> None:
    """An ``sys.unraisablehook`` that prints nothing. Ctrl-C (or SIGTERM) whose handler ran
    inside a finalizer (a generator closed as it is dropped runs Python code) would be lost
    there, and the command go on to its end: the signal is sent again (:func:`_again`)."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        _again(signal.SIGINT)
    elif isinstance(unraisable.exc_value, SystemExit) and unraisable.exc_value.code == 128 + signal.SIGTERM:
        _again(signal.SIGTERM)


_RUNNING = threading.Event()
"""Set while :func:`main` runs a command: a signal lost in a finalizer is sent again only then."""


def _again(signum: int) -> None:
    """Send ``signum`` to this process again, 10 ms from now, from a helper thread: sent at once,
    its handler would run inside the unraisable hook and be lost the same way."""
    pid = os.getpid()

    def send() -> None:
        if _RUNNING.is_set():
            os.kill(pid, signum)

    timer = threading.Timer(0.01, send)
    timer.daemon = True
    timer.start()


def _terminated(signum: int, frame: Any) -> None:
    raise SystemExit(128 + signum)


class _Parser(argparse.ArgumentParser):
    """argparse's parser with a usage error on one line: what is wrong and where the help is
    (argparse prints the whole usage first); the subcommands' parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(BAD_INPUT, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")


def value_options(command: str) -> frozenset[str]:
    """The options of ``command`` (``"check"``) that take a value (``-j``, ``--report``, ...), from
    its parser: what a word after one of them is, before the command runs
    (:func:`stackdsl._entry.spare_workers`). Raises KeyError for an unknown command."""
    parser = _parser([command])
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return frozenset(o for a in sub.choices[command]._actions if a.nargs != 0 for o in a.option_strings)


def _parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The ``stackdsl`` parser. Given ``argv``, only the command it names is built in full, so
    that only that command's modules load; the others are their line of help (:data:`COMMANDS`)."""
    parser = _Parser(
        prog="stackdsl",
        description="Declarative stacking scenarios for pybullet.",
        epilog=EXIT_STATUS,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="show the version and exit")
    parser.add_argument("--debug", action="store_true", help=_DEBUG_HELP)
    sub = parser.add_subparsers(required=True, metavar="COMMAND")
    common = _Parser(add_help=False)  # --debug after the command too
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=_DEBUG_HELP)
    given = None if argv is None else command_of(argv)
    for name in COMMANDS:
        if argv is None or name == given:
            _add_command(sub, name, common)
        else:
            sub.add_parser(name, help=COMMANDS[name])
    _described(parser)
    return parser


def _described(parser: argparse.ArgumentParser) -> None:
    """Give each command and subcommand under ``parser`` that has no description its line of
    help as one, so that its own ``--help`` opens with what it does (``stackdsl run --help``,
    ``stackdsl bench folder --help`` said only their usage)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            for name, command in action.choices.items():
                if command.description is None and helps.get(name):
                    command.description = helps[name]
                _described(command)


_DEBUG_HELP = "on an internal error, print the traceback (also STACKDSL_TRACEBACK=1)"
_ONE_STATUS = exit_status("done", None)


def _add_command(sub: Any, name: str, common: argparse.ArgumentParser) -> None:
    """Add command ``name`` (a key of :data:`COMMANDS`) in full; its modules load here."""
    from .scene import NAMES

    if name in ("check", "compare", "compile", "run") or name in NAMES:
        _add_scenario_command(sub, name, common)
    elif name == "sweep":
        from ..batch.guard import TIMEOUT
        from .sweep import add_sweep

        add_sweep(
            sub,
            [common, _guarded(TIMEOUT)],
            exit_status(
                "every statistical expectation held (PASS)",
                "an expectation failed or was inconclusive, or a run reached its --timeout",
            ),
            jobs_type,
            MODELS,
            MODES,
        )
    elif name == "search":
        from ..batch.guard import TIMEOUT
        from .search import add_search

        add_search(
            sub,
            [
                common,
                _guarded(
                    None,
                    "a whole search's runs may take all together (a search whose least runs the compiler estimates to "
                    f"take longer is refused before anything runs; without it, each run may take {TIMEOUT:g} s)",
                ),
            ],
            exit_status(
                "a threshold found; no counterexample in the runs",
                "a counterexample found (the expectation fails), no threshold found, or a run reached its --timeout",
            ),
            jobs_type,
            MODELS,
            MODES,
        )
    elif name == "bench":
        from .bench import add_bench

        add_bench(sub, [common], _ONE_STATUS, MODES)
    else:
        p = sub.add_parser(
            "schema",
            parents=[common],
            help=COMMANDS["schema"],
            epilog=_ONE_STATUS,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
        shown = p.add_mutually_exclusive_group()
        shown.add_argument(
            "--path", action="store_true", help="print the path of the schema file installed with stackdsl, for editors"
        )
        shown.add_argument(
            "--modeline",
            action="store_true",
            help="print the first line for a scenario file anywhere: # yaml-language-server: $schema=<that path>",
        )
        shown.add_argument("--write", action="store_true", help=argparse.SUPPRESS)  # regenerates the shipped copies
        p.set_defaults(func=_print_schema)


def _check_command(args: argparse.Namespace) -> int:
    """``check``, its modules loaded when it runs (``check --help`` loads none of them)."""
    from .check import check_command

    return check_command(args)


def _compare_command(args: argparse.Namespace) -> int:
    """``compare``, its modules loaded when it runs."""
    from .check import compare_command

    return compare_command(args)


def _guarded(timeout: float | None, what: str = "a scenario may run") -> argparse.ArgumentParser:
    """The parent parser of the commands that run scenarios: --timeout (``what`` it bounds;
    ``timeout`` None: no default, the command's own)."""
    guarded = _Parser(add_help=False)
    guarded.add_argument(
        "--timeout",
        type=timeout_type,
        default=timeout,
        metavar="SECONDS",
        help=f"wall seconds {what} before it is stopped and fails (default: "
        + ("none" if timeout is None else f"{timeout:g}")
        + "); "
        "worker processes may also map at most 4 GiB each",
    )
    return guarded


def _add_scenario_command(sub: Any, name: str, common: argparse.ArgumentParser) -> None:
    """Add check, compare, compile, run, or a drawing command (:mod:`stackdsl.cli.draw`)."""
    raw = argparse.RawDescriptionHelpFormatter
    modes = MODES
    one = _Parser(add_help=False, parents=[common])
    one.add_argument("file")
    add_engine_overrides(one, modes, MODELS, BACKENDS)
    add_seed(one)
    add_sample_options(one, name)
    if name == "compile":  # the one that runs nothing
        p = sub.add_parser("compile", parents=[one], help=COMMANDS["compile"], epilog=_ONE_STATUS, formatter_class=raw)
        p.add_argument("--json", action="store_true", help="print the Program as JSON")
        p.set_defaults(func=_compile)
        return
    from ..batch.guard import TIMEOUT

    guarded = _guarded(TIMEOUT)
    files = _guarded(
        TIMEOUT,
        "a scenario file may run (with compare, each of its runs: one mode on one engine), a sweep file's runs all "
        "together, and with check's --perturb a scenario's run and its "
        "reruns together (runs the compiler estimates to take longer are refused before anything runs, and runs that take "
        "longer stop where the budget ran out),",
    )
    many = _Parser(add_help=False, parents=[common, files])
    many.add_argument(
        "paths",
        nargs="+",
        metavar="PATH",
        help="scenario files, or folders searched for *.yaml and *.yml (a file named twice runs once)",
    )
    many.add_argument("--model", choices=MODELS, help="override every scenario's stability model")
    add_seed(many)
    many.add_argument(
        "--backend",
        metavar="ENGINE",
        help=f"override every scenario's engine: {' or '.join(BACKENDS)} (compare: several, comma-separated)",
    )
    many.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="auto",
        help="runs at the same time, this process included: 1 to the number of cores, or auto (default: one per "
        "free core, the cores less the tasks other processes run now). Work estimated cheaper than starting a worker runs "
        "in this process whatever -j says",
    )
    many.add_argument(
        "-k",
        metavar="EXPR",
        dest="pattern",
        action="append",
        help="only the scenarios EXPR selects, as pytest's -k: words joined by and, or, not and parentheses, a word "
        "holding when the file's path or the scenario's name contains it, ignoring case ('tower and not hard/'; a "
        "word is letters, digits and _:+-.[]\\/); give -k again for more: a scenario runs when any of them selects it",
    )
    many.add_argument("--json", action="store_true", help="print one JSON document of every result instead of the table")
    if name == "check":
        p = sub.add_parser(
            "check",
            parents=[many],
            help=COMMANDS["check"],
            description="Run scenario files or folders and check their expectations: a row per scenario as it "
            f"finishes (under a progress line on a terminal; elsewhere, a line on standard error every {EVERY:g} s says how "
            "far it is), what moved under each FAIL, then a summary. A row's "
            "verdict: PASS, FAIL, INCONCLUSIVE (a sweep's statistic its samples did not decide, or a run that ended "
            "with its bricks still moving before they could decide an expectation), SKIP (the file's "
            "skip mark, with its reason), XFAIL or XPASS (its xfail mark: failed as expected, or passed).",
            epilog=CHECK_STATUS,
            formatter_class=raw,
        )
        p.add_argument("--mode", choices=modes, help="override every scenario's engine mode")
        p.add_argument(
            "-x", "--exitfirst", action="store_true", help="stop after the first failure (runs not started are cancelled)"
        )
        p.add_argument("--junit-xml", metavar="FILE", help="also write JUnit XML to FILE: one testcase per scenario")
        p.add_argument(
            "--perturb",
            metavar="N",
            type=perturb_type,
            default=0,
            help="then rerun every scenario N times under changes that should not matter (a placement jitter of "
            "10 micrometres, the timestep +-1%%, solver iterations +-10%%, the other engine where the scene allows, "
            "each kind in turn: the other engine is the fourth) "
            "and say, for each verdict, how many held, with the certificate's margin: a verdict that flips is "
            "FRAGILE (exit 1), and what flipped it is named",
        )
        p.add_argument(
            "--report",
            metavar="DIR",
            help="also record every run and write DIR/index.html: a row per scenario (failures first) with a picture at "
            "the collapse or the end, the timeline, a clip and a brick-graph plot, then a summary (made if missing)",
        )
        p.set_defaults(func=_check_command)
    elif name == "compare":
        p = sub.add_parser(
            "compare",
            parents=[many],
            help=COMMANDS["compare"],
            description="Run scenario files or folders in every mode, in one run, and print one table.\n\n"
            "The tuned modes are the slow ones (pybullet at 1 kHz with 150 solver iterations): a Jenga\n"
            "tower with a pull or two takes 30 s to minutes there, and a run past --timeout (100 s by\n"
            "default) is stopped and its cell fails; give such scenes --timeout 600.",
            epilog=CHECK_STATUS.replace("  0    every expectation held", "  0    in every cell, every expectation held").replace(
                "  1    an expectation failed", "  1    an expectation failed in some cell"
            ),
            formatter_class=raw,
        )
        p.add_argument("--modes", default=",".join(modes), help=f"comma-separated (default: {','.join(modes)})")
        p.set_defaults(func=_compare_command)
    elif name == "run":
        from .draw import add_record_options

        p = sub.add_parser(
            "run",
            parents=[one, guarded],
            help=COMMANDS["run"],
            epilog=EXIT_STATUS + "\n\nWith --json too, the exit status is 1 when an expectation failed.",
            formatter_class=raw,
        )
        p.add_argument(
            "--json", action="store_true", help="print the whole Outcome as JSON (exit 1 still means a failed expectation)"
        )
        add_record_options(p)
        p.set_defaults(func=_run)
    else:
        from .scene import add_commands

        add_commands(sub, [one, guarded], _ONE_STATUS, (name,))


def _compile(args: argparse.Namespace) -> int:
    from ..compile.compiler import compile_scenario
    from ..compile.program import format_program

    scenario = scenario_of(args, "compile")
    program = compile_scenario(scenario, args.mode, args.model, args.backend)
    print(program.model_dump_json(indent=2) if args.json else format_program(program))
    return OK


def _run(args: argparse.Namespace) -> int:
    from ..batch.judge import run_guarded, stopped_by
    from ..compile.compiler import compile_scenario
    from ..verdicts.expect import evaluate, explain

    scenario = scenario_of(args, "run")
    program = compile_scenario(scenario, args.mode, args.model, args.backend, draw_time=args.timeout)
    if args.rate is not None and args.record is None:
        raise ScenarioError("--rate is the recording's: give --record OUT.npz too", file="--rate")
    outcome = _run_recorded(args, program) if args.record is not None else run_guarded(program, args.timeout)
    stopped = stopped_by(outcome)
    verdicts = evaluate(scenario.expect, outcome, program.collapse_threshold)
    if args.json:  # the outcome, with the verdicts of the file's expectations beside its certificate
        data = {**outcome.model_dump(mode="json"), "verdicts": [v.model_dump() for v in verdicts]}
        print(json.dumps(data, indent=2))
    else:
        _print_run(args, outcome, program, verdicts)
        if not stopped and not all(v.passed for v in verdicts):  # what check says under a failure
            for line in explain(scenario.expect, outcome, program.collapse_threshold):
                print(f"      {line}")
        if stopped and all(v.passed for v in verdicts):  # no verdict says it
            print(f"FAIL  {stopped}")
        if stopped and stopped.startswith("timeout"):  # as check says it after its table
            print(f"      the rest of the run was not simulated: a longer --timeout (now {args.timeout:g} s) lets it finish")
    return OK if all(v.passed for v in verdicts) and not stopped else FAILED


def _run_recorded(args: argparse.Namespace, program: Program) -> Outcome:
    """``run --record OUT.npz``: run ``program`` with a recorder, write its trajectory to the
    checked path, say so (on standard error under ``--json``), and return the outcome.

    Raises:
        ScenarioError: the path does not end in ``.npz``, or is refused as an output, or the
            recording passes what a trajectory file may hold (the run ends then; nothing is written).
        OSError: the trajectory cannot be written.
    """
    from .outputs import Input, Output, check_outputs

    if args.record.strip() and Path(args.record).suffix.lower() != ".npz":
        raise ScenarioError("a trajectory file must end in .npz", file=args.record, field="--record")
    (record,) = check_outputs(
        [Output("--record", args.record, "the trajectory file")], [Input(args.file, "the scenario being run")]
    )
    from ..runtime.recorder import RATE, record_program
    from ..runtime.trajectory import TrajectoryTooLarge

    try:
        outcome, trajectory = record_program(program, args.rate or RATE, source=args.file, timeout=args.timeout)
        trajectory.save(record)
    except TrajectoryTooLarge as exc:  # nothing written: replay and render would refuse it
        lower = f"a lower --rate than {args.rate or RATE:g}, " if args.rate is None or args.rate > 1 else ""
        raise ScenarioError(
            f"{exc}; nothing was written: give {lower}or record a shorter run", file=args.record, field="--record"
        ) from None
    print(
        f"wrote {record}: {len(trajectory.times)} frames of {len(trajectory.ids)} bodies",
        file=sys.stderr if args.json else sys.stdout,
    )
    return outcome


def _print_run(args: argparse.Namespace, outcome: Outcome, program: Program, verdicts: list[Verdict]) -> None:
    """What ``run`` prints without ``--json``: the events, a summary line, the certificate, the
    actions not run, and each verdict, those that held first (a failure at the line of its
    expectation)."""
    from ..runtime.outcome import describe_certificate
    from ..verdicts.expect import describe_outcome, not_run_line

    for e in outcome.events:
        level = "" if e.level is None else f"level {e.level}"
        print(f"t={e.time:9.3f} s  {e.kind:<8} {e.brick:<10} {level:<9} {e.detail}")
    print(
        f"{Path(args.file).name} on {program.engine.backend} {program.engine.mode}: "
        f"{describe_outcome(outcome, program.collapse_threshold)} "
        f"({outcome.levels_placed} level{'s' * (outcome.levels_placed != 1)} placed), {outcome.simulated_time:.1f} s simulated, "
        f"{outcome.wall_time:.2f} s wall ({outcome.engine_time:.2f} s in the engine's steps"
        + (f", {outcome.after_collapse:.2f} s after the collapse" if outcome.collapse else "")
        + f"), {outcome.steps} steps ({outcome.steps_skipped} skipped)"
    )
    if outcome.certificate is not None:
        print(f"certificate: {describe_certificate(outcome.certificate)}")
    if outcome.not_run:
        print(not_run_line(outcome))
    # what held first, then each failure at the line of its expectation, as a parse error is shown,
    # so that the lines saying why (run's caller prints them next) follow the failures, not a PASS
    for v in sorted(verdicts, key=lambda v: not v.passed):
        head, *shown = v.lines() if not v.passed else [f"expected {v.expected}, measured {v.measured}"]
        said = "PASS" if v.passed else "INCONCLUSIVE" if v.inconclusive else "FAIL"
        print(f"{said}  {head}", *(f"      {line}" for line in shown), sep="\n")


def _print_schema(args: argparse.Namespace) -> int:
    from ..lang.jsonschema import packaged_path, schema_text

    if args.path or args.modeline:
        path = packaged_path()
        if not path.is_file():  # a broken install: say so rather than point editors nowhere
            raise ScenarioError("the schema file is missing from this install: reinstall stackdsl", file=str(path))
        print(f"# yaml-language-server: $schema={path}" if args.modeline else path)
    elif args.write:  # the copies in a checkout (a developer's command): the package's, and schema/'s
        shipped = Path(__file__).resolve().parents[2] / "schema"
        for path in (packaged_path(), *([shipped / "scenario.schema.json"] if shipped.is_dir() else [])):
            path.write_text(schema_text())
            print(f"wrote {path}")
    else:
        print(schema_text(), end="")
    return OK


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())


#: Commands whose work runs in this process (drawing, reading trajectories, one recorded run):
#: they get the address-space limit the workers of ``check`` have.
_IN_PROCESS = {"render", "animate", "graph", "run", "replay", "view", "export"}
_DRAWING = {"render", "animate"}  # the commands that take --size and draw frames
