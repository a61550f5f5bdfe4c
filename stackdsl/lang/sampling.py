"""A scenario with random fields or a sweep: the file as a template, and its samples.

A :class:`Template` keeps a scenario file as read (plain data, its distributions in place,
see :mod:`stackdsl.lang.distributions`) with its ``sweep``: ``samples`` draws for each cell of
``grid`` (field paths, each with a list of values, run as their product). Sample ``k`` of
cell ``c`` is the file with the cell's values put in and every distribution drawn from the
k-th child of the file's seed (the same in every cell: cells are compared on the same draws),
validated as a file is. An error in a sample is reported at the distribution or the grid value
that put the wrong value there.

>>> t = Template.of({"stackdsl": 1, "structure": {"tower": {"levels": {"choice": [2, 3]}}},
...                  "sweep": {"samples": 4, "grid": {"timing.interval": [0.5, 1]}}}, SourceMap("t.yaml"))
>>> t.cells, t.samples, [t.scenario(1, k).structure.tower.levels for k in range(8)]
(2, 4, [3, 3, 3, 3, 2, 2, 2, 3])
>>> t.parameters(1, 4)
{'timing.interval': 1.0, 'structure.tower.levels': 2}

Source: stackdsl's own.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .distributions import NAMED, Distribution, draw, find, tower_field
from .errors import FieldPath, ScenarioError, SourceMap, format_path
from .expressions import Condition, check_kinds, parse
from .field_kinds import a_field_in, field_kind, whole_of
from .schema import Scenario, Structure
from .schema_sweep import GRID_KEY_CHECKS, MAX_SAMPLES, MAX_SWEEP_RUNS, grid_name
from .spelling import spelled
from .units import in_language_units, in_unit, language_unit, split_quantity
from .validate import validate
from .yaml_out import flow


def _drawn_into(distributions: tuple[Distribution, ...] | list[Distribution]) -> dict[FieldPath, FieldPath]:
    """The fields the concrete form of a tower's per-layer shifts lands in (its ``shifts``), each
    with the field written (its ``shift``), for every tower (the structure's, or a part's) that has them."""
    out: dict[FieldPath, FieldPath] = {}
    for d in distributions:
        spot = tower_field(d.path)
        if spot and spot[1] == "shift" and d.per != "sample":
            out[spot[0] + ("shifts",)] = spot[0] + ("shift",)
    return out


@dataclass(frozen=True)
class Template:
    """A scenario file with random fields or a sweep (see the module docstring).

    Attributes:
        data: the file as plain data, distributions in place.
        source: where each field came from (not compared: two templates of the same data from
            two files, or from a file and its ``to_yaml()``, are equal).
        distributions: in file order.
        grid: (field path, the key as written, its values) for each grid field.
        samples: draws a cell; seed: the file's seed.
    """

    data: dict[str, Any]
    source: SourceMap = dataclasses.field(compare=False)
    distributions: tuple[Distribution, ...]
    grid: tuple[tuple[FieldPath, str, tuple[Any, ...]], ...]
    samples: int
    seed: int

    @classmethod
    def of(cls, data: Any, source: SourceMap) -> Template | None:
        """The template of a file's plain ``data``, or None when it has neither random fields nor
        a sweep (it is then one scenario, validated as usual).

        Raises:
            ScenarioError: a malformed distribution, sweep or grid field, at its node.
        """
        if not isinstance(data, dict):
            return None
        distributions = find(data, source)
        if not distributions and "sweep" not in data:
            return None
        plain = dict(data)
        sweep = data.get("sweep")
        samples: int = 1
        grid: tuple[tuple[FieldPath, str, tuple[Any, ...]], ...] = ()
        if sweep is not None:
            checked = validate({"stackdsl": 1, "structure": {"tower": {"levels": 1}}, "sweep": sweep}, source)
            assert checked.sweep is not None
            samples = checked.sweep.samples
            asked = [_grid_field(key, values, source) for key, values in checked.sweep.grid.items()]
            drawn = {d.path for d in distributions}
            grid = tuple((_grid_path(plain, path, key, source, drawn), key, values) for path, key, values in asked)
            _no_overlap(grid, source)
        for into, written in _drawn_into(distributions).items():  # errors at a tower's drawn shifts point at its 'shift'
            if written in source.values:
                source.values[into] = source.values[written]
                source.keys[into] = source.keys.get(written, source.values[written])
        seed = plain.get("seed", 0)
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:  # as a plain file's seed is checked
            raise source.error(("seed",), f"a seed is a whole number, 0 or more, not {seed!r}")
        return cls(plain, source, tuple(distributions), grid, samples, seed)

    @property
    def random(self) -> bool:
        """Whether a sample draws anything: a distribution, or a placement error in some cell. When
        it does not, every sample of a cell is the same run, and its statistics are exact."""
        if self.distributions:
            return True
        return any(self.scenario(c, 0).timing.placement_error > 0 for c in range(self.cells))

    def values(self, c: int) -> dict[str, float]:
        """Cell ``c``'s grid values by their dotted keys (:func:`grid_name`), numbers in SI (angles in
        degrees), as a cell's condition (``expect.cells``) reads them; a value that is no number is left out."""
        return self._si(tuple(self.cell(c).values()))

    @property
    def cells(self) -> int:
        """How many combinations of grid values (1 without a grid)."""
        count = 1
        for _, _, values in self.grid:
            count *= len(values)
        return count

    def cell(self, c: int) -> dict[str, Any]:
        """The grid values of cell ``c`` (key as written -> value as written), cells in the
        order of ``itertools.product`` over the grid fields in file order.

        Raises:
            IndexError: no such cell.
        """
        if not 0 <= c < self.cells:
            raise IndexError(f"cell {c} of {self.cells}")
        combination = list(itertools.product(*(values for _, _, values in self.grid)))[c]
        return {key: value for (_, key, _), value in zip(self.grid, combination)}

    def label(self, c: int) -> str:
        """Cell ``c``'s grid values as the file writes them: ``"structure.b.interleave = true,
        actions.0.push.target = {point: [0, 0, 4 mm]}"``.

        Raises:
            IndexError: no such cell.
        """
        return _shown(self.cell(c))

    def with_samples(self, samples: int, where: str = "--samples") -> Template:
        """This template with ``samples`` draws a cell, within the same budget as a file's own
        ``sweep.samples`` (at most :data:`MAX_SAMPLES` a cell and :data:`MAX_SWEEP_RUNS` runs in
        all), however the number is given.

        Raises:
            ScenarioError: at ``where`` (the option or field that gave it), with the cap named.
        """
        if not 1 <= samples <= MAX_SAMPLES:
            raise ScenarioError(f"samples must be from 1 to {MAX_SAMPLES}, not {samples}", file=where)
        if self.cells * samples > MAX_SWEEP_RUNS:
            raise ScenarioError(
                f"{self.cells} cells x {samples} samples is {self.cells * samples} runs; at most {MAX_SWEEP_RUNS} in a sweep",
                file=where,
            )
        return dataclasses.replace(self, samples=samples)

    def _data(
        self, c: int, k: int, attempt: int = 0, put: dict[str, Any] | None = None, pin: Distribution | None = None
    ) -> dict[str, Any]:
        """Cell ``c``'s sample ``k`` as plain data: grid values put in, distributions drawn (draw
        ``attempt`` of the sample: see :func:`stackdsl.lang.distributions.sample_seed`). ``put``:
        grid values (key as written -> value) in place of the cell's, put in before anything is
        drawn, so that a per-layer or per-brick draw is sized by the tower they make. ``pin``: a
        distribution of the file with its ``pinned`` value, drawn in its place."""
        data = self.data  # draw copies it
        if self.grid:
            data = copy.deepcopy(self.data)
            values = self.cell(c) | (put or {})
            for path, key, _ in self.grid:
                _put(data, path, values[key])
        grid_paths = [path for path, _, _ in self.grid]
        drawn = [d for d in self.distributions if not any(d.path[: len(p)] == p for p in grid_paths)]
        if pin is not None:
            drawn = [pin if d.path == pin.path else d for d in drawn]
        return draw(data, drawn, self.seed, k, attempt)

    def plain(self, c: int, k: int) -> dict[str, Any]:
        """Cell ``c``'s sample ``k`` as the plain data a scenario file holds (a new dict: grid
        values put in, every distribution drawn, a pinned one giving its value), before any
        validation: what a counterexample file writes
        (:func:`stackdsl.batch.search.counterexample_file`). Source: stackdsl's own."""
        return self._data(c, k)

    def drawn(self, c: int, k: int) -> dict[str, Any]:
        """What cell ``c``'s sample ``k`` drew once a sample, by field (dotted), as a file writes it
        (``{"structure.dominoes.count": 3}``); the fields the grid replaces are left out."""
        grid_paths = [path for path, _, _ in self.grid]
        data = self._data(c, k)
        return {
            d.label: _get(data, d.path)
            for d in self.distributions
            if d.per == "sample" and not any(d.path[: len(p)] == p for p in grid_paths)
        }

    def bounds(self) -> list[tuple[Distribution, Any]]:
        """Each distribution drawn once a sample that the grid does not replace, with each value
        that bounds what it draws (:meth:`Distribution.bounds`): what :meth:`pinned` gives, to
        compile a sample with each before any runs."""
        grid_paths = [path for path, _, _ in self.grid]
        return [
            (d, value)
            for d in self.distributions
            if d.per == "sample" and not any(d.path[: len(p)] == p for p in grid_paths)
            for value in d.bounds()
        ]

    def pinned(self, c: int, d: Distribution, value: Any) -> Scenario:
        """Cell ``c``'s sample 0 with distribution ``d`` giving ``value`` (one of its
        :meth:`bounds`) and every other drawing what it draws in that sample: a sample the sweep
        can draw (the others' draws are sample 0's).

        Raises:
            ScenarioError: ``value`` refused by its field, at ``d``.
        """
        pin = dataclasses.replace(d, pinned=(value,))
        what = f"{'a value' if d.kind != 'choice' else 'a choice'} this distribution can draw, {value!r}"
        scenario = validate(self._data(c, 0, pin=pin), self.source, self._blame(c, only=d), what)
        if self.grid:
            scenario._source = self._cell_source(c)
        scenario._template = self
        scenario._sample = (c, 0)
        return scenario

    def scenario(self, c: int, k: int, *, checked: bool = False, attempt: int = 0) -> Scenario:
        """The validated scenario of cell ``c``'s sample ``k``; with ``checked``, every value each
        distribution and grid field can give is validated first (the file's own check).

        Raises:
            ScenarioError: a sample or a value is refused by its field, at the distribution or
                grid value that gave it; an unknown grid cell.

        ``attempt`` > 0 draws the sample again (a sample that failed ``require:``).
        """

        if checked:
            self._check_values()
        scenario = self._validate(self._data(c, k, attempt), self._blame(c, around=True), self._note(c, k))
        if checked:
            self._check_cells(scenario.expect.cells or [], scenario.expect.p_stands)
            self._check_exact_means(scenario.expect)
        if self.grid:  # what the compiler refuses in a field the grid filled in is the grid value's fault
            scenario._source = self._cell_source(c)
        scenario._template = self
        scenario._sample = (c, k)
        return scenario

    def parameters(self, c: int, k: int, attempt: int = 0) -> dict[str, Any]:
        """What cell ``c``'s sample ``k`` (its draw ``attempt``) drew and took from the grid: column -> value, each a
        number in the unit a bare number means for its field (SI; angles in degrees), the column
        named with that unit when the file wrote one (``"timing.placement_error [m]"``; a list
        for a tower's per-layer or per-brick draws; a value that is no number, as written)."""
        data = self._data(c, k, attempt)
        out: dict[str, Any] = {}
        for (_, key, values), value in zip(self.grid, self.cell(c).values()):
            number, _ = in_language_units(value)
            out[_column(key, _grid_unit(tuple(values)))] = number
        grid_paths = [path for path, _, _ in self.grid]
        for d in self.distributions:
            if any(d.path[: len(p)] == p for p in grid_paths):
                continue
            factor, unit = language_unit(d.unit) if d.unit else (1.0, "")
            column = _column(d.label, unit)
            if d.per == "sample":
                out[column] = _scaled(_number(_get(data, d.path), d.unit), factor)
            elif (spot := tower_field(d.path)) and spot[1] == "shift":
                part = d.path[len(spot[0]) + 1 :]
                out[column] = [
                    _scaled(_number(_get(s, part) if part else s, d.unit), factor) for s in _get(data, spot[0] + ("shifts",))
                ]
            else:
                out[column] = [_scaled(_number(v, d.unit), factor) for v in _get(data, d.path)]
        return out

    def _check_values(self) -> None:
        """Every grid value, and each end of every distribution (both ends of a uniform, every
        choice, a normal's clip), validated with the other fields at sample 0 of cell 0."""

        for path, key, values in self.grid:
            for i, value in enumerate(values):
                data = self._data(0, 0, put={key: value})
                try:
                    self._validate(data, _at_grid(path, key, i), f"the grid value {_value(value)}", f"with {key} = {flow(value)}")
                except ScenarioError:
                    # an error at a field around the grid's (a tower's levels against its shifts) is the
                    # grid value's only when the file's own cell 0 is valid: else the file's error is said
                    self._validate(self._data(0, 0), self._blame(0), self._note(0, 0))
                    raise
        for d in self.distributions:
            for end, what in _ends(d):
                fixed = Distribution(d.path, "choice", (end,), "", d.per)
                others = [x if x is not d else fixed for x in self.distributions]
                data = draw(copy.deepcopy(self.data), others, self.seed, 0)
                try:
                    validate(data, self.source, self._blame(0, only=d), f"{what}, {end!r}")
                except ScenarioError as exc:
                    if "sd" in what and exc.field == format_path(d.path):
                        exc.message += "; give the normal a clip: [low, high] within what the field takes"
                    raise

    def _validate(self, data: Any, relocate: Callable[[FieldPath], FieldPath | None], note: str, elsewhere: str = "") -> Scenario:
        """:func:`validate` of a sample's ``data``; with a grid, an error the grid's values make at a
        field no grid value or distribution is blamed for (a part's ``on`` naming a part the grid
        renamed) says ``elsewhere`` (default ``note``: the grid cell it is in) too, as the errors
        blamed on one say ``note``."""
        try:
            return validate(data, self.source, relocate, note)
        except ScenarioError as exc:
            if self.grid and not exc.message.startswith(note) and not exc.field.startswith("sweep.grid") and self._grids(exc):
                exc.message = f"{elsewhere or note}: {exc.message}"
            raise

    def _grids(self, exc: ScenarioError) -> bool:
        """Whether the grid's values make ``exc``: the file's own values in their place (its
        distributions at sample 0) are not refused so."""
        grid_paths = [path for path, _, _ in self.grid]
        drawn = [d for d in self.distributions if not any(d.path[: len(p)] == p for p in grid_paths)]
        try:
            validate(draw(self.data, drawn, self.seed, 0), self.source)
        except ScenarioError as own:
            return (own.field, own.message) != (exc.field, exc.message)
        return True

    def _note(self, c: int, k: int) -> str:
        """What an error in cell ``c``'s sample ``k`` is said after: ``"sample 3 of grid cell 1 (timing.interval = 1 s)"``."""
        return f"sample {k}" + (f" of grid cell {c} ({_shown(self.cell(c))})" if self.grid else "")

    def _check_cells(self, rules: list[Any], own: Any = None) -> None:
        """Each condition of ``expect.cells`` (``rules``, validated) against the grid, once: both
        sides of a comparison quantities of one kind (as ``require:`` has them), and some cell in
        which it holds (else its expectations would judge nothing, and the sweep pass on nothing).

        Raises:
            ScenarioError: at the rule's ``where``, naming the kinds, or the grid's values.
        """
        if not rules:
            return
        kinds = {grid_name(key): field_kind(grid_name(key)) for _, key, _ in self.grid}
        cells = [self._si(combination) for combination in itertools.product(*(values for _, _, values in self.grid))]
        conditions = [parse(rule.where) for rule in rules]
        for i, condition in enumerate(conditions):
            at = ("expect", "cells", i, "where")
            try:
                check_kinds(condition, kinds)
            except ValueError as exc:
                raise self.source.error(at, str(exc)) from None
            if not any(condition.holds(values) for values in cells):
                shown = "; ".join(f"{key}: {', '.join(str(v) for v in values)}" for _, key, values in self.grid)
                raise self.source.error(
                    at,
                    f"no grid cell meets this condition, so these expectations would judge nothing; the grid's values "
                    f"are {shown} (a condition reads them in SI units and degrees); change the condition or the grid",
                )
        self._check_bounds(rules, conditions, cells, own)

    def _check_exact_means(self, expect: Any) -> None:
        """In a sweep that draws nothing, each cell's samples are one run repeated, so a mean
        collapse level is the whole level that run collapses at: a ``mean`` whose tolerance
        holds no whole level could never pass. (Within ± 0, and a quantile's level, are refused
        so in any sweep, by the language.)

        Raises:
            ScenarioError: at the ``mean``.
        """
        written: list[tuple[FieldPath, Any]] = [(("expect", "collapse", "mean"), getattr(expect.collapse, "mean", None))]
        written += [
            (("expect", "cells", i, "collapse", "mean"), getattr(rule.collapse, "mean", None))
            for i, rule in enumerate(expect.cells or [])
        ]
        means = [(at, mean) for at, mean in written if mean is not None and mean.levels() is None]
        if not means or self.random:
            return
        at, mean = means[0]
        raise self.source.error(
            at,
            f"this sweep draws nothing, so each cell's samples are one run and its mean collapse level is the whole "
            f"level that run collapses at; '{mean.text()}' holds none, so it could never pass: write a whole level "
            f"such as {max(round(mean.target), 1)} (± 0), or a tolerance that reaches one",
        )

    def _check_bounds(
        self, rules: list[Any], conditions: list[Condition], cells: list[dict[str, float]], own: Any = None
    ) -> None:
        """No grid cell may be held to ``p_stands`` rules that no probability meets (``>= 0.9`` and
        ``<= 0.1`` by overlapping conditions, or the file's own ``p_stands``, ``own``, and a rule
        of ``expect.cells``), nor, when the samples draw, that meet at one probability only
        (``>= 0.5`` and ``<= 0.5``): no 95% interval narrows to one value; nor, when nothing is
        drawn, that leave out both 0 and 1 (``>= 0.3`` and ``<= 0.7``): one run a cell stands or
        not. The sweep could never pass.

        Raises:
            ScenarioError: at the later rule's ``p_stands``, naming the earlier one and the cell.
        """
        written: list[_Rule] = []
        if own is not None:
            written.append((("expect", "p_stands"), "the file's own p_stands", own, None))
        written += [
            (("expect", "cells", i, "p_stands"), f"cells[{i}]", rule.p_stands, conditions[i])
            for i, rule in enumerate(rules)
            if rule.p_stands is not None
        ]
        for values in cells:
            clash = _bounds_clash(written, values, self.random)
            if clash is None:
                continue
            first, later, why = clash
            shown = ", ".join(f"{k} = {v:g}" for k, v in values.items())
            raise self.source.error(
                written[later][0],
                f"in the grid cell {shown} (SI units), {written[first][1]} asks P(stands) {written[first][2].text()} "
                f"and this rule P(stands) {written[later][2].text()}: {why}; "
                + (
                    "the file's own holds in every cell: give it to the cells it is for, in expect.cells"
                    if written[first][3] is None
                    else "make their conditions apart"
                ),
            )

    def _si(self, combination: tuple[Any, ...]) -> dict[str, float]:
        """A cell's grid values (``combination``, in grid order) as :meth:`values` gives them."""
        out: dict[str, float] = {}
        for (_, key, _), value in zip(self.grid, combination):
            number, _ = in_language_units(value)
            if isinstance(number, (int, float)) and not isinstance(number, bool):
                out[grid_name(key)] = float(number)
        return out

    def _cell_source(self, c: int) -> SourceMap:
        """The source map of cell ``c``'s samples: an error at a field the grid filled in (the
        compiler's, found after validation) is placed at the grid value, naming the grid key."""
        values = self.cell(c)
        moved = tuple(
            (path, ("sweep", "grid", key, list(vs).index(values[key])), f"the grid value {_value(values[key])}")
            for path, key, vs in self.grid
        )
        return dataclasses.replace(self.source, moved=moved)

    def _blame(self, c: int, only: Distribution | None = None, around: bool = False) -> Any:
        """``relocate`` for :func:`stackdsl.lang.validate.validate`: a field a distribution (or the grid)
        filled in -> the distribution's (or grid value's) node; with ``around``, an error at a model
        around a grid field that no distribution explains too (a tower whose grid ``levels`` no
        list of its fits) -> that grid value."""
        values = self.cell(c) if self.grid else {}
        index = {key: list(vs).index(values[key]) if key in values else 0 for _, key, vs in self.grid}
        distributions = [only] if only is not None else list(self.distributions)

        drawn_into = _drawn_into(distributions)

        def relocate(loc: FieldPath) -> FieldPath | None:
            if only is not None and loc[: len(only.path)] == only.path:
                return only.path  # the distribution's own end, checked where a grid replaces it too
            for path, key, _ in self.grid:
                if loc[: len(path)] == path:
                    return ("sweep", "grid", key, index[key])
            loc = next((written + loc[len(into) + 1 :] for into, written in drawn_into.items() if loc[: len(into)] == into), loc)
            for d in distributions:
                if loc[: len(d.path)] == d.path or ((_around(d.path, loc) or _beside(d.path, loc)) and d.per != "sample"):
                    return d.path
            if around:
                for path, key, _ in self.grid:
                    if _around(path, loc) or _beside(path, loc):
                        return ("sweep", "grid", key, index[key])
            return None

        return relocate


