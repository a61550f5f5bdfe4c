"""``stackdsl bench``: speed against error, and its sub-benchmarks solve, height, hard, limits, record, sweep, verdicts,
freeze, dominoes and startup.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from ..bench.actions import AS_WRITTEN
from ..bench.actions import SIDES as ACTION_SIDES
from ..bench.bench import DEFAULT_SETTINGS, SETTINGS, TIMING, UPRIGHT, run_matrix, savings, scenes
from ..bench.dominoes import DEFAULT as DOMINO_SETTINGS
from ..bench.dominoes import KNOWN as DOMINO_KNOWN
from ..lang.bounds import MAX_LEVELS
from ..lang.errors import ScenarioError
from ..util.extras import installed, missing
from ..verdicts.expect import describe
from .args import COMMANDS, OK, jobs_type, output_folder
from .progress import Lines

if TYPE_CHECKING:
    from ..bench.verdicts import Plan

#: The most bricks ``bench solve`` takes a tower of: a 4 stack (two bricks a level) of the most levels a tower has.
MAX_SOLVE_BRICKS = 2 * MAX_LEVELS


class _Elsewhere(argparse.Action):
    """An option of another ``bench`` command, given here: a usage error (exit 2) that names the
    option this command takes instead, where argparse would read its value as a subcommand's name.
    Hidden from the help. Source: stackdsl's own."""

    def __init__(self, option_strings: list[str], dest: str, instead: str = "", **kwargs: Any) -> None:
        super().__init__(option_strings, dest, help=argparse.SUPPRESS, **kwargs)
        self.instead = instead

    def __call__(
        self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any, option_string: str | None = None
    ) -> None:
        parser.error(f"{option_string} is not an option of this command: {self.instead}")


_SIDES_ELSEWHERE = (
    "`stackdsl bench actions` and `stackdsl bench folder` take --sides; this table takes --settings, of: " + ", ".join(SETTINGS)
)
_SETTINGS_ELSEWHERE = "the speed-against-error table (`stackdsl bench`) takes --settings; this command takes --sides, of: "


