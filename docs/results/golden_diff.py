"""Compare two folders of golden snapshots field by field (docs/results/portability.md).

    python docs/results/golden_diff.py golden/ /tmp/goldens/lowest/golden

Every ``*.json`` below either folder is read as a golden snapshot (``Outcome.golden()``, one
scenario a file, as stackdsl's pytest plugin writes it) and compared with the file of the same
relative path in the other folder. Numbers of a measured field are compared as numbers, and the
largest absolute difference of each field kind is printed, per scenario and over all of them:

- ``position_mm``, ``com_above_mm`` (mm), ``quaternion_xyzw`` (a component), ``mass_above_g`` (g),
  ``area_mm2`` (mm^2), ``load_share`` (a fraction), ``margin_mm`` (the certificate's margin, mm);
  each for the bricks present in both graphs (the final graph and the collapse graph).

Everything else is a verdict field, compared for equality, and counted when it differs:
``levels_placed``, the collapse record (``level``, ``brick``, ``brick_level``), the certificate's
``verdict``, ``kind`` and ``bricks``, a brick's ``level`` and ``state``, which bricks a brick rests
on (``rests_on``), which bricks a graph holds, a margin that is a number in one and none in the
other, a scenario file in one folder only.

Prints Markdown tables: one row per scenario that differs, then a row per field kind over all.
Exit status 0 when every file is identical field by field, 1 when any differs, 2 for a bad
argument. Source: stackdsl's own (a measurement script, not part of the package).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

#: Measured fields compared as numbers, with the unit printed beside their differences.
MEASURED = {
    "position_mm": "mm",
    "quaternion_xyzw": "component",
    "com_above_mm": "mm",
    "mass_above_g": "g",
    "area_mm2": "mm^2",
    "load_share": "",
    "margin_mm": "mm",
}


class Differences:
    """What differs between two snapshots: the largest absolute difference of each measured
    field kind and how many values of it differ; verdict fields that differ, counted by name."""

    def __init__(self) -> None:
        self.largest: dict[str, float] = defaultdict(float)
        self.changed: dict[str, int] = defaultdict(int)
        self.compared: dict[str, int] = defaultdict(int)
        self.verdicts: dict[str, int] = defaultdict(int)

    def number(self, kind: str, a: float, b: float) -> None:
        self.compared[kind] += 1
        if a != b:
            self.changed[kind] += 1
            self.largest[kind] = max(self.largest[kind], abs(a - b))

    def verdict(self, name: str) -> None:
        self.verdicts[name] += 1

    def __bool__(self) -> bool:
        return bool(self.changed or self.verdicts)


def compare(a: Any, b: Any, out: Differences, key: str = "") -> None:
    """Walk two snapshots side by side, ``key`` the name of the field they are."""
    if key in MEASURED:
        if a is None or b is None:  # a margin in one, none in the other
            if (a is None) != (b is None):
                out.verdict(f"{key} (none in one)")
            return
        for x, y in zip(a, b) if isinstance(a, list) else [(a, b)]:
            out.number(key, float(x), float(y))
        return
    if isinstance(a, dict) and isinstance(b, dict):
        if key in ("final_graph", "collapse_graph", "rests_on") and set(a) != set(b):
            out.verdict("bricks in the graph" if key != "rests_on" else "rests_on (the bricks below)")
        for k in a.keys() & b.keys():
            compare(a[k], b[k], out, k if key not in ("final_graph", "collapse_graph", "rests_on") else key + ".")
        return
    if key.endswith("."):  # a brick (of a graph) or a support (of rests_on) by its id
        return compare(a, b, out, "")
    if a != b:
        out.verdict(key or "snapshot")


def compare_folders(first: Path, second: Path) -> tuple[dict[str, Differences], int]:
    """Each relative path's differences (those that differ), and how many files were compared."""
    paths = sorted(
        {p.relative_to(first).as_posix() for p in first.rglob("*.json")}
        | {p.relative_to(second).as_posix() for p in second.rglob("*.json")}
    )
    found: dict[str, Differences] = {}
    for name in paths:
        out = Differences()
        one, two = first / name, second / name
        if not (one.is_file() and two.is_file()):
            out.verdict(f"file only in {first if one.is_file() else second}")
        else:
            compare(json.loads(one.read_text()), json.loads(two.read_text()), out)
        if out:
            found[name] = out
    return found, len(paths)


def _g(x: float) -> str:
    return f"{x:.4g}" if x and not math.isclose(x, round(x, 3)) else f"{round(x, 3):g}"


def report(found: dict[str, Differences], files: int, first: Path, second: Path) -> str:
    """Markdown: a row per scenario that differs, then a row per field kind over all."""
    lines = [
        f"{files} snapshots compared ({first} against {second}): {files - len(found)} identical field by field, {len(found)} differ.",
        "",
    ]
    if not found:
        return "\n".join(lines)
    kinds = [k for k in MEASURED if any(d.changed.get(k) for d in found.values())]
    lines += [
        "| scenario | " + " | ".join(f"{k} ({MEASURED[k] or 'fraction'})" for k in kinds) + " | verdict fields that differ |"
    ]
    lines += ["|---" * (len(kinds) + 2) + "|"]
    for name, d in found.items():
        cells = [f"{_g(d.largest[k])} ({d.changed[k]} of {d.compared[k]})" if d.changed.get(k) else "0" for k in kinds]
        verdicts = ", ".join(f"{v} ({n})" for v, n in sorted(d.verdicts.items())) or "none"
        lines.append(f"| {name.removesuffix('.json')} | " + " | ".join(cells) + f" | {verdicts} |")
    lines += ["", "| field kind | largest difference | values that differ | scenarios |", "|---|---|---|---|"]
    for k in MEASURED:
        changed = sum(d.changed.get(k, 0) for d in found.values())
        compared = sum(d.compared.get(k, 0) for d in found.values())
        where = sum(bool(d.changed.get(k)) for d in found.values())
        largest = max((d.largest.get(k, 0.0) for d in found.values()), default=0.0)
        lines.append(f"| {k} ({MEASURED[k] or 'fraction'}) | {_g(largest)} | {changed} of {compared} | {where} |")
    verdicts: dict[str, int] = defaultdict(int)
    for d in found.values():
        for v, n in d.verdicts.items():
            verdicts[v] += n
    lines.append(f"| verdict fields | {', '.join(f'{v} ({n})' for v, n in sorted(verdicts.items())) or 'none differ'} | | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("first", type=Path, help="a folder of golden snapshots (e.g. golden/)")
    parser.add_argument("second", type=Path, help="another one, written by other versions, another process or -n")
    args = parser.parse_args(argv)
    for folder in (args.first, args.second):
        if not folder.is_dir():
            parser.error(f"{folder}: not a folder")
    found, files = compare_folders(args.first, args.second)
    print(report(found, files, args.first, args.second))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
