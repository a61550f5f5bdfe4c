"""How closely a golden snapshot must be matched: the tolerances of its measured fields.

A golden snapshot (:meth:`stackdsl.Outcome.golden`) compares what decides a verdict exactly and
what is measured within these tolerances (:mod:`stackdsl.verdicts.golden_compare`). The
defaults follow from two lengths of the scene, not from the snapshot's rounding:

* the **collapse threshold** (half the thinnest brick side, 4 mm for KAPLA): a brick that
  moved that far has collapsed, so a tolerance well under it can never hide a collapse;
* the engine's **contact margin** (pybullet's 1 mm collision margin; MuJoCo's contact width,
  0.1 mm tuned): within it the engine's contact points, not the geometry, decide where a brick
  settles, so two honest runs differ by about that much.

``position`` = max(contact margin, collapse threshold / 4): 1 mm for KAPLA on either engine.
Four times under the threshold, a change that can flip a verdict shows; at the contact margin,
what the engine settles by noise does not. Positions and centres of mass above use it.

``angle`` = the turn that moves the end of the scene's longest brick by ``position``: 0.95 deg
for a KAPLA brick (1 mm at 60 mm).

``load_share`` = 0.05: a share is (distance of the centre of mass above to the other support)
/ (distance between the supports); a 1 mm move over supports 20 mm apart moves it 0.05.
``mass`` = 0.05 of the mass above, for the same reason (what a brick carries is the shares of
the bricks above). ``area`` = 0.05 of a contact area, and at least ``position`` times the
contact's shorter side (a 1 mm slide of a 24 mm wide brick changes its overlap by 24 mm^2).

``margin`` = ``position``: the certificate's margin is a distance of the same centres of mass.
``friction_share`` = 0.05: the friction a stand needs moves with its contact angles, 0.05 for
about 1.5 deg at a leaning brick's 20 deg.

``level`` = 1: the first brick to move of twins and the lowest level to go are decided by
chaos at the boundary (which of two bricks of a level tips first); a change of more than one
level is a change of behaviour.

A project sets its own in ``pyproject.toml`` (``[tool.stackdsl.golden.tolerance]``, the keys
and values of a scenario's ``golden: {tolerance: ...}``), and a scenario in its YAML; the
scenario's win, key by key.

Source: stackdsl's own.

>>> t = Tolerances(position_mm=1.0, angle_deg=1.0)
>>> t.area_mm2(576.0, 24.0), t.mass_g(200.0)
(28.8, 10.0)
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from ..compile.program import Program
from ..lang.errors import ScenarioError
from ..lang.schema import Scenario
from ..lang.schema_golden import GoldenTolerance

#: The defaults that do not follow from the scene (see the module docstring).
LOAD_SHARE = 0.05
MASS_SHARE = 0.05
AREA_SHARE = 0.05
FRICTION_SHARE = 0.05
LEVELS = 1
#: mm, a KAPLA brick's corner from its long axis (hypot(12, 4)) and its width.
KAPLA_RADIUS = math.hypot(12.0, 4.0)
KAPLA_WIDTH = 24.0
#: Degrees and millimetres the snapshot rounds to: no tolerance is finer than its rounding.
ROUNDING_MM = 0.1
ROUNDING_DEG = 0.1


@dataclass(frozen=True)
class Tolerances:
    """Tolerances of a golden snapshot's measured fields (see the module docstring).

    Attributes:
        position_mm: mm, positions and centres of mass above.
        angle_deg: degrees, a brick's turn.
        mass: a share of the mass above.
        area: a share of a contact area.
        load_share: a load share's own units.
        margin_mm: mm, the certificate's margin.
        friction_share: the share of friction a stand needs.
        level: levels, the first moved brick's and the moved levels' ends.
        radius_mm: mm, the least distance of a brick's corner from its long axis (KAPLA: 12.6):
            a turn that moves its corners by d mm is at most d / radius radians.
        width_mm: mm, the scene's narrowest brick side across its length (KAPLA: 24).
    """

    position_mm: float = 1.0
    angle_deg: float = 1.0
    mass: float = MASS_SHARE
    area: float = AREA_SHARE
    load_share: float = LOAD_SHARE
    margin_mm: float = 1.0
    friction_share: float = FRICTION_SHARE
    level: int = LEVELS
    radius_mm: float = KAPLA_RADIUS
    width_mm: float = KAPLA_WIDTH

    def mass_g(self, mass_above_g: float) -> float:
        """Grams a mass above of ``mass_above_g`` may differ by (at least the rounding)."""
        return max(self.mass * abs(mass_above_g), ROUNDING_MM)

    def area_mm2(self, area_mm2: float, side_mm: float) -> float:
        """mm^2 a contact area may differ by: its share, and at least ``position`` times the
        contact's shorter side ``side_mm``."""
        return max(self.area * abs(area_mm2), self.position_mm * side_mm, ROUNDING_MM)

    def described(self) -> str:
        """``'position 1 mm, angle 0.95 deg, ...'``, for a failure message."""
        return (
            f"position {self.position_mm:.3g} mm, angle {self.angle_deg:.3g} deg, mass {self.mass:.3g}, "
            f"area {self.area:.3g}, load share {self.load_share:.3g}, margin {self.margin_mm:.3g} mm, "
            f"friction share {self.friction_share:.3g}, level {self.level}"
        )

    def with_given(self, given: GoldenTolerance | None) -> Tolerances:
        """These, with each key ``given`` sets (SI: metres, degrees) in its place."""
        if given is None:
            return self
        update: dict[str, Any] = {}
        for name, value in given.model_dump().items():
            if value is None:
                continue
            key = {"position": "position_mm", "angle": "angle_deg", "margin": "margin_mm"}.get(name, name)
            update[key] = value * 1000 if key.endswith("_mm") else value
        return replace(self, **update)


