"""A scenario's ``require:``: conditions a sample's draws must meet, checked before simulating.

Each condition (:mod:`stackdsl.lang.expressions`) reads the scene's fields by their path
(``timing.placement_error``, ``structure.tower.spacing``, ``structure.tower.shift.0``,
``structure.left.tower.levels`` for a part, or ``structure.0.tower.levels`` in a list of parts;
a tower's shift drawn per layer as its ``shifts``, ``structure.tower.shifts.0.0``; a name that
reads no number is refused at its condition, :func:`unreadable`) and these quantities of the bricks where the program
puts them (placement error included), all in metres:

* ``overhang``: how far the top level's centre (the mean of its bricks' centres) lies from the
  centre of the level below, horizontally;
* ``max_overhang``: the largest such distance between a level and the one below it;
* ``com_offset``: the largest horizontal distance, over the levels L and every level T above it
  (the top while it is built), from the centre of mass of levels L + 1 to T to the centre of
  level L (a single-file stack of bricks of length l stands while it is built when this is
  below l / 2: the harmonic-stack condition at every stage);
* ``gap``: the smallest horizontal gap between two bricks of one level (their footprints), or
  infinity when no level has two bricks;
* ``levels``, ``bricks``: how many levels and bricks are built.

A random scene's sample ``k`` is its first draw that meets every condition: draw ``j`` of sample
``k`` comes from ``SeedSequence(seed, spawn_key=(k,))`` for j = 0 (as without ``require``) and
``spawn_key=(k, j)`` after, so it is a function of (seed, k) whoever draws it; after
:data:`MAX_DRAWS` draws that all fail, the file is refused at the condition that failed most.

Source: stackdsl's own (rejection sampling as in Scenic: Fremont et al., PLDI 2019).
"""

from __future__ import annotations

import itertools
import math
from collections import Counter
from time import perf_counter
from typing import Any, NamedTuple

import numpy as np
from shapely import Polygon, STRtree

from stability import Box

from ..lang.distributions import tower_field
from ..lang.errors import FieldPath, ScenarioError
from ..lang.expressions import Condition, check_kinds, parse
from ..lang.field_kinds import field_kind
from ..lang.schema import Scenario, Structure
from ..lang.schema_parts import LAYOUTS, named_parts
from ..lang.validation_errors import fields_at
from .layouts import LaidBrick, with_placement_error
from .parts import arrange

MAX_DRAWS = 1000
"""Draws a sample may take to meet its conditions; more is a ScenarioError."""
DRAW_TIME = 30.0
"""Wall seconds a sample's draws may take to meet its conditions, at most (a run's ``--timeout``
narrows it); past it the file is refused as past :data:`MAX_DRAWS`. A draw of a 1000-level
random tower takes about 40 ms, so its 1000 draws fit; a scene whose draws cost more is refused
after this long, not after minutes."""
DERIVED = ("overhang", "max_overhang", "com_offset", "gap", "levels", "bricks")
KIND = {
    "overhang": "length",
    "max_overhang": "length",
    "com_offset": "length",
    "gap": "length",
    "levels": "count",
    "bricks": "count",
}
"""The kind of quantity of each derived name (:data:`stackdsl.lang.expressions.KINDS`)."""


