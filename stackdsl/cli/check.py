"""The ``stackdsl check`` and ``stackdsl compare`` commands: scenarios run in their modes,
a line (or a row of compare's table) each, and the exit status of the whole.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import textwrap
import time
from itertools import chain
from pathlib import Path
from typing import TextIO

from ..batch.check import (
    Prepared,
    discover,
    estimates,
    prepare,
    result_key,
    run_checks,
    run_key,
    select_comparison,
    sweep_runs,
    tabulate,
)
from ..batch.perturb import Fragility, fragility_lines, perturbed_runs, within_budget
from ..batch.report import HEADER, failure_lines, json_document, junit_xml, mode_label, rerun_command, row, summary
from ..compile.compiler import BACKEND_DEFAULTS, MODE_DEFAULTS
from ..draw.artefacts import FILES, folder_name
from ..lang.errors import ScenarioError
from ..verdicts.check_result import CheckResult
from ..verdicts.expect import describe, millimetres, near_tie
from .args import BAD_INPUT, FAILED, HINT, INTERNAL, OK
from .outputs import Input, Output, check_default_golden, check_outputs, odd_files
from .progress import Lines, Remaining, is_live


def _say_sweeps(prepared: list[Prepared], timeout: float | None) -> None:
    """Say on stderr, before anything runs, how many runs each sweep makes and what they take by
    the compiler's estimate, against the one --timeout that bounds the whole file."""
    for p in prepared:
        if p.template is not None:
            runs, seconds = sweep_runs(p.template, p.program)
            bound = "no --timeout" if timeout is None else f"--timeout {timeout:g} s bounds them all"
            print(
                f"stackdsl check: {p.path}: a sweep of {runs} run{'s' * (runs != 1)}, about {seconds:.2g} s by the compiler's estimate; {bound}",
                file=sys.stderr,
            )


def check_command(args: argparse.Namespace) -> int:
    """``stackdsl check``: run every scenario under ``args.paths``; the exit status. The files
    are read and compiled first (bad input raises there), the report's folders made
    (:func:`_report_folders`), the runs shown as they finish (:func:`_run_all`), then listed in
    file order in the reports (:func:`_write_reports`) and the summary."""
    start = time.perf_counter()
    files = discover(args.paths)
    report = _check_outputs(args, files)
    backends = _backends(args.backend, several=False)
    broken: list[CheckResult] = []  # files an internal error met as they were read: a row each, the others run
    skipped: list[CheckResult] = []  # runs the file's skip mark holds on: a row each, nothing runs
    prepared = prepare(
        files,
        args.mode,
        model=args.model,
        backends=backends,
        seed=args.seed,
        timeout=args.timeout,
        broken=broken,
        skipped=skipped,
    )  # bad input raises here
    prepared, broken = select_comparison(prepared, broken + skipped, args.pattern)
    _say_sweeps(prepared, args.timeout)
    if args.perturb:
        within_budget(prepared, args.perturb, args.timeout)  # bad input raises here, before anything runs
    total = len(prepared) + len(broken)
    folders = _report_folders(args, report, prepared) if report is not None else None
    stream = sys.stderr if args.json else sys.stdout  # with --json only the progress line, on a terminal
    results, commands = _run_all(args, prepared, broken, folders, stream)
    wall = time.perf_counter() - start
    # rows came as runs finished; the reports list them in file order, so that they diff from run to run
    order = {str(path): i for i, path in enumerate(files)}
    pairs = sorted(zip(results, commands, strict=True), key=lambda pair: order.get(pair[0].file, len(order)))
    results, commands = [r for r, _ in pairs], [c for _, c in pairs]
    _write_reports(args, report, folders, prepared, results, commands, total, wall, stream)
    fragile = _perturbed(args, prepared, results, stream) if args.perturb else None
    return _finish(args, results, commands, fragile, total, wall)


