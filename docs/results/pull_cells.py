"""Every cell of sweeps/jenga_pulls.yaml at fixed speeds, in several settings: verdict and drag per pull.

Writes one scenario a cell and speed into ``FOLDER`` (the sweep's tower and its one pull, the
speed fixed, ``expect: stands``), then runs each in every setting named (the settings of
docs/results/pull_freeze.py: ``ext``, ``ext-free``, ``tuned-mj``, ...; and ``ext-hzN``, the extension
with a pull's substeps at N Hz instead of 960; ``ext-splitN``, with N solver iterations a substep
of a split step instead of the engine's; ``ext-untied``, a level tied by the one on it held to the
safety of one brick alone, ``stability._drag.TIE_SAFETY``), two processes at a time,
and prints a row each: the pull, the setting, stands or the collapse level, the largest
distance (mm) a brick above the pulled level ended from where it was placed, and the wall time.
Then a line a setting: how many stood, and how many verdicts differ from the first setting's.

    python docs/results/pull_cells.py FOLDER [SETTINGS] [SPEEDS] [LEVELS]
    # e.g. python docs/results/pull_cells.py /tmp/pulls ext,ext-free 20,60 2-11
    # LEVELS: the middle and a side block of each level in the range (default: the sweep's grid)

Output: docs/results/actions-freeze.md ("The bricks on a dragged level ride free").
Source: stackdsl's own.
"""

from __future__ import annotations

import os
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SWEEP = ROOT / "sweeps" / "jenga_pulls.yaml"


def cells(folder: Path, speeds: list[int], levels: range | None = None) -> list[tuple[Path, int]]:
    """Write a scenario a cell (or a side and the middle block of each of ``levels``) and speed
    into ``folder``; each file with the pulled brick's level."""
    text = SWEEP.read_text(encoding="utf-8")
    grid = re.search(r"actions\[0\]\.remove\.brick: \[([^\]]*)\]", text, re.S)
    assert grid is not None, "the sweep's grid of pulled bricks"
    bricks = [b.strip() for b in grid.group(1).replace("\n", " ").split(",") if b.strip()]
    if levels is not None:
        bricks = [f"L{level:02d}.{k}" for level in levels for k in (1, 2)]
    head = text[: text.index("actions:")]
    folder.mkdir(parents=True, exist_ok=True)
    made = []
    for brick in bricks:
        for speed in speeds:
            path = folder / f"pull_{brick}_{speed}.yaml"
            path.write_text(
                head + f"actions:\n  - remove: {{brick: {brick}, at: after level 12, speed: {speed} mm/s}}\n"
                "expect:\n  stands: true\n",
                encoding="utf-8",
            )
            made.append((path, int(brick[1:3])))
    return made


def run(path: str, name: str, level: int) -> tuple[str, str, str, float, float]:
    """One pull in one setting: (file name, setting, verdict, largest drag above in mm, wall s)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import pull_freeze

    import stability._drag as drag
    import stackdsl.runtime.actions as actions
    from stackdsl import compile_scenario, parse_scenario, run_program
    from stackdsl.compile.program import PULL_STEP
    from stackdsl.engines.pybullet.world import PyBulletWorld

    hz = int(name[6:]) if name.startswith("ext-hz") else None  # ext-hz480: a pull's substeps at 480 Hz
    actions.PULL_STEP = 1.0 / hz if hz else PULL_STEP  # a worker runs several settings
    split = int(name[9:]) if name.startswith("ext-split") else None  # ext-split25: 25 iterations a substep
    if not hasattr(PyBulletWorld, "_kept_stepping"):
        PyBulletWorld._kept_stepping = PyBulletWorld._stepping  # type: ignore[attr-defined]
    kept = PyBulletWorld._kept_stepping  # type: ignore[attr-defined]

    def stepping(self: PyBulletWorld, on: bool) -> None:
        kept(self, on)
        iterations = split if on and split else self._engine.solver_iterations
        self._client.setPhysicsEngineParameter(numSolverIterations=iterations)

    PyBulletWorld._stepping = stepping  # type: ignore[method-assign]
    plain = "ext" if hz or split else name
    text, mode, backend, drag.DRAG_SAFETY, drag.TIE_SAFETY = pull_freeze.setting(plain, Path(path).read_text(encoding="utf-8"))
    if mode == "extension-free":
        mode = "extension"
        PyBulletWorld.merge = lambda self, bodies: False  # type: ignore[method-assign]
    program = compile_scenario(parse_scenario(text, path), mode, None, backend)
    started = time.perf_counter()
    out = run_program(program)
    wall = time.perf_counter() - started
    above = [d for b, d in out.displacement.items() if b[:1] == "L" and int(b[1:3]) > level]
    verdict = f"collapse {out.collapse.level}" if out.collapse else "stands"
    return Path(path).name, name, verdict, max(above, default=0.0) * 1000, wall


def main(folder: Path, names: list[str], speeds: list[int], levels: range | None) -> None:
    made = cells(folder, speeds, levels)
    print(f"{len(made)} pulls into {folder}; load average {os.getloadavg()[0]:.1f}", flush=True)
    with ProcessPoolExecutor(2) as pool:
        jobs = [pool.submit(run, str(p), n, level) for p, level in made for n in names]
        results = [j.result() for j in jobs]
    print("| pull | setting | verdict | largest drag above (mm) | wall (s) |")
    print("|---|---|---|---:|---:|")
    for file, name, verdict, most, wall in results:
        print(f"| {file} | {name} | {verdict} | {most:.2f} | {wall:.2f} |")
    first = {f: v for f, n, v, *_ in results if n == names[0]}
    for name in names:
        mine = {f: v for f, n, v, *_ in results if n == name}
        stood = sum(v == "stands" for v in mine.values())
        differ = sum(mine[f] != first[f] for f in mine)
        print(f"{name}: {stood} of {len(mine)} stand; {differ} verdicts differ from {names[0]}'s")
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main(
        Path(sys.argv[1]),
        sys.argv[2].split(",") if len(sys.argv) > 2 else ["ext", "ext-free"],
        [int(s) for s in sys.argv[3].split(",")] if len(sys.argv) > 3 else [20, 60],
        range(int(sys.argv[4].split("-")[0]), int(sys.argv[4].split("-")[1]) + 1) if len(sys.argv) > 4 else None,
    )