def accept(scenario: Scenario, seconds: float | None = None) -> tuple[Scenario, int]:
    """The sample to run for ``scenario`` and how many draws it took (1 without ``require``).

    A random scene's sample is redrawn (attempt 1, 2, ...) until its conditions hold, for at
    most :data:`MAX_DRAWS` draws and ``seconds`` of wall time (a run's ``--timeout``; at most,
    and by default, :data:`DRAW_TIME`). The clock only ends the search: a sample that is found
    is the same whatever the budget, a function of (seed, k).

    Raises:
        ScenarioError: a condition names an unknown field or quantity (at it); a scene that is
            not random fails a condition; no draw meets them within :data:`MAX_DRAWS` draws or
            the time (at the condition that failed most, with the draws tried and the time).
    """
    if not scenario.require:
        return scenario, 1
    budget = DRAW_TIME if seconds is None else min(seconds, DRAW_TIME)
    started = perf_counter()
    conditions = [parse(text) for text in scenario.require]
    _check_names(scenario, conditions)
    wanted = {name for c in conditions for name in c.names}
    template = scenario.template
    failed: Counter[int] = Counter()
    by_zero: Counter[int] = Counter()  # the draws in which a condition failed dividing by zero
    seen: dict[str, tuple[float, float]] = {}  # each name's lowest and highest value over the draws
    tried = 0
    for attempt in range(MAX_DRAWS if template is not None else 1):
        if attempt and perf_counter() - started > budget:
            break
        tried += 1
        candidate = scenario if attempt == 0 else template.scenario(*scenario.sample, attempt=attempt)
        values = quantities(candidate, wanted)
        _note_ranges(seen, values, wanted)
        broken = next((i for i, c in enumerate(conditions) if not c.holds(values)), None)
        if broken is None:
            return candidate, attempt + 1
        failed[broken] += 1
        by_zero[broken] += conditions[broken].divides_by_zero(values)
        if template is None:
            raise _not_met(scenario, broken, conditions[broken], values, bool(by_zero[broken]))
    elapsed = perf_counter() - started
    worst, count = failed.most_common(1)[0]
    c, k = scenario.sample
    why = (
        "it divides by zero in every one of them (a division by zero makes a condition false); change the condition"
        if by_zero[worst] == count
        else advice(conditions[worst], seen)
    )
    over = _time_taken(tried, elapsed, budget, seconds)
    raise scenario.source.error(
        ("require", worst),
        f"sample {k}{f' of grid cell {c}' if template is not None and template.grid else ''}: none of "
        f"{tried} draws met every condition{over}; {count} failed this one; {why}",
    )


def _not_met(scenario: Scenario, i: int, condition: Condition, values: dict[str, float], by_zero: bool) -> ScenarioError:
    """The error at ``require[i]`` when a scene that is not random fails its ``condition``: the
    ``values`` it read, and whether it divided by zero."""
    shown = ", ".join(f"{n} = {_with_unit(n, values.get(n, math.nan))}" for n in condition.names)
    zero = "; it divides by zero" if by_zero else ""
    return scenario.source.error(("require", i), f"the scene does not meet it ({shown}{zero}); it is not random")


def _note_ranges(seen: dict[str, tuple[float, float]], values: dict[str, float], wanted: set[str]) -> None:
    """Widen ``seen`` (each name's lowest and highest value over the draws) by this draw's
    ``values`` of the ``wanted`` names; a name this draw lacks (NaN) is left out."""
    for name in wanted:
        value = values.get(name, math.nan)
        if not math.isnan(value):  # a name this draw lacks is left out: no draw may have it
            lo, hi = seen.get(name, (value, value))
            seen[name] = (min(lo, value), max(hi, value))


def _time_taken(tried: int, elapsed: float, budget: float, seconds: float | None) -> str:
    """How long ``tried`` draws took (``elapsed`` s), for the message when none met the
    conditions: when they ran out of time, which limit (``--timeout``, ``seconds``, or the
    :data:`DRAW_TIME` a sample may take: ``budget``) stopped them."""
    if tried >= MAX_DRAWS:
        return f" (in {elapsed:.1f} s)"
    limit = (
        f"--timeout {budget:g}"
        if seconds is not None and seconds < DRAW_TIME
        else f"the {DRAW_TIME:g} s a sample's draws may take"
    )
    return f" in {elapsed:.1f} s, stopped by {limit} before the {MAX_DRAWS} draws it may take"


#: The least a derived quantity can be, whatever is drawn: a distance or a count is never negative.
LEAST = {name: 0.0 for name in DERIVED}
_UNITS = {"length": "m", "time": "s", "speed": "m/s", "angle": "deg", "per time": "/s", "density": "kg/m^3"}