def _finish(
    args: argparse.Namespace,
    results: list[CheckResult],
    commands: list[str],
    fragile: list[Fragility] | None,
    total: int,
    wall: float,
) -> int:
    """The summary (or with ``--json`` the document) of a check, and its exit status: internal
    errors first (3), then bad input found once a sample was drawn (2), then a failure or a
    fragile scenario (1), else 0."""
    if args.json:
        document = json_document("check", results, commands, total, wall)
        if fragile is not None:
            document["perturbed"] = [f.as_json() for f in fragile]
        print(json.dumps(document, indent=2))
    else:
        print(summary(results, total, wall))
        if fragile is not None:
            print("\n".join(fragility_lines(fragile, args.perturb)))
    if _internal_errors(results, args.debug):
        return INTERNAL
    refused = [r for r in results if r.bad_input]
    for r in refused:  # a sweep's sample the language refuses: bad input, found once it was drawn
        print(r.bad_input, file=sys.stderr)
    if refused:
        return BAD_INPUT
    return FAILED if any(not r.held for r in results) or any(f.fragile for f in fragile or ()) else OK


def _report_folders(args: argparse.Namespace, report: Path, prepared: list[Prepared]) -> list[str]:
    """``--report``: the report's folder made, and one folder in it for each prepared run, named
    after its file relative to the files' common folder.

    Raises:
        ScenarioError: the report's folder takes no file, or a run's folder holds one that is
            not a regular file (a FIFO where a run's picture goes would block its worker).
    """
    try:
        report.mkdir(parents=True, exist_ok=True)
        probe = report / ".stackdsl-write-test"
        probe.touch()
        probe.unlink()
    except OSError as exc:
        raise ScenarioError(f"cannot write the report there: {exc.strerror or exc}", file=args.report) from None
    taken: set[str] = set()
    base = os.path.commonpath([path.resolve().parent for path, *_ in prepared] or [Path.cwd()])  # names relative to it
    folders = [str(report / folder_name(os.path.relpath(path.resolve(), base), taken=taken)) for path, *_ in prepared]
    for folder in folders:
        problem = odd_files(Path(folder), FILES.values())
        if problem:
            raise ScenarioError(problem, file=folder, field="--report")
    return folders


def _run_all(
    args: argparse.Namespace, prepared: list[Prepared], broken: list[CheckResult], folders: list[str] | None, stream: TextIO
) -> tuple[list[CheckResult], list[str]]:
    """Every prepared run (the ``broken`` rows first), a row each and its failure's lines as it
    finishes, under a progress line on ``stream``; until the first failure with ``-x``. The
    results as they came, and the command that reruns each."""
    results: list[CheckResult] = []
    commands: list[str] = []
    remaining = Remaining(estimates(prepared))
    with Lines(len(prepared) + len(broken), "check", file=stream, live=is_live(stream), remaining=remaining) as lines:
        if not args.json:
            lines.line(HEADER)
        checks = run_checks(prepared, args.jobs, timeout=args.timeout, folders=folders)
        try:
            for r in chain(broken, checks):
                results.append(r)
                commands.append(
                    rerun_command(
                        "sweep" if r.sweep else "run",
                        r.file,
                        mode=args.mode,
                        model=args.model,
                        backend=args.backend,
                        seed=args.seed,
                        timeout=args.timeout,
                    )
                )
                if not args.json:
                    lines.line(row(r))
                    for text in failure_lines(r, commands[-1]):
                        lines.line(text)
                lines.advance(key=result_key(r), took=r.wall_time)
                if args.exitfirst and not r.held:
                    break
        finally:
            checks.close()  # cancels what has not started and stops the workers
    return results, commands


def _write_reports(
    args: argparse.Namespace,
    report: Path | None,
    folders: list[str] | None,
    prepared: list[Prepared],
    results: list[CheckResult],
    commands: list[str],
    total: int,
    wall: float,
    stream: TextIO,
) -> None:
    """``--junit-xml`` (the runs that did not run, after ``-x``, as skipped) and ``--report`` (the
    HTML page; the folders of an earlier report that this one has not, removed), each said on
    ``stream``."""
    if args.junit_xml:
        ran = {r.file for r in results}
        junit_xml(results, commands, [str(p.path) for p in prepared if str(p.path) not in ran], wall, args.junit_xml)
    if report is None:
        return
    from ..batch.htmlreport import remove_stale_folders, write_report

    page = write_report(results, report, total=total, wall=wall, commands=commands, argv=sys.argv[1:] or ["check"])
    stale = remove_stale_folders(report, {Path(f).name for f in folders or []})
    if stale:
        print(f"report: removed {stale} folders of an earlier report in {report}", file=stream)
    drawn = [r for r in results if r.draw_error]
    print(f"report: {page}" + (f" ({len(drawn)} runs not fully drawn: {drawn[0].draw_error})" if drawn else ""), file=stream)


