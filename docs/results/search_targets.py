"""The counterexample target of docs/results/search.md: runs to the first counterexample of
searches/rare_overhang.yaml by the search (10 seeds) against plain sampling (the sweep's samples
in order, 10 seeds), and whether each counterexample file fails when run.

Plain sampling's first failure is counted on the sweep's own draws (Template.parameters, the k-th
child of the seed), each judged by the closed form (5 levels and a shift above 24 mm) rather than
simulated: the search's runs and tests/test_signed_margin.py show the simulation agrees with it
at 0.08 mm from the boundary. Run: python docs/results/search_targets.py [OUT]
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
from pathlib import Path

from stackdsl import load_scenario

FILE = "searches/rare_overhang.yaml"


def plain_first(seed: int, limit: int = 100_000) -> int:
    template = load_scenario(FILE, seed).template
    assert template is not None
    for k in range(limit):
        p = template.parameters(0, k)
        if p["structure.tower.levels"] == 5 and p["structure.tower.shift [m]"] > 0.024:
            return k + 1
    return limit


def main(out: Path) -> None:
    rows = []
    for seed in range(10):
        folder = out / f"seed{seed}"
        subprocess.run(
            [sys.executable, "-m", "stackdsl", "search", FILE, "-j", "1", "--seed", str(seed), "--out", str(folder)],
            capture_output=True,
            check=False,
        )
        summary = json.loads((folder / "search.json").read_text())
        files = summary["files"]
        reproduced = all(
            subprocess.run([sys.executable, "-m", "stackdsl", "run", f], capture_output=True, check=False).returncode == 1
            for f in files
        )
        rows.append((seed, summary["first"], plain_first(seed), len(files), reproduced))
        print(
            f"seed {seed}: search {summary['first']} runs, plain sampling {rows[-1][2]}, {len(files)} file(s), reproduced {reproduced}",
            flush=True,
        )
    search = statistics.median(r[1] or 10**9 for r in rows)
    plain = statistics.median(r[2] for r in rows)
    print(f"median runs to the first counterexample: search {search}, plain sampling {plain} ({plain / search:.1f}x)")
    print(f"every counterexample file fails when run: {all(r[4] for r in rows)}")


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "/tmp/search-targets"))
