"""pytest plugin: scenario files are test items, with golden snapshots in ``golden/``.

Installed with stackdsl (entry point ``pytest11``); it needs syrupy
(``pip install 'stackdsl[pytest]'``). As Tavern does for its YAML tests, pytest collects
every ``*.yaml``/``*.yml`` file below the folders named by the ini option
``stackdsl_paths`` (default: ``scenarios``), relative to the project root::

    [tool.pytest.ini_options]
    stackdsl_paths = ["scenarios", "more/scenarios"]

Each file is one test item, ``scenarios/four_stack.yaml::four_stack``: it loads and
compiles the scenario (a bad file fails with its ``file:line:col`` message), runs it,
checks its expectations, then compares the outcome with its golden snapshot
``golden/scenarios/four_stack.json`` (one brick per line, :mod:`stackdsl.verdicts.snapshot`).
An item opens its file by its absolute path, so pytest may run from any folder; failures name
files relative to that folder, as pytest names the items.
``pytest --snapshot-update`` writes the snapshots of the items that pass. An item that fails (a
bad file, an expectation, a crash) leaves its golden as it was, and syrupy counts a golden
unused, and ``--snapshot-update`` deletes it, only when its scenario file is gone (nothing that
happens to an item, ``-x``, ``--ignore`` or ``-k`` loses a golden whose file exists). ``-k``,
``-x``, ``--lf``, ``-n`` (pytest-xdist) and ``--junit-xml`` work as on any test.
A golden that cannot be one (a FIFO, not JSON, ...), or none where it is looked for while the
scenario has one where another project layout keeps goldens, fails its item in one line before
the scenario runs, and ``--snapshot-update`` writes nothing over it (:mod:`stackdsl.pytest_plugin.golden`).

A file's ``skip`` and ``xfail`` marks (:mod:`stackdsl.lang.schema_marks`) are pytest's, on the
file's own backend, mode and model: a skipped item is ``s`` at the line of its ``skip:``, an item
whose expectations fail under ``xfail`` is ``x``, one whose expectations hold and whose golden
matches is ``X`` (a failure when strict: ``[XPASS(strict)] reason``); the terminal summary says
their reasons without ``-r``.

A sweep file (``sweep:``) is one item too: its samples run one after the other, each
statistical expectation must be decided PASS in every grid cell (its 95% interval inside the
tolerance), and its golden snapshot holds every sample's collapse level, a line a cell.

As pytest-playwright keeps a screenshot of a failed test, ``--stackdsl-pictures
only-on-failure`` keeps what a person needs to look at a failed scenario: its picture at the
collapse (or the end), a clip, the brick-graph plot and the trajectory file, in a folder of
its own under ``--stackdsl-output`` (default ``test-results``), named in the failure message
(``on``: for every scenario; ``off``, the default: none, and nothing is recorded).

The ``golden`` fixture gives Python tests the same snapshots (JSON under ``golden/``,
floats rounded).

Source: stackdsl's own, after Tavern's pytest plugin and syrupy's single-file extensions.
"""

from __future__ import annotations

import json
import os
import re
import shlex
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any

import pytest

from ..batch.report import rerun_command
from ..compile.compiler import compile_scenario
from ..compile.program import Program
from ..draw.artefacts import draw_run, folder_name
from ..lang.errors import ScenarioError, one_line
from ..lang.loader import load_scenario
from ..lang.schema import Scenario
from ..lang.schema_marks import XFail
from ..runtime.outcome import Outcome
from ..runtime.recorder import record_program
from ..runtime.run import run_program
from ..runtime.trajectory import TrajectoryTooLarge
from ..verdicts.expect import evaluate, explain
from ..verdicts.golden_compare import Comparison, compare_golden, near_tie
from ..verdicts.snapshot import dumps, scenario_golden_path, summarize
from ..verdicts.snapshot import golden_dir as golden_dir
from ..verdicts.tolerances import Tolerances, tolerances_for
from .golden import BadGolden, golden_elsewhere, golden_problem, read_golden_text, where_goldens_go
from .hint import SUFFIXES, collection_hint, remember_collected, scenario_folders

try:
    from syrupy.assertion import SnapshotAssertion
    from syrupy.data import SnapshotCollection, SnapshotCollections
    from syrupy.extensions.json import JSONSnapshotExtension
    from syrupy.extensions.single_file import SingleFileSnapshotExtension, WriteMode
    from syrupy.terminal import disable_color
except ImportError:  # pragma: no cover - syrupy is a test extra
    JSONSnapshotExtension = SingleFileSnapshotExtension = SnapshotAssertion = None  # type: ignore[assignment,misc]

_rename = os.replace  # atomic within a folder (POSIX); a name of its own, so a test can fail it alone


def round_floats(data: Any, path: Any) -> Any:
    """syrupy matcher: floats to 6 decimals, so that last-bit noise never shows as a diff.

    Not a tolerance: stackdsl's snapshot data is rounded to 0.1 mm already.
    """
    return round(data, 6) + 0.0 if isinstance(data, float) else data


