"""A golden snapshot compared as a physicist would: verdicts exactly, measurements within
tolerances, what chaos decides loosely.

A scenario's golden snapshot (:meth:`stackdsl.Outcome.golden`) holds three kinds of field:

* **verdict fields**, compared exactly: the scenario and mode, the levels placed, how many
  bricks toppled, whether and at which level it collapsed, the certificate's verdict and kind,
  which bricks there are, and of every brick that stands (not ``moved``: within the collapse
  threshold of where it was placed) its level, its state and what it rests on;
* **measured fields**, compared within :class:`~stackdsl.verdicts.tolerances.Tolerances`: a
  standing brick's position (mm), turn (deg), centre of mass above (mm), mass above (g), and
  each support's contact area (mm^2) and load share; the certificate's margin (mm) and
  friction share;
* **what chaos decides**, compared loosely or not at all: which of twin bricks moved first
  (not compared) and its level (within ``level``), the bricks a collapse certificate names (not
  compared), which of the proofs racing to decide one collapse held first (:data:`RACING_PROOFS`), where debris lies (a brick beyond the collapse threshold in both: not compared), and
  a brick at the edge of what fell (beyond the threshold in one, standing in the other: allowed
  within ``level`` of a level that fell in the run where it stood, or where it was knocked
  short of the threshold).

:func:`compare_golden` lists what is outside its tolerance, worst first (verdicts, then the
measured fields by how many tolerances they are off), and says bricks that moved together in
one line: ``final_graph: levels 1-6 (12 bricks) moved by 6.0 mm in x``. Nothing within
tolerance is listed; what chaos decided differently is counted, and named on request.

Source: stackdsl's own.

>>> def brick(x):
...     return {"level": 1, "state": "frozen", "position_mm": [x, 0.0, 4.0], "displaced_mm": 0.0}
>>> stored = {"levels_placed": 1, "final_graph": {"b1": brick(0.0)}}
>>> compare_golden(stored, {"levels_placed": 1, "final_graph": {"b1": brick(0.4)}}).matches
True
>>> compare_golden(stored, {"levels_placed": 1, "final_graph": {"b1": brick(6.0)}}).lines()
['final_graph b1: moved by 6.0 mm in x (tolerance 1 mm)']
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..compile.program import Program
from ..runtime.outcome import Outcome
from .snapshot import GRAPHS
from .tolerances import ROUNDING_MM, Tolerances

#: Keys compared exactly at the top of a snapshot (any key not known here is compared exactly too).
_EXACT = ("scenario", "mode", "levels_placed", "toppled")
#: The kinds of :class:`Difference`: a verdict field, a measured one.
_VERDICT, _MEASURED = 0, 1


@dataclass(frozen=True)
class Difference:
    """One field outside its tolerance.

    Attributes:
        where: the snapshot's key path, ``'final_graph L05.1'`` or ``'certificate.kind'``.
        text: what changed, ``'moved by 6.0 mm in x (tolerance 1 mm)'``.
        kind: 0, a verdict field (compared exactly); 1, a measured field.
        excess: how many tolerances it is off (inf for a verdict field), for the order.
        brick: the brick it is of, or ``""``; delta: for a brick that moved as a whole, its
            move (mm, x y z), else None (bricks that moved alike are said together).
        level: the brick's level, or None.
        field: with ``delta``, what moved: ``"position"`` or ``"centre of mass above"``.
    """

    where: str
    text: str
    kind: int = _MEASURED
    excess: float = math.inf
    brick: str = ""
    delta: tuple[float, float, float] | None = None
    level: int | None = None
    field: str = ""


@dataclass
class Comparison:
    """What :func:`compare_golden` found.

    Attributes:
        differences: outside tolerance (the golden does not match when any).
        within: fields that differ within their tolerance.
        loose: fields that differ where chaos decides them and that are not compared (where
            debris lies; what the model measured of a brick knocked, tilted or loaded by one).
        chaos: what chaos decides that differs, in words (never a failure).
        tolerances: what was compared with.
    """

    differences: list[Difference] = field(default_factory=list)
    within: int = 0
    loose: int = 0
    chaos: list[str] = field(default_factory=list)
    tolerances: Tolerances = field(default_factory=Tolerances)

    @property
    def matches(self) -> bool:
        """No difference outside its tolerance."""
        return not self.differences

    def not_failures(self) -> list[str]:
        """What differs that is no failure, counted: within tolerance, and decided by chaos
        (``[]`` when nothing is)."""
        said = [f"{self.within} fields differ within their tolerance"] if self.within else []
        chaos = self.loose + len(self.chaos)
        if chaos:
            said.append(f"{chaos} differ where chaos decides (debris, which of twins fell first, what knocked bricks carry)")
        return [f"not failures: {'; '.join(said)}"] if said else []

    def lines(self, limit: int = 30) -> list[str]:
        """The differences, worst first, bricks that moved alike in one line; at most ``limit``
        lines, the rest counted."""
        ordered = sorted(self.differences, key=lambda d: (d.kind, -d.excess))
        said = _grouped(ordered, self.tolerances)
        if len(said) > limit:
            said = [*said[:limit], f"... and {len(said) - limit} more"]
        return said


def compare_golden(
    stored: Mapping[str, Any],
    new: Mapping[str, Any],
    tolerances: Tolerances | None = None,
    *,
    toppled: bool = False,
    may_fall: Iterable[int | str] = (),
) -> Comparison:
    """Compare a scenario's stored golden snapshot with this run's (both plain data, as
    :meth:`stackdsl.Outcome.golden` gives it), within ``tolerances`` (default: KAPLA's,
    :class:`~stackdsl.verdicts.tolerances.Tolerances`). A key one snapshot has and the other
    has not is a difference; keys it does not know are compared exactly.

    Args:
        toppled: the scene expects a number of toppled bricks (``expect: toppled``), which is
            then a verdict field, compared exactly; else how many pieces of debris lie tipped
            over is chaos's, and not compared.
        may_fall: the levels and bricks (ids, or starts of ids) the scene says may fall
            (``expect: may_fall``): whether one of them moved is chaos's.
    """
    t = tolerances or Tolerances()
    out = Comparison(tolerances=t)
    threshold = _threshold(stored, new)
    edge = (_near_fall(stored, t, threshold), _near_fall(new, t, threshold), tuple(may_fall))
    for key in dict.fromkeys([*stored, *new]):
        a, b = stored.get(key, _MISSING), new.get(key, _MISSING)
        if key == "toppled" and not toppled and a != b and a is not _MISSING and b is not _MISSING:
            out.chaos.append(f"toppled {_said(a)} -> {_said(b)} (debris tipped over; not expected by the scene)")
        elif key == "collapse":
            _collapse(out, a, b, t, (_fallen(stored, threshold), _fallen(new, threshold)))
        elif key == "certificate":
            _certificate(out, a, b, t)
        elif key in GRAPHS and isinstance(a, dict) and isinstance(b, dict):
            _graph(out, key, a, b, t, threshold, edge)
        elif key in GRAPHS and a != b:
            out.differences.append(Difference(key, f"{_bricks(a)} -> {_bricks(b)}", _VERDICT))
        elif a != b:
            out.differences.append(Difference(key, f"{_said(a)} -> {_said(b)}", _VERDICT))
    return out


def _bricks(graph: Any) -> str:
    """A graph in a few words: ``'none'``, ``'12 bricks'``."""
    if isinstance(graph, dict):
        return f"{len(graph)} brick{'' if len(graph) == 1 else 's'}"
    return _said(graph)


def _fallen(snapshot: Mapping[str, Any], threshold: float) -> set[str]:
    """The bricks beyond the collapse threshold at the collapse or at the end (a shaken brick
    that passed it may come back under it by the end): empty when the snapshot does not say."""
    graphs = [g for key in GRAPHS if isinstance(g := snapshot.get(key), dict)]
    return {x for graph in graphs for x, b in graph.items() if isinstance(b, dict) and _moved(b, threshold)}


def _threshold(*snapshots: Mapping[str, Any]) -> float:
    """The collapse threshold, mm, as the snapshots give it (the larger; 4 mm when neither does)."""
    given = [float(s["collapse_threshold_mm"]) for s in snapshots if _numbers(s.get("collapse_threshold_mm"))]
    return max(given) if given else 4.0


class _Missing:
    def __repr__(self) -> str:
        return "missing"


_MISSING: Any = _Missing()


def _said(value: Any) -> str:
    if value is _MISSING:
        return "missing"
    if value is None:
        return "none"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_said(v)}" for k, v in value.items()) + "}"
    return str(value)


def _collapse(out: Comparison, a: Any, b: Any, t: Tolerances, moved: tuple[set[str], set[str]]) -> None:
    """The collapse record: whether and at which level exactly; the brick that moved first
    loosely (chaos picks which of the bricks that fall together passes the threshold first): it
    must be one that moved in the other run too, and its level within ``level``."""
    if not (isinstance(a, dict) and isinstance(b, dict)):
        if a != b:
            out.differences.append(Difference("collapse", f"{_collapse_said(a)} -> {_collapse_said(b)}", _VERDICT))
        return
    for key in dict.fromkeys([*a, *b]):
        u, v = a.get(key, _MISSING), b.get(key, _MISSING)
        if u == v:
            continue
        if key == "brick" and (not all(moved) or (v in moved[0] and u in moved[1])):
            out.chaos.append(f"collapse.brick {_said(u)} -> {_said(v)} (both fell in both runs: chaos picks which passes first)")
        elif key == "brick" and isinstance(v, str):
            where = "did not move in the golden" if v not in moved[0] else f"{_said(u)} did not move in this run"
            out.differences.append(Difference("collapse.brick", f"{_said(u)} -> {v} ({where})", _VERDICT))
        elif key == "brick_level" and _numbers(u, v) and abs(u - v) <= t.level:
            out.chaos.append(f"collapse.brick_level {u} -> {v} (within {t.level} level)")
        elif key == "brick_level" and _numbers(u, v) and all(moved):
            out.chaos.append(f"collapse.brick_level {u} -> {v} (a brick that fell in both runs)")
        else:
            out.differences.append(Difference(f"collapse.{key}", f"{_said(u)} -> {_said(v)}", _VERDICT))


def _collapse_said(c: Any) -> str:
    if isinstance(c, dict) and "level" in c:
        return f"collapse {c['level']}"
    return "stands" if c is None else _said(c)


def _certificate(out: Comparison, a: Any, b: Any, t: Tolerances) -> None:
    if not (isinstance(a, dict) and isinstance(b, dict)):
        if a != b:
            out.differences.append(Difference("certificate", f"{_said(a)} -> {_said(b)}", _VERDICT))
        return
    for key in dict.fromkeys([*a, *b]):
        u, v = a.get(key, _MISSING), b.get(key, _MISSING)
        if u == v:
            continue
        if key == "bricks":
            out.chaos.append(f"certificate.bricks: {_ids(u, v)} (the bricks a collapse took with it)")
        elif key == "kind" and u in RACING_PROOFS and v in RACING_PROOFS:
            out.chaos.append(f"certificate.kind: {u} -> {v} (proofs of one collapse: the first to hold decides)")
        elif key in ("margin_mm", "friction_share") and _numbers(u, v):
            limit = t.margin_mm if key == "margin_mm" else t.friction_share
            _measured(out, f"certificate.{key}", float(u), float(v), limit, " mm" if key == "margin_mm" else "")
        else:
            out.differences.append(Difference(f"certificate.{key}", f"{_said(u)} -> {_said(v)}", _VERDICT))


#: The proofs that race to decide a collapse while it happens: a displaced brick's centre of mass
#: off its support, the brick come to rest displaced, a mechanism the stability model proved. The
#: collapse and its level are the same whichever holds first, and which does is chaos's: of ten
#: perturbations of jenga_falls (docs/results/goldens.md), five decided by "off its support" and
#: five by "at rest displaced" at the same level. The proofs at the end of a run and a stand's
#: kind are compared exactly.
RACING_PROOFS = frozenset({"off its support", "at rest displaced", "mechanism"})


def _ids(u: Any, v: Any) -> str:
    if isinstance(u, list) and isinstance(v, list):
        came, went = [x for x in v if x not in u], [x for x in u if x not in v]
        return "; ".join([*([f"added {len(came)}"] if came else []), *([f"left out {len(went)}"] if went else [])]) or "order"
    return f"{_said(u)} -> {_said(v)}"


def _numbers(*values: Any) -> bool:
    return all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in values)


def _measured(
    out: Comparison, where: str, u: float, v: float, limit: float, unit: str, brick: str = "", level: Any = None
) -> None:
    """A measured number: within ``limit`` counts as within, else a difference."""
    off = abs(v - u)
    if off <= limit + 1e-9:
        out.within += 1
        return
    out.differences.append(
        Difference(
            where,
            f"{_num(u)} -> {_num(v)}{unit} (tolerance {_num(limit)}{unit})",
            _MEASURED,
            off / limit if limit > 0 else math.inf,
            brick,
            level=level if isinstance(level, int) else None,
        )
    )


def _num(x: float) -> str:
    return f"{x:.3g}" if abs(x) < 1 else f"{x:.1f}".removesuffix(".0") if abs(x) >= 100 else f"{x:.3g}"


def _graph(
    out: Comparison,
    key: str,
    a: Mapping[str, Any],
    b: Mapping[str, Any],
    t: Tolerances,
    threshold: float,
    edge: tuple[set[int], set[int], tuple[int | str, ...]],
) -> None:
    came, went = [x for x in b if x not in a], [x for x in a if x not in b]
    if came or went:
        said = [*([f"added {_few(came)}"] if came else []), *([f"removed {_few(went)}"] if went else [])]
        out.differences.append(Difference(key, "; ".join(said), _VERDICT))
    unsettled, sound = _soundness(key, a, b, t, threshold)
    for brick in (x for x in a if x in b):
        u, v = a[brick], b[brick]
        if u == v:
            continue
        if not (isinstance(u, dict) and isinstance(v, dict)):
            out.differences.append(Difference(f"{key} {brick}", f"{_said(u)} -> {_said(v)}", _VERDICT, brick=brick))
            continue
        _brick(out, f"{key} {brick}", brick, u, v, t, threshold, edge, unsettled, brick in sound)


def _soundness(
    key: str, a: Mapping[str, Any], b: Mapping[str, Any], t: Tolerances, threshold: float
) -> tuple[set[str], set[str]]:
    """Of two graphs' bricks (``key``: which graph): those not settled in both (every brick but
    those at rest where placed in both; mid-collapse, in the collapse graph, only a frozen one
    counts), and those whose measures are sound: settled, with everything above them and all
    that these rest on settled too (what the stability model measured of a brick, its contact
    areas, load shares, centre of mass and mass above, is then the geometry's)."""
    shared = [x for x in a if x in b and isinstance(a[x], dict) and isinstance(b[x], dict)]
    # mid-collapse, a brick at rest where it was placed may be woken or lifted already: only a
    # frozen one is settled there
    still = {x for x in shared if key != "collapse_graph" or a[x].get("state") == b[x].get("state") == "frozen"}
    settled = {x for x in still if _settled(a[x], t, threshold) and _settled(b[x], t, threshold)}
    unsettled = {x for x in (*a, *b) if x not in settled}
    above = _above([a, b], shared)
    loaded = {x: _supports_of([a, b], x) for x in shared}
    sound = {
        x for x in settled if not (above[x] & unsettled) and not any(loaded.get(y, set()) & unsettled for y in {x} | above[x])
    }
    return unsettled, sound


def _few(ids: list[str]) -> str:
    return ", ".join(ids[:6]) + (f" and {len(ids) - 6} more" if len(ids) > 6 else "")


def _displaced(brick: Mapping[str, Any]) -> float | None:
    """mm a structure brick is from where it was placed (None: a thrown body or a pusher, or a
    snapshot that does not say)."""
    d: Any = brick.get("displaced_mm")
    return float(d) if _numbers(d) else None


def _moved(brick: Mapping[str, Any], threshold: float) -> bool:
    """Beyond the collapse threshold from where it was placed: debris."""
    d = _displaced(brick)
    return d is not None and d > threshold


def _settled(brick: Mapping[str, Any], t: Tolerances, threshold: float) -> bool:
    """At rest where it was placed (within :data:`AT_REST` of the position tolerance: as far as a
    brick sinks into what carries it and the snapshot rounds, never a nudge, a drag or a knock)
    and lying level: its contacts are faces, whose areas and loads the geometry decides, not the
    engine's contact points."""
    d = _displaced(brick)
    q = brick.get("quaternion_xyzw")
    at_rest = max(AT_REST * t.position_mm, ROUNDING_MM)
    return d is not None and d <= at_rest and isinstance(q, list) and len(q) == 4 and _numbers(*q) and _level(q)


#: The share of the position tolerance within which a brick is at rest where it was placed (0.25
#: mm for KAPLA): every brick of the shipped goldens that nothing touched is within 0.3 mm, most
#: 0.0 or 0.1 (sinking and rounding); a brick dragged by a pull, 0.5 to 1.3 mm.
AT_REST = 0.25


#: Degrees within which a brick lies level (a face horizontal): under the stability model's 0.5 deg
#: for faces that lie face to face (stability's FACE_TILT), with the snapshot's rounding to spare.
LEVEL_DEG = 0.3


def _level(q: list[float]) -> bool:
    """A face of the brick turned ``q`` (x, y, z, w) is horizontal within :data:`LEVEL_DEG`."""
    x, y, z, w = (float(c) for c in q)
    n = x * x + y * y + z * z + w * w
    if n == 0:
        return False
    s = 2.0 / n
    column_z = (s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y))  # the local axes' z components
    return max(abs(c) for c in column_z) >= math.cos(math.radians(LEVEL_DEG))


