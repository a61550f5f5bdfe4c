"""Quantities in scenario files: "120 mm", "1 s", "3 m/s", or bare SI numbers.

A value is either a YAML number (SI units; degrees for angles) or a string of a
number, an optional ``/ number`` and a unit that pint understands. The number is read
here, not by pint, so that a hostile file cannot make pint evaluate ``9**9**9``; pint
only converts the unit. PyYAML loads ``1e3`` as a string: it is accepted as the number
1000.

The grammar of the string is one regular expression, written so that it means the same
in Python and in ECMA-262 (ASCII classes, no ``\\d``/``\\s``, no named groups): the JSON
Schema of scenario files (:func:`quantity_pattern`) uses the same text as the loader.

>>> length("120 mm")
0.12
>>> time("1/240 s")
0.004166666666666667
>>> angle(90), angle("0.5 rad")
(90.0, 28.64788975654116)

Source: stackdsl's own.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, GetJsonSchemaHandler
from pydantic.json_schema import JsonSchemaValue
from pydantic_core import CoreSchema

from .spelling import spelled

# Regular expressions valid and equal in Python `re` and ECMA-262 (also with the `u` flag).
WHITESPACE = "[ \\t\\r\\n]"  # not \s, on which Python and ECMA-262 disagree
SPACE = f"{WHITESPACE}*"  # what may surround the parts; a trailing newline is space, so `$` means the same in both
_EXPONENT = "(?:[eE][-+]?[0-9]{1,3})?"
UNSIGNED = f"(?:[0-9]+(?:\\.[0-9]*)?|\\.[0-9]+){_EXPONENT}"
"""The one grammar of a number the language reads, unsigned, in a quantity, a tolerance (``'7 ± .5'``),
a bound (``'>= .9'``) and a condition: ``5``, ``5.``, ``.5``, ``0.5``, ``5e-1``; not ``.``, ``..5``,
``5..`` or ``1e`` (:data:`NONZERO` and :data:`ZERO` split it by its digits for the JSON Schema)."""
NONZERO = f"(?:[0-9]*[1-9][0-9]*(?:\\.[0-9]*)?|[0-9]*\\.[0-9]*[1-9][0-9]*){_EXPONENT}"  # an UNSIGNED with a nonzero digit
ZERO = f"(?:0+(?:\\.0*)?|\\.0+){_EXPONENT}"  # an UNSIGNED with no nonzero digit
UNIT = "[A-Za-zµ°][A-Za-zµ°/^*·0-9 ]{0,30}"
_QUANTITY = re.compile(f"^{SPACE}([-+]?{UNSIGNED})(?:{SPACE}/{SPACE}({UNSIGNED}))?{SPACE}({UNIT})?{SPACE}$")

Sign = Literal["any", "non-negative", "positive"]


def quantity_pattern(sign: Sign = "any") -> str:
    """The loader's grammar of a quantity string as a regular expression for a JSON Schema ``pattern``.

    ``sign`` narrows the number for fields bounded below by 0: every unit's factor is
    positive and the denominator is unsigned, so the sign of the value is the sign of the
    numerator (``"-0 mm"`` is not negative). A zero denominator is left out: the loader
    refuses it. What the pattern cannot say: the unit's dimension (pint decides), bounds
    other than the sign, and numbers beyond a double (``1e999``, ``1e-999``).
    """
    numerator = {"any": f"[-+]?{UNSIGNED}", "non-negative": f"(?:\\+?{UNSIGNED}|-{ZERO})", "positive": f"\\+?{NONZERO}"}[sign]
    return f"^{SPACE}{numerator}(?:{SPACE}/{SPACE}{NONZERO})?{SPACE}(?:{UNIT})?{SPACE}$"


@lru_cache(maxsize=1)
def _registry() -> Any:
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

    def message() -> str:  # said only when refused: a random tower's draws convert 100,000 shifts
        return f"expected {what} such as {example} or a number of {unit_name or unit}, got {spelled(value)}"

    number, unit_text = _split(value, message)
    if unit_text:
        factor = _unit_factor(unit_text, dimension, unit)
        if factor is None:
            raise ValueError(message())
        number *= factor
    if not math.isfinite(number):
        raise ValueError(f"{message()} (not finite)")
    return number


def _split(value: Any, message: Callable[[], str]) -> tuple[float, str]:
    """(number, unit as written, ``""`` for none) of a number or a quantity string, not checked
    for finiteness.

    Raises:
        ValueError: ``message()``, for anything else.
    """
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise ValueError(message())
    if not isinstance(value, str):
        try:
            return float(value), ""
        except OverflowError:  # an integer too large for a double
            return math.inf, ""
    match = _QUANTITY.match(value)
    if not match:
        raise ValueError(message())
    numerator, denominator, unit_text = match.groups()
    if float(denominator or 1) == 0:
        raise ValueError(f"{message()} (a division by zero)")
    return float(numerator) / float(denominator or 1), (unit_text or "").strip()


#: pint's factors for the units scenario files write most, by (unit as written, dimension, unit
#: of the result), so that a file written in them never loads pint (a third to a half of a
#: second at every start); tests/test_units.py checks each against pint itself.
KNOWN_UNITS: dict[tuple[str, str, str], float] = {
    ("mm", "[length]", "m"): 0.001,
    ("cm", "[length]", "m"): 0.01,
    ("m", "[length]", "m"): 1.0,
    ("s", "[time]", "s"): 1.0,
    ("ms", "[time]", "s"): 0.001,
    ("m/s", "[length]/[time]", "m/s"): 1.0,
    ("mm/s", "[length]/[time]", "m/s"): 0.001,
    ("cm/s", "[length]/[time]", "m/s"): 0.01,
    ("kg/m^3", "[mass]/[length]**3", "kg/m**3"): 1.0,
    ("g/cm^3", "[mass]/[length]**3", "kg/m**3"): 1000.0,
    ("rad/s", "1/[time]", "rad/s"): 1.0,
    ("deg", "", "degree"): 1.0,
    ("degree", "", "degree"): 1.0,
    ("degrees", "", "degree"): 1.0,
    ("rad", "", "degree"): 180.0 / math.pi,
    ("Hz", "1/[time]", "Hz"): 1.0,
}


def _unit_factor(text: str, dimension: str, unit: str) -> float | None:
    """The factor from the unit ``text`` to ``unit``, or None when pint reads no unit of
    ``dimension`` in it: :data:`KNOWN_UNITS`, else pint (:func:`pint_factor`)."""
    known = KNOWN_UNITS.get((text, dimension, unit))
    return known if known is not None else pint_factor(text, dimension, unit)


@lru_cache(maxsize=4096)
def pint_factor(text: str, dimension: str, unit: str) -> float | None:
    """:func:`_unit_factor` by pint. Remembered: pint takes about 0.1 ms to parse a unit, and a
    random tower's draws write every layer's shift with one (``"0.0123 mm"``), 100,000 parses for
    1000 draws of 100 levels; a unit is at most 31 characters (:data:`UNIT`), of few kinds in a file."""
    ureg = _registry()
    try:
        units = ureg.parse_units(text)
        quantity = ureg.Quantity(1.0, units)
        if quantity.dimensionality != ureg.get_dimensionality(dimension or "[]"):
            raise ValueError
        base = quantity.to_base_units()
        if unit == "Hz" and dict(base.unit_items()).get("radian") == 1:
            # an angle per time is a frequency of turns: 120 rpm is 2 Hz, 2 pi rad/s is 1 Hz (pint
            # counts a radian as 1, which read 120 rpm as 12.6 Hz)
            return float(base.magnitude) / (2 * math.pi)
        if unit == "degree" and dict(base.unit_items()).get("radian") != 1:
            return None  # a plain number's unit (percent, ppm) is no angle, though pint counts a radian as 1
        return float(quantity.to(unit).magnitude)
    except Exception:  # pint's parser raises many kinds; any of them means: not a unit we know
        return None


#: The base dimensions a unit of :func:`si_unit` may be made of, in the order of its exponents.
SI_BASE = (("[length]", "m"), ("[time]", "s"), ("[mass]", "kg"))


@lru_cache(maxsize=256)
def si_unit(text: str) -> tuple[float, tuple[int, ...]] | None:
    """The factor from the unit ``text`` to SI base units and its whole exponents of metre, second
    and kilogram (:data:`SI_BASE`); None when pint reads no unit in it, or one of another kind (an
    angle's, whose radian pint counts as 1, a current's, a fractional power).

    >>> si_unit("mm/s^2"), si_unit("cm^2"), si_unit("deg/s"), si_unit("parsec") is not None
    ((0.001, (1, -2, 0)), (0.0001, (2, 0, 0)), None, True)
    """
    ureg = _registry()
    try:
        quantity = ureg.Quantity(1.0, ureg.parse_units(text))
        dimensions = dict(quantity.dimensionality)
        base = quantity.to_base_units()
    except Exception:  # pint's parser raises many kinds; any of them means: not a unit we know
        return None
    names = [d for d, _ in SI_BASE]
    if set(dimensions) - set(names) or any(not float(e).is_integer() for e in dimensions.values()):
        return None
    if any(ureg.Quantity(1.0, u).dimensionless for u, _ in base.unit_items()):  # radians, turns: angles
        return None
    return float(base.magnitude), tuple(int(dimensions.get(d, 0)) for d in names)


_BOUNDS = {"gt": "exclusiveMinimum", "ge": "minimum", "lt": "exclusiveMaximum", "le": "maximum"}


@dataclass(frozen=True)
class _QuantityJsonSchema:
    """JSON Schema of a quantity: a number within the field's bounds (SI units), or a string in the
    loader's grammar (:func:`quantity_pattern`, narrowed to the sign the lower bound allows)."""

    description: str

    def __get_pydantic_json_schema__(self, core_schema: CoreSchema, handler: GetJsonSchemaHandler) -> JsonSchemaValue:
        # Bounds set around the converter (Annotated[Length, Field(gt=0)]) are checked on the converted value, and
        # pydantic hands them over by their pydantic names ("gt"): they become JSON Schema's ("exclusiveMinimum").
        number = {_BOUNDS.get(key, key): value for key, value in handler(core_schema).items()}
        lower = number.get("exclusiveMinimum", number.get("minimum"))
        sign: Sign = (
            "any" if lower is None or lower < 0 else "positive" if lower > 0 or "exclusiveMinimum" in number else "non-negative"
        )
        return {"anyOf": [number, {"type": "string", "pattern": quantity_pattern(sign)}], "description": self.description}