def add_bench(sub: Any, parents: list[argparse.ArgumentParser], epilog: str, modes: list[str]) -> None:
    """Add ``bench`` and its sub-benchmarks to the ``stackdsl`` parser's subcommands."""
    raw = argparse.RawDescriptionHelpFormatter
    p = sub.add_parser(
        "bench",
        parents=parents,
        help=COMMANDS["bench"],
        description="Speed against error: every engine setting on the same scenes. "
        "`stackdsl bench --out docs/bench` regenerates the committed figures.",
        epilog=epilog,
        formatter_class=raw,
    )
    p.add_argument(
        "--out",
        default=None,
        help="folder for bench.csv, bench.md and the plots (default: a new private folder stackdsl-bench-* in the temporary "
        "directory); before another benchmark's name, its tables go there as bench-NAME.txt",
    )
    p.add_argument(
        "--settings",
        default=",".join(DEFAULT_SETTINGS),
        help="comma-separated, of: " + ", ".join(SETTINGS) + " (default: all but MuJoCo lean 1e-4)",
    )
    p.add_argument("--sides", action=_Elsewhere, instead=_SIDES_ELSEWHERE)
    p.add_argument("--families", default="slant log cabin,single file,upright", help="comma-separated scene families")
    p.add_argument(
        "--upright", default=",".join(map(str, UPRIGHT)), help="comma-separated heights of the upright towers, in levels"
    )
    p.add_argument("--repeats", type=int, default=3, help="runs per cell, every cell alike (median; default: 3)")
    p.add_argument(
        "--repeat-below",
        type=float,
        default=float("inf"),
        help="seconds; a cell whose first run is slower runs once (default: inf, every cell runs --repeats times)",
    )
    p.add_argument(
        "--after-collapse",
        type=float,
        default=0.0,
        metavar="SECONDS",
        help="how long a run goes on once its collapse is decided, every setting alike, the lean peers too "
        "(default: 0, it ends there; 2 also times the falling debris, as a run of stackdsl's settles)",
    )
    p.add_argument("--quick", action="store_true", help="one small cell per setting (a smoke test)")
    p.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="1",
        help="worker processes (default: 1, for steady timings: two cells at once on two cores slow each other unevenly)",
    )
    p.set_defaults(func=_bench)
    bench = p.add_subparsers(
        metavar="[solve | height | hard | limits | record | sweep | verdicts | freeze | dominoes | actions | folder | pulls "
        "| startup]",
        title="other benchmarks (optional)",
    )
    q = bench.add_parser("solve", help="equilibrium solve time for towers of 10 to 100 bricks")
    q.add_argument("--sizes", default="10,25,50,100", help="bricks per tower, comma-separated")
    q.add_argument("--repeats", type=int, default=5)
    q.set_defaults(func=_bench_solve)
    q = bench.add_parser(
        "height",
        help="upright towers of 10 to 200 levels per stability model: wall time per brick, ratios, exponent, profile",
    )
    q.add_argument("--levels", default="10,20,30,60,100,200", help="tower heights, comma-separated")
    q.add_argument(
        "--settings",
        default="extension report,extension equilibrium",
        help="comma-separated, of: " + ", ".join(SETTINGS) + " (ratios are to the first)",
    )
    q.add_argument("--repeats", type=int, default=5, help="runs per cell under 30 s (median; default: 5)")
    q.add_argument(
        "--no-profile",
        action="store_true",
        help="skip the sampled profiles of the 30-level and the tallest tower (they need the profile extra)",
    )
    q.add_argument("-j", "--jobs", type=jobs_type, default="1", help="worker processes (default: 1, for steady timings)")
    q.set_defaults(func=_bench_height)
    q = bench.add_parser(
        "hard", help="the hard cases in extension and raw mode, a brick thrown at a wall, the leaning limits swept"
    )
    q.add_argument("folder", nargs="?", default="scenarios/hard")
    q.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="auto",
        help="runs at the same time (default: auto, one per free core: the cores less the tasks other processes run now)",
    )
    q.set_defaults(func=_bench_hard)
    q = bench.add_parser("record", help="what recording costs: the 30-level tower with recording off and on, alternately")
    q.add_argument("scenario", nargs="?", default="scenarios/four_stack.yaml")
    q.add_argument("--repeats", type=int, default=7, help="runs of each setting (default: 7)")
    q.add_argument("--mode", choices=modes, help="override the scenario's engine mode")
    q.add_argument(
        "--before",
        metavar="PYTHON",
        help="also time the check in another stackdsl's Python (e.g. the virtualenv of an older commit) and in this one, "
        "alternately, and print the ratio",
    )
    q.add_argument("--rounds", type=int, default=None, help="with --before: alternating rounds of --repeats runs (default: 10)")
    q.set_defaults(func=_bench_record)
    q = bench.add_parser(
        "sweep",
        help="samples a second of a random 10-level single-file stack (or of FILE's sweep): 1 process, 2, "
        "a 2-worker Dask LocalCluster",
    )
    q.add_argument("file", nargs="?", metavar="FILE", help="a sweep file (default: a random 10-level single-file stack)")
    q.add_argument(
        "--samples", type=int, default=None, help="samples a grid cell on each executor (default: 1000, or FILE's own)"
    )
    q.add_argument(
        "--no-loaded",
        dest="loaded",
        action="store_false",
        help="leave out the second table: -j 1 against -j auto with one core kept busy (a minute's spin-up)",
    )
    q.set_defaults(func=_bench_sweep)
    q = bench.add_parser(
        "verdicts",
        help="each setting's collapse verdicts on random assemblies against rigid-block equilibrium, on both engines "
        "and at several drop gaps; random single-file stacks against the exact centre-of-mass rule",
    )
    q.add_argument(
        "--families",
        default="assemblies,single-file",
        help="comma-separated, of: assemblies, single-file, near-tie (single-file stacks and two-brick overhangs 0 to 1 mm "
        "from their tipping edge), shake (a block on a shake table at 0.8 to 1.2 of its closed-form threshold) "
        "(default: assemblies,single-file)",
    )
    q.add_argument("--count", type=int, default=1000, help="assemblies (default: 1000; 0: none)")
    q.add_argument("--seed", type=int, default=1, help="assembly k is drawn from SeedSequence(seed, spawn_key=(k,))")
    q.add_argument("--engines", default="pybullet,mujoco", help="comma-separated, of: pybullet, mujoco (default: both)")
    q.add_argument(
        "--gaps", default="0,0.5,1,2", help="drop gaps of the extension settings, mm, comma-separated (default: 0,0.5,1,2)"
    )
    q.add_argument("--no-baselines", action="store_true", help="leave out raw and tuned (run the extension settings only)")
    q.add_argument(
        "--single-file",
        type=int,
        default=1000,
        metavar="N",
        help="random single-file stacks run in the extension settings against the exact rule (default: 1000; 0: none)",
    )
    q.add_argument(
        "--near-tie",
        type=int,
        default=1600,
        metavar="N",
        help="near-tie samples, a quarter in each margin band 0-0.1, 0.1-0.2, 0.2-0.5 and 0.5-1 mm (default: 1600)",
    )
    q.add_argument(
        "--shakes",
        type=int,
        default=20,
        metavar="N",
        help="shake samples in each of the 11 (block, frequency) cells (default: 20)",
    )
    q.add_argument(
        "-j",
        "--jobs",
        type=jobs_type,
        default="auto",
        help="worker processes (default: auto, one per free core: the cores less the tasks other processes run now)",
    )
    q.add_argument(
        "--out",
        help="folder for the journal of finished assemblies (a run given the same folder again resumes) and the "
        "misjudged assemblies' files, and each family's table and samples (default: a new temporary folder)",
    )
    q.set_defaults(func=_bench_verdicts)
    q = bench.add_parser("freeze", help="the ways to freeze a brick on MuJoCo: weld, its own sleeping, a held mocap body")
    q.add_argument("--levels", default="10,30,60", help="tower heights, comma-separated")
    q.set_defaults(func=_bench_freeze)
    q = bench.add_parser(
        "dominoes", help="a row of dominoes pushed over: the engine alone, MuJoCo with its own sleeping, the extension"
    )
    q.add_argument("--count", type=int, default=30, help="dominoes in the row (2 to 500; default: 30)")
    q.add_argument("--settings", default=",".join(DOMINO_SETTINGS), help="comma-separated, of: " + ", ".join(DOMINO_KNOWN))
    q.add_argument("--repeats", type=int, default=1, help="timed runs of each setting (median; default: 1)")
    q.set_defaults(func=_bench_dominoes)
    q = bench.add_parser(
        "actions",
        help="Jenga pulls, domino rows pushed over, shake tables: the extension on both engines, raw pybullet and the "
        "lean MuJoCo peer driving the same hands, every cell timed alike and judged against its scene's expectations",
    )
    q.add_argument("--scenes", default=None, help="comma-separated scene names (default: all; see the table)")
    q.add_argument("--sides", default=",".join(ACTION_SIDES), help="comma-separated, of: " + ", ".join(ACTION_SIDES))
    q.add_argument("--settings", action=_Elsewhere, instead=_SETTINGS_ELSEWHERE + ", ".join(ACTION_SIDES))
    q.add_argument(
        "--repeats", type=int, default=None, help="runs per cell, each in a fresh process (median; default: 3, with --quick 1)"
    )
    q.add_argument("--quick", action="store_true", help="tiny scenes, one run a cell (a smoke test)")
    q.add_argument("-j", "--jobs", type=jobs_type, default="1", help="worker processes (default: 1, for steady timings)")
    q.set_defaults(func=_bench_actions)
    q = bench.add_parser(
        "folder",
        help="`stackdsl check FOLDER` wall time with -j 1 and -j auto, then each scenario on its own settings "
        "against the lean MuJoCo peer",
    )
    q.add_argument("folder", nargs="?", default="scenarios", help="a folder of scenario files (default: scenarios)")
    q.add_argument("--repeats", type=int, default=3, help="runs of each check and each cell (median; default: 3)")
    q.add_argument("--no-cells", action="store_true", help="time the folder's check only")
    q.add_argument(
        "--sides",
        default=f"{AS_WRITTEN},MuJoCo lean",
        help=f"comma-separated, each scenario run on each (default: {AS_WRITTEN!r} and the lean MuJoCo peer), of: "
        + ", ".join([AS_WRITTEN, *ACTION_SIDES]),
    )
    q.add_argument("--settings", action=_Elsewhere, instead=_SETTINGS_ELSEWHERE + ", ".join([AS_WRITTEN, *ACTION_SIDES]))
    q.set_defaults(func=_bench_folder)
    q = bench.add_parser(
        "pulls", help="the sweep of Jenga pulls: samples a second, the extension against the lean MuJoCo peer, same draws"
    )
    q.add_argument("file", nargs="?", default="sweeps/jenga_pulls.yaml")
    q.add_argument("--samples", type=int, default=None, help="samples a grid cell (default: the file's own, sweep.samples)")
    q.add_argument(
        "--cells", type=int, default=None, help="run the first N grid cells only (default: every cell of the file's grid)"
    )
    q.add_argument("-j", "--jobs", type=jobs_type, default="1", help="worker processes a side (default: 1)")
    q.set_defaults(func=_bench_pulls)
    q = bench.add_parser(
        "limits", help="each engine's own limits measured past them: smallest side, fastest throw, mass ratio, restitution"
    )
    q.add_argument("--backend", default=None, help="pybullet or mujoco (default: every installed engine)")
    q.set_defaults(func=_bench_limits)
    q = bench.add_parser("startup", help="how long stackdsl takes to start: --version, import, a one-file check")
    q.add_argument("--repeats", type=int, default=5, help="runs of each command (median; default: 5)")
    q.set_defaults(func=_bench_startup)
    for name, parser in bench.choices.items():
        if name != "verdicts":  # its own --out: a journal and every family's files
            parser.set_defaults(func=_written(name, parser.get_default("func")))
            # `stackdsl bench NAME ... --out DIR` as well as `stackdsl bench --out DIR NAME ...`
            parser.add_argument("--out", default=argparse.SUPPRESS, help="as `stackdsl bench --out`: its tables go there")