def _supports_of(graphs: list[Mapping[str, Any]], brick: str) -> set[str]:
    """What ``brick`` rests on in either snapshot."""
    out: set[str] = set()
    for graph in graphs:
        fields = graph.get(brick)
        supports = fields.get("rests_on") if isinstance(fields, dict) else None
        out |= set(supports) if isinstance(supports, dict) else set()
    return out


def _above(graphs: list[Mapping[str, Any]], bricks: list[str]) -> dict[str, set[str]]:
    """Each brick -> the bricks that rest on it, or on those, in either snapshot."""
    carried: dict[str, set[str]] = {x: set() for x in bricks}
    for graph in graphs:
        for upper, fields in graph.items():
            supports = fields.get("rests_on") if isinstance(fields, dict) else None
            for support in supports if isinstance(supports, dict) else ():
                carried.setdefault(support, set()).add(upper)
    out: dict[str, set[str]] = {}
    for brick in bricks:
        seen, todo = set(), list(carried.get(brick, ()))
        while todo:
            x = todo.pop()
            if x not in seen:
                seen.add(x)
                todo += carried.get(x, ())
        out[brick] = seen
    return out


def _may_fall(brick: str, level: Any, selection: tuple[int | str, ...]) -> bool:
    """Whether the scene says ``brick`` (of ``level``) may fall: its level, its id or the start of
    its id is in ``selection`` (an ``expect: may_fall``; ``'L05'`` is the start of ``'L05.2'``)."""
    return any(
        (isinstance(s, int) and s == level) or (isinstance(s, str) and (brick == s or brick.startswith(s.rstrip(".") + ".")))
        for s in selection
    )


