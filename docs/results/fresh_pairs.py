"""One scene's wall time on this checkout against another, in fresh processes taken in turns.

    git worktree add /tmp/before <commit>
    python docs/results/fresh_pairs.py scenarios/jenga_falls.yaml /tmp/before --pairs 8

Runs SCENE (a scenario file) with the extension on pybullet ``--pairs`` times on each side,
alternately: this checkout, then BEFORE (another checkout's folder, put first on ``PYTHONPATH``),
each run in a fresh process that first runs a one-level tower, untimed, as ``stackdsl bench``
warms a cell's process, and times the run from the compiled program to its result. Taking the
sides in turns puts both on the same stretches of a machine whose speed drifts by a tenth within
minutes; the medians and the fastest runs are printed.

Output: docs/results/actions.md, "The whole family now, on both engines".
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
from pathlib import Path

ONE_RUN = """
import sys, time
from stackdsl.bench.actions import _WARM_UP, program_for
from stackdsl.runtime.run import run_program
run_program(program_for(_WARM_UP, "warm-up.yaml", "extension"))
program = program_for(open(sys.argv[1]).read(), sys.argv[1], "extension")
start = time.perf_counter()
run_program(program)
print(time.perf_counter() - start)
"""


def one_run(scene: Path, checkout: Path) -> float:
    """Seconds of one run of ``scene`` in a fresh process importing stackdsl from ``checkout``."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    done = subprocess.run(
        [sys.executable, "-c", ONE_RUN, str(scene)], env=env, cwd=checkout, capture_output=True, text=True, check=True
    )
    return float(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("before", type=Path, help="the other checkout's folder")
    parser.add_argument("--pairs", type=int, default=8)
    args = parser.parse_args()
    here = Path(__file__).resolve().parents[2]
    scene = args.scene.resolve()
    times: dict[str, list[float]] = {"this checkout": [], "before": []}
    for _ in range(args.pairs):
        times["this checkout"].append(one_run(scene, here))
        times["before"].append(one_run(scene, args.before.resolve()))
    for side, runs in times.items():
        shown = " ".join(f"{t:.2f}" for t in runs)
        print(f"{side}: median {statistics.median(runs):.2f} s, fastest {min(runs):.2f} s ({shown})")


if __name__ == "__main__":
    main()