#: When scenario items keep their pictures (``--stackdsl-pictures``).
PICTURES = ("off", "only-on-failure", "on")


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addini(
        "stackdsl_paths",
        type="linelist",
        default=[],  # none named: DEFAULT_FOLDERS, and only the files that say they are stackdsl's
        help="folders (relative to the rootdir) whose *.yaml files are stackdsl scenario tests (default: scenarios, "
        "whose files with a top-level 'stackdsl:' key are)",
    )
    group = parser.getgroup("stackdsl", "stackdsl scenario files")
    if SnapshotAssertion is None:  # syrupy's option, so that the command the docs give says what to install
        group.addoption("--snapshot-update", action="store_true", help=f"(needs syrupy) {NEEDS_EXTRA}")
    group.addoption(
        "--stackdsl-pictures",
        choices=PICTURES,
        default="off",
        help="keep a scenario's picture, clip, brick-graph plot and trajectory: only-on-failure, on (every "
        "scenario) or off (default; nothing is recorded)",
    )
    group.addoption(
        "--stackdsl-output",
        default="test-results",
        metavar="DIR",
        help="folder for --stackdsl-pictures, relative to the rootdir (default: test-results)",
    )


def pytest_collect_file(file_path: Path, parent: pytest.Collector) -> pytest.Collector | None:
    """Collect a YAML file below one of the scenario folders: every one below folders the
    project names (``stackdsl_paths``), and below the default ``scenarios`` only those that
    say they are stackdsl's (a top-level ``stackdsl:`` key), so that a project which merely
    has stackdsl installed keeps its own YAML files out of its tests."""
    if file_path.suffix not in SUFFIXES:
        return None
    config = parent.config
    roots = [(config.rootpath / p).resolve() for p in scenario_folders(config)]
    here = file_path.resolve()
    if not any(here.is_relative_to(root) for root in roots):
        return None
    if not config.getini("stackdsl_paths") and not _declares_stackdsl(file_path):
        return None
    return ScenarioFile.from_parent(parent, path=file_path)


def _declares_stackdsl(path: Path) -> bool:
    """Whether the YAML file at ``path`` has a top-level ``stackdsl:`` key (a line starting
    so); False when it cannot be read as text."""
    try:
        text = path.read_text(encoding="utf-8-sig", errors="replace")
    except OSError:
        return False
    return any(line.startswith("stackdsl:") or line.startswith('"stackdsl":') for line in text.splitlines())


def golden_owners(golden: Path, folder: Path) -> list[Path] | None:
    """The files that may own a golden snapshot found below the goldens of the scenario folder
    ``folder``: the scenario file ``<folder>/<sub>/<stem>.yaml`` (or ``.yml``) of
    ``golden/<folder>/<sub>/<stem>.json``, then the Python test module ``<folder>/<sub>.py``
    whose ``golden`` fixture stores its snapshots in ``golden/<folder>/<sub>/``; None when
    ``golden`` is not below that folder's goldens."""
    folder = folder.resolve()
    stored = scenario_golden_path(folder / "x.yaml").parent
    try:
        relative = Path(golden).resolve().relative_to(stored)
    except ValueError:
        return None
    owners = [folder / relative.parent / f"{relative.stem}{suffix}" for suffix in SUFFIXES]
    if relative.parent != Path("."):
        owners += [folder / f"{relative.parent}{suffix}" for suffix in (".py", ".pyi")]
    return owners


def left_over(golden: Path, folder: Path) -> bool:
    """Whether a golden snapshot below the goldens of scenario folder ``folder`` has no file left
    that owns it (:func:`golden_owners`): its scenario file was removed or renamed. The only
    golden snapshots reported unused, and deleted by ``--snapshot-update``; a file not named
    ``*.json`` is no golden (a note, or a file where a folder of goldens goes) and never is."""
    owners = golden_owners(golden, folder)
    return Path(golden).suffix == ".json" and owners is not None and not any(owner.is_file() for owner in owners)


def orphan_goldens(config: pytest.Config) -> list[Path]:
    """Golden snapshots under ``golden/<configured folder>/`` whose scenario file is gone."""
    orphans = []
    for folder in scenario_folders(config):
        root = (config.rootpath / folder).resolve()
        stored = scenario_golden_path(root / "x.yaml").parent
        orphans += [g for g in sorted(stored.rglob("*.json")) if stored.is_dir() and left_over(g, root)]
    return orphans


#: How syrupy's diff names a golden that could not be read (its exception's first line).
_BAD_GOLDEN = f"{BadGolden.__module__}.{BadGolden.__qualname__}: "