def _written(name: str, func: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """The sub-benchmark ``func`` (``stackdsl bench NAME``), whose tables also go into the folder
    of ``--out`` when it is given (``stackdsl bench --out DIR NAME``), as ``bench-NAME.txt``."""

    def run(args: argparse.Namespace) -> int:
        if args.out is None:
            return func(args)
        path = _out_folder(args.out, "stackdsl-bench-") / f"bench-{name}.txt"
        with open(path, "w", encoding="utf-8") as file, contextlib.redirect_stdout(_Tee(sys.stdout, file)):
            status = func(args)
        print(f"wrote {path.resolve()}")
        return status

    return run


class _Tee(io.TextIOBase):
    """A text stream that writes to each of ``streams``."""

    def __init__(self, *streams: IO[str]) -> None:
        self._streams = streams

    def write(self, text: str) -> int:
        for stream in self._streams:
            stream.write(text)
        return len(text)

    def flush(self) -> None:
        for stream in self._streams:
            stream.flush()


def _need(extra: str, where: str) -> None:
    """Nothing when ``extra`` (a key of :data:`stackdsl.util.extras.EXTRAS`) is installed.

    Raises:
        ScenarioError: it is not; one line at ``where`` (the option or command that asks for it)
            naming the pip install that adds it, before anything runs.
    """
    if not installed(extra):
        raise ScenarioError(missing(extra), file=where)


def _need_engines(settings: list[str]) -> None:
    """Nothing when every engine the named :data:`SETTINGS` use is installed.

    Raises:
        ScenarioError: a MuJoCo setting without MuJoCo, at ``--settings``.
    """
    for name in settings:
        _need_backend(SETTINGS[name].backend, "--settings")


def _need_backend(name: str, where: str) -> None:
    """Nothing when engine ``name`` is known and installed, or is not known (the bench's own
    check says so).

    Raises:
        ScenarioError: an engine whose optional extra is not installed, at ``where``.
    """
    from ..engines.registry import backend, names

    extra = backend(name).extra if name in names() else None
    if extra is not None:
        _need(extra, where)


def _names(text: str, option: str, known: list[str], what: str) -> list[str]:
    """The comma-separated names of ``option``, each one of ``known``.

    Raises:
        ScenarioError: at ``option``: none given (only commas and spaces), or one unknown.
    """
    names = list(dict.fromkeys(x.strip() for x in text.split(",") if x.strip()))
    unknown = [x for x in names if x not in known]
    if unknown:
        raise ScenarioError(f"unknown {what} {', '.join(map(repr, unknown))}; known: {', '.join(known)}", file=option)
    if not names:
        raise ScenarioError(f"give at least one {what}, comma-separated, of: {', '.join(known)}", file=option)
    return names


def _at_least_one(value: int, option: str = "--repeats") -> None:
    """Refuse a count of runs below 1 (nothing would be timed: no median)."""
    if value < 1:
        raise ScenarioError(f"runs to take the median of: at least 1, not {value}", file=option)


def _out_folder(given: str | None, prefix: str) -> Path:
    """The folder a benchmark writes into (:func:`output_folder`), made and checked before
    anything runs: a file there, or a folder that cannot be made or written in, is bad input."""
    out = output_folder(given, prefix)
    if out.exists() and not out.is_dir():
        raise ScenarioError("this is a file, not a folder: give a folder for the benchmark's files", file=str(out))
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):  # a folder that takes no file (read-only, /proc)
            pass
    except OSError as exc:
        raise ScenarioError(f"cannot write in this folder: {exc.strerror or exc}", file=str(out)) from None
    return out