def advice(condition: Condition, seen: dict[str, tuple[float, float]]) -> str:
    """What to change when no draw met ``condition``, given the lowest and highest value each name
    took over the draws (``seen``): a name that took one value in every draw is what no
    distribution changes, and the others may be anything they can be (a derived quantity is never
    negative). When the condition cannot hold even so, the distributions are not what limits it:
    say so, and why; else the distributions (or the condition) are to be widened.

    >>> advice(parse("levels > 100"), {"levels": (5.0, 5.0)})
    'it can never hold, whatever is drawn: levels is 5 in every draw (no distribution changes it); change the condition'
    >>> advice(parse("com_offset > 1 m"), {"com_offset": (0.01, 0.2)})
    'widen the distributions or the condition (com_offset was 10 to 200 mm in these draws)'
    """
    fixed = {n: lo for n, (lo, hi) in seen.items() if n in condition.names and lo == hi}
    missing = [n for n in condition.names if n not in seen]  # no draw had it (NaN): it compares false
    ranges = {n: (v, v) for n, v in fixed.items()} | {n: (math.nan, math.nan) for n in missing}
    free = [n for n in condition.names if n not in ranges]
    ranges |= {n: (LEAST[n], math.inf) for n in free if n in LEAST}
    if not condition.can_hold(ranges):
        return (
            f"it can never hold, whatever is drawn: {_why_never(condition, ranges, fixed, missing, free)}; change the condition"
        )
    spread = [f"{n} was {_with_unit(n, seen[n][0], bare=True)} to {_with_unit(n, seen[n][1])}" for n in free]
    return "widen the distributions or the condition" + (f" ({', '.join(spread)} in these draws)" if spread else "")


def _why_never(
    condition: Condition, ranges: dict[str, tuple[float, float]], fixed: dict[str, float], missing: list[str], free: list[str]
) -> str:
    """Why ``condition`` cannot hold with its names in ``ranges`` (see :func:`advice`): the names
    whose range alone keeps it from holding (all of them when it takes more than one): one
    ``fixed`` in every draw, ``missing`` from every draw, or ``free`` but never below 0."""
    reasons = {n: f"{n} is {_with_unit(n, v)} in every draw (no distribution changes it)" for n, v in fixed.items()}
    reasons |= {n: f"no draw of the scene has {n}" for n in missing}
    reasons |= {n: f"{n} is never below 0" for n in free if n in LEAST}
    # the names whose range alone keeps it from holding; all of them when it takes more than one
    causes = [n for n in reasons if condition.can_hold({m: r for m, r in ranges.items() if m != n})] or list(reasons)
    return "; ".join(reasons[n] for n in causes) or "not for any values"


def _with_unit(name: str, value: float, bare: bool = False) -> str:
    """``value`` of ``name`` with its unit: SI (degrees for angles), a length in mm as a file
    writes it: ``"125 mm"``, ``"0.5 s"``, ``"5"`` for a count; ``bare``: the number alone (the
    first of a range)."""
    kind = KIND.get(name) or field_kind(name)
    if kind == "length" and math.isfinite(value):
        value, unit = value * 1000, "mm"
    else:
        unit = _UNITS.get(kind, "")
    return f"{_shown(value)} {unit}" if unit and not bare else _shown(value)


def quantities(scenario: Scenario, wanted: set[str] | None = None) -> dict[str, float]:
    """Every name a condition may read: the derived quantities (module docstring; only those in
    ``wanted`` when given, as ``gap`` compares every pair of bricks of a level) and each numeric
    field of the scene, by path (``timing.interval``), in SI units and degrees (only when a name
    in ``wanted`` is no derived one, or ``wanted`` is empty or None: the scene's plain data is
    most of a draw's cost on a tall tower)."""
    values = {}
    derived = set(DERIVED) if wanted is None else set(DERIVED) & wanted
    if derived:
        bricks = [b for b in with_placement_error(scenario, arrange(scenario)) if not b.fixed]
        values = {k: v for k, v in _derived(scenario, bricks, "gap" in derived, "com_offset" in derived).items() if k in derived}
    if not wanted or not wanted <= set(DERIVED):
        _fields(scene(scenario), "", values)
    return values