def _near_fall(snapshot: Mapping[str, Any], t: Tolerances, threshold: float) -> set[int]:
    """The levels within ``level`` of a level at which a brick of ``snapshot`` moved (in either of
    its graphs): a brick there that moved in the other snapshot is at the edge of the same fall,
    which chaos draws (which twin goes first, how far the fall reaches down)."""
    fell: set[int] = set()
    for key in GRAPHS:
        graph = snapshot.get(key)
        if isinstance(graph, dict):
            fell |= _moved_levels(graph, threshold)
    return {n + k for n in fell for k in range(-t.level, t.level + 1)}


def _moved_levels(graph: Mapping[str, Any], threshold: float) -> set[int]:
    """The levels with a brick beyond the collapse threshold."""
    return {
        b["level"]
        for b in graph.values()
        if isinstance(b, dict) and _moved(b, threshold) and isinstance(b.get("level"), int) and not isinstance(b["level"], bool)
    }


def _brick(
    out: Comparison,
    where: str,
    brick: str,
    u: dict[str, Any],
    v: dict[str, Any],
    t: Tolerances,
    threshold: float,
    edge: tuple[set[int], set[int], tuple[int | str, ...]],
    unsettled: set[str],
    sound: bool,
) -> None:
    """One brick of both snapshots (module docstring): debris and thrown bodies by their level
    alone; a brick at a fall's edge loosely; a standing one's verdict fields exactly, its pose
    within the tolerance plus how far each run moved it, and, where its loads pass level faces
    of bricks at rest where placed (``sound``), what the stability model measured of it."""
    level = u.get("level")
    da, db = _displaced(u), _displaced(v)
    if _fate(out, where, brick, u, v, t, threshold, edge, da, db):
        return
    assert da is not None and db is not None  # _fate decides debris, which has no displacement
    knocked = da + db  # mm: how far the two runs moved it, together
    _state(out, where, brick, u, v, level, settled=brick not in unsettled)
    _position(out, where, brick, u, v, t, level, knocked)
    _turn(out, where, brick, u, v, t, level, knocked)
    _loads_above(out, where, brick, u, v, t, level, sound)
    _supports(out, where, brick, u.get("rests_on", {}), v.get("rests_on", {}), t, level, sound)
    for name in dict.fromkeys([*u, *v]):
        if name in _BRICK_FIELDS:
            continue
        if u.get(name, _MISSING) != v.get(name, _MISSING):
            text = f"{name} {_said(u.get(name, _MISSING))} -> {_said(v.get(name, _MISSING))}"
            out.differences.append(Difference(where, text, _VERDICT, brick=brick, level=level))