def _bench(args: argparse.Namespace) -> int:
    from ..bench.out import write_outputs
    from ..bench.versions import version_line

    settings = _names(args.settings, "--settings", list(SETTINGS), "setting")
    if not 0.0 <= args.after_collapse <= 600.0:
        raise ScenarioError(f"seconds from 0 to 600, not {args.after_collapse!r}", file="--after-collapse")
    _at_least_one(args.repeats)
    if not args.repeat_below >= 0.0:  # NaN too
        raise ScenarioError(f"seconds, 0 or more (inf: every cell repeated), not {args.repeat_below!r}", file="--repeat-below")
    _need_engines(settings)
    try:
        heights = [int(x) for x in args.upright.split(",") if x.strip()]
    except ValueError:
        raise ScenarioError(f"whole numbers of levels, not {args.upright!r}", file="--upright") from None
    if any(not 1 <= h <= 1000 for h in heights):
        raise ScenarioError("each height from 1 to 1000 levels", file="--upright")
    known = list(dict.fromkeys(sc.family for sc in scenes(False, UPRIGHT)))
    families = set(_names(args.families, "--families", known, "scene family"))
    chosen = [sc for sc in scenes(args.quick, heights) if sc.family in families or args.quick]
    if not chosen:
        raise ScenarioError("no scene to run: the upright family is chosen alone, and no height is given", file="--upright")
    out = _out_folder(args.out, "stackdsl-bench-")
    start = time.perf_counter()
    total = len(chosen) * len(settings)
    print(version_line())
    print(f"stackdsl bench: {len(chosen)} scenes x {len(settings)} settings, {args.jobs} workers, writing to {out}", flush=True)
    repeats = 1 if args.quick else args.repeats  # a smoke test: one round
    below = (
        "" if args.repeat_below == float("inf") else f"; a cell whose first run takes {args.repeat_below:g} s or more runs once"
    )
    timing = TIMING.format(repeats=repeats, below=below)
    print(timing, flush=True)
    with Lines(total, "bench") as lines:
        count = 0

        def progress(c: Any) -> None:
            nonlocal count
            count += 1
            lines.line(
                f"  [{count}/{total}] {c.setting:<22} {c.family:<16} {c.parameter:>5g}: {describe(c.collapse_level)} "
                f"(closed form: {describe(c.closed_form)}), {c.wall:.2f} s"
            )
            lines.advance()

        cells = run_matrix(settings, chosen, repeats, args.repeat_below, args.jobs, progress, args.after_collapse)
    saved = [] if args.quick else savings(args.repeats)
    targets = write_outputs(cells, saved, out)
    print((out / "bench.md").read_text())
    print(timing)
    for line in _targets(targets):
        print(line)
    print(
        f"wrote {out.resolve()}: bench.csv, bench.md, wall_vs_error.png, wall_vs_height.png "
        f"({time.perf_counter() - start:.0f} s wall)"
    )
    return OK