@pytest.hookimpl(wrapper=True)
def pytest_assertrepr_compare(
    config: pytest.Config, op: str, left: Any, right: Any
) -> Generator[None, list[list[str] | None], list[list[str] | None]]:
    """A golden that could not be read (:class:`stackdsl.pytest_plugin.golden.BadGolden`: a FIFO, a
    folder, not UTF-8) fails its ``assert golden == ...`` in one line naming it and saying why,
    before syrupy's explanation (a traceback of the read), which pytest then leaves out; the
    snapshot still counts as used, so ``--snapshot-update`` never deletes it."""
    explanations = yield
    for side in (left, right):
        said = side.get_assert_diff() if SnapshotAssertion is not None and isinstance(side, SnapshotAssertion) else []
        if said and said[0].startswith(_BAD_GOLDEN):
            return [[said[0].removeprefix(_BAD_GOLDEN)], *explanations]
    return explanations


def pytest_collection_finish(session: pytest.Session) -> None:
    remember_collected(session)


def pytest_terminal_summary(terminalreporter: Any, config: pytest.Config) -> None:
    """Say how to collect scenario files given on the command line outside the configured
    folders (``pytest mine/`` collects nothing from ``mine/`` unless ``stackdsl_paths`` names
    it), and name golden snapshots left behind by scenario files that were removed or renamed."""
    ran = [
        (config.rootpath / nodeid.split("::", 1)[0]).resolve()
        for reports in terminalreporter.stats.values()
        for report in reports
        if (nodeid := getattr(report, "nodeid", ""))
    ]
    hint = collection_hint(config, ran)
    if hint:
        terminalreporter.section("stackdsl: scenario files not collected", yellow=True)
        for line in hint:
            terminalreporter.line(line)
    ties = [
        value
        for reports in terminalreporter.stats.values()
        for report in reports
        for name, value in getattr(report, "user_properties", ())
        if name == NEAR_TIE and getattr(report, "when", "call") == "call"
    ]
    if ties:
        terminalreporter.section("stackdsl: golden snapshots written on a near tie", yellow=True)
        for line in ties:
            terminalreporter.line(line)
        terminalreporter.line("a near tie may flip on another machine: `stackdsl check --perturb 4 FILE` says whether it holds")
    marked = _marked_lines(terminalreporter)
    if marked:
        terminalreporter.section("stackdsl: scenarios skipped or expected to fail, and why", yellow=True)
        for line in marked:
            terminalreporter.line(line)
    orphans = orphan_goldens(config)
    if orphans:
        terminalreporter.section("stackdsl: golden snapshots with no scenario file", yellow=True)
        for golden in orphans:
            terminalreporter.line(f"{_shown(golden, config)} (its scenario file is gone: delete it or restore the file)")


def _marked_lines(terminalreporter: Any) -> list[str]:
    """The reason of each scenario item skipped, xfailed or xpassed by its file's marks, a line
    each as pytest's ``-rs``/``-rx``/``-rX`` say them (``SKIPPED scenarios/t.yaml:3: why``,
    ``XFAIL scenarios/t.yaml::t - why``), so that the default output says why without ``-r``;
    none of a kind pytest's own ``-r`` shows already."""
    shown = getattr(terminalreporter, "reportchars", "")
    lines = []
    for kind, char in (("skipped", "s"), ("xfailed", "x"), ("xpassed", "X")):
        if char in shown:
            continue
        for report in terminalreporter.stats.get(kind, []):
            nodeid = getattr(report, "nodeid", "")
            if Path(nodeid.split("::", 1)[0]).suffix not in SUFFIXES:
                continue  # not a scenario item: pytest's own reporting, unchanged
            if kind == "skipped" and not hasattr(report, "wasxfail") and isinstance(report.longrepr, tuple):
                where, line, reason = report.longrepr
                where = _relative(Path(where), terminalreporter.startpath)
                lines.append(f"SKIPPED {where}:{line}: {reason.removeprefix('Skipped: ')}")
            elif hasattr(report, "wasxfail"):
                lines.append(f"{'XFAIL' if kind == 'xfailed' else 'XPASS'} {nodeid} - {report.wasxfail}")
    return lines


class ScenarioFile(pytest.File):
    """A scenario file: one test item, named after the file."""

    def collect(self) -> Iterator[pytest.Item]:
        if SnapshotAssertion is None:  # no syrupy: its golden cannot be compared
            yield NeedsExtra.from_parent(self, name=self.path.stem)
            return
        item = ScenarioItem.from_parent(self, name=self.path.stem, callobj=_scenario_test)
        item.extra_keyword_matches.update(_keywords(self.path, Path(self.config.rootpath)))
        yield item


#: Characters of a scenario file read for its ``name:`` at collection (a name lies near the top).
NAME_READ = 65536


def _keywords(path: Path, root: Path) -> set[str]:
    """What ``-k`` matches of a scenario item besides pytest's own names: its path from pytest's
    rootdir, ``/`` and all (``-k scenarios/tower``), and the scenario's top-level ``name:``
    (``-k tips`` of "my overhang that tips"), as ``stackdsl check -k`` matches them. The name is
    read from the file's first lines as text, not parsed: collecting must not wait on a file
    that a run would refuse."""
    words = {Path(_relative(path, root)).as_posix()}
    try:
        with open(path, encoding="utf-8", errors="replace") as file:
            head = file.read(NAME_READ)
    except OSError:
        return words
    found = re.search(r"^name:[ \t]*(.+?)[ \t]*$", head, re.MULTILINE)
    if found is not None:
        words.add(found.group(1).strip("'\""))
    return words