def scene(scenario: Scenario) -> dict[str, Any]:
    """The fields of ``scenario`` as a condition reads them: its plain data (SI numbers), without
    ``expect``, ``sweep`` and ``require``, the structure's parts under ``structure`` by their names
    and, in a list of parts, by their indices too (``structure.left`` and ``structure.0``)."""
    data = scenario.model_dump(exclude={"expect", "sweep", "require"})
    parts = scenario.structure.parts
    if parts is not None:
        dumped = [(name, path[-1], data["structure"]["parts"][path[-1]]) for name, path, _ in named_parts(parts)]
        data["structure"] = {str(at): part for _, at, part in dumped} | {name: part for name, _, part in dumped if name}
    return data


def _fields(data: Any, prefix: str, out: dict[str, float]) -> None:
    if isinstance(data, bool) or data is None:
        return
    if isinstance(data, (int, float)):
        out[prefix.rstrip(".")] = float(data)
    elif isinstance(data, dict):
        for key, value in data.items():
            _fields(value, f"{prefix}{key}.", out)
    elif isinstance(data, (list, tuple)):
        for i, value in enumerate(data):
            _fields(value, f"{prefix}{i}.", out)


#: Levels whose centre-of-mass offsets :func:`_com_offsets` takes at once.
_ROWS = 32


def _com_offsets(mass: Any, moment: Any, centres: Any) -> list[float]:
    """For each level i but the top, the largest horizontal distance, m, from the centre of mass
    of levels i + 1 to T to ``centres[i]``, over every T above i (the levels' ``mass``, kg,
    ``moment``, kg m, and ``centres``, m, in order).

    The sums run from level i + 1 up, as ``np.cumsum(moment[i + 1:])`` gives them, for
    :data:`_ROWS` levels at once: each row holds the levels from the block's first i + 1 up,
    those not above its own i zeroed, and zeros added first change no bit, so a random tower's
    draws are accepted exactly as with a cumsum a level (at 1000 levels, 16 ms against 43)."""
    n = len(mass)
    out: list[float] = []
    for start in range(0, n - 1, _ROWS):
        rows = np.arange(start, min(n - 1, start + _ROWS))
        above = np.arange(start + 1, n)[None, :] > rows[:, None]  # (rows, levels from start + 1): T above i
        weight = np.cumsum(np.where(above, mass[None, start + 1 :], 0.0), axis=1)
        x = np.cumsum(np.where(above, moment[None, start + 1 :, 0], 0.0), axis=1)
        y = np.cumsum(np.where(above, moment[None, start + 1 :, 1], 0.0), axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):  # 0 / 0 where nothing is above yet: masked out
            dx = x / weight - centres[rows, 0][:, None]
            dy = y / weight - centres[rows, 1][:, None]
        out += np.where(above, np.sqrt(dx * dx + dy * dy), -np.inf).max(axis=1).tolist()
    return out