def _at_grid(path: FieldPath, key: str, i: int) -> Any:
    """``relocate``: a field under ``path``, a model around it, or another field of its model
    (:func:`_beside`; the file's own cell 0 being valid) -> the grid's value ``i`` of ``key``."""

    def relocate(loc: FieldPath) -> FieldPath | None:
        return ("sweep", "grid", key, i) if loc[: len(path)] == path or _around(path, loc) or _beside(path, loc) else None

    return relocate


def _around(path: FieldPath, loc: FieldPath) -> bool:
    """Whether ``loc`` is a model around the field at ``path``."""
    return path[: len(loc)] == loc


def _beside(path: FieldPath, loc: FieldPath) -> bool:
    """Whether ``loc`` is another field of the model ``path``'s field is in, or under one: a check
    of one field against another (a tower's ``shifts`` against its ``levels``) says it there."""
    return len(path) > 1 and loc[: len(path) - 1] == path[:-1]


#: How far an unclipped side of a normal is taken to reach, in standard deviations from its mean:
#: a draw beyond it has a chance of 1.5e-23, so that no sweep within the budget (at most
#: :data:`stackdsl.lang.schema_sweep.MAX_SWEEP_RUNS` samples, each a few thousand draws) comes near one.
NORMAL_REACH = 10.0