def _perturbed(args: argparse.Namespace, prepared: list[Prepared], results: list[CheckResult], stream: TextIO) -> list[Fragility]:
    """``check --perturb N``: every scenario that ran rerun N times perturbed, under a progress line."""
    ran = {result_key(r) for r in results if not r.error and not r.skipped}
    chosen = [p for p in prepared if run_key(p) in ran]
    runs = sum(args.perturb for p in chosen if p.template is None)
    with Lines(runs, "perturbed runs", file=stream, live=is_live(stream)) as lines:
        fragile = list(perturbed_runs(chosen, results, args.perturb, args.jobs, args.timeout, args.seed, lines.advance))
    return fragile


def _check_outputs(args: argparse.Namespace, files: list[Path]) -> Path | None:
    """``--junit-xml`` and ``--report``, checked before anything runs (none may be a scenario
    checked or a golden snapshot; see :func:`stackdsl.cli.outputs.check_outputs`), and with
    ``--report`` the goldens its replays read; the report's folder, or None.

    Raises:
        ScenarioError: an output refused, or a golden that is not a regular file.
    """
    from ..verdicts.snapshot import scenario_golden_path

    goldens = [(f, scenario_golden_path(f)) for f in files]
    outputs = []
    if args.junit_xml is not None:
        outputs.append(Output("--junit-xml", args.junit_xml, "the JUnit XML file"))
    if args.report is not None:
        outputs.append(Output("--report", args.report, "the report", folder=True, inside=("index.html",)))
    check_outputs(
        outputs,
        [
            *(Input(f, f"a scenario being checked ({f})") for f in files),
            *(Input(g, f"the golden snapshot of {f}") for f, g in goldens),
        ],
    )
    if args.report is None:
        return None
    for _, golden in goldens:  # the report's replays read them
        check_default_golden(golden)
    return Path(args.report)


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


def compare_command(args: argparse.Namespace) -> int:
    """``stackdsl compare``: every scenario in every mode, as one table; the exit status."""
    modes, backends = _compared(args)
    start = time.perf_counter()
    plain = tuple(dict.fromkeys(m.split()[-1] for m in modes))
    refusals: list[CheckResult] = []
    broken: list[CheckResult] = []  # a cell each for a file an internal error met as it was read
    skipped: list[CheckResult] = []  # a cell each for a run the file's skip mark holds on
    files = discover(args.paths)
    prepared = prepare(
        files,
        modes=plain,
        model=args.model,
        backends=backends,
        refused=refusals,
        seed=args.seed,
        timeout=args.timeout,
        broken=broken,
        skipped=skipped,
    )
    prepared, refused = select_comparison(prepared, refusals + broken + skipped, args.pattern)
    done: list[CheckResult] = []
    live = is_live(sys.stdout)
    # On a terminal a progress line; elsewhere a line per finished cell on stderr, so that
    # stdout holds the table (or the JSON) alone.
    stream, remaining = (sys.stdout if live else sys.stderr), Remaining(estimates(prepared))
    with Lines(len(prepared) + len(refused), "compare", file=stream, live=live, remaining=remaining) as lines:

        def each(r: CheckResult) -> None:
            done.append(r)
            lines.advance(key=result_key(r), took=r.wall_time)
            if not live:
                lines.line(
                    f"[{len(done)}/{len(prepared) + len(refused)}] {Path(r.file).stem} {r.backend} {r.mode}: "
                    + (
                        "refused (why is said after the table)"  # said once, there
                        if r.refused
                        else f"SKIP: {r.skipped}"
                        if r.skipped
                        else f"{r.verdict} {r.error or r.stopped or _cell(r)} ({r.wall_time:.1f} s)"
                    )
                )

        table = tabulate(prepared, modes, chain(refused, run_checks(prepared, args.jobs, timeout=args.timeout)), each, files)
    wall = time.perf_counter() - start
    if args.json:
        # the table's order (files, then modes as given), not the order the runs finished in
        ordered = [r for cells in table.values() for r in cells.values()]
        tabled = {id(r) for r in ordered}
        done = ordered + [r for r in done if id(r) not in tabled]
        commands = [
            rerun_command(
                "sweep" if r.sweep else "run",
                r.file,
                mode=r.mode,
                model=args.model,
                backend=r.backend if args.backend else None,
                seed=args.seed,
                timeout=args.timeout,
            )
            for r in done
        ]
        print(json.dumps(json_document("compare", done, commands, len(prepared), wall), indent=2))
        return _status(done, args.debug)
    width = table_width()
    for line in compare_lines(table, width):
        print(line)
    print(f"{len(table)} scenarios x {len(modes)} modes ({wall:.1f} s wall)")
    _notes(table, done, refused, width)
    return _status(done, args.debug)


