"""The measurements of docs/results/search.md: each shipped threshold search (searches/) on both
engines against its closed form and against a grid of the same resolution, and the runs to the
first counterexample of searches/rare_overhang.yaml by the search (10 seeds) against plain
sampling, each counterexample file run to see that it fails.

Plain sampling's first failure is counted on the sweep's own draws (Template.parameters: sample k
from the k-th child of the seed), each judged by the closed form (5 levels and a shift above
24 mm) rather than simulated: the search's runs and tests/test_signed_margin.py show the
simulation agrees with it to 0.08 mm of the boundary.

The interval is the one reported (the runs' interval, its ends moved out by the engine's tie band
where statics decides: docs/searches.md).

Run: python docs/results/search_targets.py [OUT] (about 10 minutes on 2 cores).
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path

from stackdsl import load_scenario

#: file, closed form (the field's unit), what it is
THRESHOLDS = [
    ("searches/single_file_shift.yaml", 24.0, "critical shift of 5 bricks in single file, 120 mm / 5"),
    ("searches/jenga_last_block.yaml", 12.5, "last Jenga block's critical offset, 25 mm / 2"),
    ("searches/shake_tipping.yaml", 20.71, "shake amplitude where rocking starts, g b / h at 2 Hz"),
    ("searches/shake_rocking_onset.yaml", 20.71, "shake amplitude where rocking starts (still: tilt 0.02 deg), g b / h at 2 Hz"),
    ("searches/shake_sliding_onset.yaml", 31.06, "shake amplitude where sliding starts (still: slip 0.02 mm), mu g at 2 Hz"),
    (
        "searches/dominoes_reach.yaml",
        128.0,
        "dominoes' reach, h + t for a foot that holds (none does: docs/results/domino_reach.py)",
    ),
]
RARE = "searches/rare_overhang.yaml"


def stackdsl(*args: str) -> int:
    return subprocess.run([sys.executable, "-m", "stackdsl", *args], capture_output=True, check=False).returncode


def thresholds(out: Path) -> None:
    print("| search | closed form | engine | interval | the runs' interval | contains it | off by | runs | grid runs | fewer |")
    print("|---|---:|---|---|---|---|---:|---:|---:|---:|")
    for file, truth, what in THRESHOLDS:
        for engine in ("pybullet", "mujoco"):
            folder = out / f"{Path(file).stem}-{engine}"
            stackdsl("search", file, "-j", "1", "--backend", engine, "--out", str(folder))
            s = json.loads((folder / "search.json").read_text())
            low, high = s["interval"]
            runs_low, runs_high = s["runs_interval"]
            off = 0.0 if low <= truth <= high else min(abs(low - truth), abs(high - truth))
            print(
                f"| {Path(file).name}: {what} | {truth:g} {s['unit']} | {engine} | {low:.3f} to {high:.3f} {s['unit']} | "
                f"{runs_low:.3f} to {runs_high:.3f} | "
                f"{'yes' if off == 0 else 'no'} | {off:.3f} {s['unit']} | {s['runs']} | {s['grid_runs']} | "
                f"{s['grid_runs'] / s['runs']:.1f}x |",
                flush=True,
            )


def plain_first(seed: int, limit: int = 100_000) -> int:
    template = load_scenario(RARE, seed).template
    assert template is not None
    for k in range(limit):
        p = template.parameters(0, k)
        if p["structure.tower.levels"] == 5 and p["structure.tower.shift [m]"] > 0.024:
            return k + 1
    return limit


def counterexamples(out: Path) -> None:
    print("\n| seed | search: runs to the first | plain sampling: samples to the first | files | each fails when run |")
    print("|---:|---:|---:|---:|---|")
    rows = []
    for seed in range(10):
        folder = out / f"rare-seed{seed}"
        stackdsl("search", RARE, "-j", "1", "--seed", str(seed), "--out", str(folder))
        s = json.loads((folder / "search.json").read_text())
        failed = all(stackdsl("run", f) == 1 for f in s["files"])
        rows.append((s["first"] or 10**9, plain_first(seed)))
        print(f"| {seed} | {s['first']} | {rows[-1][1]} | {len(s['files'])} | {'yes' if failed else 'NO'} |", flush=True)
    search, plain = statistics.median(r[0] for r in rows), statistics.median(r[1] for r in rows)
    print(f"\nmedian: search {search:g} runs, plain sampling {plain:g} samples: {plain / search:.0f}x fewer")


if __name__ == "__main__":
    folder = Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/search-targets")
    thresholds(folder)
    counterexamples(folder)
