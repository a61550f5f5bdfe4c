"""The drawing commands of ``stackdsl``: render, animate, graph.

Each draws from a trajectory: a scenario file (``.yaml``) is run with a recorder first; a
trajectory file (``.npz``, from ``stackdsl run FILE --record PATH``) is read as it is.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..lang.errors import ScenarioError
from ..util.extras import installed, missing
from .args import COMMANDS, at_type, fps_type, rate_type

if TYPE_CHECKING:
    from ..compile.program import Program

#: Suffixes of trajectory files and of scenario files: what the drawing commands read.
TRAJECTORY_SUFFIXES = (".npz",)
SCENARIO_SUFFIXES = (".yaml", ".yml")
#: Pixels a side of a picture or a clip, at least and at most (a picture keeps a title strip).
MIN_SIDE, MAX_SIDE = 64, 4096
#: Pixels a picture may have: render peaked at 2047 MiB at 4096 x 4096 (16.8 million: the z-buffer's
#: layers and each face's pixel arrays), about 125 bytes a pixel; 8 million keeps it under 1.5 GB.
MAX_PIXELS = 8_000_000


#: The drawing commands, in the order of ``stackdsl --help``.
NAMES = ("render", "animate", "graph")


def add_commands(sub: Any, parents: list[argparse.ArgumentParser], epilog: str, names: tuple[str, ...] = NAMES) -> None:
    """Add ``names`` (of render, animate and graph) to the ``stackdsl`` parser's subcommands;
    ``parents`` give --debug, --timeout, --mode and --model."""
    for name in names:
        _ADD[name](sub, parents, epilog)


_SOURCE = "FILE: a scenario (run and recorded first) or a trajectory file (.npz) from 'stackdsl run FILE --record PATH'."


def _add_render(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "render",
        parents=parents,
        help=COMMANDS["render"],
        description="Draw the scene at one moment as a PNG, framed on the structure, bricks coloured by state "
        "(frozen, active, woken, fallen), with the ground, fixed bodies and a scale bar. " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--at",
        type=at_type,
        default=None,
        metavar="collapse|end|SECONDS",
        help="when: just after the first collapse, when its bricks are seen falling; the end; or a time in seconds "
        "(default: what the scenario's expectations judge: the end for toppled, stays and moved alone, else the "
        "collapse if the structure collapsed, else the end)",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT.png", help="the picture to write")
    p.add_argument(
        "--size",
        default="800x600",
        metavar="WxH",
        help=f"pixels, {MIN_SIDE} to {MAX_SIDE} a side, {MAX_PIXELS / 1e6:g} million at most (default: 800x600)",
    )
    p.set_defaults(func=_render)


def _add_animate(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "animate",
        parents=parents,
        help=COMMANDS["animate"],
        description="A clip of the run from the first placement to the end (2 s after a collapse), in real time "
        "while anything moves, the quiet waits between placements shortened. " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT.gif|OUT.mp4", help="the clip to write")
    p.add_argument(
        "--fps", type=fps_type, default=30.0, help="frames a second of the clip, 1 to 120 (a GIF: at most 50; default: 30)"
    )
    p.add_argument(
        "--size",
        default="480x360",
        metavar="WxH",
        help=f"pixels, {MIN_SIDE} to {MAX_SIDE} a side, {MAX_PIXELS / 1e6:g} million at most (default: 480x360)",
    )
    p.set_defaults(func=_animate)


def _add_graph(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "graph",
        parents=parents,
        help=COMMANDS["graph"],
        description="Plot the brick graph as a PNG: who rests on whom with the share of the load each support "
        "takes, and each brick's centre of mass above against its support polygon. " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--at",
        choices=["collapse", "end"],
        default=None,
        help="the graph at the first collapse or at the end (default: what the scenario's expectations judge: the end "
        "for toppled, stays and moved alone, else the collapse if the structure collapsed, else the end)",
    )
    p.add_argument("-o", "--output", required=True, metavar="OUT.png", help="the plot to write")
    p.set_defaults(func=_graph)


_ADD = {"render": _add_render, "animate": _add_animate, "graph": _add_graph}


#: The recorder's frames a simulated second by default (``stackdsl.runtime.recorder.RATE``),
#: written here so that ``run --help`` loads no runtime; a test keeps the two equal.
RATE = 30.0


def add_record_options(p: argparse.ArgumentParser) -> None:
    """``run``'s --record and --rate."""
    p.add_argument(
        "--record",
        metavar="OUT.npz",
        help="also write the trajectory: every brick's pose and state at each placement and event, and every "
        "1/RATE s while anything moves (read it with stackdsl.load_trajectory)",
    )
    p.add_argument(
        "--rate",
        type=rate_type,
        default=None,
        metavar="HZ",
        help=f"frames a simulated second while anything moves (default: {RATE:g}; at most one a physics step)",
    )