def _kind(dimension: str, unit: str, what: str, example: str, unit_name: str = "") -> tuple[Callable[[Any], float], Any]:
    unit_name = unit_name or unit

    def convert(value: Any) -> float:
        return parse_quantity(value, dimension, unit, what, example, unit_name)

    schema = _QuantityJsonSchema(f"{what}: a number of {unit_name} or a string with a unit, e.g. {example}")
    return convert, Annotated[float, BeforeValidator(convert), schema]


def within(
    kind: Any,
    convert: Callable[[Any], Any],
    low: float,
    high: float,
    shown: str,
    why: str | tuple[str, str] = "",
    *,
    above: bool = False,
    below: bool = False,
) -> Any:
    """``kind`` (a quantity type such as :data:`Length`, or a number type) bounded to [``low``,
    ``high``] (open at ``low`` if ``above``, at ``high`` if ``below``) after ``convert``
    (:func:`length`, :func:`real`...).

    Refusals read ``expected <shown>, got <value>; <why>``: ``shown`` says the range with units
    ("a length from 3 mm to 10 m"), ``why`` the physical reason for the bounds, or a pair: the
    reason for the lower bound (given for a value below it) and for the upper one. The bounds reach
    the JSON Schema as ``minimum``/``maximum``. Values that ``convert`` refuses keep its message;
    ``convert`` may return ``value`` unchanged when it is not a number, for a later validator.
    Source: stackdsl's own.
    """

    def inside(number: float) -> bool:
        return (low < number if above else low <= number) and (number < high if below else number <= high)

    def check(value: Any) -> Any:
        number = convert(value)
        if isinstance(number, float) and math.isfinite(number):
            number = _at_bound(number, low, above) if number < low else _at_bound(number, high, below)
        if isinstance(number, float) and math.isfinite(number) and not inside(number):
            reason = "" if number <= 0 < low else why if isinstance(why, str) else why[number > low]  # no reason for <= 0
            slip = ""
            if convert is length and number > high and bare(value) and inside(number / 1000):
                slip = f" ({value:g} m: a bare number is metres; did you mean '{value:g} mm'?)"
            slip = slip or _converted(value, number, convert)
            raise ValueError(f"expected {shown}, got {spelled(value)}{slip}" + (f"; {reason}" if reason else ""))
        return number

    bounds = Field(gt=low if above else None, ge=None if above else low, lt=high if below else None, le=None if below else high)
    return Annotated[kind, bounds, BeforeValidator(check)]


