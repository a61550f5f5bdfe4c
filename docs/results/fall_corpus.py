"""Write a folder of Jenga pulls that fell the tower, none of them shipped; or follow one's fall.

Each scene is a Jenga tower (three 75 x 25 x 15 mm maple blocks a layer, 25.5 mm apart, 8 to
16 levels, friction 0.3 to 0.6) from one level of which two blocks are pulled out, one after the
other, at 20, 40 or 80 mm/s: the middle one and then a side one, or a side one and then the
middle one. What is left of that level is one side block, and the tower above falls off it;
each expects the collapse at the top level and the levels two below the pulled one to stay. The
draws are seeded, so the folder is the same on every machine.

    python docs/results/fall_corpus.py FOLDER [COUNT]    # COUNT draws, 12 unless given
    stackdsl bench folder FOLDER --repeats 1             # each scene against the lean MuJoCo peer
    python docs/results/fall_corpus.py --drag FILE       # how far the tower above rides the last pull

With ``--drag``, FILE runs with four settings (the extension and tuned mode, on pybullet and
on MuJoCo; ``stackdsl run --record`` into a temporary folder), and for each the table gives, from
the start of the last pull, where the lowest level above the pulled one and the top level have
moved to (mm along x and y: the middle block of each) at a quarter, half and nine tenths of
the pull's length, and at the run's end.

Output: docs/actions.md and docs/results/actions-freeze.md, "A pull that fells the tower".
"""

from __future__ import annotations

import random
import subprocess
import sys
import tempfile
from pathlib import Path

SETTINGS = {
    "extension, pybullet": [],
    "tuned, pybullet": ["--mode", "tuned"],
    "extension, MuJoCo": ["--backend", "mujoco"],
    "tuned, MuJoCo": ["--mode", "tuned", "--backend", "mujoco"],
}


def scene(rng: random.Random) -> tuple[str, str]:
    """One draw: (a name, the scenario's text)."""
    levels = rng.choice([8, 10, 12, 14, 16])
    level = rng.randint(3, levels - 3)
    order = rng.choice(["ms", "sm", "ms"])  # the middle block first, or a side one first
    side = rng.choice([1, 3])
    speed = rng.choice([20, 40, 80])
    friction = rng.choice([0.3, 0.4, 0.5, 0.6])
    middle, edge = f"L{level:02d}.2", f"L{level:02d}.{side}"
    first, second = (middle, edge) if order == "ms" else (edge, middle)
    second_at = 1.5 * levels + 75 / speed + 2.5  # levels are placed 1.5 s apart; the first pull's 75 mm, then 2.5 s
    text = (
        f"stackdsl: 1\nmaterials: {{maple: {{density: 700 kg/m^3, friction: {friction}}}}}\n"
        "brick_types: {jenga: {size: [75 mm, 25 mm, 15 mm], material: maple}}\nground: {material: maple}\n"
        f"structure:\n  tower: {{levels: {levels}, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: jenga}}\n"
        "timing: {interval: 0.5 s, settle: 1 s}\nactions:\n"
        f"  - remove: {{brick: {first}, at: after level {levels}, speed: {speed} mm/s}}\n"
        f"  - remove: {{brick: {second}, at: {second_at:.1f} s, speed: {speed} mm/s}}\n"
        f"expect:\n  collapse: {levels}\n  stays: 1-{level - 2}\n"
    )
    return f"{levels}_{level}{order}{side}_{speed}_{friction}", text


def write(folder: Path, count: int) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    rng = random.Random(99)
    for i in range(count):
        name, text = scene(rng)
        (folder / f"f{i:02d}_{name}.yaml").write_text(text, encoding="utf-8")
    print(f"{count} scenes in {folder}")


def drag(file: Path) -> None:
    from stackdsl import load_trajectory, parse_scenario

    scenario = parse_scenario(file.read_text(encoding="utf-8"), str(file))
    last = [a.remove for a in scenario.actions if a.remove is not None][-1]
    level = int(last.brick[1:3])
    print(
        f"{file.name}: the last pull, {last.brick}; mm along x and y of the middle block of level {level + 1}, then of the top level\n"
    )
    print(f"| setting | verdict | {' | '.join(f'{share} of the pull' for share in ('1/4', '1/2', '9/10'))} | end |")
    print("|---|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for name, flags in SETTINGS.items():
            out = Path(tmp) / "run.npz"
            run = subprocess.run(
                [sys.executable, "-m", "stackdsl", "run", str(file), "--record", str(out), *flags],
                capture_output=True,
                text=True,
                check=False,
            )
            said = next((line for line in run.stdout.splitlines() if " on " in line and "simulated" in line), "?: ?")
            trajectory = load_trajectory(out)
            ids = [str(i) for i in trajectory.ids]
            top = max(int(i[1:3]) for i in ids if i.startswith("L"))
            watched = [ids.index(f"L{level + 1:02d}.2"), ids.index(f"L{top:02d}.2")]
            start = max(e.time for e in trajectory.events if e.kind == "remove")
            length, end = 0.075 / last.speed, float(trajectory.times[-1])
            then = trajectory.at(start - 1e-6).positions
            cells = []
            for t in (start + 0.25 * length, start + 0.5 * length, start + 0.9 * length, end):
                now = trajectory.at(min(t, end)).positions
                cells.append(
                    ", ".join(f"({(now[b, 0] - then[b, 0]) * 1000:.1f}, {(now[b, 1] - then[b, 1]) * 1000:.1f})" for b in watched)
                )
            print(f"| {name} | {said.split(': ', 1)[-1].split(' (')[0]} | {' | '.join(cells)} |")


def main(argv: list[str]) -> None:
    if argv[:1] == ["--drag"]:
        drag(Path(argv[1]))
    else:
        write(Path(argv[0]), int(argv[1]) if len(argv) > 1 else 12)


if __name__ == "__main__":
    main(sys.argv[1:])
