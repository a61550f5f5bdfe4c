"""A scenario written back as YAML: the other half of building one in Python.

The pydantic models of :mod:`stackdsl.lang.schema` are the public way to build a scenario in
code (``Scenario(stackdsl=1, structure=Structure(tower=Tower(levels=3)))``);
:meth:`Scenario.to_yaml` writes one as a file that reads back to the same scenario, and so
compiles to the same Program: every value in SI units (metres, seconds) and degrees, fields at
their defaults left out, a structure of parts written as the list (or map) of them. A scenario
read from a random file or a sweep is written as that file's data, distributions and all. Text
the loader would read as something else (``1e3``, ``yes``, ``null``) is quoted, and text with a
character YAML reads as a line break (U+0085) double-quoted, where it is escaped.

Source: stackdsl's own.
"""

from __future__ import annotations

import re
from typing import Any

import yaml

#: A number with an exponent and no point, ``1e-4``: a float in YAML 1.2 (and to anyone writing
#: a tolerance), a string in YAML 1.1, which PyYAML follows. The loader reads it as a number
#: (:mod:`stackdsl.lang.loader`), so the writer quotes text written so (a part named ``1e3``).
EXPONENT_ONLY = re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$")
#: Characters YAML reads as a line break (folded into a space in a quoted scalar) besides ``\n``
#: and ``\r``: text with one is written double-quoted, where YAML escapes them (``\N``).
_BREAKS = ("\x85", "\u2028", "\u2029")


def yaml_text(data: dict[str, Any]) -> str:
    """A scenario's plain data (``Scenario.model_dump(mode="json")`` or a file's data) as YAML text
    that the loader reads back to the same data, ``stackdsl: 1`` first."""
    data = {"stackdsl": data.pop("stackdsl", 1), **data}
    return dump(data)


def dump(data: Any) -> str:
    """Plain data as YAML text that the loader reads back to the same data (:class:`_Dumper`).

    Raises:
        yaml.representer.RepresenterError: what YAML cannot write (an object)."""
    return str(yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=120))


class _Dumper(yaml.SafeDumper):
    """PyYAML's safe dumper writing a list of plain values on one line (``at: [0.0, 0.048, 0.004]``)
    and text of several lines as a block (``description: |``), that quotes all text the loader
    would read as something else: what YAML 1.1 reads as a number, a flag or null (PyYAML's own
    resolvers) and a number with an exponent and no point (:data:`EXPONENT_ONLY`, the loader's)."""


def _list(dumper: yaml.SafeDumper, value: list[Any]) -> yaml.Node:
    flat = all(not isinstance(v, (list, dict)) for v in value)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)


def _text(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    block = "\n" in value and all(c.isprintable() or c == "\n" for c in value) and value == value.rstrip(" ")
    style = "|" if block else '"' if any(c in value for c in _BREAKS) else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_Dumper.add_representer(list, _list)
_Dumper.add_representer(str, _text)
_Dumper.add_implicit_resolver("tag:yaml.org,2002:float", EXPONENT_ONLY, list("+-0123456789"))


class _FlowDumper(_Dumper):
    """:class:`_Dumper` writing everything on one line, in flow style (``{point: [0, 0, 4 mm]}``)."""


def _flow_list(dumper: yaml.SafeDumper, value: list[Any] | tuple[Any, ...]) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", list(value), flow_style=True)


def _flow_text(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    style = '"' if "\n" in value or "\r" in value or any(c in value for c in _BREAKS) else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_FlowDumper.add_representer(list, _flow_list)
_FlowDumper.add_representer(tuple, _flow_list)
_FlowDumper.add_representer(str, _flow_text)


def flow(value: Any) -> str:
    """A value of a file as YAML writes it on one line: ``null``, ``true``, ``4 mm``, ``'yes'``,
    ``{point: [0, 0, 4 mm]}`` (not Python's ``None``, ``True``, ``{'point': [0, 0, '4 mm']}``);
    what YAML cannot write as Python spells it.

    >>> flow(None), flow(True), flow("4 mm"), flow("yes"), flow({"point": [0, 0, "4 mm"]}), flow([["a", "b"], "a"])
    ('null', 'true', '4 mm', "'yes'", '{point: [0, 0, 4 mm]}', '[[a, b], a]')
    """
    try:
        text = yaml.dump(value, Dumper=_FlowDumper, default_flow_style=True, sort_keys=False, allow_unicode=True, width=10**9)
    except yaml.YAMLError:
        return repr(value)
    text = text.rstrip("\n")
    return text.removesuffix("\n...").rstrip("\n")