def _derived(scenario: Scenario, bricks: list[LaidBrick], gap: bool, com: bool = True) -> dict[str, float]:
    if not bricks:
        return dict.fromkeys(DERIVED, 0.0)
    grouped: dict[int, list[LaidBrick]] = {}
    for b in bricks:  # one pass: a level's bricks in their order
        grouped.setdefault(b.level, []).append(b)
    levels = sorted(grouped)
    by_level = {level: grouped[level] for level in levels}
    centres = {level: np.mean([b.position[:2] for b in bs], axis=0) for level, bs in by_level.items()}
    steps = [float(np.linalg.norm(centres[hi] - centres[lo])) for lo, hi in itertools.pairwise(levels)]
    masses = {name: _mass(scenario, name) for name in {b.type for b in bricks}}
    mass = np.array([sum(masses[b.type] for b in by_level[level]) for level in levels])
    moment = np.array([sum(masses[b.type] * b.position[:2] for b in by_level[level]) for level in levels])
    below = np.array([centres[level] for level in levels])
    offsets = _com_offsets(mass, moment, below) if com else []
    gaps = [_gap(scenario, bs) for bs in by_level.values() if gap and len(bs) > 1]
    return {
        "overhang": steps[-1] if steps else 0.0,
        "max_overhang": max(steps, default=0.0),
        "com_offset": max(offsets, default=0.0),
        "gap": min(gaps, default=math.inf),
        "levels": float(len(levels)),
        "bricks": float(len(bricks)),
    }


def _gap(scenario: Scenario, bricks: list[LaidBrick]) -> float:
    """The smallest horizontal gap between two of ``bricks``' footprints, m: 0 where two touch or
    overlap (shapely's STRtree finds each one's nearest, so a long row costs n log n, not n^2;
    its nearest leaves out a footprint equal to the one asked, so overlaps are asked first: a
    level of three bricks laid at one place, spacing 0, had no nearest at all)."""
    footprints = [_footprint(scenario, b) for b in bricks]
    tree = STRtree(footprints)
    inputs, found = tree.query(footprints, predicate="intersects")
    if bool((inputs != found).any()):
        return 0.0
    return min(
        float(footprints[i].distance(footprints[j]))
        for i, j in tree.query_nearest(footprints, exclusive=True, all_matches=False).T
    )


def _mass(scenario: Scenario, name: str) -> float:
    """The mass of a brick of type ``name``, kg."""
    kind = scenario.brick_type(name)
    return float(np.prod(kind.size)) * scenario.material(kind.material).density


def _footprint(scenario: Scenario, brick: LaidBrick) -> Polygon:
    """The brick's outline seen from above (the hull of its corners), m."""
    corners = Box(np.array(scenario.brick_type(brick.type).size) / 2, 1.0).corners(brick.pose())[:, :2]
    return Polygon(corners).convex_hull


def _check_names(scenario: Scenario, conditions: list[Condition]) -> None:
    known = {**quantities(scenario, set()), **dict.fromkeys(DERIVED, 0.0)}
    tree = scene(scenario)
    listed = isinstance(scenario.structure.parts, list)
    for i, condition in enumerate(conditions):
        unknown = [n for n in condition.names if n not in known and not _a_field(n)]
        if unknown:
            fields = sorted(n for n in known if n not in DERIVED)
            near = [f for f in fields if f.split(".")[-1] == unknown[0].split(".")[-1]][:3]
            hint = f"; did you mean {', '.join(near)}?" if near else ""
            raise scenario.source.error(
                ("require", i),
                f"unknown name {unknown[0]!r}: a condition reads {', '.join(DERIVED)} or a numeric field of the scene "
                f"by its path (timing.interval, structure.tower.spacing){hint}",
            )
        for name in condition.names:
            why = None if name in DERIVED else unreadable(tree, name, scenario.template, listed)
            if why is not None:
                raise scenario.source.error(("require", i), why)
        try:
            check_kinds(condition, {n: KIND.get(n) or field_kind(n) for n in condition.names})
        except ValueError as exc:
            raise scenario.source.error(("require", i), str(exc)) from None


def _a_field(name: str) -> bool:
    """Whether ``name`` is a path of the language's fields, whatever its indices (a draw of a random
    scene may have a list item, or a part's field, that the first draw lacks)."""
    path = [int(p) if p.isdigit() else p for p in name.split(".")]
    for i, part in enumerate(path):
        if isinstance(part, int):
            continue
        allowed = fields_at(tuple(path[:i]))
        if path[:i] == ["structure"] and part not in allowed:
            continue  # a part's name
        if part not in allowed:
            return False
    return True


