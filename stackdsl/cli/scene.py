"""The scene commands of ``stackdsl``: replay (an interactive 3D page), view (MuJoCo's viewer),
export (MJCF and URDF at one moment).

Like the drawing commands (:mod:`stackdsl.cli.draw`), each reads a trajectory file (``.npz``)
or runs and records a scenario file first.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..lang.errors import ScenarioError
from ..util.extras import installed, missing
from .args import COMMANDS, at_type
from .draw import _SOURCE, _wrote, moment, recorded, resolved, trajectory_of, undrawable, when
from .draw import NAMES as DRAWING

#: Exit status of ``view`` where there is no display to open a window on (as bad input: the
#: command cannot do what was asked here).
NO_DISPLAY = 2

#: The commands that draw or show one run: the drawing commands, then the scene commands.
NAMES = (*DRAWING, "replay", "view", "export")


def add_commands(sub: Any, parents: list[argparse.ArgumentParser], epilog: str, names: tuple[str, ...] = NAMES) -> None:
    """Add ``names`` (of :data:`NAMES`) to the ``stackdsl`` parser's subcommands; ``parents`` give
    --debug, --timeout, --mode and --model (:func:`stackdsl.cli.draw.add_commands` adds the
    drawing commands)."""
    from .draw import add_commands as add_drawing

    for name in names:
        if name in _ADD:
            _ADD[name](sub, parents, epilog)
        else:
            add_drawing(sub, parents, epilog, (name,))


def _add_replay(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "replay",
        parents=parents,
        help=COMMANDS["replay"],
        description="Write DIR/replay.html: one self-contained page (three.js inlined, no network) that plays the run "
        "in 3D. Orbit and zoom with the mouse, scrub the timeline or step frame by frame and event by event (slow "
        "motion at impacts and the collapse), click a brick for its id, level, state, supports and load shares; "
        "bricks are coloured by state, and the golden snapshot's final poses, where they differ, are drawn as green "
        "ghosts. " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="the folder to write replay.html in (made if missing)")
    p.add_argument(
        "--golden",
        metavar="FILE.json",
        help="the golden snapshot whose final poses are the ghosts (default: the scenario's own, golden/.../NAME.json, "
        "when it exists); a sweep's golden holds each sample's collapse level and no poses: the replayed sample's "
        "level is compared with it instead",
    )
    p.set_defaults(func=_replay)


def _replay(args: argparse.Namespace) -> int:
    from ..draw.artefacts import golden_of
    from ..draw.replay import GoldenError, is_sweep_golden, read_golden, sweep_note, write_replay
    from ..verdicts.snapshot import scenario_golden_path
    from .outputs import Input, Output, check_default_golden, check_outputs

    if args.golden is not None and not args.golden.strip():
        raise ScenarioError("the path is empty: give the golden snapshot's file, or leave --golden out", file="--golden")
    golden_path = Path(args.golden) if args.golden else None
    if golden_path is not None and not golden_path.exists():
        raise ScenarioError("No such file or directory: no golden snapshot to show beside the run", file=args.golden)
    try:
        read_golden(golden_path)  # a golden given that stackdsl cannot use: said before anything runs
    except GoldenError as exc:
        raise ScenarioError(exc.why, file=exc.file) from None
    # a scenario's own golden, read by default, is checked before it runs; a trajectory's once read
    default = None if golden_path is not None or Path(args.file).suffix.lower() == ".npz" else scenario_golden_path(args.file)
    check_default_golden(default, "or give --golden")
    (out,) = check_outputs(
        [Output("-o", args.output, "the replay", folder=True, inside=("replay.html",))],
        [Input(args.file, "the file being replayed"), *(Input(g, "the golden snapshot") for g in (golden_path, default) if g)],
    )
    trajectory = trajectory_of(args, "replay")
    read = golden_path or golden_of(trajectory)
    try:  # the golden must be of this run's scenario; a trajectory's, found now, is refused unopened if not a regular file
        golden = read_golden(read, trajectory)
    except GoldenError as exc:
        raise ScenarioError(exc.why, file=exc.file) from None
    note = None
    if golden is not None and read is not None and is_sweep_golden(golden):  # each sample's level, no poses: said, and compared
        collapse = trajectory.meta.get("collapse")
        level = collapse.get("level") if isinstance(collapse, dict) else None
        cell, sample = getattr(args, "cell", None) or 0, getattr(args, "sample", None) or 0
        note = sweep_note(read, golden, cell, sample, level, trajectory.meta.get("mode"), getattr(args, "seed", None) is not None)
        print(f"golden: {note}", flush=True)
    out.mkdir(parents=True, exist_ok=True)
    return _wrote(
        write_replay(trajectory, out / "replay.html", golden, note),
        trajectory,
        f"a 3D replay of {len(trajectory.ids)} bodies",
    )


def has_display() -> bool:
    """Whether a window can be opened: an X or Wayland display on Linux and the BSDs; always on
    macOS and Windows."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def display_problem() -> str | None:
    """Why the display that ``DISPLAY`` or ``WAYLAND_DISPLAY`` names cannot take a window, in
    GLFW's words (``X11: Failed to open display :99``), or None when it can (and on macOS and
    Windows, where MuJoCo's viewer opens its own). GLFW, which MuJoCo's viewer starts, is
    started and stopped again here, its complaints caught rather than printed."""
    if sys.platform in ("darwin", "win32"):
        return None
    import glfw

    reporting = glfw.ERROR_REPORTING
    glfw.ERROR_REPORTING = "ignore"  # not a warning on stderr: said below, in one line
    try:
        started = glfw.init()
        _, description = glfw.get_error()
    finally:
        glfw.ERROR_REPORTING = reporting
    if not started:
        said = description.decode(errors="replace") if isinstance(description, bytes) else str(description or "")
        return said or "GLFW cannot start"
    glfw.terminate()
    return None


