"""Write a folder of shaken stacks none of the shipped files are: for ``stackdsl bench folder``.

Each scene is one stack shaken once, after its last level: a single file (one KAPLA brick a
level, 3 to 12 levels, turned 0 or 90 degrees), a 4 stack (two bricks a layer, 96 mm apart,
3 to 10 levels) or a Jenga tower (three 75 x 25 x 15 mm blocks a layer, 25.5 mm apart, 3 to 8
levels), of one material (friction 0.25 to 0.7), shaken at 1 to 4 Hz along x, y or the diagonal
for 1 to 3 s with a peak acceleration of 0.2 g to 0.95 g, below and above the sliding threshold
mu g. The scenes carry no expectation: the bench times them and gives each side's verdict. The
draws are seeded, so the folder is the same on every machine; a draw whose amplitude passes the
100 mm a shake table moves is left out (``stackdsl check`` refuses it).

    python docs/results/shake_corpus.py FOLDER [COUNT]    # COUNT draws, 44 unless given
    stackdsl bench folder FOLDER --repeats 1              # each scene against the lean MuJoCo peer

Output: docs/results/shake-table.md, "What a ride's step costs".
"""

from __future__ import annotations

import math
import random
import sys
from pathlib import Path

#: name -> (density, kg/m^3; friction coefficient)
MATERIALS = {"pine": (500, 0.5), "slick": (500, 0.25), "grip": (600, 0.7), "maple": (700, 0.4)}


def scene(rng: random.Random) -> tuple[str, str] | None:
    """One draw: (a name, the scenario's text), or None when its amplitude passes 100 mm."""
    kind = rng.choice(["file", "four", "jenga", "file", "four"])
    density, friction = MATERIALS[rng.choice(list(MATERIALS))]
    if kind == "file":
        levels = rng.randint(3, 12)
        tower = f"{{levels: {levels}, bricks_per_layer: 1, turn: {rng.choice([0, 90])}, brick: b}}"
    elif kind == "four":
        levels = rng.randint(3, 10)
        tower = f"{{levels: {levels}, bricks_per_layer: 2, spacing: 96 mm, turn: 90, brick: b}}"
    else:
        levels = rng.randint(3, 8)
        tower = f"{{levels: {levels}, bricks_per_layer: 3, spacing: 25.5 mm, turn: 90, brick: b}}"
    size = "[75 mm, 25 mm, 15 mm]" if kind == "jenga" else "[120 mm, 24 mm, 8 mm]"
    frequency = rng.choice([1, 1.5, 2, 3, 4])
    peak = rng.uniform(0.2, 0.95) * 9.81
    amplitude = round(peak / (2 * math.pi * frequency) ** 2 * 1000, 1)
    direction = rng.choice(["[1, 0]", "[0, 1]", "[1, 1]"])
    duration = rng.choice([1, 2, 3])
    if amplitude > 100.0:
        return None
    text = (
        f"stackdsl: 1\nmaterials: {{m: {{density: {density} kg/m^3, friction: {friction}}}}}\n"
        f"brick_types: {{b: {{size: {size}, material: m}}}}\nground: {{material: m}}\n"
        f"structure:\n  tower: {tower}\ntiming: {{interval: 0.5 s, settle: 1 s}}\nactions:\n"
        f"  - shake: {{amplitude: {amplitude} mm, frequency: {frequency} Hz, duration: {duration} s, "
        f"direction: {direction}, at: after level {levels}}}\n"
    )
    return f"{kind}{levels}", text


def main(argv: list[str]) -> None:
    folder = Path(argv[0])
    folder.mkdir(parents=True, exist_ok=True)
    rng = random.Random(96)
    written = 0
    for i in range(int(argv[1]) if len(argv) > 1 else 44):
        drawn = scene(rng)
        if drawn is not None:
            (folder / f"shake{i:02d}_{drawn[0]}.yaml").write_text(drawn[1], encoding="utf-8")
            written += 1
    print(f"{written} scenes in {folder}")


if __name__ == "__main__":
    main(sys.argv[1:])