def unreadable(tree: dict[str, Any], name: str, template: Any = None, listed: bool = False) -> str | None:
    """Why ``name`` (a field's path in a condition) reads no number of the scene ``tree``
    (:func:`scene`) in any draw, or None when it reads one (in this draw, or may in another: an
    item of a list, or a field, that a distribution of ``template`` draws or makes). ``listed``:
    the structure is a list of parts (``structure.left`` is then ``structure.0`` in the file).

    A tower's ``shift`` drawn ``per: layer`` is no one number: its draws are its ``shifts``, which
    the answer names.

    >>> tree = {"structure": {"tower": {"levels": 3, "shift": [0.0, 0.0], "shifts": None}}}
    >>> unreadable(tree, "structure.tower.levels"), unreadable(tree, "structure.tower.levels.0")
    (None, "no such field 'structure.tower.levels.0': structure.tower.levels is a number, with no item 0")
    >>> unreadable(tree, "structure.tower.shift.2")
    "no such field 'structure.tower.shift.2': structure.tower.shift has items 0 (along x) and 1 (along y), no item 2"
    """
    why = _why(tree, name, template, listed)
    return why if why is None or why.startswith(repr(name)) else f"no such field {name!r}: {why}"


class _Walk(NamedTuple):
    """Where :func:`_why` has got to along a name: the scene's value there, its path in the file
    as read (a part of a list by its index), and the value it is in."""

    node: Any
    at: FieldPath
    parent: Any


def _why(tree: dict[str, Any], name: str, template: Any, listed: bool) -> str | None:
    """:func:`unreadable`'s answer before its prefix: the name followed one field or item at a time
    (:func:`_step`), then what it ends at (:func:`_at_the_end`)."""
    drawn = [d for d in template.distributions] if template is not None else []
    per_layer: dict[FieldPath, list[str]] = {}  # a tower whose shift is drawn per layer -> its columns in samples.csv
    for d in drawn:
        if (spot := tower_field(d.path)) and spot[1] == "shift" and d.per != "sample":
            per_layer.setdefault(spot[0], []).append(d.label)
    segs = name.split(".")
    walk = _Walk(tree, (), None)
    for i in range(len(segs)):
        step = _step(walk, segs, i, drawn, per_layer, listed)
        if not isinstance(step, _Walk):
            return step
        walk = step
    return _at_the_end(name, walk, drawn)


def _step(
    walk: _Walk, segs: list[str], i: int, drawn: list[Any], per_layer: dict[FieldPath, list[str]], listed: bool
) -> _Walk | str | None:
    """``walk`` one step on, into its field or item ``segs[i]``; or why it cannot go (a string), or
    None when a draw may make what is not there."""
    node, at, parent = walk
    seg, where = segs[i], ".".join(segs[:i])
    if seg == "shift" and at in per_layer:
        columns = " and ".join(per_layer[at])
        return (
            f"{'.'.join(segs)!r} is no one number: {where}.shift is drawn per layer, into {where}.shifts (samples.csv's "
            f"{columns}); read level 2's shift on level 1 as {where}.shifts.0.0 (along x) or "
            f"{where}.shifts.0.1 (along y), level 3's as {where}.shifts.1.0, and so on"
        )
    if node is None:
        if _made(at, drawn):
            return None
        kind = next((k for group in _ONE_OF for k in group if segs[i - 1] in group and parent.get(k) is not None), None)
        if kind is not None:
            return f"{'.'.join(segs[: i - 1])} is a {kind}, not a {segs[i - 1]}"
        return f"{where} is not given in this scene, so it has no {seg!r}"
    if isinstance(node, dict):
        return _into_field(walk, seg, where, listed)
    if isinstance(node, (list, tuple)):
        return _into_item(walk, seg, where, drawn, per_layer)
    if isinstance(node, bool) or not isinstance(node, (int, float)):
        return f"{where} is {node!r}, not a number"
    return f"{where} is a number, with no {'item' if seg.isdigit() else 'field'} {seg}"


