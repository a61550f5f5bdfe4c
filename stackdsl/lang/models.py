"""The scenario language's models in one place: the public way to build a scenario in Python.

Each model is the pydantic model a YAML file is validated into, with the same fields, units
(SI numbers, or strings with a unit) and checks; :meth:`Scenario.to_yaml` writes one as a file::

    >>> from stackdsl.lang.models import Expect, Part, Scenario, Structure, Tower
    >>> bridge = Scenario(
    ...     stackdsl=1,
    ...     name="bridge",
    ...     structure=Structure(parts=[
    ...         Part(name="left", origin=(-0.1, 0), tower=Tower(levels=6, yaw=90)),
    ...         Part(name="right", origin=(0.1, 0), tower=Tower(levels=6, yaw=90)),
    ...         Part(name="deck", on=["left", "right"], bricks=[{"at": (0, y, 0.004)} for y in (-0.048, 0.048)]),
    ...     ]),
    ...     expect=Expect(stands=True),
    ... )
    >>> print(bridge.to_yaml().splitlines()[3])
    - name: left

Source: stackdsl's own.
"""

from __future__ import annotations

from .expectations import CollapseLevel, CollapseStatistic, Expect, Probability, Quantile, Within
from .sampling import grid_key_problem  # noqa: F401  (loading it adds its check to Sweep's grid keys)
from .schema import BrickType, Engine, Ground, Material, Scenario, Stability, Structure, Timing
from .schema_generators import Dominoes, Pyramid, Wall
from .schema_impacts import AfterLevel, Impact, Target
from .schema_layouts import BrickPlacement, CardHouse, Tower
from .schema_parts import Part
from .schema_sweep import Sweep

__all__ = [
    "AfterLevel",
    "BrickPlacement",
    "BrickType",
    "CardHouse",
    "CollapseLevel",
    "CollapseStatistic",
    "Dominoes",
    "Engine",
    "Expect",
    "Ground",
    "Impact",
    "Material",
    "Part",
    "Probability",
    "Pyramid",
    "Quantile",
    "Scenario",
    "Stability",
    "Structure",
    "Sweep",
    "Target",
    "Timing",
    "Tower",
    "Wall",
    "Within",
]