def _ends(d: Distribution) -> list[tuple[Any, str]]:
    """The values of ``d`` that bound what it can draw, as a file would write them, each with what
    it is (the start of an error at it): both ends of a uniform, every choice, a normal's clip or,
    on a side it does not clip, :data:`NORMAL_REACH` standard deviations from its mean."""
    can = "a value this distribution can draw"
    if d.kind == "choice":
        return [(v, can) for v in d.values]
    if d.kind == "uniform":
        bounds = [(d.values[0], can), (d.values[1], can)]
    else:
        mean, sd, low, high = d.values
        bounds = []
        for sign, clip in ((-1, low), (1, high)):
            if abs(clip) != float("inf"):
                bounds.append((clip, can))
            else:  # unbounded: where its draws end in practice, said as such
                side = "-" if sign < 0 else "+"
                bounds.append((mean + sign * NORMAL_REACH * sd, f"{can} with no clip (its mean {side} {NORMAL_REACH:g} sd)"))
    out: list[tuple[Any, str]] = []
    for number, what in bounds:
        written = float(number) if not d.unit else f"{float(number)!r} {d.unit}"
        if all(written != w for w, _ in out):
            out.append((written, what))
    return out


_Rule = tuple[FieldPath, str, Any, Condition | None]
"""A ``p_stands`` rule of a sweep: where it is written, how a message names it, its bound, its condition."""


