"""Random values in scenario files: distributions on numbers, drawn per sample, layer or brick.

Any number or quantity of a scenario may be written as a distribution instead::

    spacing: {uniform: [90 mm, 100 mm]}                        # drawn once a sample
    placement_error: {choice: [0, 2 mm, 4 mm]}
    settle: {normal: {mean: 2 s, sd: 0.1 s, clip: [1.5 s, 2.5 s]}}
    shift: {uniform: [-60 mm, 60 mm], per: layer}             # a tower: one draw a layer (a random walk)
    yaw_jitter: {normal: {mean: 0, sd: 2}, per: brick}         # a tower: one draw a brick

``uniform: [low, high]`` draws uniformly; ``normal`` draws from a normal distribution,
then clips to ``clip`` when given; ``choice`` picks one of its items, each as likely. Every
value of a distribution is written with units of one kind (the first value's unit is the
one the drawn value is written in) or with none; the field then checks the drawn value as
if it had been written there, so units, ranges and error positions are those of the field.

``per: layer`` (a tower's ``shift``, ``yaw_jitter``) and ``per: brick`` (its ``yaw_jitter``)
draw one value a layer or a brick: the sample then has the tower's ``shifts`` (one a layer
above the first, each relative to the layer below) or a ``yaw_jitter`` list (one a brick).

Every draw of sample ``k`` comes from one ``numpy.random.Generator`` seeded with
``SeedSequence(seed, spawn_key=(k,))``, the k-th child ``SeedSequence(seed).spawn`` would
give: sample ``k`` is the same whoever draws it, in whatever order. Distributions are drawn in
the order they appear in the file, ``per: layer`` and ``per: brick`` ones last (they need the
number of levels and bricks, which may be drawn too).

Source: stackdsl's own (distributions on parameters as in Scenic and OpenSCENARIO).
"""

from __future__ import annotations

import copy
import difflib
import math
from dataclasses import dataclass, replace
from typing import Any, Literal, cast

import numpy as np

from .errors import FieldPath, ScenarioError, SourceMap, format_path
from .field_kinds import a_field_in, whole_of
from .units import in_unit, split_quantity

KINDS = ("uniform", "normal", "choice")
#: The share of a uniform's width inside each end at which :meth:`Distribution.bounds` takes it:
#: one draw in a thousand falls beyond, on each side.
INSIDE = 1e-3
#: The fields of a tower (the structure's own, or a part's) a distribution may be drawn on more
#: often than once a sample, and how often.
PER: dict[str, tuple[str, ...]] = {"shift": ("layer",), "yaw_jitter": ("layer", "brick")}


def tower_field(path: FieldPath) -> tuple[FieldPath, str] | None:
    """The tower and the field of it that ``path`` is in, when that field is one of :data:`PER`:
    ``("structure", "tower", "shift", 0)`` -> ``(("structure", "tower"), "shift")``, and a part's
    tower alike (``("structure", 1, "tower", "yaw_jitter")`` in a list of parts, ``("structure",
    "left", "tower", "shift")`` in a map); None otherwise."""
    for at in (1, 2):
        if len(path) > at + 1 and path[0] == "structure" and path[at] == "tower" and path[at + 1] in PER:
            return path[: at + 1], str(path[at + 1])
    return None


#: Sections whose values are not the scene's and take no distribution (a golden tolerance, a mark or its
#: reason drawn at random would judge each sample by another rule; a search's ends, tolerance or runs
#: drawn at random searched another range with each seed).
NOT_RANDOM = (
    "stackdsl",
    "seed",
    "sweep",
    "search",
    "require",
    "expect",
    "name",
    "description",
    "allow",
    "golden",
    "skip",
    "xfail",
)
MAX_CHOICES = 1000
#: Mappings keyed by names the file chooses, not by fields: their keys are never distributions.
NAMED = (("materials",), ("brick_types",))


#: How often a distribution draws: once a sample, or a tower's per layer or brick.
Per = Literal["sample", "layer", "brick"]


