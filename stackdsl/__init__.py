"""stackdsl: declarative stacking scenarios for pybullet, checked against expectations.

Data flows one way, one module per step::

    load_scenario(path)        YAML -> Scenario         (_loader)
    compile_scenario(scenario) Scenario -> Program      (_compiler)
    run_program(program)       Program -> Outcome       (_runtime, with stability/)
    evaluate(expect, outcome)  Outcome -> verdicts      (_expect)
    check(paths)               all of it over files     (_check)

>>> import stackdsl
>>> s = stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\nexpect: {stands: true}")
>>> stackdsl.compile_scenario(s).levels
2
"""

from ._check import CheckResult, ScenarioErrors, check
from ._compiler import MODE_DEFAULTS, compile_scenario
from ._errors import ScenarioError
from ._expect import Verdict, evaluate
from ._loader import load_scenario, parse_scenario
from ._outcome import Collapse, Event, Graph, Outcome
from ._program import End, EngineSettings, Launch, Place, Program, format_program
from ._runtime import run_program
from ._schema import Scenario

__all__ = [
    "MODE_DEFAULTS",
    "CheckResult",
    "Collapse",
    "End",
    "EngineSettings",
    "Event",
    "Graph",
    "Launch",
    "Outcome",
    "Place",
    "Program",
    "Scenario",
    "ScenarioError",
    "ScenarioErrors",
    "Verdict",
    "check",
    "compile_scenario",
    "evaluate",
    "format_program",
    "load_scenario",
    "parse_scenario",
    "run_program",
]