def _fate(
    out: Comparison,
    where: str,
    brick: str,
    u: dict[str, Any],
    v: dict[str, Any],
    t: Tolerances,
    threshold: float,
    edge: tuple[set[int], set[int], tuple[int | str, ...]],
    da: float | None,
    db: float | None,
) -> bool:
    """Whether the brick's level and fall already decide it (True: nothing more of it is
    compared): another level, debris or thrown in both runs (loose), or moved beyond the
    collapse threshold in one run only (``da``, ``db``: mm each run moved it), which is chaos's
    at a fall's edge (``edge``) and a verdict difference elsewhere."""
    level = u.get("level")
    if u.get("level", _MISSING) != v.get("level", _MISSING):
        text = f"level {_said(u.get('level', _MISSING))} -> {_said(v.get('level', _MISSING))}"
        out.differences.append(Difference(where, text, _VERDICT, brick=brick))
        return True
    if da is None or db is None or (_moved(u, threshold) and _moved(v, threshold)):  # debris, or thrown: chaos's
        out.loose += 1
        return True
    if _moved(u, threshold) == _moved(v, threshold):
        return False
    now = "moved beyond the collapse threshold; it stood" if _moved(v, threshold) else "stands; it had moved"
    standing = da if _moved(v, threshold) else db
    # near what fell in the run where it stood, or knocked there too: past the threshold or just short is chaos's
    if level in edge[0 if _moved(v, threshold) else 1] or standing > t.position_mm or _may_fall(brick, level, edge[2]):
        out.chaos.append(f"{where}: {now} in the golden")
        return True
    out.differences.append(Difference(where, f"{now} in the golden", _VERDICT, brick=brick, level=level))
    return True