#: What a scenario item says when syrupy, which compares its golden snapshot, is not installed.
NEEDS_EXTRA = "scenario files as pytest items need the [pytest] extra (syrupy): pip install 'stackdsl[pytest]'"


class NeedsExtra(pytest.Item):
    """A scenario file's item when syrupy is missing: it fails with :data:`NEEDS_EXTRA`, one
    line, where pytest would say "fixture 'snapshot' not found" with its fixture list."""

    def runtest(self) -> None:
        pytest.fail(NEEDS_EXTRA, pytrace=False)

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"scenario {self.path.name}"


class ScenarioItem(pytest.Function):
    """The test item of one scenario file: a function item (so that fixtures, syrupy and
    pytest's flags work as on any test) reported under the scenario file's name."""

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, 0, f"scenario {self.path.name}"


def _scenario_test(request: pytest.FixtureRequest, scenario_golden: Any) -> None:
    """Run one scenario file: expectations first, then the golden snapshot.

    An item that fails before its golden is compared (a bad file, a failed expectation, a
    crash) still marks its golden as this run's, compared but never written
    (:func:`_keep_golden`): otherwise syrupy would count it unused, and ``--snapshot-update``
    would delete the reviewed snapshot of a scenario that still exists. A skipped item's golden
    is not compared at all (syrupy would count it failed): it is kept as every golden whose
    scenario file exists is (:meth:`ScenarioSnapshotExtension.discover_snapshots`)."""
    skipped = False
    try:
        _run_scenario_item(request, scenario_golden)
    except pytest.skip.Exception:
        skipped = True
        raise
    finally:
        if not scenario_golden.num_executions and not skipped:
            _keep_golden(scenario_golden, Path(request.node.path), _NOT_COMPARED)


def _run_scenario_item(request: pytest.FixtureRequest, scenario_golden: Any) -> None:
    # pytest's item.path is absolute: the file opens from any working directory, and every
    # file the messages name is as the user can type it from where pytest was run
    path = Path(request.node.path)
    config = request.config
    shown = _shown(path, config)
    scenario, program, xfail = _compiled_item(request, path, shown)
    stored = scenario_golden_path(path)
    unusable = _unusable_golden(path, stored, config)
    if unusable:  # before anything runs, and before syrupy reads, compares or writes it
        pytest.fail(f"{shown}: {unusable}", pytrace=False)
    error = ""
    try:
        scenario_golden.extension.tolerances = tolerances_for(program, scenario, _pyproject(config))
    except ScenarioError as exc:
        error = str(exc)
    if error:  # a project's tolerances refused: said as a bad file is
        pytest.fail(error, pytrace=False)
    scenario_golden.extension.toppled = scenario.expect.toppled is not None
    scenario_golden.extension.may_fall = scenario.expect.may_fall or ()
    if scenario.sweep is not None:
        _sweep_test(request, scenario, program, shown, scenario_golden, xfail)
        return
    pictures = config.getoption("stackdsl_pictures")
    trajectory, too_large = None, ""
    if pictures == "off":
        outcome = run_program(program)
    else:
        try:
            outcome, trajectory = record_program(program, source=str(path))
        except TrajectoryTooLarge as exc:  # judged from a run without a recorder; its pictures said lost
            outcome, too_large = run_program(program), f"pictures: not drawn: {exc}"
    lines = _failure_lines(request, (scenario, program, xfail), outcome, scenario_golden, path)
    if too_large and (lines or pictures == "on"):
        lines.append(too_large)
    if not lines and _written(scenario_golden) and (tie := near_tie(outcome, program)):
        # a property of the item's report: said by the terminal summary, also of an xdist worker's item
        request.node.user_properties.append((NEAR_TIE, f"{_shown(stored, config)}: {tie}"))
    if trajectory is not None and (lines or pictures == "on"):
        kept = _keep_pictures(trajectory, path, config)
        if lines or kept.startswith(CANNOT_KEEP):  # a failure: say where to look; pictures asked for and lost: fail
            lines.append(kept)
    if lines:
        pytest.fail("\n".join(lines), pytrace=False)
    _expect_failure(request, xfail)  # every expectation held and the golden matched: XPASS


def _compiled_item(request: pytest.FixtureRequest, path: Path, shown: str) -> tuple[Scenario, Program, XFail | None]:
    """The item's scenario, read and compiled, and its ``xfail`` mark when it holds on the file's
    own backend, mode and model (else None); a bad file fails the item in its one message, and a
    ``skip`` mark that holds skips it before compiling (at the line of its ``skip:``)."""
    try:
        scenario = load_scenario(path, shown=shown)
    except ScenarioError as exc:
        error = str(exc)  # failed outside the handler: no "during handling" chain in the report
    else:
        error = ""
    if error:
        pytest.fail(error, pytrace=False)
    run = (scenario.engine.backend, scenario.engine.mode, scenario.stability.model)
    if scenario.skip is not None and scenario.skip.applies(*run):  # before compiling, as pytest's skip before setup
        request.node.stash[_SKIP_LINE] = scenario.source.keys.get(("skip",), (0, 0))[0] + 1
        pytest.skip(scenario.skip.reason)
    xfail = scenario.xfail if scenario.xfail is not None and scenario.xfail.applies(*run) else None
    try:
        program = compile_scenario(scenario)
    except ScenarioError as exc:
        error = str(exc)
    if error:
        pytest.fail(error, pytrace=False)
    return scenario, program, xfail