def default_tolerances(program: Program) -> Tolerances:
    """The defaults of a compiled scene (the module docstring): from its collapse threshold,
    its engine's contact margin and its longest brick."""
    position = max(program.engine.contact_margin, program.collapse_threshold / 4) * 1000
    sizes = [sorted(p.brick.half_extents) for p in program.placements] or [[0.004, 0.012, 0.06]]
    longest = max(s[2] for s in sizes) * 1000
    radius = min(math.hypot(s[0], s[1]) for s in sizes) * 1000
    return Tolerances(
        position_mm=max(position, ROUNDING_MM),
        angle_deg=max(math.degrees(position / longest), ROUNDING_DEG),
        margin_mm=max(position, ROUNDING_MM),
        radius_mm=radius,
        width_mm=min(s[1] for s in sizes) * 2000,
    )


#: The table of ``pyproject.toml`` a project's tolerances are read from.
PROJECT_TABLE = ("tool", "stackdsl", "golden", "tolerance")


def project_tolerance(pyproject: str | Path) -> GoldenTolerance | None:
    """A project's tolerances: ``[tool.stackdsl.golden.tolerance]`` of ``pyproject`` (None when
    the file or the table is not there).

    Raises:
        ScenarioError: the file is not TOML, or a key or value of the table is refused (the
            message names the file and the key, as a scenario's would).
    """
    path = Path(pyproject)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot be read: {getattr(exc, 'strerror', None) or exc}", file=str(path)) from None
    try:
        table: Any = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"not TOML: {exc}", file=str(path)) from None
    for depth, key in enumerate(PROJECT_TABLE):
        if not isinstance(table, dict) or key not in table:  # 'tool' is every tool's: not ours to judge
            return None
        table = table[key]
        here = ".".join(PROJECT_TABLE[: depth + 1])
        if depth + 1 < len(PROJECT_TABLE) and depth >= 1 and not isinstance(table, dict):  # tool.stackdsl = 3
            raise ScenarioError(f"{here}: expected a table, got {type(table).__name__} {table!r:.40}", file=str(path))
        if here == "tool.stackdsl.golden" and set(table) - {"tolerance"}:  # a misspelt tolerance table is not ignored
            raise ScenarioError(f"{here}.{sorted(set(table) - {'tolerance'})[0]}: unknown key; known: tolerance", file=str(path))
    where = ".".join(PROJECT_TABLE)
    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: expected a table of tolerances", file=str(path))
    try:
        return GoldenTolerance.model_validate(table)
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(part) for part in first["loc"])
        message = first["msg"].removeprefix("Value error, ")
        if first["type"] == "extra_forbidden":  # the keys a scenario's golden.tolerance takes, the same
            message = f"unknown key; known: {', '.join(GoldenTolerance.model_fields)}"
        raise ScenarioError(f"{where}.{field}: {message}", file=str(path)) from None


def tolerances_for(program: Program, scenario: Scenario, pyproject: str | Path | None = None) -> Tolerances:
    """A scenario's tolerances: the defaults of its compiled ``program``, then the project's
    (``pyproject``'s ``[tool.stackdsl.golden.tolerance]``), then the scenario's own
    (``golden: {tolerance: ...}``), key by key.

    Raises:
        ScenarioError: the project's table is refused (:func:`project_tolerance`).
    """
    project = project_tolerance(pyproject) if pyproject is not None else None
    return default_tolerances(program).with_given(project).with_given(scenario.golden.tolerance)