@dataclass(frozen=True)
class Distribution:
    """One distribution in a scenario file.

    Attributes:
        path: where it stands (field path; a tower's ``shift`` may have it on one of its parts).
        kind: ``"uniform"``, ``"normal"`` or ``"choice"``.
        values: uniform: (low, high); normal: (mean, sd, clip low, clip high) (clip: -inf, inf
            when not given); all numbers of ``unit``. choice: the items as written.
        unit: the unit the values are numbers of, as written (``""``: bare numbers).
        per: ``"sample"``, ``"layer"`` or ``"brick"``.
        part: the name of the part of a list of parts it stands in, else None.
        pinned: ``(value,)`` to give that value, as written, whatever is drawn (the generator
            still advances as a draw would, so that the other distributions draw what they
            would have); ``()``: drawn.
    """

    path: FieldPath
    kind: Literal["uniform", "normal", "choice"]
    values: tuple[Any, ...]
    unit: str
    per: Per = "sample"
    part: str | None = None
    pinned: tuple[Any, ...] = ()

    def draw(self, rng: np.random.Generator, count: int | None = None) -> Any:
        """One value as a file would write it (``count`` None) or a list of ``count`` values."""
        picked = self._draw(rng, count)
        if not self.pinned:
            return picked
        return self.pinned[0] if count is None else [self.pinned[0]] * count

    def _draw(self, rng: np.random.Generator, count: int | None = None) -> Any:
        n = 1 if count is None else count
        if self.kind == "choice":
            picked = [self.values[i] for i in rng.integers(0, len(self.values), size=n)]
        else:
            if self.kind == "uniform":
                numbers = rng.uniform(self.values[0], self.values[1], size=n)
            else:
                mean, sd, low, high = self.values
                numbers = np.clip(rng.normal(mean, sd, size=n), low, high)
            picked = [float(x) if not self.unit else f"{float(x)!r} {self.unit}" for x in numbers]
        return picked[0] if count is None else picked

    @property
    def label(self) -> str:
        """The field it draws, as a dotted path (``structure.tower.shift``), a part of a list
        of parts by its name (``structure.deck.origin.0``, as ``require:`` names it)."""
        path = self.path
        if self.part is not None:
            path = (path[0], self.part, *path[2:])
        return ".".join(str(p) for p in path)

    def bounds(self) -> list[Any]:
        """The values, as a file would write them, that bound what it draws with a chance worth
        a sweep's while: every choice (each is drawn once in so many samples), a uniform
        :data:`INSIDE` of its width inside each end (its ends themselves are degenerate cases a
        draw all but never gives, such as a brick shifted exactly half its length, resting on an
        edge), a normal's clip (its tail's chance lands there; an unclipped side has no bound).

        >>> Distribution(("x",), "choice", (3, 5, 3), "").bounds()
        [3, 5]
        >>> Distribution(("x",), "uniform", (20.0, 100.0), "mm").bounds()
        ['20.08 mm', '99.92 mm']
        >>> Distribution(("x",), "normal", (0.096, 0.002, 0.09, float("inf")), "m").bounds()
        ['0.09 m']
        """
        if self.kind == "choice":
            ends = list(self.values)
        elif self.kind == "uniform":
            low, high = self.values
            ends = [low + INSIDE * (high - low), high - INSIDE * (high - low)]
        else:
            ends = [v for v in self.values[2:] if math.isfinite(v)]
        out: list[Any] = []
        for v in ends:
            written = v if self.kind == "choice" else float(v) if not self.unit else f"{float(v)!r} {self.unit}"
            if written not in out:
                out.append(written)
        return out


def find(data: Any, source: SourceMap) -> list[Distribution]:
    """Every distribution in ``data`` (a scenario file as plain data), in file order.

    Raises:
        ScenarioError: a malformed distribution, one where none may stand (the format version,
            the seed, ``sweep``, ``expect``...), or a ``per`` its field does not take; at its node.
    """
    found: list[Distribution] = []
    _walk(data, (), source, found)
    parts = data.get("structure") if isinstance(data, dict) else None
    if isinstance(parts, list):
        for i, d in enumerate(found):
            if d.path[:1] == ("structure",) and len(d.path) > 1 and isinstance(d.path[1], int) and d.path[1] < len(parts):
                name = parts[d.path[1]].get("name") if isinstance(parts[d.path[1]], dict) else None
                if isinstance(name, str):
                    found[i] = replace(d, part=name)
    return found


def _walk(value: Any, path: FieldPath, source: SourceMap, found: list[Distribution]) -> None:
    if isinstance(value, dict):
        if path in NAMED:  # keyed by names the file chooses ("normal" may be a material)
            for key, item in value.items():
                _walk(item, path + (key,), source, found)
            return
        if any(k in value for k in KINDS):
            found.append(_parse(value, path, source))
            return
        for key in value:  # no field of the language is named like a distribution: a misspelt one
            near = difflib.get_close_matches(str(key), KINDS, n=1, cutoff=0.75)
            if near:
                raise source.error(path + (key,), f"unknown key {key!r}; did you mean the distribution {near[0]!r}?", at_key=True)
        for key, item in value.items():
            _walk(item, path + (key,), source, found)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            _walk(item, path + (i,), source, found)