def trajectory_of(args: argparse.Namespace, verb: str) -> Any:
    """The trajectory ``args.file`` names, for the command ``verb``: :func:`recorded`'s."""
    return recorded(args, verb)[1]


def recorded(args: argparse.Namespace, verb: str) -> tuple[Program | None, Any]:
    """The compiled scenario and the trajectory ``args.file`` names: a trajectory file read (no
    Program), or a scenario run and recorded (with ``args.mode``, ``args.model``,
    ``args.backend``, ``args.seed``, ``args.timeout``; of a random file, the sample
    ``args.sample`` of cell ``args.cell``, as the command ``verb`` says on stderr).

    Raises:
        ScenarioError: a bad scenario, or a file that is not a trajectory, or a run whose recording
            passes what a trajectory file may hold.
    """
    from ..compile.compiler import compile_scenario
    from ..runtime.recorder import record_program
    from ..runtime.trajectory import TrajectoryTooLarge, load_trajectory
    from .sample import scenario_of

    path = Path(args.file)
    if path.suffix.lower() not in TRAJECTORY_SUFFIXES + SCENARIO_SUFFIXES:
        raise ScenarioError(
            "give a scenario (.yaml, .yml) or a trajectory file (.npz) from 'stackdsl run FILE --record'", file=args.file
        )
    if path.suffix.lower() in TRAJECTORY_SUFFIXES:
        if any(getattr(args, o, None) is not None for o in ("mode", "model", "backend", "seed", "sample", "cell")):
            raise ScenarioError(
                "--mode, --model and --backend apply to a scenario, not to a recorded trajectory, and so do --seed, "
                "--sample and --cell",
                file=args.file,
            )
        try:
            return None, load_trajectory(path)
        except OSError as exc:  # said as the OS says it: 'No such file or directory', not '[Errno 2] ...'
            raise ScenarioError(exc.strerror or str(exc), file=args.file) from None
        except ValueError as exc:
            raise ScenarioError(str(exc).removeprefix(f"{path}: "), file=args.file) from None
    scenario = scenario_of(args, verb)
    program = compile_scenario(scenario, args.mode, args.model, args.backend, draw_time=args.timeout)
    at = getattr(args, "at", None)
    if isinstance(at, float) and at > program.duration:  # refused before anything is simulated
        raise ScenarioError(f"t = {at:g} s is outside the run, which lasts from 0 to {program.duration:g} s", file="--at")
    # a frame at the moment asked for, so that what is drawn or exported is the run's state then
    try:
        _, trajectory = record_program(program, source=args.file, timeout=args.timeout, at=(at,) if isinstance(at, float) else ())
    except TrajectoryTooLarge as exc:  # as a trajectory file of that size would be refused
        raise ScenarioError(f"{exc}: too large to {verb}", file=args.file) from None
    return program, trajectory


def when(shown: float, asked: float, step: object = None, digits: int = 3) -> str:
    """``t = 8.021 s``, the time of the frame shown (to ``digits`` decimals); when it is not the time
    asked for, to the millisecond, and which frame it is: the last physics step at or before it
    (within ``step`` seconds, the run's timestep), or a trajectory file's last recorded frame at or
    before it.

    >>> when(8.0208, 8.03), when(2.0, 2.0, digits=2), when(8.02917, 8.03, 1 / 240)
    ('t = 8.021 s (the last recorded frame at or before 8.030 s)', 't = 2.00 s', 't = 8.029 s (the last physics step at or before 8.030 s)')
    """
    if abs(shown - asked) <= 1e-6:
        return f"t = {shown:.{digits}f} s"
    which = "physics step" if isinstance(step, float) and asked - shown < step else "recorded frame"
    return f"t = {shown:.3f} s (the last {which} at or before {asked:.3f} s)"