def _state(out: Comparison, where: str, brick: str, u: dict[str, Any], v: dict[str, Any], level: Any, *, settled: bool) -> None:
    """The brick's state exactly where it ``settled`` in both runs; elsewhere a knock or a tilt
    can change it by chance."""
    if u.get("state", _MISSING) == v.get("state", _MISSING):
        return
    text = f"state {_said(u.get('state', _MISSING))} -> {_said(v.get('state', _MISSING))}"
    if settled:
        out.differences.append(Difference(where, text, _VERDICT, brick=brick, level=level))
    else:
        out.chaos.append(f"{where}: {text} (knocked or tilted)")


def _loads_above(
    out: Comparison, where: str, brick: str, u: dict[str, Any], v: dict[str, Any], t: Tolerances, level: Any, sound: bool
) -> None:
    """The centre of mass and the mass above the brick, within tolerance where its loads are
    ``sound``; loose elsewhere."""
    if not sound:
        if any(u.get(k) != v.get(k) for k in ("com_above_mm", "mass_above_g")):
            out.loose += 1
        return
    _com_above(out, where, brick, u, v, t, level)
    p, q = u.get("mass_above_g", _MISSING), v.get("mass_above_g", _MISSING)
    if p != q and _numbers(p, q):
        _measured(out, f"{where} mass above", float(p), float(q), t.mass_g(max(p, q)), " g", brick, level)
    elif p != q:
        out.differences.append(Difference(where, f"mass above {_said(p)} -> {_said(q)}", _VERDICT, brick=brick))