def _bounds_clash(written: list[_Rule], values: dict[str, float], random: bool) -> tuple[int, int, str] | None:
    """The first two ``p_stands`` rules (``written``, in file order) holding in the grid cell
    ``values`` that no probability the sweep can measure meets (see :meth:`Template._check_bounds`):
    their indices, earlier first, and why; ``None`` when they all can be met. ``random``: the
    samples draw."""
    lowest: tuple[float, bool, int] | None = None  # the tightest lower bound: value, strict, rule
    highest: tuple[float, bool, int] | None = None  # the tightest upper bound: value, not strict, rule
    for i, (_, _, bound, condition) in enumerate(written):
        if condition is not None and not condition.holds(values):
            continue
        low, high = bound.ends()
        if low is not None:
            lowest = max(lowest or (low[0], low[1], i), (low[0], low[1], i))
        if high is not None:
            highest = min(highest or (high[0], not high[1], i), (high[0], not high[1], i))
        if lowest is None or highest is None:
            continue
        why = _why_unmet(lowest, highest, random)
        if why is not None:
            first, later = sorted((lowest[2], highest[2]))
            return first, later, why
    return None


def _why_unmet(lowest: tuple[float, bool, int], highest: tuple[float, bool, int], random: bool) -> str | None:
    """Why the tightest lower and upper ``p_stands`` bounds (value, strict or not open, rule) can
    never both hold: they leave no probability, meet at one (which no 95% interval narrows to,
    when the samples draw: ``random``), or leave out both 0 and 1 (one run a cell); else ``None``."""
    (lo, lo_strict, a), (hi, hi_open, b) = lowest, highest
    if lo > hi or (lo == hi and (lo_strict or not hi_open)):
        return "no sweep can meet both"
    if lo == hi and a != b and random:  # one probability, which no interval narrows to
        return f"they meet at {lo:g} alone, which no 95% interval narrows to"
    if a != b and not random and lo > 0.0 and hi < 1.0:  # one run a cell: P(stands) is 0 or 1
        return "this sweep draws nothing, so its P(stands) is 0 or 1, which they leave out"
    return None