def _at_bound(number: float, bound: float, open_: bool) -> float:
    """``bound`` for a ``number`` that misses a closed bound by rounding alone ('1 g/L' is
    0.9999999999999999 kg/m^3 in doubles; a bound written "at most X" takes X however it is
    written), else ``number``: within a relative 1e-12 of the bound, some thousands of ulps."""
    return bound if not open_ and number != bound and abs(number - bound) <= 1e-12 * abs(bound) else number


def _converted(value: Any, number: float, convert: Callable[[Any], Any]) -> str:
    """`` (0.0796 Hz)``: a value written in a unit other than the one its bounds are said in,
    converted to that one; "" for a bare number, a value in that unit, or a converter not known."""
    unit = {length: "m", time: "s", speed: "m/s", density: "kg/m^3", angular_speed: "rad/s", angle: "deg", frequency: "Hz"}
    shown = unit.get(convert)
    written = split_quantity(value)[1] if isinstance(value, str) else ""
    if shown is None or not written or written.replace(" ", "") in (shown, "degree", "degrees"):
        return ""
    if shown == "m" and abs(number) < 1:  # lengths are said in mm
        number, shown = number * 1000, "mm"
        if written == "mm":
            return ""
    text = f"{number:.4g}"
    whole = "e+" in text and abs(number) < 1e9  # 30000, not 3e+04
    return f" ({f'{number:.0f}' if whole else text} {shown})"