_BRICK_FIELDS = ("level", "state", "position_mm", "quaternion_xyzw", "com_above_mm", "mass_above_g", "rests_on", "displaced_mm")


def _position(
    out: Comparison, where: str, brick: str, u: dict[str, Any], v: dict[str, Any], t: Tolerances, level: Any, knocked: float
) -> None:
    """Within the position tolerance plus ``knocked`` (mm the two runs moved the brick from where
    it was placed, together: how far apart chaos alone can leave it)."""
    p, q = u.get("position_mm"), v.get("position_mm")
    if p == q:
        return
    if not (isinstance(p, list) and isinstance(q, list) and len(p) == len(q) == 3 and _numbers(*p, *q)):
        out.differences.append(Difference(where, f"position {_said(p)} -> {_said(q)}", _VERDICT, brick=brick))
        return
    delta = np.subtract(q, p)
    off = float(np.linalg.norm(delta))
    limit = t.position_mm + knocked
    if off <= limit + 1e-9:
        out.within += 1
        return
    out.differences.append(
        Difference(
            where,
            f"moved by {_direction(delta, t.position_mm)} (tolerance {_num(limit)} mm)",
            _MEASURED,
            off / limit,
            brick,
            (float(delta[0]), float(delta[1]), float(delta[2])),
            level if isinstance(level, int) else None,
            "position",
        )
    )


def _com_above(out: Comparison, where: str, brick: str, u: dict[str, Any], v: dict[str, Any], t: Tolerances, level: Any) -> None:
    p, q = u.get("com_above_mm"), v.get("com_above_mm")
    if p == q:
        return
    if not (isinstance(p, list) and isinstance(q, list) and len(p) == len(q) == 3 and _numbers(*p, *q)):
        out.differences.append(Difference(where, f"com_above_mm {_said(p)} -> {_said(q)}", _VERDICT, brick=brick, level=level))
        return
    delta = np.subtract(q, p)
    off = float(np.linalg.norm(delta))
    if off <= t.position_mm + 1e-9:
        out.within += 1
        return
    text = f"centre of mass above moved by {_direction(delta, t.position_mm)} (tolerance {_num(t.position_mm)} mm)"
    moved = (float(delta[0]), float(delta[1]), float(delta[2]))
    out.differences.append(Difference(where, text, _MEASURED, off / t.position_mm, brick, moved, level, "centre of mass above"))


def _direction(delta: np.ndarray, limit: float) -> str:
    """``'6.0 mm in x'``, ``'6.0 mm in x, -2.1 mm in z'``: the components beyond a tenth of the
    tolerance; the length when none is."""
    parts = [f"{c:.1f} mm in {axis}" for c, axis in zip(delta, "xyz") if abs(c) > max(limit / 10, 0.05)]
    return ", ".join(parts) or f"{float(np.linalg.norm(delta)):.1f} mm"


