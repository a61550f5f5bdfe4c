"""The scene commands of ``stackdsl``: replay (an interactive 3D page), view (MuJoCo's viewer),
export (MJCF and URDF at one moment).

Like the drawing commands (:mod:`stackdsl.cli.draw`), each reads a trajectory file (``.npz``)
or runs and records a scenario file first.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..lang.errors import ScenarioError
from .args import COMMANDS
from .draw import _SOURCE, _wrote, trajectory_of

#: The scene commands, in the order of ``stackdsl --help``.
NAMES = ("replay",)


def add_command(name: str, sub: Any, parents: list[argparse.ArgumentParser], epilog: str) -> None:
    """Add the scene command ``name`` (of :data:`NAMES`) to the ``stackdsl`` parser's subcommands."""
    _ADD[name](sub, parents, epilog)


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
        "when it exists)",
    )
    p.set_defaults(func=_replay)


def _replay(args: argparse.Namespace) -> int:
    from ..draw.artefacts import golden_of
    from ..draw.replay import read_golden, write_replay

    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ScenarioError("the replay goes to a folder: this is a file", file=args.output)
    golden_path = Path(args.golden) if args.golden else None
    if golden_path is not None and (not golden_path.is_file() or read_golden(golden_path) is None):
        raise ScenarioError("not a readable golden snapshot (a JSON object)", file=args.golden)
    trajectory = trajectory_of(args)
    golden = read_golden(golden_path or golden_of(trajectory))
    out.mkdir(parents=True, exist_ok=True)
    return _wrote(write_replay(trajectory, out / "replay.html", golden), trajectory)


_ADD = {"replay": _add_replay}
