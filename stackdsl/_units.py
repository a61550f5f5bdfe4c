"""Quantities in scenario files: "120 mm", "1 s", "3 m/s", or bare SI numbers.

A value is either a YAML number (SI units; degrees for angles) or a string of a
number, an optional ``/ number`` and a unit that pint understands. The number is read
here, not by pint, so that a hostile file cannot make pint evaluate ``9**9**9``; pint
only converts the unit. PyYAML loads ``1e3`` as a string: it is accepted as the number
1000.

>>> length("120 mm")
0.12
>>> time("1/240 s")
0.004166666666666667
>>> angle(90), angle("0.5 rad")
(90.0, 28.64788975654116)
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from functools import lru_cache
from typing import Annotated, Any

from pydantic import BeforeValidator, WithJsonSchema

_NUMBER = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d{1,3})?"
_QUANTITY = re.compile(
    rf"^\s*(?P<num>{_NUMBER})(?:\s*/\s*(?P<den>{_NUMBER}))?\s*(?P<unit>[A-Za-zµ°][A-Za-zµ°/^*·\d ]{{0,30}})?\s*$"
)


@lru_cache(maxsize=1)
def _registry():
    import pint  # imported lazily: it takes a third of a second

    return pint.UnitRegistry()


def parse_quantity(value: Any, dimension: str, unit: str, what: str, example: str, unit_name: str = "") -> float:
    """Convert ``value`` to a float in ``unit`` (an SI unit, or degrees).

    Args:
        value: a number (already in ``unit``) or a string such as ``"120 mm"``.
        dimension: pint dimensionality the unit must have, e.g. ``"[length]"``
            (``""`` for dimensionless).
        unit: the unit of the result, e.g. ``"m"``.
        what: the kind of quantity, for messages ("a length").
        example: an example for messages ("'120 mm'").
        unit_name: how messages name ``unit`` ("metres"); defaults to ``unit``.

    Raises:
        ValueError: not a number, a unit of the wrong kind, or not finite.
    """
    expected = f"expected {what} such as {example} or a number of {unit_name or unit}"
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(f"{expected}, got {value!r}")
    if isinstance(value, str):
        match = _QUANTITY.match(value)
        if not match:
            raise ValueError(f"{expected}, got {value!r}")
        denominator = float(match["den"]) if match["den"] else 1.0
        if denominator == 0:
            raise ValueError(f"{expected}, got {value!r} (a division by zero)")
        number = float(match["num"]) / denominator
        if match["unit"]:
            number *= _factor(match["unit"].strip(), dimension, unit, f"{expected}, got {value!r}")
    else:
        number = float(value)
    if not math.isfinite(number):
        raise ValueError(f"{expected}, got {value!r} (not finite)")
    return number


def _factor(text: str, dimension: str, unit: str, message: str) -> float:
    ureg = _registry()
    try:
        units = ureg.parse_units(text)
        quantity = ureg.Quantity(1.0, units)
        if quantity.dimensionality != ureg.get_dimensionality(dimension or "[]"):
            raise ValueError
        return float(quantity.to(unit).magnitude)
    except Exception:  # pint's parser raises many kinds; any of them means: not a unit we know
        raise ValueError(message) from None


def _kind(dimension: str, unit: str, what: str, example: str, unit_name: str = "") -> tuple[Callable[[Any], float], Any]:
    unit_name = unit_name or unit

    def convert(value: Any) -> float:
        return parse_quantity(value, dimension, unit, what, example, unit_name)

    schema = WithJsonSchema(
        {
            "anyOf": [{"type": "number"}, {"type": "string"}],
            "description": f"{what}: a number of {unit_name} or a string with a unit, e.g. {example}",
        }
    )
    return convert, Annotated[float, BeforeValidator(convert), schema]


length, Length = _kind("[length]", "m", "a length", "'120 mm'", "metres")
time, Time = _kind("[time]", "s", "a time", "'1 s'", "seconds")
speed, Speed = _kind("[length]/[time]", "m/s", "a speed", "'3 m/s'")
density, Density = _kind("[mass]/[length]**3", "kg/m**3", "a density", "'460 kg/m^3'", "kg/m^3")
angular_speed, AngularSpeed = _kind("1/[time]", "rad/s", "an angular speed", "'0.05 rad/s'")
angle, Angle = _kind("", "degree", "an angle", "'30 deg' or '0.5 rad'", "degrees")