def _compared(args: argparse.Namespace) -> tuple[tuple[str, ...], tuple[str | None, ...]]:
    """``--modes`` and ``--backend`` of compare: the table's columns (a mode each, ``"backend
    mode"`` with several backends) and the backends.

    Raises:
        ScenarioError: an unknown mode, or none, at ``--modes``.
    """
    modes = tuple(m.strip() for m in args.modes.split(",") if m.strip())
    unknown = [m for m in modes if m not in MODE_DEFAULTS]
    if unknown or not modes:
        raise ScenarioError(f"unknown mode {', '.join(unknown) or '(none)'}; known: {', '.join(MODE_DEFAULTS)}", file="--modes")
    backends = _backends(args.backend, several=True)
    if len(backends) > 1:
        modes = tuple(f"{b} {m}" for b in backends for m in modes)
    return modes, backends


def _notes(table: dict[str, dict[str, CheckResult]], done: list[CheckResult], refused: list[CheckResult], width: int) -> None:
    """What compare says under its table: a failure the run's end cut short (with check's hint),
    a cell its ``--timeout`` stopped (and how to let it finish), why cells were skipped or
    expected to fail (once each), and on stderr why a compared engine or mode refused a file."""
    for r in done:  # a failure or an undecided run the run's end cut short: the hint check gives under it
        for line in r.explanation if not r.passed else ():
            if line.startswith(("still moving", "undecided: the run ended")):
                print(
                    "\n".join(textwrap.wrap(f"{Path(r.file).stem} {r.backend} {r.mode}: {line}", width, subsequent_indent="    "))
                )
    for r in done:  # a cell its --timeout cut short judged nothing: how to let it finish
        if r.stopped.startswith("timeout"):
            words = (
                f"{Path(r.file).stem} {r.backend} {r.mode}: {r.stopped}; nothing was judged: a longer --timeout lets it finish"
            )
            print("\n".join(textwrap.wrap(words, width, subsequent_indent="    ")))
    marked: dict[tuple[str, str, str], list[str]] = {}  # (file, word, reason) -> the columns it was said of
    for file, cells in table.items():
        for column, r in cells.items():
            if r.skipped or r.xfail:
                word = "SKIP" if r.skipped else "XPASS (strict)" if r.verdict == "XPASS" and r.strict else r.verdict
                marked.setdefault((Path(file).stem, word, r.skipped or r.xfail), []).append(column)
    for (stem, word, reason), where in marked.items():  # why cells were skipped or expected to fail, once each
        print(f"{stem}: {word} in {', '.join(where)}: {reason}")
    for r in refused:  # why, once each, after the table
        if r.refused:
            print(f"refused in {r.mode} on {r.backend}: {r.refused}", file=sys.stderr)


#: The widest compare's table is, in columns, and the narrowest a terminal makes it.
MAX_WIDTH, MIN_WIDTH = 100, 60


def table_width() -> int:
    """The columns compare's table fits in: the terminal's (``COLUMNS`` first, as
    :func:`shutil.get_terminal_size` reads it), at most :data:`MAX_WIDTH` and at least
    :data:`MIN_WIDTH`; :data:`MAX_WIDTH` when stdout is no terminal (piped, in CI)."""
    columns = shutil.get_terminal_size((MAX_WIDTH, 24)).columns
    return max(MIN_WIDTH, min(MAX_WIDTH, columns))