def moment(at: str | float | None, trajectory: Any) -> str | float:
    """The moment ``--at`` names (:func:`stackdsl.cli.args.at_type`), or when none is given the one
    the scenario's expectations judge (:attr:`stackdsl.Trajectory.shown_at`: the end for final
    positions such as ``toppled``, else the collapse if the run collapsed, else the end). ``--at
    0`` is the start, not "not given"."""
    if at is not None:
        return at
    return str(trajectory.shown_at)


def size_of(text: str, option: str = "--size") -> tuple[int, int]:
    """``'800x600'`` -> (800, 600); each side :data:`MIN_SIDE` to :data:`MAX_SIDE` pixels, at most
    :data:`MAX_PIXELS` in all.

    Raises:
        ScenarioError: anything else (exit 2).
    """
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ScenarioError(f"{text!r} is not WIDTHxHEIGHT in pixels, such as 800x600", file=option) from None
    if not (MIN_SIDE <= width <= MAX_SIDE and MIN_SIDE <= height <= MAX_SIDE):
        raise ScenarioError(f"{text}: each side must be {MIN_SIDE} to {MAX_SIDE} pixels", file=option)
    if width * height > MAX_PIXELS:
        raise ScenarioError(
            f"{text}: {width * height / 1e6:.1f} million pixels; a picture may have at most {MAX_PIXELS / 1e6:g} million "
            "(drawing more needs more than 1.5 GB of memory), such as 4096x1950 or 2800x2800",
            file=option,
        )
    return width, height


def _output(args: argparse.Namespace, suffixes: tuple[str, ...], what: str) -> Path:
    """``-o``, checked before anything runs (:func:`stackdsl.cli.outputs.check_outputs`)."""
    from .outputs import Input, Output, check_outputs

    if args.output.strip() and Path(args.output).suffix.lower() not in suffixes:
        raise ScenarioError(f"the output must end in {' or '.join(suffixes)}", file=args.output, field="-o")
    (out,) = check_outputs([Output("-o", args.output, what)], [Input(args.file, "the file being drawn")])
    return out


def _draw(
    args: argparse.Namespace, verb: str, suffixes: tuple[str, ...], what: str, draw: Callable[[Any, Path, int, int], str]
) -> int:
    """Check the output and the size, get the trajectory (for the command ``verb``), ``draw(trajectory, out, width,
    height)`` (which says what it drew, in a few words). The options are checked before
    (``--at`` against the run by :func:`resolved`): a ValueError of the drawing is then the
    trajectory file's (bad input, :func:`undrawable`), or a bug when the run was made here."""
    out = _output(args, suffixes, what)
    width, height = size_of(args.size)
    trajectory = trajectory_of(args, verb)
    try:
        what = draw(trajectory, out, width, height)
    except ValueError as exc:
        refusal = undrawable(args.file, exc, "drawn")
        if refusal is None:
            raise
        raise refusal from None
    except TimeoutError as exc:
        print(f"stackdsl: {exc} ({args.timeout:g} s with the run); nothing written to {out}", file=sys.stderr)
        return 1
    return _wrote(out, trajectory, f"{what}, {width} x {height} pixels")


def resolved(trajectory: Any, at: str | float) -> float:
    """The time ``at`` names in ``trajectory`` (:func:`stackdsl.draw.render.resolve_time`).

    Raises:
        ScenarioError: at ``--at``: ``collapse`` and nothing collapsed, a time past the end.
    """
    from ..draw.render import resolve_time

    try:
        return resolve_time(trajectory, at)
    except ValueError as exc:
        raise ScenarioError(str(exc), file="--at") from None


def undrawable(file: str, exc: ValueError, verb: str) -> ScenarioError | None:
    """A ValueError met drawing (or exporting, as ``verb`` says) the run of ``file`` as bad
    input at a trajectory file (``.npz``), whose numbers stackdsl did not make; None for a
    scenario, whose run was made here: the error is then a bug."""
    if Path(file).suffix.lower() not in TRAJECTORY_SUFFIXES:
        return None
    return ScenarioError(f"this trajectory cannot be {verb}: {exc}", file=file)