def _parse(node: dict[str, Any], path: FieldPath, source: SourceMap) -> Distribution:
    """One distribution node, checked."""
    if path and path[0] in NOT_RANDOM:
        raise source.error(path, f"a distribution cannot stand in '{path[0]}': only the scene's numbers are drawn")
    whole = whole_of(path)
    if whole is not None:  # a section, an item or a list: its values would be drawn from numbers
        inside = format_path(path + a_field_in(path))
        raise source.error(
            path,
            f"a distribution draws the value of one field, and {format_path(path)} is {whole}; put it on a field inside, such as {inside}",
        )
    kinds = [k for k in KINDS if k in node]
    unknown = [k for k in node if k not in (*KINDS, "per")]
    if len(kinds) != 1 or unknown:
        extra = f"; unknown key {unknown[0]!r}" if unknown else ""
        raise source.error(
            path, f"a distribution is one of {{uniform: ...}}, {{normal: ...}}, {{choice: ...}}, with an optional 'per'{extra}"
        )
    kind = kinds[0]
    per = _per(node, path, source)
    try:
        if kind == "choice":
            return _choice(node[kind], path, per)
        if kind == "uniform":
            return _uniform(node[kind], path, per)
        return _normal(node[kind], path, per)
    except ValueError as exc:
        raise source.error(path + (kind,), str(exc)) from None


def _per(node: dict[str, Any], path: FieldPath, source: SourceMap) -> Per:
    """How often the distribution at ``path`` draws (``per``): once a sample, or per layer or brick
    where a tower's field allows it, on the whole field.

    Raises:
        ScenarioError: at ``per``, not allowed there.
    """
    per = node.get("per", "sample")
    spot = tower_field(path)
    allowed = ("sample", *(PER[spot[1]] if spot else ()))
    if per not in allowed:
        where = "a tower's shift (per: layer) and yaw_jitter (per: layer or brick), in a part too"
        raise source.error(
            path + ("per",), f"'per: {per}' is not allowed here: once a sample is the default; only {where} draw more often"
        )
    if per != "sample" and spot is not None and spot[1] != "shift" and len(path) != len(spot[0]) + 1:
        raise source.error(path + ("per",), "'per' goes on the whole field")
    return cast(Per, per)


def _choice(items: Any, path: FieldPath, per: Per) -> Distribution:
    """``{choice: [...]}``: 1 to :data:`MAX_CHOICES` numbers or quantities. Raises ValueError: not so."""
    if not isinstance(items, list) or not items or len(items) > MAX_CHOICES:
        raise ValueError(f"expected a list of 1 to {MAX_CHOICES} values to choose from")
    if any(isinstance(i, (dict, list)) for i in items):
        raise ValueError("each choice is a number or a quantity such as '12 mm'")
    return Distribution(path, "choice", tuple(items), "", per)


def _uniform(ends: Any, path: FieldPath, per: Per) -> Distribution:
    """``{uniform: [low, high]}`` in one unit, low at most high. Raises ValueError: not so."""
    if not isinstance(ends, list) or len(ends) != 2:
        raise ValueError("expected [low, high], such as [90 mm, 100 mm]")
    unit = _unit_of(ends)
    low, high = (in_unit(v, unit) for v in ends)
    if low > high:
        raise ValueError(f"low {ends[0]!r} is above high {ends[1]!r}")
    return Distribution(path, "uniform", (low, high), unit, per)


def _normal(spec: Any, path: FieldPath, per: Per) -> Distribution:
    """``{normal: {mean, sd, clip: [low, high]}}`` in one unit, sd at least 0, clip's low at most
    its high. Raises ValueError: not so."""
    if not isinstance(spec, dict) or not {"mean", "sd"} <= set(spec) or set(spec) - {"mean", "sd", "clip"}:
        raise ValueError("expected {mean: ..., sd: ...} and an optional clip: [low, high]")
    unit = _unit_of([spec["mean"], spec["sd"], *(spec["clip"] if isinstance(spec.get("clip"), list) else [])])
    mean = in_unit(spec["mean"], unit)
    sd = in_unit(spec["sd"], unit)
    if sd < 0:
        raise ValueError(f"the standard deviation must be at least 0, not {spec['sd']!r}")
    low, high = -math.inf, math.inf
    if "clip" in spec:
        clip = spec["clip"]
        if not isinstance(clip, list) or len(clip) != 2:
            raise ValueError("expected clip: [low, high]")
        low, high = (in_unit(v, unit) for v in clip)
        if low > high:
            raise ValueError(f"clip's low {clip[0]!r} is above its high {clip[1]!r}")
    return Distribution(path, "normal", (mean, sd, low, high), unit, per)


