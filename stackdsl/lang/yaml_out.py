"""A scenario written back as YAML: the other half of building one in Python.

The pydantic models of :mod:`stackdsl.lang.schema` are the public way to build a scenario in
code (``Scenario(stackdsl=1, structure=Structure(tower=Tower(levels=3)))``);
:meth:`Scenario.to_yaml` writes one as a file that reads back to the same scenario, and so
compiles to the same Program: every value in SI units (metres, seconds) and degrees, fields at
their defaults left out, a structure of parts written as the list (or map) of them. A scenario
read from a random file or a sweep is written as that file's data, distributions and all.

Source: stackdsl's own.
"""

from __future__ import annotations

from typing import Any

import yaml


def yaml_text(data: dict[str, Any]) -> str:
    """A scenario's plain data (``Scenario.model_dump(mode="json")`` or a file's data) as YAML text
    that the loader reads back to the same data, ``stackdsl: 1`` first."""
    data = {"stackdsl": data.pop("stackdsl", 1), **data}
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=120)


class _Dumper(yaml.SafeDumper):
    """PyYAML's safe dumper writing a list of plain values on one line (``at: [0.0, 0.048, 0.004]``)
    and text of several lines as a block (``description: |``)."""


def _list(dumper: yaml.SafeDumper, value: list[Any]) -> yaml.Node:
    flat = all(not isinstance(v, (list, dict)) for v in value)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)


def _text(dumper: yaml.SafeDumper, value: str) -> yaml.Node:
    block = "\n" in value and all(c.isprintable() or c == "\n" for c in value) and value == value.rstrip(" ")
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style="|" if block else None)


_Dumper.add_representer(list, _list)
_Dumper.add_representer(str, _text)