def _failure_lines(
    request: pytest.FixtureRequest,
    compiled: tuple[Scenario, Program, XFail | None],
    outcome: Outcome,
    scenario_golden: Any,
    path: Path,
) -> list[str]:
    """Why the item fails, a line each (none: it passes): its failed expectations where the file
    writes them, why, how to rerun it, and the golden kept (then XFAIL when ``compiled``'s xfail
    mark expects it); or no golden yet; or the outcome's difference from its golden."""
    scenario, program, xfail = compiled
    config = request.config
    shown = _shown(path, config)
    verdicts = evaluate(scenario.expect, outcome, program.collapse_threshold)
    failed = [v for v in verdicts if not v.passed]
    if failed:
        lines = [line if v.at else f"{shown}: {line}" for v in failed for line in v.lines()]
        lines += [f"  {line}" for line in explain(scenario.expect, outcome, program.collapse_threshold)]
        lines.append(f"more: {rerun_command('run', shown)}")
        lines += _kept_golden(request, scenario_golden, path, outcome.golden())
        _expect_failure(request, xfail)  # the expectations failed: XFAIL, when the file expects it
        return lines
    if missing := _no_golden_yet(request, path, shown):
        return [missing]
    if not scenario_golden == outcome.golden():
        with disable_color():  # plain text: the message also goes to JUnit XML and CI logs
            diff = scenario_golden.get_assert_diff()
        stored = _shown(scenario_golden_path(path), config)
        return [f"{shown}: the outcome differs from {stored} beyond its tolerances", *diff, UPDATE_HINT]
    return []


def _expect_failure(request: pytest.FixtureRequest, xfail: Any) -> None:
    """Put the file's ``xfail`` mark (when it holds on this run) on the item, as pytest's
    ``request.applymarker`` does in a test: pytest then reports a failure after it as XFAIL
    (``x``) and the item's end as XPASS (``X``, a failure when strict: pytest's
    ``[XPASS(strict)] reason``), in the terminal and in JUnit XML alike. Put on only where the
    expectations were judged, so that a bad golden, a missing golden or a crash fails as
    any item does. ``strict`` not given: pytest's ``strict_xfail`` setting."""
    if xfail is None:
        return
    strict = {} if xfail.strict is None else {"strict": xfail.strict}
    request.applymarker(pytest.mark.xfail(reason=xfail.reason, **strict))


#: The line of a skipped scenario's ``skip:`` key, which its report names (as pytest names a skip mark's test).
_SKIP_LINE = pytest.StashKey[int]()


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: Any) -> Generator[None, Any, Any]:
    """A scenario skipped by its file's ``skip`` mark is reported at that file and line
    (``SKIPPED [1] scenarios/t.yaml:3: why``), not at the line of this plugin that skipped it."""
    report = yield
    line = item.stash.get(_SKIP_LINE, None)
    if line is not None and report.skipped and isinstance(report.longrepr, tuple) and not hasattr(report, "wasxfail"):
        report.longrepr = (str(item.path), line, report.longrepr[2])
    return report


def _sweep_test(
    request: pytest.FixtureRequest, scenario: Any, program: Any, shown: str, scenario_golden: Any, xfail: Any = None
) -> None:
    """A sweep's item: every sample here, one after the other; each statistical expectation must
    be decided PASS in every grid cell; the golden snapshot holds every sample's collapse level,
    one line a cell (sample k of a cell is the same run on any machine). With the file's
    ``xfail`` mark, a statistic not decided PASS is XFAIL, and all PASS with the golden matched XPASS."""
    from ..batch.sweep import SweepOptions, collect, run_sweep
    from ..batch.sweep_out import by_cell, failure_lines, verdicts

    path = Path(request.node.path)
    template = scenario.template
    results = collect(
        run_sweep(
            template, SweepOptions(program.engine.mode, program.stability.model, False, None, program.engine.backend), jobs=1
        )
    )
    refused = [r for r in results if r.bad_input or r.error]
    if refused:
        pytest.fail(refused[0].bad_input or f"{refused[0].error} (sample {refused[0].sample})", pytrace=False)
    golden = {"scenario": program.name, "mode": program.engine.mode, "samples": template.samples}
    for c, rs in enumerate(by_cell(results, template.cells)):
        golden[f"cell {c}"] = {"grid": template.cell(c), "collapse_levels": [r.collapse_level for r in rs]}
    lines = failure_lines(template, scenario.expect, verdicts(template, scenario.expect, results), f"{shown}: ")
    if lines:
        lines.append(f"more: {rerun_command('sweep', shown)}")
        kept = _kept_golden(request, scenario_golden, path, golden)
        _expect_failure(request, xfail)
        pytest.fail("\n".join([*lines, *kept]), pytrace=False)
    if missing := _no_golden_yet(request, path, shown):
        pytest.fail(missing, pytrace=False)
    if not scenario_golden == golden:
        with disable_color():
            diff = scenario_golden.get_assert_diff()
        where = _shown(scenario_golden_path(path), request.config)
        pytest.fail("\n".join([f"{shown}: the samples differ from {where}", *diff, UPDATE_HINT]), pytrace=False)
    _expect_failure(request, xfail)


