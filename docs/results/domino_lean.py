"""How far the next domino of a row still turns once a fallen one is within a degree of its final lean.

Runs a domino row (``scenarios/dominoes_30.yaml`` unless FILE is given) with the extension on
pybullet and a recorder at 240 Hz, and prints for each fallen domino how far it has turned from
where it was placed at the end (its lean), the moment it first comes within ``--within`` degrees
(default 1) of that, and how many degrees the next domino still turns from then to the run's end. A domino that is a rigid part of the next from that moment
would have to move with it that much: the test of a design that freezes a fallen domino onto the
one it leans on as one rigid body (docs/results/dominoes.md, "Where the 30 row's time goes").

    python docs/results/domino_lean.py [FILE] [--within DEG]

Output: docs/results/dominoes.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from stackdsl import compile_scenario, parse_scenario
from stackdsl.runtime.recorder import record_program


def turns(path: Path) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The row's brick ids, the frames' times (s) and how far each brick has turned from the
    orientation it was placed in, at each frame (degrees, shape (bricks, frames); NaN before it
    is placed)."""
    program = compile_scenario(parse_scenario(path.read_text(encoding="utf-8"), str(path)), "extension", None, "pybullet")
    _, trajectory = record_program(program, 240.0, source=str(path))
    frames = list(trajectory.frames())
    turned = np.full((len(trajectory.ids), len(frames)), np.nan)
    placed: dict[int, Rotation] = {}
    for k, frame in enumerate(frames):
        for b in np.flatnonzero(~np.isnan(frame.orientations[:, 0])):
            now = Rotation.from_quat(frame.orientations[b])
            turned[b, k] = np.degrees((placed.setdefault(int(b), now).inv() * now).magnitude())
    return list(trajectory.ids), np.array([f.time for f in frames]), turned


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", default="scenarios/dominoes_30.yaml")
    parser.add_argument("--within", type=float, default=1.0, help="degrees from the final tilt (default 1)")
    args = parser.parse_args()
    ids, times, up = turns(Path(args.file))
    print(f"{args.file}: each fallen domino, and how far the next one turns once it is within {args.within:g} deg\n")
    print("| domino | its lean (deg) | within at (s) | the next turns after (deg) |\n|---|---:|---:|---:|")
    after_turns = []
    for i in range(len(ids) - 1):
        final = up[i, -1]
        near = np.flatnonzero(np.abs(up[i] - final) < args.within)
        after = up[i + 1, near[0] :]
        if final < 10.0 or not len(near) or np.isnan(after).all():  # standing, never settled, or the row's last
            continue
        turn = float(np.nanmax(after) - np.nanmin(after))
        after_turns.append(turn)
        print(f"| {ids[i]} | {final:.1f} | {times[near[0]]:.3f} | {turn:.2f} |")
    if after_turns:
        low, high, mid = min(after_turns), max(after_turns), float(np.median(after_turns))
        print(f"\n{len(after_turns)} fallen with a next; it turns {low:.2f} to {high:.2f} deg after (median {mid:.2f})")


if __name__ == "__main__":
    main()