def compare_lines(table: dict[str, dict[str, CheckResult]], width: int = MAX_WIDTH) -> list[str]:
    """compare's table as lines of at most ``width`` characters: a block a scenario, its name and
    what it expects, then a row a mode (engine, mode, PASS or FAIL with what was measured
    (:func:`_cell`), wall seconds), the measured text wrapped under itself when it is longer
    than the room left; the wall times of every row in one column.

    >>> from stackdsl.verdicts.check_result import CheckResult, Verdict
    >>> held = Verdict(name="stands", passed=True, expected="stands", measured="stands")
    >>> r = CheckResult(file="s/tower.yaml", scenario="t", mode="raw", model="report", verdicts=(held,),
    ...     collapse_level=None, levels_placed=2, simulated_time=5.0, wall_time=1.25)
    >>> print("\\n".join(compare_lines({"s/tower.yaml": {"raw": r}}, 60)))
    scenario: what it expects
      engine   mode       result        wall
    tower: stands
      pybullet raw        PASS stands  1.2 s
    """
    rows = [(c, _cell(c)) for cells in table.values() for c in cells.values()]
    walls = [f"{c.wall_time:.1f} s" for c, _ in rows]
    wall = max([6, *(len(w) for w in walls)])
    words = max([4, *(len(_verdict(c)) for c, _ in rows)])  # PASS, FAIL, SKIP, XFAIL, INCONCLUSIVE...
    lead = 2 + 8 + 1 + 9 + 2 + words + 1  # indent, engine, mode, verdict
    room = max(12, width - lead - 1 - wall)
    said = min(room, max([len("result") - 5, *(len(REFUSED if c.refused else text) for c, text in rows)]))
    lines = [
        "scenario: what it expects",
        f"  {'engine':<8} {'mode':<9}  {'result':<{said + words + 1}} {'wall':>{wall}}".rstrip(),
    ]
    for file, cells in table.items():
        first = next((c for c in cells.values() if not c.refused), next(iter(cells.values())))
        lines += textwrap.wrap(f"{Path(file).stem}: {first.expected}", width, subsequent_indent="    ")
        for c in cells.values():
            parts = textwrap.wrap(REFUSED if c.refused else _cell(c), said) or [""]
            head = f"  {c.backend:<8} {mode_label(c):<9}  {_verdict(c):<{words}} "
            lines.append(f"{head}{parts[0]:<{said}} {'' if c.refused else f'{c.wall_time:.1f} s':>{wall}}".rstrip())
            lines += [f"{'':<{len(head)}}{part}" for part in parts[1:]]
    return lines


def _verdict(c: CheckResult) -> str:
    """A cell's verdict word: PASS, FAIL, INCONCLUSIVE, SKIP, XFAIL or XPASS; none when refused."""
    return "" if c.refused else c.verdict


#: A refused cell of compare's table: the engine or mode refused the file (beyond what it simulates
#: faithfully, or a time off its step grid): why is said after the table.
REFUSED = "refused (why: below the table)"


def _status(done: list[CheckResult], debug: bool) -> int:
    """compare's exit status, as check's: 3 when a run hit an internal error, else 1 when some
    cell did not hold (:attr:`CheckResult.held`: an expectation failed or was undecided, raw mode
    failing where the extension holds is one, or a strict xfail passed), else 0."""
    if _internal_errors(done, debug):
        return INTERNAL
    return FAILED if any(not r.held and not r.refused for r in done) else OK


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
    what = "one of" if not several else "one or more of"
    if unknown or not names:
        said = ", ".join(repr(b) for b in unknown) if unknown else repr(given)
        raise ScenarioError(f"unknown backend {said}: give {what} {', '.join(BACKEND_DEFAULTS)}", file="--backend")
    if len(names) > 1 and not several:
        raise ScenarioError(
            f"one backend, not {len(names)} ({given!r}): give {what} {', '.join(BACKEND_DEFAULTS)}", file="--backend"
        )
    return names