def _grid_field(key: str, values: list[Any], source: SourceMap) -> tuple[FieldPath, str, tuple[Any, ...]]:
    """A grid key (``timing.placement_error``, ``structure.bricks.1.at.0`` or ``structure.bricks[1].at[0]``)
    as a field path."""
    path: FieldPath = tuple(int(part) if part.isdigit() else part for part in grid_name(key).split("."))
    problem = grid_key_problem(key)
    if problem:
        raise source.error(("sweep", "grid", key), problem, at_key=True)
    return path, key, tuple(values)


def grid_key_problem(key: str) -> str | None:
    """Why the grid key ``key`` names no field of the scene (one line), or None. The loader says it
    at the key (:func:`_grid_field`); the Python builder's :class:`~stackdsl.lang.schema_sweep.Sweep`
    refuses the same keys, so that what it builds its ``to_yaml()`` writes as a file the loader reads."""
    from .validation_errors import fields_at

    path: FieldPath = tuple(int(part) if part.isdigit() else part for part in grid_name(key).split("."))
    for i, part in enumerate(path):
        named = path[:i] == ("structure",) or path[:i] in NAMED  # a part's, a material's or a brick type's name
        allowed = fields_at(path[:i]) if isinstance(part, str) and not named else []
        if allowed and part not in allowed:
            return f"the grid names {key!r}, but {'.'.join(map(str, path[:i])) or 'a scenario'} has no field {part!r}; it has: {', '.join(allowed)}"
        if path[0] in ("stackdsl", "sweep", "expect", "seed"):
            return f"the grid varies the scene: {key!r} is not part of it"
    return None