def _pyproject(config: pytest.Config) -> Path:
    """The project's ``pyproject.toml``: pytest's ini file when it is one, else the rootdir's."""
    inipath = config.inipath
    if inipath is not None and inipath.name == "pyproject.toml":
        return Path(inipath)
    return Path(config.rootpath) / "pyproject.toml"


def _written(scenario_golden: Any) -> bool:
    """The golden snapshot was written (made or replaced) by this comparison."""
    results = getattr(scenario_golden, "executions", {})
    return any(r.created or r.updated for r in results.values())


#: The report property of an item whose golden was written on a near tie (said in the terminal summary).
NEAR_TIE = "stackdsl_near_tie"


def _unusable_golden(path: Path, stored: Path, config: pytest.Config) -> str:
    """Why a scenario's golden ``stored`` cannot be compared or written, in one line: it is
    damaged (:func:`stackdsl.pytest_plugin.golden.golden_problem`: never replaced, not even by
    ``--snapshot-update``), or there is none while one for the scenario sits where another
    project layout stores goldens (:func:`stackdsl.pytest_plugin.golden.golden_elsewhere`: to be moved,
    not written anew beside it); ``""`` when it can."""

    def show(p: Path) -> str:
        return _shown(p, config)

    problem = golden_problem(stored, show)
    if problem or os.path.lexists(stored):
        return problem
    found = golden_elsewhere(path, stored.name, stored)
    if found is None:
        return ""
    return (
        f"no golden at {show(stored)}, but {show(found)} is one for this scenario ({where_goldens_go(path, show)}): "
        f"move it to {show(stored)}"
    )


#: What a failed item's golden is compared with when the item has no outcome (a bad file, a crash):
#: never a snapshot, so the comparison fails and nothing is written.
_NOT_COMPARED: dict[str, Any] = {"not compared": "the item failed before its golden snapshot was compared"}


def _keep_golden(scenario_golden: Any, path: Path, data: Any) -> None:
    """Compare a failed item's stored golden with ``data`` with every update switched off, when
    the golden exists: syrupy then counts it used (matched or failed), never unused, so
    ``--snapshot-update`` neither deletes it nor rewrites it with a failing run's outcome."""
    stored = scenario_golden_path(path)
    if not stored.is_file() or golden_problem(stored):
        return  # nothing to keep (or nothing to read); and a failing run writes no new golden either
    scenario_golden.update_snapshots = False
    scenario_golden.update_new_snapshots_only = False
    _ = scenario_golden == data  # recorded by syrupy (used); its result is not the item's verdict


def _kept_golden(request: pytest.FixtureRequest, scenario_golden: Any, path: Path, data: Any) -> list[str]:
    """Keep a failed item's golden (:func:`_keep_golden`); under ``--snapshot-update``, the line
    that says it was left as it was."""
    _keep_golden(scenario_golden, path, data)
    stored = scenario_golden_path(path)
    if not stored.is_file() or not getattr(request.config.option, "update_snapshots", False):
        return []
    return [f"{_shown(stored, request.config)} left as it was: a golden is written only when the expectations hold"]


#: The last line of a failed golden comparison.
UPDATE_HINT = "if the change is meant: rerun with --snapshot-update, and say in the commit why the new snapshot is right"


def _no_golden_yet(request: pytest.FixtureRequest, path: Path, shown: str) -> str:
    """The failure of an item whose scenario has no golden snapshot yet (and the run is not
    writing them: ``--snapshot-update`` or ``--snapshot-update-new-only``), naming the command
    that writes it (this run's, with ``--snapshot-update``: its ``-o stackdsl_paths`` kept);
    ``""`` when it has one or one is being written."""
    option = request.config.option
    stored = scenario_golden_path(path)
    if stored.is_file() or getattr(option, "update_snapshots", False) or getattr(option, "update_new_snapshots_only", False):
        return ""
    where = _shown(stored, request.config)
    again = shlex.join(["pytest", *request.config.invocation_params.args, "--snapshot-update"])  # as it was run
    return f"{shown}: no golden yet ({where}): run with --snapshot-update to write it ({again})"


#: How :func:`_keep_pictures` starts its line when nothing could be written.
CANNOT_KEEP = "pictures: cannot write them to"