def _wrote(out: Path, trajectory: Any, what: str) -> int:
    """Say what was written (``wrote OUT: what, size``); 1 when the run was stopped early (its
    ``--timeout``), else 0."""
    size = out.stat().st_size
    shown = f"{size / 1e6:.1f} MB" if size >= 1e6 else f"{size / 1e3:.0f} kB"
    print(f"wrote {out}: {what} ({shown})", flush=True)
    stopped = trajectory.meta.get("stopped")
    if stopped:
        print(f"stackdsl: the run was stopped early: {stopped}; the file shows it until then", file=sys.stderr)
        return 1
    return 0


def _render(args: argparse.Namespace) -> int:
    from ..draw.render import picture

    def draw(trajectory: Any, out: Path, width: int, height: int) -> str:
        at = moment(args.at, trajectory)
        asked = resolved(trajectory, at)
        drawn = picture(trajectory, asked, out, width=width, height=height)
        named = f"{at}, " if at in ("collapse", "end") else ""
        return f"the run at {named}{when(drawn, asked, trajectory.meta.get('timestep'), digits=2)}"

    return _draw(args, "render", (".png",), "the picture", draw)


def _animate(args: argparse.Namespace) -> int:
    from ..draw.animate import END_HOLD, GIF_MAX_FPS, MAX_FRAMES, animate, check_pixel_work

    started = time.perf_counter()
    if str(args.output).lower().endswith(".mp4") and not installed("video"):  # said before anything runs
        raise ScenarioError(missing("video", "an MP4 clip"), file=str(args.output))
    try:  # the most a clip can draw, refused before anything is simulated
        check_pixel_work(*size_of(args.size), MAX_FRAMES, args.fps)
    except ValueError as exc:
        raise ScenarioError(str(exc), file="--size") from None
    if str(args.output).lower().endswith(".gif") and args.fps > GIF_MAX_FPS:  # said before anything runs too
        raise ScenarioError(f"a GIF plays at most {GIF_MAX_FPS:g} frames a second, not {args.fps:g}", file="--fps")
    deadline = None if args.timeout is None else started + args.timeout

    def draw(trajectory: Any, out: Path, width: int, height: int) -> str:
        # TimeoutError: past --timeout, nothing written
        plan = animate(trajectory, out, fps=args.fps, width=width, height=height, deadline=deadline)
        seconds = len(plan.frames) / args.fps + END_HOLD
        return (
            f"a clip of {len(plan.frames)} frames, {seconds:.1f} s at {args.fps:g} a second (the last held {END_HOLD:g} s), "
            f"t = {plan.times[0]:.2f} to {plan.times[-1]:.2f} s simulated (x{plan.speeds.max():.3g} at most)"
        )

    return _draw(args, "animate", (".gif", ".mp4"), "the clip", draw)


def _graph(args: argparse.Namespace) -> int:
    from ..draw.graphplot import plot_graph

    out = _output(args, (".png",), "the plot")
    trajectory = trajectory_of(args, "graph")
    at = moment(args.at, trajectory)
    if at == "collapse" and args.at is None and "collapse" not in trajectory.graphs:  # a file without its graph
        at = "end"
    if at == "collapse" and "collapse" not in trajectory.graphs:
        raise ScenarioError("nothing collapsed in this run: there is no graph at the collapse (use --at end)", file="--at")
    graph = trajectory.graphs["collapse" if at == "collapse" else "final"]
    plot_graph(graph, out, title=f"{trajectory.meta.get('scenario', '')}: brick graph at the {at}")
    bricks = sum(n.state != "ground" and n.level is not None for n in graph.nodes)
    others = sum(n.state != "ground" and n.level is None for n in graph.nodes)  # a pusher, a projectile
    besides = f", {others} other bod{'y' if others == 1 else 'ies'}" if others else ""
    edges = len(graph.edges)
    said = f"{bricks} brick{'' if bricks == 1 else 's'}{besides} and {edges} rests-on edge{'' if edges == 1 else 's'}"
    return _wrote(out, trajectory, f"the brick graph at the {at}, {said}")