def _unit_of(values: list[Any]) -> str:
    """The unit a distribution's values are written in: the first one's that has a unit (a bare
    0 is 0 of any unit, so ``[0, 20 mm]`` is in mm); "" when none has."""
    for v in values:
        try:
            unit = split_quantity(v)[1]
        except ValueError:
            continue
        if unit:
            return unit
    return ""


def sample_seed(seed: int, k: int, attempt: int = 0) -> np.random.SeedSequence:
    """The seed sequence of sample ``k``: the k-th child of ``SeedSequence(seed)``; its draw
    ``attempt`` after the first (a sample redrawn to meet ``require:``), that child's child."""
    return np.random.SeedSequence(seed, spawn_key=(k,) if attempt == 0 else (k, attempt))


def draw(data: dict[str, Any], distributions: list[Distribution], seed: int, k: int, attempt: int = 0) -> dict[str, Any]:
    """Sample ``k`` of a scenario: ``data`` (plain, with distributions) with each one drawn.

    The sample's own ``seed`` (which the compiler's placement error draws from) is taken from
    the same generator, so every random part of sample ``k`` is the same whoever draws it.
    """
    rng = np.random.default_rng(sample_seed(seed, k, attempt))
    out = copy.deepcopy(data)
    later = []
    for d in distributions:
        if d.per == "sample":
            _put(out, d.path, d.draw(rng))
        else:
            later.append(d)
    for d in later:
        _draw_into_tower(out, d, rng)
    out["seed"] = int(rng.integers(0, 2**63 - 1))
    return out


def _draw_into_tower(out: dict[str, Any], d: Distribution, rng: np.random.Generator) -> None:
    """Draw distribution ``d`` (one value a layer or a brick) into its tower in ``out``: a
    ``shift`` becomes the tower's ``shifts``, one a layer above the first; a yaw becomes its
    ``yaw_jitter``, one a brick. A tower that is not there, or whose ``levels`` or
    ``bricks_per_layer`` is not a whole number, is left for its own validation to report."""
    spot = tower_field(d.path)
    tower = _tower(out, spot[0]) if spot else None
    if tower is None:  # the structure's own validation says what is wrong
        return
    at = len(spot[0]) + 1 if spot else 0  # where the field's own path ends
    levels, across = _whole(tower.get("levels")), _whole(tower.get("bricks_per_layer", 2))
    if levels is None or across is None:  # the tower's own validation says what is wrong
        return
    if spot and spot[1] == "shift":
        _draw_shifts(tower, d, rng, levels, at)
    else:
        values = d.draw(rng, levels if d.per == "layer" else levels * across)
        tower["yaw_jitter"] = [v for v in values for _ in range(across)] if d.per == "layer" else values


def _draw_shifts(tower: dict[str, Any], d: Distribution, rng: np.random.Generator, levels: int, at: int) -> None:
    """Draw ``d``, a tower's ``shift`` (whole, or one of its (x, y) parts when its path goes on
    past ``at``), once for each of the tower's ``levels - 1`` layers above the first, into its
    ``shifts``."""
    if "shifts" not in tower:  # one shift a layer above the first, each a copy of the field
        shift = tower.pop("shift")  # (drawn whole, each is replaced: no copy needed)
        whole = len(d.path) == at
        tower["shifts"] = [shift if whole else copy.deepcopy(shift) for _ in range(levels - 1)]
    for i, value in enumerate(d.draw(rng, levels - 1)):
        if len(d.path) == at:
            tower["shifts"][i] = value
        else:  # one part of an (x, y) pair
            tower["shifts"][i][d.path[at]] = value


def _tower(data: Any, path: FieldPath) -> dict[str, Any] | None:
    """The tower at ``path`` in ``data``, or None when there is none there."""
    for key in path:
        if isinstance(data, dict) and key in data:
            data = data[key]
        elif isinstance(data, list) and isinstance(key, int) and 0 <= key < len(data):
            data = data[key]
        else:
            return None
    return data if isinstance(data, dict) else None


def _whole(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 1 else None


def _put(data: Any, path: FieldPath, value: Any) -> None:
    for key in path[:-1]:
        data = data[key]
    data[path[-1]] = value


def error_at(source: SourceMap, path: FieldPath, message: str, k: int) -> ScenarioError:
    """An error found in sample ``k``, at the distribution that drew it."""
    return source.error(path, f"sample {k}: {message}")