def _keep_pictures(trajectory: Any, path: Path, config: pytest.Config) -> str:
    """Draw a run into ``--stackdsl-output``/<its folder> (named after the scenario's path from
    the rootdir); one line saying where (or what failed)."""
    output = Path(config.rootpath) / config.getoption("stackdsl_output")
    folder = output / folder_name(_relative(path, config.rootpath))
    try:
        written, failure, _ = draw_run(trajectory, folder)
    except OSError as exc:  # the output folder cannot be made or written: say so in the failure
        return f"{CANNOT_KEEP} {one_line(str(config.getoption('stackdsl_output')))}: {exc.strerror or exc}"
    where = _shown(folder, config)
    return f"pictures: {where}/ ({', '.join(written.values())})" + (f"; {failure}" if failure else "")


def _shown(path: Path, config: pytest.Config) -> str:
    """``path`` as the user can type it where pytest was run (relative to that folder, as pytest
    names test files in its report)."""
    return _relative(path, config.invocation_params.dir)


def _relative(path: Path, root: Path) -> str:
    try:
        return os.path.relpath(path, root)
    except ValueError:  # another drive
        return str(path)


if SingleFileSnapshotExtension is not None:

    class _AtomicWrites(SingleFileSnapshotExtension):
        """Golden files written whole or not at all: to a hidden temporary file beside the
        golden file, flushed to disk, then renamed over it (a rename within a folder is atomic
        on POSIX), so an update interrupted even by SIGKILL leaves the old file or the new one,
        never a truncated one."""

        def read_snapshot_data_from_location(self, *, snapshot_location: str, snapshot_name: str, session_id: str) -> Any:
            """The stored text (None: no golden yet), never blocking on a FIFO; a golden that
            cannot be read (:func:`stackdsl.pytest_plugin.golden.read_golden_text`) fails the comparison
            with one line saying why, and is not written over."""
            return read_golden_text(Path(snapshot_location))

        @classmethod
        def write_snapshot_collection(cls, *, snapshot_collection: Any, name_order: Any = None) -> None:
            final = Path(snapshot_collection.location)
            final.parent.mkdir(parents=True, exist_ok=True)
            temporary = final.with_name(f".{final.name}.{os.getpid()}.tmp")  # not *.json: never taken for a snapshot
            staged = SnapshotCollection(location=str(temporary))
            for snapshot in snapshot_collection:
                staged.add(snapshot)
            try:
                super().write_snapshot_collection(snapshot_collection=staged, name_order=name_order)
                with open(temporary, "rb+") as written:
                    os.fsync(written.fileno())
                _rename(temporary, final)
            finally:
                temporary.unlink(missing_ok=True)

    def _summarized(serialized_data: Any, snapshot_data: Any) -> Iterator[str]:
        """What changed, by key (:func:`stackdsl.verdicts.snapshot.summarize`), before the diff."""
        summary = summarize(str(snapshot_data), str(serialized_data))
        if summary:
            yield "what changed (stored -> this run):"
            yield from (f"  {line}" for line in summary)
            yield "the snapshot's diff:"

    class GoldenSnapshotExtension(_AtomicWrites, JSONSnapshotExtension):
        """syrupy JSON snapshots of Python tests: ``golden/<test file's folder>/<test file's
        stem>/<test name>.json``, so that tests of the same name in two files never share one; a
        failing comparison starts with what changed, by key, as a scenario's does."""

        def diff_lines(self, serialized_data: Any, snapshot_data: Any) -> Iterator[str]:
            yield from _summarized(serialized_data, snapshot_data)
            yield from super().diff_lines(serialized_data, snapshot_data)

        @classmethod
        def dirname(cls, *, test_location: Any) -> str:
            return str(scenario_golden_path(test_location.filepath).with_suffix(""))

        def discover_snapshots(self, *, test_location: Any, ignore_extensions: Any = None) -> Any:
            """syrupy's discovery, less the golden snapshots of scenario files that exist (the
            scenario items' own, never this extension's to count unused)."""
            found = super().discover_snapshots(test_location=test_location, ignore_extensions=ignore_extensions)
            folder = Path(test_location.filepath).parent
            kept = SnapshotCollections()
            for collection in found:
                owners = golden_owners(Path(collection.location), folder) or []
                if not any(owner.is_file() for owner in owners if owner.suffix in SUFFIXES):
                    kept.add(collection)
            return kept

    class ScenarioSnapshotExtension(_AtomicWrites):
        """A scenario's golden snapshot: ``golden/<folder>/<file stem>.json``, mirroring the
        scenario's place below the project root, written one brick per line
        (:func:`stackdsl.verdicts.snapshot.dumps`), and compared as a physicist would
        (:func:`stackdsl.verdicts.golden_compare.compare_golden`): verdict fields exactly,
        measured ones within :attr:`tolerances`, what chaos decides loosely. A failing comparison
        lists what is outside its tolerance, worst first; ``--snapshot-update`` rewrites a golden
        only then (within tolerance it matches, and is kept as it is)."""

        file_extension = "json"
        _write_mode = WriteMode.TEXT
        #: What the item compares with (:func:`stackdsl.verdicts.tolerances.tolerances_for`).
        tolerances: Tolerances = Tolerances()
        #: The scene expects a number of toppled bricks: that count is a verdict field.
        toppled: bool = False
        #: The levels and bricks the scene says may fall (``expect: may_fall``).
        may_fall: tuple[int | str, ...] = ()

        def _compared(self, serialized_data: Any, snapshot_data: Any) -> Comparison | None:
            """Both texts as snapshots, compared; None when either is not a JSON object (a
            sweep's golden is compared key by key, exactly, as a snapshot with no graph)."""
            try:
                new, old = json.loads(str(serialized_data)), json.loads(str(snapshot_data))
            except (TypeError, ValueError, RecursionError):
                return None
            if not isinstance(new, dict) or not isinstance(old, dict):
                return None
            return compare_golden(old, new, self.tolerances, toppled=self.toppled, may_fall=self.may_fall)

        def matches(self, *, serialized_data: Any, snapshot_data: Any) -> bool:
            compared = self._compared(serialized_data, snapshot_data)
            if compared is None:
                return bool(serialized_data == snapshot_data)
            return compared.matches

        @classmethod
        def discovery_dirname(cls, *, test_location: Any) -> str:
            # the scenario goldens of the folder, never the shared golden/ above it (syrupy looks
            # one level up when the folder is named as the file, ``stairs/stairs.yaml``)
            return cls.dirname(test_location=test_location)

        def discover_snapshots(self, *, test_location: Any, ignore_extensions: Any = None) -> Any:
            """The golden snapshots below this scenario's golden folder that syrupy may count unused:
            only those whose scenario file is gone (:func:`left_over`). A golden whose scenario file
            exists is never unused, whatever happened to its item (failed before its comparison,
            not run after ``-x``, ignored), so ``--snapshot-update`` never deletes it."""
            found = super().discover_snapshots(test_location=test_location, ignore_extensions=ignore_extensions)
            folder = Path(test_location.filepath).parent
            kept = SnapshotCollections()
            for collection in found:
                if left_over(Path(collection.location), folder):
                    kept.add(collection)
            return kept

        @classmethod
        def dirname(cls, *, test_location: Any) -> str:
            return str(scenario_golden_path(test_location.filepath).parent)

        @classmethod
        def get_snapshot_name(cls, *, test_location: Any, index: Any = 0) -> str:
            return Path(test_location.filepath).stem

        def serialize(self, data: Any, **kwargs: Any) -> str:
            return dumps(data) + "\n"

        def diff_lines(self, serialized_data: Any, snapshot_data: Any) -> Iterator[str]:
            compared = self._compared(serialized_data, snapshot_data)
            if compared is None:
                yield from _summarized(serialized_data, snapshot_data)
                yield from super().diff_lines(serialized_data, snapshot_data)
                return
            yield "outside tolerance, worst first (stored -> this run):"
            yield from (f"  {line}" for line in compared.lines())
            yield f"tolerances: {compared.tolerances.described()}"
            yield from compared.not_failures()