def _turn(
    out: Comparison, where: str, brick: str, u: dict[str, Any], v: dict[str, Any], t: Tolerances, level: Any, knocked: float
) -> None:
    """Within the angle tolerance plus the turn ``knocked`` mm of corner motion can make about a
    brick's long axis (:attr:`Tolerances.radius_mm`)."""
    p, q = u.get("quaternion_xyzw"), v.get("quaternion_xyzw")
    if p == q:
        return
    if not (isinstance(p, list) and isinstance(q, list) and len(p) == len(q) == 4 and _numbers(*p, *q)):
        out.differences.append(Difference(where, f"quaternion {_said(p)} -> {_said(q)}", _VERDICT, brick=brick))
        return
    angle = _angle(p, q)
    limit = t.angle_deg + math.degrees(knocked / t.radius_mm)
    if angle <= limit + 1e-9:
        out.within += 1
        return
    text = f"turned {angle:.1f} deg (tolerance {_num(limit)} deg)"
    out.differences.append(Difference(where, text, _MEASURED, angle / limit, brick, level=level))


def _angle(p: Iterable[float], q: Iterable[float]) -> float:
    """Degrees between two orientations (quaternions x, y, z, w, as rounded in a snapshot)."""
    a, b = np.asarray(list(p), dtype=float), np.asarray(list(q), dtype=float)
    na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
    if na == 0 or nb == 0:
        return 0.0 if na == nb else 180.0
    dot = min(1.0, abs(float(a @ b)) / (na * nb))
    return math.degrees(2 * math.acos(dot))


def _supports(out: Comparison, where: str, brick: str, a: Any, b: Any, t: Tolerances, level: Any, sound: bool) -> None:
    """What a standing brick rests on, and each support's contact area and load share (within
    tolerance), where it is ``sound``; elsewhere a knock or the wake that a blow or debris above
    brought can make or drop a contact by chance."""
    if not (isinstance(a, dict) and isinstance(b, dict)):
        if a != b:
            out.differences.append(Difference(where, f"rests on {_said(a)} -> {_said(b)}", _VERDICT, brick=brick, level=level))
        return
    came, went = [s for s in b if s not in a], [s for s in a if s not in b]
    for said in [*(f"now rests on {s}" for s in came), *(f"no longer rests on {s}" for s in went)]:
        if sound:
            out.differences.append(Difference(where, said, _VERDICT, brick=brick, level=level))
        else:
            out.chaos.append(f"{where}: {said} (knocked, tilted, or under what was)")
    for s in (s for s in a if s in b):
        u, v = a[s], b[s]
        if u == v:
            continue
        if not sound:
            out.loose += 1
            continue
        if not (isinstance(u, dict) and isinstance(v, dict)):
            out.differences.append(Difference(where, f"rests on {s}: {_said(u)} -> {_said(v)}", _VERDICT, brick=brick))
            continue
        _support(out, where, brick, s, u, v, t, level)


def _support(
    out: Comparison, where: str, brick: str, s: str, u: dict[str, Any], v: dict[str, Any], t: Tolerances, level: Any
) -> None:
    """One support ``s`` the brick rests on in both runs: its contact area (mm^2) and load share
    within tolerance."""
    p, q = u.get("area_mm2", _MISSING), v.get("area_mm2", _MISSING)
    if p != q and _numbers(p, q):
        side = min(math.sqrt(max(p, q)), t.width_mm)  # a contact's shorter side, at most a brick's width
        _measured(out, f"{where} rests on {s}: area", float(p), float(q), t.area_mm2(max(p, q), side), " mm^2", brick, level)
    elif p != q:
        out.differences.append(Difference(where, f"rests on {s}: area {_said(p)} -> {_said(q)}", _VERDICT, brick=brick))
    p, q = u.get("load_share", _MISSING), v.get("load_share", _MISSING)
    if p != q and _numbers(p, q):
        _measured(out, f"{where} rests on {s}: load share", float(p), float(q), t.load_share, "", brick, level)
    elif p != q:
        out.differences.append(Difference(where, f"rests on {s}: load share {_said(p)} -> {_said(q)}", _VERDICT, brick=brick))


def _grouped(differences: list[Difference], t: Tolerances) -> list[str]:
    """Each difference as a line, ``where: text``, in the given order; bricks of one graph that
    moved by about the same (within the position tolerance of the first) said in one line, by
    level where they are whole levels, and a brick's centre of mass above that moved with it
    said with it: ``final_graph left: levels 1-6 (12 bricks) moved by -6.0 mm in x, their
    centres of mass above with them``."""
    moved = {(d.where.split(" ", 1)[0], d.brick): d for d in differences if d.field == "position"}
    carried = [_carried(d, moved, t) for d in differences]
    lines: list[str] = []
    done: set[int] = set()
    for i, d in enumerate(differences):
        if i in done or carried[i]:
            continue
        if d.delta is None:
            lines.append(f"{d.where}: {d.text}")
            continue
        alike = _alike(differences, d, done, carried, t)
        done |= set(alike)
        group = [differences[j] for j in alike]
        bricks = {g.brick for g in group}
        lines.append(_group_line(d, group, any(c and e.brick in bricks for e, c in zip(differences, carried)), t))
    return lines