def _targets(targets: dict[str, Any]) -> list[str]:
    """The benchmark's targets as lines: slant errors per setting, the 30-level speed-up, the
    extension against the peer, exponents."""
    lines = [
        f"slant error, {s}: " + ", ".join(f"{e:+g}" for e in errors) + " levels" for s, errors in targets["slant errors"].items()
    ]
    ratio = targets.get("30-level speed-up, raw 240 Hz / extension")
    if ratio:
        lines.append(f"30-level 4 stack: raw 240 Hz takes {ratio:.0f} times the extension's wall time")
    for r in targets.get("peer", []):
        for levels, (x, e, p) in r.upright.items():
            lines.append(
                f"{levels}-level 4 stack: {r.peer} takes {x:.1f} times {r.extension}'s wall time (errors {e:+d}, {p:+d})"
            )
        if r.slant_least is not None:
            lines.append(
                f"slant scenes: {r.peer} takes at least {r.slant_least:.1f} times {r.extension}'s wall time "
                f"(geometric mean {r.slant_mean:.1f})"
            )
    lines += [f"exponent of wall time in bricks, {s}: {x:.2f}" for s, x in targets["exponents"].items()]
    return lines or ["(no slant scene and fewer than two upright towers: no target measured)"]


def _bench_solve(args: argparse.Namespace) -> int:
    from ..bench.cost import format_solve_times, solve_times

    try:
        sizes = tuple(int(x) for x in args.sizes.split(",") if x.strip())
    except ValueError:
        raise ScenarioError(f"whole numbers of bricks, comma-separated, not {args.sizes!r}", file="--sizes") from None
    if not sizes or not all(1 <= n <= MAX_SOLVE_BRICKS for n in sizes):
        raise ScenarioError(
            f"bricks per tower from 1 to {MAX_SOLVE_BRICKS} (a 4 stack of {MAX_LEVELS} levels), not {args.sizes!r}",
            file="--sizes",
        )
    _at_least_one(args.repeats)
    print(format_solve_times(solve_times(sizes, args.repeats)))
    return OK


def _bench_height(args: argparse.Namespace) -> int:
    from ..bench.cost import format_heights, format_profiles, measure_heights, profile_tower
    from ..bench.versions import version_line

    levels = _height_levels(args.levels)
    settings = [s.strip() for s in args.settings.split(",") if s.strip()]
    unknown = [s for s in settings if s not in SETTINGS]
    if unknown or not settings:
        raise ScenarioError(f"unknown setting {unknown[0] if unknown else ''!r}; known: {', '.join(SETTINGS)}", file="--settings")
    _need_engines(settings)
    if args.repeats < 1:
        raise ScenarioError(f"--repeats must be at least 1, not {args.repeats}", file="--repeats")
    if not args.no_profile and not installed("profile"):
        raise ScenarioError(missing("profile", "the profile") + " (or --no-profile)", file="bench height")
    print(version_line(), flush=True)
    with Lines(len(levels) * len(settings), "towers") as progress:
        cells = measure_heights(settings, levels, args.repeats, args.jobs, lambda c: progress.advance())
    print(format_heights(cells, settings), flush=True)
    if not args.no_profile:
        print()
        heights = sorted({min(30, max(levels)), max(levels)})
        profiled = [s for s in settings if not SETTINGS[s].lean]  # a lean peer runs outside stackdsl's loop
        if profiled:
            print(format_profiles([profile_tower(s, n) for n in heights for s in profiled]))
    return OK


def _height_levels(text: str) -> list[int]:
    """``bench height --levels``: the tower heights, from ``"10,30,100"``.

    Raises:
        ScenarioError: not whole numbers separated by commas, none, or one outside 1..1000.
    """
    try:
        levels = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ScenarioError(f"--levels must be whole numbers separated by commas, not {text!r}", file="--levels") from None
    if not levels or not all(1 <= n <= 1000 for n in levels):
        raise ScenarioError(f"--levels must be from 1 to 1000, not {text!r}", file="--levels")
    return levels


def _bench_hard(args: argparse.Namespace) -> int:
    from ..bench.hard import format_hard, format_limits, format_wall, leaning_limits, thrown_at_wall
    from ..bench.versions import version_line

    start = time.perf_counter()
    print(version_line(), flush=True)
    print(format_hard(args.folder, args.jobs), end="\n\n", flush=True)
    print(format_wall(thrown_at_wall()), end="\n\n", flush=True)
    print(format_limits(leaning_limits()), end="\n\n")
    print(f"({time.perf_counter() - start:.0f} s wall)")
    return OK