if SnapshotAssertion is None:

    @pytest.fixture
    def snapshot() -> Any:
        """Without syrupy: the ``golden`` fixture fails with one line naming the extra, where
        pytest would say "fixture 'snapshot' not found"."""
        pytest.fail(NEEDS_EXTRA.replace("scenario files as pytest items need", "golden snapshots need"), pytrace=False)


@pytest.fixture
def golden(snapshot: Any, request: pytest.FixtureRequest) -> Any:
    """A syrupy snapshot assertion that stores JSON under ``golden/`` with floats rounded:
    ``assert golden == data`` (``data``: plain JSON values, e.g. ``outcome.golden()``);
    ``pytest --snapshot-update`` writes it."""
    if JSONSnapshotExtension is None:  # pragma: no cover
        pytest.fail("the golden fixture needs syrupy: pip install 'stackdsl[pytest]'")
    source = Path(request.node.path)
    stored = scenario_golden_path(source).with_suffix("")  # the test file's folder of goldens
    found = None if os.path.lexists(stored) else golden_elsewhere(source, stored.name, stored)
    if found is not None:

        def show(p: Path) -> str:
            return _shown(p, request.config)

        pytest.fail(
            f"{show(source)}: no goldens at {show(stored)}/, but {show(found)}/ holds this test file's "
            f"({where_goldens_go(source, show)}): move that folder to {show(stored)}/",
            pytrace=False,
        )
    return snapshot.with_defaults(extension_class=GoldenSnapshotExtension, matcher=round_floats)


@pytest.fixture
def scenario_golden(snapshot: Any) -> Any:
    """The snapshot assertion of a scenario file's test item (see the module docstring)."""
    if SingleFileSnapshotExtension is None:  # pragma: no cover
        pytest.fail("scenario snapshots need syrupy: pip install 'stackdsl[pytest]'")
    return snapshot.with_defaults(extension_class=ScenarioSnapshotExtension)
