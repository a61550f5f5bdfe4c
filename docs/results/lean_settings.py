"""The lean MuJoCo peer's settings, measured: solver tolerance 1e-8 (MuJoCo's default) against
1e-10, and each brick let go the drop gap above its nominal pose against above the actual top of
what it rests on, on upright 4 stacks, MuJoCo's own sleeping at tolerance 1e-4.

    python docs/results/lean_settings.py [HEIGHTS] [ROUNDS]

HEIGHTS: comma-separated levels (default 30,60); ROUNDS: runs of each setting (default 3). Each run
is a fresh process that runs a one-level tower first, untimed (:func:`stackdsl.bench.lean_mujoco.run_lean`
with ``tolerance`` and ``from_top``); the settings take turns within a round. The drop from the
actual top is measured at 30 levels and lower only (it was 3 to 5 times slower there). Output: a
Markdown table (docs/results/actions.md, "The lean peer's settings").
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys

CHILD = r"""
import sys, json
from stackdsl.bench.lean_mujoco import run_lean
from stackdsl import compile_scenario, parse_scenario
levels, sleep, tol, top = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), sys.argv[4] == "top"
def prog(n):
    text = f"stackdsl: 1\nstructure: {{tower: {{levels: {n}}}}}\nengine: {{mode: tuned, backend: mujoco, sleep_tolerance: {sleep}}}\n"
    return compile_scenario(parse_scenario(text, "t.yaml"))
run_lean(prog(1), tolerance=tol, from_top=top)
o = run_lean(prog(levels), tolerance=tol, from_top=top)
print(json.dumps([o.wall, o.level]))
"""


def main(heights: list[int], rounds: int) -> None:
    rows: dict[tuple[int, str, float], list[tuple[float, int | None]]] = {}
    for _ in range(rounds):
        for levels in heights:
            for top in ("nominal", "top") if levels <= 30 else ("nominal",):
                for tol in (1e-8, 1e-10):
                    out = subprocess.run(
                        [sys.executable, "-c", CHILD, str(levels), "1e-4", str(tol), top],
                        capture_output=True,
                        text=True,
                        check=True,
                    )
                    wall, level = json.loads(out.stdout.strip().splitlines()[-1])
                    rows.setdefault((levels, top, tol), []).append((wall, level))
                    print(levels, top, tol, f"{wall:.2f}", level, f"load {os.getloadavg()[0]:.1f}", flush=True)
    print("| levels | let go above | solver tolerance | wall (s), median | runs (s) | collapse |")
    print("|---:|---|---:|---:|---|---|")
    for (levels, top, tol), runs in sorted(rows.items()):
        walls = sorted(w for w, _ in runs)
        where = "the actual top" if top == "top" else "the nominal pose"
        fell = ", ".join(sorted({str(lv) if lv else "stands" for _, lv in runs}))
        print(
            f"| {levels} | {where} | {tol:g} | {statistics.median(walls):.2f} | {' '.join(f'{w:.2f}' for w in walls)} | {fell} |"
        )


if __name__ == "__main__":
    main(
        [int(x) for x in (sys.argv[1] if len(sys.argv) > 1 else "30,60").split(",")], int(sys.argv[2]) if len(sys.argv) > 2 else 3
    )