def bare(value: Any) -> bool:
    """Whether ``value`` is a YAML number (not a string with a unit, not true/false)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def real(value: Any) -> Any:
    """A YAML number as a float (for :func:`within`); anything else unchanged, for the field's own type to refuse."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        try:
            number = float(value)
        except OverflowError:  # an integer beyond a double
            return value
        return number if math.isfinite(number) else value
    return value


length, Length = _kind("[length]", "m", "a length", "'120 mm'", "metres")
time, Time = _kind("[time]", "s", "a time", "'1 s'", "seconds")
speed, Speed = _kind("[length]/[time]", "m/s", "a speed", "'3 m/s'")
density, Density = _kind("[mass]/[length]**3", "kg/m**3", "a density", "'460 kg/m^3'", "kg/m^3")
angular_speed, AngularSpeed = _kind("1/[time]", "rad/s", "an angular speed", "'0.05 rad/s'")
angle, Angle = _kind("", "degree", "an angle", "'30 deg' or '0.5 rad'", "degrees")
frequency, Frequency = _kind("1/[time]", "Hz", "a frequency", "'2 Hz'", "hertz")


def split_quantity(value: Any) -> tuple[float, str]:
    """A number or a quantity string as (number, unit as written; ``""`` for a bare number).

    >>> split_quantity("12.5 mm"), split_quantity(3), split_quantity("1/240 s")
    ((12.5, 'mm'), (3.0, ''), (0.004166666666666667, 's'))

    Raises:
        ValueError: not a finite number or a quantity string.
    """
    number, unit = _split(value, lambda: f"expected a number or a quantity such as '12 mm', got {spelled(value)}")
    if not math.isfinite(number):
        raise ValueError(f"expected a finite number, got {spelled(value)}")
    return number, unit