def _bench_record(args: argparse.Namespace) -> int:
    from ..bench.record import format_record_costs, record_costs

    if args.repeats < 1:
        raise ScenarioError(f"--repeats must be at least 1, not {args.repeats}", file="--repeats")
    if args.rounds is not None and not args.before:
        raise ScenarioError("--rounds is the comparison's: give --before PYTHON too", file="--rounds")
    if args.before:
        from ..bench.record import check_interpreter

        problem = check_interpreter(args.before)
        if problem:
            raise ScenarioError(problem, file=args.before)
    from ..bench.versions import version_line

    print(version_line(), flush=True)
    print(format_record_costs(record_costs(args.scenario, args.repeats, args.mode), args.scenario), flush=True)
    if args.before:
        from ..bench.record import before_and_after, format_before_and_after

        args.rounds = 10 if args.rounds is None else args.rounds
        if args.rounds < 1:
            raise ScenarioError(f"--rounds must be at least 1, not {args.rounds}", file="--rounds")
        times = before_and_after(args.before, args.scenario, args.rounds, args.repeats)
        print(format_before_and_after(times, args.before, args.scenario))
    return OK


def _bench_sweep(args: argparse.Namespace) -> int:
    from ..bench.sweep import HEADER, SPIN_UP, Throughput, footer, format_row, loaded, template, throughputs, title, wall_text

    if args.samples is not None and not 1 <= args.samples <= 100_000:
        raise ScenarioError(f"--samples must be from 1 to 100000, not {args.samples}", file="--samples")
    from ..bench.versions import version_line

    _need("dask", "stackdsl bench sweep")  # its last row is a Dask cluster
    t = template(args.samples if args.samples or args.file else 1000, args.file)
    print(version_line(), title(t), HEADER, sep="\n", flush=True)
    rows: list[Throughput] = []

    def each(row: Throughput) -> None:
        rows.append(row)
        print(format_row(row, rows[0]), flush=True)

    _, same = throughputs(t, each)
    print(footer(same))
    if args.loaded:
        print(f"\nthe same samples with one core kept busy (a spinning process, {SPIN_UP:.0f} s before):", flush=True)
        busy, load = loaded(
            t, lambda row: print(f"{row.executor:<32} {wall_text(row.seconds):>7} s {row.rate:>10.1f}", flush=True)
        )
        print(f"1-minute load average at the start: {load:.2f}; -j auto / -j 1 wall: {busy[1].seconds / busy[0].seconds:.2f}")
    return OK


def _bench_limits(args: argparse.Namespace) -> int:
    from ..bench.limits import format_report
    from ..bench.versions import version_line
    from ..engines.registry import backend, names
    from ..util.extras import installed

    moving = [b for b in names() if backend(b).dynamics]  # a static backend has no limits of motion
    if args.backend is not None and args.backend not in moving:
        raise ScenarioError(f"unknown backend {args.backend!r}; known: {', '.join(moving)}", file="--backend")
    if args.backend is not None:
        _need_backend(args.backend, f"stackdsl bench limits --backend {args.backend}")
    backends = (
        [args.backend] if args.backend else [b for b in moving if backend(b).extra is None or installed(str(backend(b).extra))]
    )
    start = time.perf_counter()
    print(version_line(), flush=True)
    print(format_report(backends), end="\n\n")
    print(f"({time.perf_counter() - start:.0f} s wall)")
    return OK


def _bench_freeze(args: argparse.Namespace) -> int:
    from ..bench.freeze import MEANS, format_freeze, freeze_cost
    from ..bench.versions import version_line

    try:
        levels = [int(v) for v in args.levels.split(",")]
    except ValueError:
        raise ScenarioError("give whole numbers of levels, comma-separated", file="--levels") from None
    if not levels or min(levels) < 2 or max(levels) > 200:
        raise ScenarioError("levels are from 2 to 200", file="--levels")
    _need("mujoco", "stackdsl bench freeze")
    print(version_line(), flush=True)
    costs = []
    for n in levels:
        for means in MEANS:
            costs.append(freeze_cost(n, means))
            print(f"{n} levels, {means}: {costs[-1].us_per_step:.1f} us a step", flush=True)
    print(format_freeze(costs))
    return OK


def _bench_dominoes(args: argparse.Namespace) -> int:
    from ..bench.dominoes import KNOWN, domino_cost, format_dominoes
    from ..bench.versions import version_line

    if not 2 <= args.count <= 500:
        raise ScenarioError("a row has 2 to 500 dominoes", file="--count")
    if not 1 <= args.repeats <= 100:
        raise ScenarioError("repeats are from 1 to 100", file="--repeats")
    settings = [x.strip() for x in args.settings.split(",") if x.strip()]
    unknown = [x for x in settings if x not in KNOWN or KNOWN[x].lean]
    if unknown or not settings:
        known = ", ".join(n for n, s in KNOWN.items() if not s.lean)
        raise ScenarioError(f"unknown setting {unknown[0] if unknown else ''!r}; known: {known}", file="--settings")
    for name in settings:
        _need_backend(KNOWN[name].backend, "--settings")
    print(version_line(), flush=True)
    costs = []
    for setting in settings:
        costs.append(domino_cost(args.count, setting, args.repeats))
        c = costs[-1]
        print(f"{setting}: {c.toppled} of {c.count} toppled, {c.wall:.2f} s", flush=True)
    print(format_dominoes(costs))
    return OK