def _into_field(walk: _Walk, seg: str, where: str, listed: bool) -> _Walk | str:
    """``walk`` (at a mapping) into its field ``seg`` (a part of the structure by its name), or
    what fields it has."""
    node, at, _ = walk
    if seg not in node:
        if at == ("structure",) and any(k not in Structure.model_fields for k in node):
            parts = [k for k in node if not k.isdigit()]
            return f"structure has no part {seg!r}; its parts are {', '.join(parts)}" + (
                f" (or by index, 0 to {len(node) - len(parts) - 1})" if listed else ""
            )
        has = [str(k) for k in node if at != ("structure",) or node[k] is not None]
        return f"{where or 'a scene'} has no field {seg!r}" + (f"; it has: {', '.join(has)}" if has else "")
    step = (_index_of(node, seg),) if at == ("structure",) and listed else (seg,)
    return _Walk(node[seg], (*at, *step), node)


def _into_item(walk: _Walk, seg: str, where: str, drawn: list[Any], per_layer: dict[FieldPath, list[str]]) -> _Walk | str | None:
    """``walk`` (at a list) into its item ``seg``, or why there is none (None: a longer list in
    another draw, the list or the tower's height being drawn)."""
    node, at, parent = walk
    if not seg.isdigit():
        return f"{where} is a list: name an item by its index, {where}.0"
    if int(seg) >= len(node):
        if _made(at, drawn) or (at[-1:] == ("shifts",) and at[:-1] in per_layer and _made(at[:-1] + ("levels",), drawn)):
            return None  # a longer list in another draw
        return f"{where} has {_items(where, len(node))}, no item {seg}"
    return _Walk(node[int(seg)], (*at, int(seg)), parent)


def _at_the_end(name: str, walk: _Walk, drawn: list[Any]) -> str | None:
    """Why what the whole ``name`` reaches (``walk``) is no number, or None when it is one (or
    a draw may make it)."""
    node = walk.node
    if node is None:
        return None if _made(walk.at, drawn) else f"{name} is not given in this scene"
    if isinstance(node, (list, tuple)):
        return f"{name} has {_items(name, len(node))}, not one number: name one, {name}.0"
    if isinstance(node, dict):
        return f"{name} has fields, not one number: name one ({', '.join(f'{name}.{k}' for k in list(node)[:3])}, ...)"
    if isinstance(node, bool) or not isinstance(node, (int, float)):
        return f"{name} is {node!r}, not a number"
    return None


def _items(where: str, n: int) -> str:
    """How a list of ``n`` items at ``where`` is said: a shift's two as along x and y."""
    last = where.rsplit(".", 2)
    if n == 2 and (last[-1] == "shift" or (len(last) > 1 and last[-2] == "shifts")):
        return "items 0 (along x) and 1 (along y)"
    return f"items 0 to {n - 1}" if n > 1 else "one item, 0" if n else "no items"


#: Fields of which a model takes one: an action's kind, a structure's (or a part's) layout.
_ONE_OF = (("remove", "push", "shake"), LAYOUTS)


def _made(at: FieldPath, drawn: list[Any]) -> bool:
    """Whether a distribution draws the field at ``at`` or one it is in (another draw may then
    have a field or an item this one lacks)."""
    return any(at[: len(d.path)] == d.path for d in drawn)


def _index_of(node: dict[str, Any], name: str) -> int:
    """The index of the part ``name`` in a list of parts as :func:`scene` gives it."""
    return next(int(k) for k, part in node.items() if k.isdigit() and part is node[name])


def _shown(value: float) -> str:
    return f"{value:.6g}"


__all__ = ["DERIVED", "MAX_DRAWS", "ScenarioError", "accept", "quantities", "scene", "unreadable"]
