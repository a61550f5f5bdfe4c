"""How far the next domino of a row still turns once a fallen one is within a degree of its final lean.

Runs a domino row (``scenarios/dominoes_30.yaml`` unless FILE is given) with the extension on
pybullet and a recorder at 240 Hz, and prints for each fallen domino how far it has turned from
where it was placed at the end (its lean), the moment it first comes within ``--within`` degrees
(default 1) of that, and how many degrees the next domino still turns from then to the run's end. A domino that is a rigid part of the next from that moment
would have to move with it that much: the test of a design that freezes a fallen domino onto the
one it leans on as one rigid body (docs/results/dominoes.md, "Where the 30 row's time goes").

    python docs/results/domino_lean.py [FILE] [--within DEG]
    python docs/results/domino_lean.py [FILE] --settle    # how long each fallen domino keeps turning

``--settle`` prints instead, for each fallen domino, when it first turned 1 deg (the chain reached
it), how long after that it came within 5, 1, 0.3 and 0.1 deg of its final lean for good, and when
the extension froze it after that (the run's last freeze of it): how long the pile behind the
chain's front really moves, and so how many dominoes stay active at the chain's pace.

Output: docs/results/dominoes.md.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from stackdsl import compile_scenario, parse_scenario
from stackdsl.runtime.recorder import record_program


def turns(path: Path) -> tuple[list[str], np.ndarray, np.ndarray, dict[str, float]]:
    """The row's brick ids, the frames' times (s), how far each brick has turned from the
    orientation it was placed in, at each frame (degrees, shape (bricks, frames); NaN before it
    is placed), and when the extension last froze each brick (s)."""
    program = compile_scenario(parse_scenario(path.read_text(encoding="utf-8"), str(path)), "extension", None, "pybullet")
    outcome, trajectory = record_program(program, 240.0, source=str(path))
    frozen = {e.brick: e.time for e in outcome.events if e.kind == "freeze"}
    frames = list(trajectory.frames())
    turned = np.full((len(trajectory.ids), len(frames)), np.nan)
    placed: dict[int, Rotation] = {}
    for k, frame in enumerate(frames):
        for b in np.flatnonzero(~np.isnan(frame.orientations[:, 0])):
            now = Rotation.from_quat(frame.orientations[b])
            turned[b, k] = np.degrees((placed.setdefault(int(b), now).inv() * now).magnitude())
    return list(trajectory.ids), np.array([f.time for f in frames]), turned, frozen


SETTLE = (5.0, 1.0, 0.3, 0.1)
"""Degrees from its final lean that :func:`settle` times a fallen domino to."""


def settle(ids: list[str], times: np.ndarray, up: np.ndarray, frozen: dict[str, float]) -> None:
    """Print, for each fallen domino, when it first turned 1 deg and how long after that it came
    for good within each of :data:`SETTLE` of its final lean, and was last frozen; then the medians."""
    heads = " | ".join(f"within {d:g} deg (s)" for d in SETTLE)
    print(f"| domino | turned 1 deg at (s) | {heads} | frozen (s) |\n|---|---:|" + "---:|" * (len(SETTLE) + 1))
    rows = []
    for i, name in enumerate(ids):
        final = up[i, -1]
        moved = np.flatnonzero(up[i] > 1.0)
        if final < 10.0 or not len(moved):  # standing
            continue
        hit = times[moved[0]]
        after = []
        for d in SETTLE:
            off = np.flatnonzero(~(np.abs(up[i] - final) < d))  # NaN (not placed) counts as off
            after.append(float(times[off[-1] + 1] - hit) if len(off) and off[-1] + 1 < len(times) else 0.0)
        froze = frozen.get(name, np.nan) - hit
        rows.append([*after, froze])
        print(f"| {name} | {hit:.3f} | " + " | ".join(f"{a:.3f}" for a in after) + f" | {froze:.3f} |")
    if rows:
        mid = np.nanmedian(np.array(rows), axis=0)
        print("| median | | " + " | ".join(f"{m:.3f}" for m in mid) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("file", nargs="?", default="scenarios/dominoes_30.yaml")
    parser.add_argument("--within", type=float, default=1.0, help="degrees from the final tilt (default 1)")
    parser.add_argument("--settle", action="store_true", help="how long each fallen domino keeps turning")
    args = parser.parse_args()
    ids, times, up, frozen = turns(Path(args.file))
    if args.settle:
        print(f"{args.file}: each fallen domino, from when it turned 1 deg to within each of {SETTLE} deg of its lean\n")
        settle(ids, times, up, frozen)
        return
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