GRID_KEY_CHECKS.append(grid_key_problem)  # the models' grid keys pass the loader's check too


def _grid_path(data: Any, path: FieldPath, key: str, source: SourceMap, drawn: set[FieldPath]) -> FieldPath:
    """The field path of grid key ``key`` (``path``, as :func:`_grid_field` read it) in the file as
    read (``data``): a part of a list of parts named by its ``name`` becomes its index. A field the
    file leaves out is put in by the grid, but never an item of a list it does not have, a field
    of a number, one of a distribution (the grid replaces it whole) or the second kind of a field
    that is one of several (an action's ``remove`` where the file has a ``shake``).

    Raises:
        ScenarioError: at the grid key, saying which step of the path the file does not have.
    """

    def refuse(why: str) -> ScenarioError:
        return source.error(("sweep", "grid", key), f"the grid names {key!r}, but {why}", at_key=True)

    out: list[str | int] = []
    node = data
    for i, seg in enumerate(path):
        where = format_path(tuple(out)) if out else "the scenario"
        if tuple(out) in drawn:
            raise refuse(f"{where} is a distribution; the grid may replace it whole, as {where!r}")
        if isinstance(node, list):
            seg = _list_item(node, seg, where, refuse)
        elif isinstance(node, dict) and (seg in node or str(seg) in node):
            seg = seg if seg in node else str(seg)
        elif isinstance(node, dict) or node is None:  # a field the file leaves out: the grid puts it in
            _check_left_out(node, path, i, tuple(out), where, refuse)
            return _one_field((*out, *path[i:]), None, key, refuse)
        elif isinstance(seg, int):
            raise refuse(f"this file has no item {seg} in {where} (it is {_value(node)})")
        else:
            raise refuse(f"{where} is {_value(node)}, which has no field {seg!r}")
        out.append(seg)
        node = node[seg]
    return _one_field(tuple(out), node, key, refuse)