def _bench_verdicts(args: argparse.Namespace) -> int:
    from ..bench.verdicts import FAMILIES, family_settings, plan
    from ..bench.versions import version_line

    chosen = _verdict_families(args, _names(args.families, "--families", list(FAMILIES), "family"))
    if args.seed < 0:
        raise ScenarioError(f"--seed must be 0 or more, not {args.seed}", file="--seed")
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    try:
        runs = plan(engines, _gaps(args.gaps), baselines=not args.no_baselines)
    except ValueError as exc:
        raise ScenarioError(str(exc), file="--engines") from None
    for name in engines:
        _need_backend(name, "--engines")
    out = _out_folder(args.out, "stackdsl-verdicts-")
    print(version_line(), flush=True)
    printed = False

    def show(text: str, name: str | None = None) -> None:
        nonlocal printed
        print("\n" * printed + text, flush=True)
        printed = True
        if name is not None:
            (out / name).write_text(text + "\n", encoding="utf-8")

    if "assemblies" in chosen:
        show(_assemblies(args, out, runs))
    samples: list[Any] = []
    if "single-file" in chosen:
        from ..bench.verdicts import format_single_file, run_single_file

        extension = family_settings(engines, baselines=False)
        start = time.perf_counter()
        with Lines(args.single_file, "single-file stacks") as progress:
            samples = run_single_file(args.seed, args.single_file, args.jobs, extension, lambda b: progress.advance(len(b)))
        show(format_single_file(samples, extension, time.perf_counter() - start))
    settings = family_settings(engines, baselines=not args.no_baselines)
    if "near-tie" in chosen:
        from ..bench.near_tie import format_near_ties, run_near_ties

        start = time.perf_counter()
        with Lines(args.near_tie, "near-tie samples") as progress:
            ties = run_near_ties(args.seed, args.near_tie, args.jobs, settings, lambda b: progress.advance(len(b)))
        _write_samples(out / "near_tie.jsonl", ties)
        show(format_near_ties(ties, settings, time.perf_counter() - start, samples, out), "near_tie.txt")
    if "shake" in chosen:
        from ..bench.shake_family import CELLS, format_shakes, run_shakes

        start = time.perf_counter()
        with Lines(args.shakes * len(CELLS), "shake samples") as progress:
            shaken = run_shakes(args.seed, args.shakes, args.jobs, settings, lambda b: progress.advance(len(b)))
        _write_samples(out / "shake.jsonl", shaken)
        show(format_shakes(shaken, settings, time.perf_counter() - start), "shake.txt")
    if any(f in chosen for f in ("near-tie", "shake")):
        print(f"(the tables and every sample are in {out})")
    return OK


def _verdict_families(args: argparse.Namespace, families: list[str]) -> list[str]:
    """The ``families`` ``bench verdicts`` runs: those whose size option is above 0.

    Raises:
        ScenarioError: a size outside 0..100000, or none above 0.
    """
    sizes = {"assemblies": args.count, "single-file": args.single_file, "near-tie": args.near_tie, "shake": args.shakes}
    options = {"assemblies": "--count", "single-file": "--single-file", "near-tie": "--near-tie", "shake": "--shakes"}
    for family, size in sizes.items():
        if not 0 <= size <= 100_000:
            raise ScenarioError(f"{options[family]} must be from 0 to 100000, not {size}", file=options[family])
    chosen = [f for f in families if sizes[f]]
    if not chosen:
        raise ScenarioError(
            "nothing to run: give " + " or ".join(f"{options[f]} above 0" for f in families), file=options[families[0]]
        )
    return chosen


def _gaps(text: str) -> list[float]:
    """``bench verdicts --gaps``: the gaps (m) from millimetres separated by commas.

    Raises:
        ScenarioError: not numbers, none, or one outside 0..3 mm.
    """
    try:
        gaps = [float(g) / 1000 for g in text.split(",") if g.strip()]
    except ValueError:
        raise ScenarioError(f"--gaps must be millimetres separated by commas, not {text!r}", file="--gaps") from None
    if not gaps or not all(0 <= g <= 0.003 for g in gaps):
        raise ScenarioError(f"--gaps must be from 0 to 3 mm (below the collapse threshold), not {text!r}", file="--gaps")
    return gaps


