"""stackdsl: declarative stacking scenarios for pybullet, checked against expectations.

Data flows one way, one module per step::

    load_scenario(path)        YAML -> Scenario         (_loader)
    compile_scenario(scenario) Scenario -> Program      (_compiler)
    run_program(program)       Program -> Outcome       (_runtime, with stability/)
    record_program(program)    Program -> Outcome, Trajectory  (_recorder: every brick's pose and state)
    evaluate(expect, outcome)  Outcome -> verdicts      (_expect)
    check(paths)               all of it over files     (_check)

>>> import stackdsl
>>> s = stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\nexpect: {stands: true}")
>>> stackdsl.compile_scenario(s).levels
2
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ._check import ScenarioErrors, check
    from ._check_result import CheckResult
    from ._compiler import MODE_DEFAULTS, compile_scenario
    from ._errors import ScenarioError
    from ._expect import Verdict, evaluate
    from ._loader import load_scenario, parse_scenario
    from ._outcome import Certificate, Collapse, Event, Graph, Outcome
    from ._program import End, EngineSettings, Launch, Place, Program, format_program
    from ._recorder import Recorder, record_program
    from ._runtime import run_program
    from ._schema import Scenario
    from ._trajectory import Frame, Trajectory, load_trajectory

#: Where each public name lives. The modules load on first use, so that the ``stackdsl``
#: command can take Ctrl-C while numpy, pybullet and shapely load (about 0.7 s).
_HOME = {
    "CheckResult": "_check_result",
    "ScenarioErrors": "_check",
    "check": "_check",
    "MODE_DEFAULTS": "_compiler",
    "compile_scenario": "_compiler",
    "ScenarioError": "_errors",
    "Verdict": "_expect",
    "evaluate": "_expect",
    "load_scenario": "_loader",
    "parse_scenario": "_loader",
    "Certificate": "_outcome",
    "Collapse": "_outcome",
    "Event": "_outcome",
    "Graph": "_outcome",
    "Outcome": "_outcome",
    "End": "_program",
    "EngineSettings": "_program",
    "Launch": "_program",
    "Place": "_program",
    "Program": "_program",
    "format_program": "_program",
    "Recorder": "_recorder",
    "record_program": "_recorder",
    "run_program": "_runtime",
    "Scenario": "_schema",
    "Frame": "_trajectory",
    "Trajectory": "_trajectory",
    "load_trajectory": "_trajectory",
}

__all__ = [
    "MODE_DEFAULTS",
    "Certificate",
    "CheckResult",
    "Collapse",
    "End",
    "EngineSettings",
    "Event",
    "Frame",
    "Graph",
    "Launch",
    "Outcome",
    "Place",
    "Program",
    "Recorder",
    "Scenario",
    "ScenarioError",
    "ScenarioErrors",
    "Trajectory",
    "Verdict",
    "check",
    "compile_scenario",
    "evaluate",
    "format_program",
    "load_scenario",
    "load_trajectory",
    "parse_scenario",
    "record_program",
    "run_program",
]


def __getattr__(name: str) -> Any:
    """Load a public name's module on first use (PEP 562)."""
    home = _HOME.get(name)
    if home is None:
        raise AttributeError(f"module 'stackdsl' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{home}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
