"""How long the replay page takes to load for a 400-brick, 60 s run (the target: under 2 s).

Two runs, each written with ``stackdsl.draw.replay.write_replay`` and opened in headless
Chromium (WebGL on SwiftShader, tests/replay_browser.py) ``--repeat`` times, each load in a
new tab, timed from navigation to the page's ``window.stackdslReplay.ready`` (the first
picture drawn):

* ``recorded``: a 100-level tower of 4 bricks a layer placed every 0.15 s (400 bricks, 60 s of
  building), hit at level 85 by a 10 m/s brick (it collapses) and left to settle, in extension mode;
* ``synthetic``: the worst case the recorder can write, every one of the 400 bricks moving in
  every frame at 30 Hz for 60 s (720,000 rows).

Run it (a minute or two on 2 cores; it needs the test extra and Debian's chromium)::

    python tests/replay_load.py [--repeat 3] [--keep DIR]

It prints each page's size and load times, and exits 1 when a median load is 2 s or more.

Source: stackdsl's own.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from replay_browser import browser, open_replay

#: The budget of one load, seconds.
BUDGET = 2.0

SCENARIO = """stackdsl: 1
name: 400 bricks, 60 s
structure: {tower: {levels: 100, bricks_per_layer: 4, spacing: 32 mm, turn: 90}}
timing: {interval: 0.15 s, settle: 3 s}
impacts:
  - {target: {level: 85, side: +y}, speed: 10 m/s, at: after level 100}
engine: {mode: extension}
"""


def recorded() -> object:
    """The recorded run of :data:`SCENARIO`."""
    import stackdsl
    from stackdsl.runtime.recorder import record_program

    program = stackdsl.compile_scenario(stackdsl.parse_scenario(SCENARIO))
    start = time.perf_counter()
    _, trajectory = record_program(program, source="400 bricks")
    print(f"recorded: {len(trajectory.ids)} bodies, {trajectory.end:.1f} s simulated in {time.perf_counter() - start:.1f} s wall")
    return trajectory


def synthetic(bricks: int = 400, seconds: float = 60.0, rate: float = 30.0) -> object:
    """A trajectory of ``bricks`` bricks each moving in every frame, ``rate`` frames a second."""
    from stackdsl.runtime.outcome import Graph
    from stackdsl.runtime.trajectory import ACTIVE, Trajectory

    frames = int(seconds * rate) + 1
    times = np.arange(frames) / rate
    rng = np.random.default_rng(0)
    base = np.column_stack([rng.uniform(-0.2, 0.2, bricks), rng.uniform(-0.2, 0.2, bricks), 0.004 + 0.008 * np.arange(bricks)])
    phase = times[:, None, None] * np.array([0.01, 0.013, 0.0])[None, None, :]
    positions = (base[None, :, :] + phase).reshape(-1, 3)
    angle = np.repeat(times, bricks) * 0.3
    orientations = np.column_stack([np.zeros_like(angle), np.zeros_like(angle), np.sin(angle / 2), np.cos(angle / 2)])
    return Trajectory(
        meta={"scenario": "synthetic: every brick moving", "file": "", "mode": "extension", "rate": rate, "collapse": None},
        ids=np.array([f"b{i:03d}" for i in range(bricks)]),
        levels=np.arange(1, bricks + 1, dtype=np.int32),
        half_extents=np.tile([0.06, 0.012, 0.004], (bricks, 1)),
        fixture_ids=np.zeros(0, dtype=str),
        fixture_half_extents=np.zeros((0, 3)),
        fixture_positions=np.zeros((0, 3)),
        fixture_orientations=np.zeros((0, 4)),
        times=times,
        row_frame=np.repeat(np.arange(frames, dtype=np.int32), bricks),
        row_body=np.tile(np.arange(bricks, dtype=np.int32), frames),
        row_position=positions,
        row_orientation=orientations,
        row_state=np.full(frames * bricks, ACTIVE, np.int8),
        events=(),
        graphs={"final": Graph(nodes=(), edges=())},
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="Time the replay page of a 400-brick, 60 s run in headless Chromium.")
    parser.add_argument("--repeat", type=int, default=3, help="loads of each page (default: 3)")
    parser.add_argument("--keep", metavar="DIR", help="write the pages there (default: a temporary folder, removed)")
    parser.add_argument("--only", choices=["recorded", "synthetic"], help="time one of the two runs")
    args = parser.parse_args(argv)
    from stackdsl.draw.replay import write_replay

    slow = False
    with tempfile.TemporaryDirectory() as scratch, browser() as launched:
        out = Path(args.keep or scratch)
        out.mkdir(parents=True, exist_ok=True)
        for name, make in (("recorded", recorded), ("synthetic", synthetic)):
            if args.only and name != args.only:
                continue
            trajectory = make()
            start = time.perf_counter()
            page = write_replay(trajectory, out / f"{name}.html")  # type: ignore[arg-type]
            written = time.perf_counter() - start
            rows = len(trajectory.row_frame)  # type: ignore[attr-defined]
            frames = len(trajectory.times)  # type: ignore[attr-defined]
            print(f"{name}: {rows} rows, {frames} frames; page {page.stat().st_size / 1e6:.1f} MB written in {written:.2f} s")
            loads = []
            for k in range(args.repeat):
                opened = open_replay(launched, page)
                loads.append(opened.seconds)
                print(f"  load {k + 1}: {opened.seconds:.2f} s to ready; console {opened.console or 'clean'}")
                opened.page.close()
            median = statistics.median(loads)
            slow |= median >= BUDGET
            print(f"  median {median:.2f} s ({'within' if median < BUDGET else 'OVER'} the {BUDGET:g} s budget)")
    return 1 if slow else 0


if __name__ == "__main__":
    sys.exit(main())