def _list_item(node: list[Any], seg: str | int, where: str, refuse: Callable[[str], ScenarioError]) -> int:
    """The index in the file's list ``node`` (at ``where``) of the grid path's step ``seg``: an
    index, or the name of an item (a part's ``name``).

    Raises:
        ScenarioError: (from ``refuse``) when no item has that name or the list has no such index.
    """
    if isinstance(seg, str):
        found = [j for j, item in enumerate(node) if isinstance(item, dict) and item.get("name") == seg]
        if not found:
            names = [str(item["name"]) for item in node if isinstance(item, dict) and "name" in item]
            known = f"its items are named {', '.join(names)}" if names else "name an item by its index"
            raise refuse(f"{where} is a list with no item named {seg!r}; {known} (or by index, 0 to {len(node) - 1})")
        return found[0]
    if not 0 <= seg < len(node):
        raise refuse(f"this file has no item {seg} in {where}")
    return seg


def _check_left_out(
    node: dict[str, Any] | None,
    path: FieldPath,
    i: int,
    out: tuple[str | int, ...],
    where: str,
    refuse: Callable[[str], ScenarioError],
) -> None:
    """Refuse the grid putting in step ``i`` of ``path`` (and those after it), a field the file
    leaves out of ``node`` (at ``out``, shown as ``where``; ``None`` when the file leaves the whole
    section out) when it would make up an item of a list, a part the structure has no name for,
    or a second kind of a field that is one of several.

    Raises:
        ScenarioError: (from ``refuse``) saying which step the file does not have.
    """
    from .validation_errors import model_at

    seg = path[i]
    later = [j for j in range(i, len(path)) if isinstance(path[j], int)]
    if later:
        missing = format_path(path[: later[0]])
        raise refuse(f"this file has no item {path[later[0]]} in {missing}")
    if isinstance(node, dict) and out == ("structure",) and node:
        parts = [str(k) for k in node if k not in Structure.model_fields]
        if parts or seg not in Structure.model_fields:
            has = f"its parts: {', '.join(parts)}" if parts else f"it is a {next(iter(node))}, not parts"
            raise refuse(f"structure has no part named {seg!r} ({has})")
    if isinstance(node, dict):
        _refuse_second_kind(model_at(out), node, str(seg), where, refuse)


