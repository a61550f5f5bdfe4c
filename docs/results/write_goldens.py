"""Write the golden snapshots of the shipped scenarios on either engine, outside pytest
(docs/results/portability.md).

    python docs/results/write_goldens.py /tmp/goldens/mujoco-1 --backend mujoco

Each scenario under ``scenarios/`` (or the folders given with ``--scenarios``) is run in this
process, in file order, in its own mode on ``--backend`` (default: its own engine), and its
``Outcome.golden()`` is written as pytest's plugin writes it, to ``OUT/golden/<folder>/<stem>.json``.
A scenario the engine refuses (beyond what it simulates faithfully) is listed and not written.
Two runs of this into two folders, compared by ``docs/results/golden_diff.py``, say whether a
run repeats bit for bit. Source: stackdsl's own (a measurement script, not part of the package).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from stackdsl import ScenarioError, compile_scenario, load_scenario, run_program
from stackdsl.verdicts.snapshot import dumps

ROOT = Path(__file__).resolve().parents[2]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path, help="folder to write golden/ into")
    parser.add_argument("--backend", choices=("pybullet", "mujoco"), default=None)
    parser.add_argument("--scenarios", nargs="+", type=Path, default=[ROOT / "scenarios"])
    args = parser.parse_args(argv)
    start = time.perf_counter()
    written = 0
    for folder in args.scenarios:
        for path in sorted(folder.rglob("*.yaml")):
            scenario = load_scenario(path)
            try:
                program = compile_scenario(scenario, None, backend=args.backend)
            except ScenarioError as exc:
                print(f"refused: {path.relative_to(ROOT)}: {exc.message}")
                continue
            target = args.out / "golden" / path.relative_to(ROOT).with_suffix(".json")
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(dumps(run_program(program).golden()) + "\n")
            written += 1
    print(f"{written} goldens written to {args.out / 'golden'} in {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