def _assemblies(args: argparse.Namespace, out: Path, runs: Plan) -> str:
    """The assemblies family of ``bench verdicts``: ``args.count`` assemblies run as ``runs``
    plans, resumed from the journal in ``out`` and written to it as each ends; its table.

    Raises:
        ScenarioError: the journal is of another seed or plan, or damaged.
    """
    from ..bench.verdicts import JOURNAL, Journal, Verdicts, format_verdicts, timed

    journal = Journal(out / JOURNAL, args.seed, runs)
    try:
        done = journal.load()
    except ValueError as exc:
        raise ScenarioError(str(exc), file=str(journal.path)) from None
    if done:
        print(f"resuming: {sum(k < args.count for k in done)} of {args.count} assemblies done in {journal.path}")

    def finished(v: Verdicts) -> None:
        journal.add(v)
        progress.advance()

    with Lines(args.count - sum(k < args.count for k in done), "assemblies") as progress:
        results, seconds = timed(args.seed, args.count, args.jobs, finished, runs, done)
    return format_verdicts(results, out, seconds, runs)


def _write_samples(path: Path, samples: list[Any]) -> None:
    """One JSON line per sample (a dataclass, its runs included)."""
    import dataclasses
    import json

    with path.open("w", encoding="utf-8") as f:
        for sample in samples:
            f.write(json.dumps(dataclasses.asdict(sample)) + "\n")


def _bench_startup(args: argparse.Namespace) -> int:
    from ..bench.startup import bytecode_note, format_startup, imported_sources, measure
    from ..bench.versions import version_line
    from . import check  # what a one-file check imports, whose bytecode the note looks at

    if not 1 <= args.repeats <= 100:
        raise ScenarioError(f"--repeats must be from 1 to 100, not {args.repeats}", file="--repeats")
    print(version_line(), flush=True)
    print(format_startup(measure(args.repeats)))
    note = bytecode_note(imported_sources(check))
    if note is not None:
        print(note)
    return OK


def _bench_actions(args: argparse.Namespace) -> int:
    from ..bench.actions import action_scenes, format_cells, run_cells, tiny_scenes
    from ..bench.versions import version_line

    if args.repeats is None:  # a smoke test: one round, unless asked for more
        args.repeats = 1 if args.quick else 3
    _at_least_one(args.repeats)
    sides = _names(args.sides, "--sides", list(ACTION_SIDES), "side")
    for side in sides:
        _need_backend(ACTION_SIDES[side].backend or "pybullet", "--sides")
    try:
        family = tiny_scenes() if args.quick else action_scenes()
    except OSError as exc:
        raise ScenarioError(
            f"run it from the project's folder: {exc.strerror or exc}", file=str(exc.filename or "scenarios")
        ) from None
    if args.scenes is not None:
        names = _names(args.scenes, "--scenes", [s.name for s in family], "scene")
        family = [next(s for s in family if s.name == name) for name in names]  # in the order given
    print(version_line(), flush=True)
    print(_load_line(), flush=True)
    with Lines(len(family) * len(sides) * args.repeats, "runs") as progress:
        cells = run_cells(family, sides, args.repeats, args.jobs, lambda r: progress.advance())
    print(format_cells(cells, args.repeats))
    print(_load_line())
    return OK


def _bench_folder(args: argparse.Namespace) -> int:
    from ..bench.actions import check_times, folder_scenes, format_cells, format_check_times, run_cells
    from ..bench.versions import version_line

    _at_least_one(args.repeats)
    sides = _names(args.sides, "--sides", [AS_WRITTEN, *ACTION_SIDES], "side")
    for side in sides if not args.no_cells else ():
        if side in ACTION_SIDES:  # an engine whose extra is missing: said before anything runs
            _need_backend(ACTION_SIDES[side].backend or "pybullet", "--sides")
    folder = Path(args.folder)
    scenes = folder_scenes(folder)
    print(version_line(), flush=True)
    print(_load_line(), flush=True)
    print(format_check_times(check_times(folder, ("1", "auto"), args.repeats), folder, len(scenes)), flush=True)
    if not args.no_cells:
        print(flush=True)
        with Lines(len(scenes) * len(sides) * args.repeats, "runs") as progress:
            cells = run_cells(scenes, sides, args.repeats, 1, lambda r: progress.advance())
        print(format_cells(cells, args.repeats))
        ran = [c for c in cells if c.side == sides[0]]
        print(f"\nthe {len(ran)} scenarios one after the other on {sides[0]}: {sum(c.wall for c in ran):.1f} s of runs (medians)")
    print(_load_line())
    return OK


def _bench_pulls(args: argparse.Namespace) -> int:
    from ..bench.pulls import format_sides, run_sides, template
    from ..bench.versions import version_line

    if args.samples is not None and not 1 <= args.samples <= 100_000:
        raise ScenarioError(f"--samples must be from 1 to 100000, not {args.samples}", file="--samples")
    if args.cells is not None and args.cells < 1:
        raise ScenarioError(f"--cells must be at least 1, not {args.cells}", file="--cells")
    _need("mujoco", "stackdsl bench pulls")
    t, expect = template(Path(args.file), args.samples)
    print(version_line(), flush=True)
    print(_load_line(), flush=True)
    print(format_sides(run_sides(t, args.jobs, cells=args.cells), t, expect, args.jobs, args.cells))
    print(_load_line())
    return OK


def _load_line() -> str:
    """The machine's load averages and cores, for a table's reader."""
    import os

    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f}, {five:.2f}, {fifteen:.2f} on {os.cpu_count()} cores"
