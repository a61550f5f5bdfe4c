"""The ``golden:`` block of a scenario: how closely its golden snapshot must be matched.

A golden snapshot compares its verdict fields exactly and its measured fields within
tolerances (:mod:`stackdsl.verdicts.golden_compare`); a scenario may set its own, and a
project its own for every scenario in ``pyproject.toml``'s ``[tool.stackdsl.golden.tolerance]``,
with the same keys and values. Each key left out keeps the project's value, or the default
(:mod:`stackdsl.verdicts.tolerances`)::

    golden:
      tolerance:
        position: 2 mm        # positions and centres of mass above
        angle: 2              # degrees, a brick's turn
        mass: 0.05            # a share of the mass above (5%)
        area: 0.1             # a share of a contact area (10%)
        load_share: 0.05      # a load share's own units (0 to 1)
        margin: 1 mm          # the certificate's margin
        friction_share: 0.05  # the share of each friction coefficient a stand needs
        level: 1              # levels: the first moved brick's, the ends of the moved levels

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

from pydantic import Field

from .bounds import Number, StrictModel
from .grammar import WHOLE
from .units import Angle, Length, angle, length, within

if TYPE_CHECKING:
    ToleranceLength = float
    ToleranceAngle = float
else:
    ToleranceLength = within(
        Length, length, 0.0, 1.0, "a length from 0 to 1 m", "a tolerance beyond a metre compares nothing a brick does"
    )
    ToleranceAngle = within(Angle, angle, 0.0, 180.0, "an angle from 0 to 180 degrees", "no turn is larger")

Share = Annotated[Number, Field(ge=0, le=1)]


class GoldenTolerance(StrictModel):
    """Tolerances of a golden snapshot's measured fields; None: the project's, or the default
    (what each means: :data:`stackdsl.lang.schema_docs.DOCS`, ``GoldenTolerance``)."""

    position: ToleranceLength | None = None
    angle: ToleranceAngle | None = None
    mass: Share | None = None
    area: Share | None = None
    load_share: Share | None = None
    margin: ToleranceLength | None = None
    friction_share: Share | None = None
    level: Annotated[int, Field(ge=0, le=1000), WHOLE] | None = None


class Golden(StrictModel):
    """How this scenario's golden snapshot is compared: ``tolerance`` (:class:`GoldenTolerance`)."""

    tolerance: GoldenTolerance = GoldenTolerance()