def _cell(r: CheckResult) -> str:
    """What compare's table shows of a result: the collapse level and the brick that moved first
    (``collapse 9 from L03.1``), the bricks toppled when the
    file expects a count (``stands, 0 of 5 toppled``), the bricks it expects to move that did
    (``collapse 12, brick L06.2 moved``), the bricks it expects to stay when they moved 1 mm or
    more (``levels 1-4 stayed (moved 2.4 mm at most)``), how far a standing brick moved at most from 1 mm
    (:data:`SHOWN_DRIFT`: ``stands, moved 7.1 mm at most``), where the brick a collapse is named
    after ended when that is within :data:`SHOWN_ENDED` thresholds (``collapse 7 from L06.1, which
    ended 10.5 mm from its place``), how little past its limit a collapse
    was decided under :data:`stackdsl.verdicts.expect.NEAR_TIE` (``collapse 9 from L03.1, 0.5 mm past its limit, a near
    tie``), that a run ended still moving judged
    nothing (an undecided run read "INCONCLUSIVE stands" of a card house lying 90 mm from its
    place), or what went wrong."""
    if r.error:
        return "out of memory" if "out of memory" in r.error else "internal error"
    if r.stopped:  # a timeout, or an engine that blew up (MuJoCo's "became unstable")
        return "timeout" if r.stopped.startswith("timeout") else "unstable" if "unstable" in r.stopped else "stopped"
    if not r.sweep and r.verdict == "INCONCLUSIVE":  # still moving when the run ended: judged neither way
        return "undecided: still moving at the end"
    toppled = [v.measured for v in r.verdicts if v.name == "toppled"]
    # what moved, when the file names it: a push that slid one block out reads "collapse 12" alone,
    # and which brick moved was shown only when a cell failed
    moved = [v.measured for v in r.verdicts if v.name == "moved" and v.passed]
    # and what was to stay, when it moved near its limit (a push that moved level 4 2.4 mm read
    # "collapse 10 from L05.1" beside a setting that moved it 4.8 mm and failed)
    moved += [v.measured for v in r.verdicts if v.name == "stays" and v.passed and v.measured.endswith(" at most)")]
    # what failed besides the level: a collapse at the level expected can still fail its 'stays'
    failed = [v.measured for v in r.verdicts if not v.passed and v.name not in ("collapse", "stands", "toppled")]
    # how close a stand came: a new user could not tell a pull that dragged the top level 7.1 mm
    # (0.4 mm under its threshold) from one that moved nothing
    near = [f"moved {r.drift * 1000:.1f} mm at most"] if r.collapse_level is None and r.drift >= SHOWN_DRIFT else []
    # and how close a collapse came to standing: its deciding proof's signed margin (a pull that
    # dragged a level 4.5 mm against a 4 mm threshold read "collapse 9" as one that threw it off),
    # and where the brick it is named after ended (a proof decided as a knocked brick's centre of
    # mass crossed its support's edge is 0.5 mm past it, and the brick lay on the ground)
    ended = r.first_moved_ended if r.collapse_level is not None and r.first_moved else None
    if tie := near_tie(r.margin, ended, r.threshold, r.kind):
        near = [tie]
    # which brick moved first, and where it ended when that was near: cells that agree on the
    # level may not on where the collapse began, and a block dragged 10.5 mm in a tower that
    # stands read as a fall
    if near:  # a stand's largest move said once: "stands, moved 1.0 mm at most, ..., levels 1-3 stayed" (it was said twice)
        moved = [m.removesuffix(f" ({near[0]})") for m in moved]
    head = describe(r.collapse_level) + (f" from {r.first_moved}" if r.collapse_level is not None and r.first_moved else "")
    if ended is not None and r.threshold is not None and ended < SHOWN_ENDED * r.threshold:
        head += f", which ended {millimetres(ended, against=r.threshold)} from its place"
    return ", ".join([head, *near, *toppled, *moved, *failed])


#: Metres of the largest move of a standing brick from which compare's cell says it (1 mm).
SHOWN_DRIFT = 0.001
#: Times the collapse threshold under which compare's cell says where the brick a collapse is
#: named after ended (``collapse 7 from L06.1, which ended 10.5 mm from its place``): dragged, not fallen.
SHOWN_ENDED = 3.0