def _replay_command(args: argparse.Namespace) -> str:
    """The ``stackdsl replay`` command of the run ``view`` was asked to show (its options kept)."""
    from ..batch.report import rerun_command

    return rerun_command(
        "replay",
        args.file,
        mode=args.mode,
        model=args.model,
        backend=args.backend,
        seed=args.seed,
        sample=args.sample,
        cell=args.cell,
        timeout=args.timeout,
        tail=("-o", "DIR"),
    )


def _add_view(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "view",
        parents=parents,
        help=COMMANDS["view"],
        description="Open MuJoCo's viewer and run the scene in it as it simulates (any engine: the viewer shows "
        "the bricks' poses), bricks coloured by state (frozen, active, woken, fallen, projectile); a trajectory "
        "file (.npz) is played back the same way. The window stays open at the end until closed. Needs a "
        f"display and the mujoco extra; without a display it says so and exits {NO_DISPLAY} (use 'stackdsl "
        "replay' for a page to open in a browser). " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--speed", type=float, default=1.0, help="simulated seconds a wall second (default: 1, real time)")
    p.set_defaults(func=_view)


def wait_for_close(viewer: Any, deadline: float | None, sleep: Any = None, clock: Any = None) -> bool:
    """Wait until the viewer's window is closed, or the wall ``deadline`` (``time.monotonic()``
    seconds; None: none) passes: then close it and say so on stderr. ``view --timeout`` bounds
    the whole command, the window included (under a virtual display nobody closes it, and its
    render thread spun at 99% of a core past the timeout). True when the deadline closed it."""
    sleep, clock = sleep or time.sleep, clock or time.monotonic
    while viewer.is_running():
        if deadline is not None and clock() >= deadline:
            print("stackdsl view: --timeout reached: the window is closed", file=sys.stderr)
            viewer.close()
            return True
        sleep(0.1)
    return False


def _view(args: argparse.Namespace) -> int:
    start = time.monotonic()
    if not (0 < args.speed <= 1000):  # the arguments are said before the display is looked for
        raise ScenarioError(f"{args.speed:g} is not a speed-up above 0 and at most 1000", file="--speed")
    if not has_display():
        print(
            f"stackdsl view: no display here (DISPLAY is not set): for a 3D page to open in a browser, run {_replay_command(args)}",
            file=sys.stderr,
        )
        return NO_DISPLAY
    if not installed("mujoco"):
        raise ScenarioError(missing("mujoco", "the viewer"), file=args.file)
    import mujoco.viewer

    from ..compile.compiler import compile_scenario
    from ..draw import live
    from ..runtime.run import run_program
    from ..verdicts.expect import describe_outcome
    from .sample import scenario_of

    # the file is read (a scenario compiled) before the display is tried: bad input is said first
    trajectory = trajectory_of(args, "view") if Path(args.file).suffix.lower() == ".npz" else None
    program = None if trajectory is not None else compile_scenario(scenario_of(args, "view"), args.mode, args.model, args.backend)
    deadline = None if args.timeout is None else start + args.timeout
    unusable = display_problem()
    if unusable:
        print(
            f"stackdsl view: the display cannot be opened ({unusable}): for a 3D page to open in a browser, run {_replay_command(args)}",
            file=sys.stderr,
        )
        return NO_DISPLAY
    if deadline is not None and time.monotonic() >= deadline:  # not a window opened only to be closed
        print("stackdsl view: --timeout reached before the window opened", file=sys.stderr)
        return 0
    if trajectory is not None:
        scene = live.trajectory_scene(trajectory)
        with _window(mujoco.viewer.launch_passive, scene) as viewer:
            with viewer.lock():
                scene.aim(viewer.cam)
            live.play(trajectory, scene, viewer, args.speed, clock=time.monotonic, deadline=deadline)
            wait_for_close(viewer, deadline)
        return 0
    assert program is not None
    scene = live.program_scene(program)
    with _window(mujoco.viewer.launch_passive, scene) as viewer:
        with viewer.lock():
            scene.aim(viewer.cam)
        view = live.LiveView(program, scene, viewer, args.speed)
        left = None if deadline is None else max(deadline - time.monotonic(), 0.0)  # the command's budget, not the run's own
        outcome = run_program(program, timeout=left, subscribers=(view,))
        said = describe_outcome(outcome, program.collapse_threshold)
        print(f"{program.name}: " + (f"stopped early ({outcome.stopped}); {said} until then" if outcome.stopped else said))
        wait_for_close(viewer, deadline)
    return 0


@contextlib.contextmanager
def _window(launch: Any, scene: Any) -> Iterator[Any]:
    """MuJoCo's passive viewer of ``scene`` (``launch``: ``mujoco.viewer.launch_passive``), closed on
    exit and its window's thread waited for (at most :data:`CLOSE_WAIT` seconds): left running, the
    thread tore its window down while the interpreter exited, which hung the command or aborted it
    (a pthread mutex assertion, exit 134) under a virtual display."""
    before = set(threading.enumerate())
    viewer = launch(scene.model, scene.data)
    started = [t for t in threading.enumerate() if t not in before]
    try:
        yield viewer
    finally:
        viewer.close()
        for thread in started:
            thread.join(CLOSE_WAIT)


#: Seconds ``view`` waits for the viewer's window to close once asked to.
CLOSE_WAIT = 5.0


def _add_export(sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    p = sub.add_parser(
        "export",
        parents=parents,
        help=COMMANDS["export"],
        description="Write the bricks at one moment of the run, at their poses, as MuJoCo XML (--mjcf: each brick "
        "a body with a free joint, the ground a plane; open it with 'python -m mujoco.viewer --mjcf=OUT.xml' or "
        "MuJoCo's simulate), as an SDFormat world (--sdf: a model a brick and a static ground; pybullet's "
        "loadSDF(OUT.sdf) gives one body a brick, with the pybullet friction and restitution of the run's "
        "materials) and/or as a URDF (--urdf: one robot, the ground its root link, each brick on a floating "
        "joint; MuJoCo makes these free joints, pybullet fixed ones, every brick welded into one body: for "
        "pybullet give --sdf). Masses and friction are the "
        "scenario's (a trajectory file: the built-in pine's); geoms are coloured by state. The XML carries MuJoCo's "
        "options and contacts (timestep, cone, impratio, integrator, solref, solimp, friction per material pair): "
        "the run's own on MuJoCo raw or tuned, else MuJoCo's tuned mode; a comment in the file says which. " + _SOURCE,
        epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--at",
        type=at_type,
        default=None,
        metavar="collapse|end|SECONDS",
        help="when: 0.2 s after the first collapse (as 'render'), the end, or a time in seconds (default: as "
        "'render', what the scenario's expectations judge)",
    )
    p.add_argument("--mjcf", metavar="OUT.xml", help="write MuJoCo XML")
    p.add_argument("--sdf", metavar="OUT.sdf", help="write an SDFormat world: pybullet.loadSDF(OUT.sdf), one body a brick")
    p.add_argument("--urdf", metavar="OUT.urdf", help="write a URDF (one multibody: pybullet welds its bricks; see --sdf)")
    p.set_defaults(func=_export)


#: What an exported file's name may end in, by kind.
_EXPORT_SUFFIXES = {"mjcf": (".xml", ".mjcf"), "sdf": (".sdf", ".world"), "urdf": (".urdf", ".xml")}
#: What each kind is called in what export says.
_KINDS = {"mjcf": "MJCF", "sdf": "SDF", "urdf": "URDF"}


def _export(args: argparse.Namespace) -> int:
    from ..compile.program import Fixture, Launch, Place
    from ..draw.export import mjcf, recorded_engine, sdf, snapshot, urdf, write_text
    from .outputs import Input, Output, check_outputs

    given = [(path, kind) for path, kind in ((args.mjcf, "mjcf"), (args.sdf, "sdf"), (args.urdf, "urdf")) if path is not None]
    if not given:
        raise ScenarioError("give --mjcf OUT.xml, --sdf OUT.sdf or --urdf OUT.urdf (or several)", file="export")
    paths = check_outputs(
        [Output(f"--{kind}", path, f"the {_KINDS[kind]} file") for path, kind in given],
        [Input(args.file, "the file being exported")],
    )
    for path, kind in given:  # as the drawings' outputs are: a file named for what it holds
        if path.strip() and Path(path).suffix.lower() not in _EXPORT_SUFFIXES[kind]:
            raise ScenarioError(
                f"the {_KINDS[kind]} file must end in {' or '.join(_EXPORT_SUFFIXES[kind])}", file=path, field=f"--{kind}"
            )
    outputs = [(out, kind) for out, (_, kind) in zip(paths, given, strict=True)]
    program, trajectory = recorded(args, "export")
    at = resolved(trajectory, moment(args.at, trajectory))
    try:  # the options were checked: what fails here is the trajectory's
        if program is None:  # a trajectory file: pine, and the engine its meta records
            scene, engine = snapshot(trajectory, at), recorded_engine(trajectory.meta)
        else:
            specs = {a.id: a.brick for a in (*program.fixtures, *program.actions) if isinstance(a, (Place, Launch, Fixture))}
            scene = snapshot(trajectory, at, specs, program.ground_friction, program.ground_restitution)
            engine = program.engine
        write = {"mjcf": lambda: mjcf(scene, engine=engine), "sdf": lambda: sdf(scene), "urdf": lambda: urdf(scene)}
        texts = {kind: write[kind]() for _, kind in outputs}
    except ValueError as exc:
        refusal = undrawable(args.file, exc, "exported")
        if refusal is None:
            raise
        raise refusal from None
    status = 0
    bodies = f"{len(scene.ids)} bod{'y' if len(scene.ids) == 1 else 'ies'}"
    loaded = {  # how to load each, where it is not plain
        "sdf": f", {bodies} and the ground (pybullet.loadSDF: one body each)",
        "urdf": f", {bodies} in one multibody (pybullet welds them: use --sdf)",
    }
    for out, kind in outputs:
        said = loaded.get(kind, f", {bodies}")
        status |= _wrote(
            write_text(texts[kind], out),
            trajectory,
            f"{_KINDS[kind]}{said} at {when(scene.time, at, trajectory.meta.get('timestep'))}",
        )
    return status


_ADD = {"replay": _add_replay, "view": _add_view, "export": _add_export}