def _carried(d: Difference, moved: Mapping[tuple[str, str], Difference], t: Tolerances) -> bool:
    """Whether ``d`` is a centre of mass above that moved as its brick did (within the position
    tolerance of its brick's move in ``moved``, by graph and brick)."""
    own = moved.get((d.where.split(" ", 1)[0], d.brick))
    return (
        d.field == "centre of mass above"
        and own is not None
        and d.delta is not None
        and own.delta is not None
        and float(np.linalg.norm(np.subtract(d.delta, own.delta))) <= t.position_mm
    )


def _alike(differences: list[Difference], d: Difference, done: set[int], carried: list[bool], t: Tolerances) -> list[int]:
    """The indices of the differences not yet said (``done``) and not ``carried`` that moved as
    ``d`` did: the same field of the same graph, within the position tolerance of ``d``'s move."""
    assert d.delta is not None  # the caller says a difference without a move on its own line
    graph = d.where.split(" ", 1)[0]
    return [
        j
        for j, e in enumerate(differences)
        if j not in done
        and e.delta is not None
        and e.field == d.field
        and not carried[j]
        and e.where.split(" ", 1)[0] == graph
        and float(np.linalg.norm(np.subtract(e.delta, d.delta))) <= t.position_mm
    ]


def _group_line(d: Difference, group: list[Difference], with_them: bool, t: Tolerances) -> str:
    """The line for the bricks of ``group`` (``d`` first) that moved alike: ``d``'s own line for
    one brick, else their levels (or part) and count with their mean move; ``with_them``: their
    centres of mass above moved with them."""
    also = ", their centres of mass above with them" if with_them else ""
    if len(group) == 1:
        return f"{d.where}: {d.text}{also.replace('their centres', 'its centre').replace('them', 'it')}"
    graph = d.where.split(" ", 1)[0]
    mean = np.mean([g.delta for g in group if g.delta is not None], axis=0)
    levels = sorted({g.level for g in group if g.level is not None})
    parts = {g.brick.rsplit(".", 2)[0] for g in group if g.brick.count(".") >= 2}
    part = f" {parts.pop()}" if len(parts) == 1 and all(g.brick.count(".") >= 2 for g in group) else ""
    who = f"levels {_spans(levels)}" if len(levels) > 1 else f"level {levels[0]}" if levels else "bricks"
    what = "" if d.field == "position" else f"{d.field} of "
    return (
        f"{graph}{part}: {what}{who} ({len(group)} bricks) moved by {_direction(mean, t.position_mm)} "
        f"(tolerance {_num(t.position_mm)} mm){also}"
    )


def _spans(levels: list[int]) -> str:
    """``[1, 2, 3, 5]`` -> ``'1-3, 5'``."""
    spans: list[list[int]] = []
    for level in levels:
        if spans and level == spans[-1][1] + 1:
            spans[-1][1] = level
        else:
            spans.append([level, level])
    return ", ".join(f"{a}-{b}" if a != b else f"{a}" for a, b in spans)


def near_tie(outcome: Outcome, program: Program) -> str:
    """Why ``outcome``'s verdict sits on a near tie, in words, or ``""``: a stand whose
    certificate's margin is under the engine's contact margin
    (:attr:`stackdsl.engines.protocol.EngineSettings.contact_margin`), or a collapse its
    certificate calls a near or exact tie (a brick placed within that margin of its support's
    edge, or within 0.1 mm of it either way: :data:`stackdsl.runtime.support.EXACT_TIE`), or
    a run left undecided with such a brick still moving (tipping too slowly to finish).
    Such a verdict may flip on another machine or engine version."""
    c = outcome.certificate
    margin = program.engine.contact_margin * 1000
    if c is None:
        return ""
    if c.verdict == "stands" and c.margin_mm is not None and c.margin_mm < margin:
        return (
            f"stands with a margin of {c.margin_mm:g} mm, under {program.engine.NAME}'s {margin:g} mm contact margin: "
            "a near tie the engine decides"
        )
    if c.verdict == "collapse" and ("near tie" in c.detail or "exact tie" in c.detail):
        return f"collapses on a near tie ({c.detail})"
    if c.verdict == "undecided" and ("near tie" in c.detail or "exact tie" in c.detail):
        return f"undecided on a near tie ({c.detail})"
    return ""