def _one_field(path: FieldPath, node: Any, key: str, refuse: Callable[[str], ScenarioError]) -> FieldPath:
    """``path`` (grid key ``key`` resolved) when it names one field; a whole section, part,
    action or list (``structure``, ``actions.0``, ``structure.left``) is refused, naming a field
    inside it (found in ``node``, the file's value there, when it has one): a cell would be a whole
    scene swapped in, labelled by all of it, and a grid is a field's values.

    Raises:
        ScenarioError: at the grid key.
    """
    what = whole_of(path)
    if what is None:
        return path
    inside = ".".join(str(seg) for seg in a_field_in(path, node))
    such = f", such as {f'{key.strip()}.{inside}'!r}" if inside else ""
    raise refuse(f"that is {what}, not one field; a grid key names one field to vary{such}, with a list of its values")


def _refuse_second_kind(model: Any, node: dict[str, Any], seg: str, where: str, refuse: Callable[[str], ScenarioError]) -> None:
    """Refuse putting ``seg`` into ``node`` (of ``model``) when the model takes one of several
    fields (its JSON Schema's ``oneOf``: an action's kind, a structure's layout) and ``node``
    already has another one."""
    extra = getattr(model, "model_config", {}).get("json_schema_extra") if model is not None else None
    branches = [set(b.get("required", ())) for b in extra.get("oneOf", ())] if isinstance(extra, dict) else []
    if not any(seg in b for b in branches):
        return
    others = [k for k in node if any(k in b and seg not in b for b in branches)]
    if others:
        raise refuse(f"{where} is a {others[0]}, not a {seg}")


def _no_overlap(grid: tuple[tuple[FieldPath, str, tuple[Any, ...]], ...], source: SourceMap) -> None:
    """Refuse two grid keys for one field, or one inside the other's (each would undo the other).

    Raises:
        ScenarioError: at the later key.
    """
    for j, (path, key, _) in enumerate(grid):
        for other, first, _ in grid[:j]:
            n = min(len(path), len(other))
            if path[:n] == other[:n]:
                how = "the same field as" if len(path) == len(other) else "a field inside" if len(path) > n else "a field around"
                raise source.error(("sweep", "grid", key), f"the grid key {key!r} names {how} {first!r}", at_key=True)


def _put(data: Any, path: FieldPath, value: Any) -> None:
    """Put ``value`` at ``path`` (from :func:`_grid_path`) in ``data``, a copy of the file as read."""
    for key in path[:-1]:
        if isinstance(key, str) and isinstance(data, dict) and data.get(key) is None:
            data[key] = {}
        data = data[key]
    data[path[-1]] = value


def _get(data: Any, path: FieldPath) -> Any:
    for key in path:
        data = data[key]
    return data


def _number(value: Any, unit: str) -> Any:
    """A drawn value as a number of ``unit`` (as written when it is not a number)."""
    if not unit and isinstance(value, (int, float)) and not isinstance(value, bool):
        return value
    try:
        return in_unit(value, unit) if unit else split_quantity(value)[0]
    except ValueError:
        return value


def _column(label: str, unit: str) -> str:
    """A parameter's column name: ``"timing.placement_error [m]"``, or the label alone without a unit."""
    return f"{label} [{unit}]" if unit else label


def _grid_unit(values: tuple[Any, ...]) -> str:
    """The unit of a grid field's column: that of its values written with one (a bare number in
    the same list is in that unit already), else ``""``."""
    return next((unit for unit in (in_language_units(v)[1] for v in values) if unit), "")


def _scaled(value: Any, factor: float) -> Any:
    """``value`` times ``factor`` when it is a number (a drawn choice of names stays as it is)."""
    return value * factor if isinstance(value, (int, float)) and not isinstance(value, bool) and factor != 1.0 else value


def _value(value: Any) -> str:
    """A grid value in a message: text quoted (``'10 mm'``), a list or a mapping as YAML writes it."""
    return flow(value) if isinstance(value, (list, dict)) else spelled(value)


def _shown(values: dict[str, Any]) -> str:
    return ", ".join(f"{k} = {flow(v)}" for k, v in values.items())


__all__ = ["ScenarioError", "Template"]