#: The unit a bare number means in a scenario, by the kind of quantity (pint's names), and how
#: tables name it: SI, with angles in degrees as the language reads them.
LANGUAGE_UNITS = (("m", "m"), ("s", "s"), ("m/s", "m/s"), ("kg/m**3", "kg/m^3"), ("rad/s", "rad/s"), ("degree", "deg"))


@lru_cache(maxsize=256)
def language_unit(unit: str) -> tuple[float, str]:
    """(factor, name) that turn a number of ``unit`` (as written: ``"mm"``) into one of the unit
    a bare number means for its kind of quantity (``(0.001, "m")``); ``(1.0, unit)`` for a unit of
    another kind or one pint does not know.

    >>> language_unit("mm"), language_unit("km/h"), language_unit("rad")
    ((0.001, 'm'), (0.2777777777777778, 'm/s'), (57.29577951308232, 'deg'))
    """
    ureg = _registry()
    try:
        quantity = ureg.Quantity(1.0, ureg.parse_units(unit))
        for target, name in LANGUAGE_UNITS:
            units = ureg.parse_units(target)
            if quantity.dimensionality == units.dimensionality:
                return float(quantity.to(units).magnitude), name
    except Exception:  # pint raises many kinds: a unit it does not know
        pass
    return 1.0, unit


def in_language_units(value: Any) -> tuple[Any, str]:
    """A value of a scenario as (number in the unit a bare number means, that unit's name):
    ``"2 mm"`` -> ``(0.002, "m")``, ``3`` -> ``(3.0, "")`` (a bare number is that unit already);
    anything that is not a number or a quantity unchanged, with ``""``."""
    try:
        number, unit = split_quantity(value)
    except ValueError:
        return value, ""
    if not unit:
        return number, ""
    factor, name = language_unit(unit)
    return number * factor, name


def in_unit(value: Any, unit: str, *, of: str = "every value of a distribution") -> float:
    """``value`` (a number or a quantity string) as a number of ``unit`` (as written in a file,
    ``""``: a bare number, whose own unit is the field's); ``of`` names, in an error, the values
    that must share a unit.

    >>> in_unit("2 cm", "mm"), in_unit(4, "")
    (20.0, 4.0)

    Raises:
        ValueError: not a number or a quantity; a unit of another kind than ``unit``'s; a bare
            number other than 0 where ``unit`` is given, or a quantity where it is not.
    """
    number, own = split_quantity(value)
    if own == unit or (number == 0.0 and not own):  # a bare 0 is 0 of any unit
        return number
    if not own or not unit:
        raise ValueError(f"give {of} with the same kind of unit, or none: {value!r} and {unit or 'no unit'!r}")
    ureg = _registry()
    try:
        quantity = ureg.Quantity(number, ureg.parse_units(own))
        return float(quantity.to(ureg.parse_units(unit)).magnitude)
    except Exception:  # pint raises many kinds: a unit it does not know, or of another dimension
        raise ValueError(f"{value!r} cannot be written in {unit!r}: give {of} in units of one kind") from None
