"""stackdsl: declarative stacking scenarios for pybullet, checked against expectations.

Data flows one way, one floor (subpackage) per step::

    load_scenario(path)                   YAML -> Scenario     (lang/)
    compile_scenario(scenario)            Scenario -> Program  (compile/)
    run_program(program)                  Program -> Outcome   (runtime/, with stability/)
    record_program(program)               Program -> Outcome, Trajectory (runtime/recorder: every brick's pose and state)
    evaluate(expect, outcome, threshold)  Outcome -> verdicts  (verdicts/; threshold: the program's collapse_threshold, m)
    check(paths)                          all of it over files (batch/)
    compare_golden(stored, new, tolerances)  a golden snapshot against a run's (verdicts/)

The seam to an engine is public, as httpx's transports are: a :class:`World` (one adapter
per engine; :class:`FakeWorld` moves bodies in memory, for tests), a :class:`StepLoop`
with named hooks, and :class:`Subscriber` s attached to it (only the hooks they override
are called). ``run_in(world, program, subscribers=...)`` runs a program in any world:

>>> import stackdsl
>>> class Counter(stackdsl.Subscriber):
...     placed = 0
...     def on_place(self, loop, record):
...         self.placed += 1
>>> p = stackdsl.compile_scenario(stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}"))
>>> counter = Counter()
>>> loop = stackdsl.run_in(stackdsl.FakeWorld(timestep=p.engine.timestep), p, subscribers=(counter,))
>>> counter.placed, loop.step == p.actions[-1].step
(4, True)

>>> s = stackdsl.parse_scenario("stackdsl: 1\\nstructure: {tower: {levels: 2}}\\nexpect: {stands: true}")
>>> stackdsl.compile_scenario(s).levels
2
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .batch.check import check
    from .compile.compiler import MODE_DEFAULTS, compile_scenario
    from .compile.program import End, Launch, Place, Program, format_program
    from .engines.fake import FakeWorld
    from .engines.protocol import EngineSettings, World
    from .lang.errors import ScenarioError, ScenarioErrors
    from .lang.loader import load_scenario, parse_scenario
    from .lang.schema import Scenario
    from .runtime.loop import StepLoop, Subscriber
    from .runtime.outcome import Certificate, Collapse, Event, Graph, Outcome
    from .runtime.recorder import Recorder, record_program
    from .runtime.run import RunOptions, outcome, run_in, run_program
    from .runtime.trajectory import Frame, Trajectory, load_trajectory
    from .verdicts.check_result import CheckResult
    from .verdicts.expect import Verdict, evaluate
    from .verdicts.golden_compare import Comparison, compare_golden
    from .verdicts.tolerances import Tolerances

#: Where each public name lives. The modules load on first use, so that the ``stackdsl``
#: command can take Ctrl-C while numpy, pybullet and shapely load (about 0.7 s).
_HOME = {
    "CheckResult": "verdicts.check_result",
    "ScenarioErrors": "lang.errors",
    "check": "batch.check",
    "MODE_DEFAULTS": "compile.compiler",
    "compile_scenario": "compile.compiler",
    "ScenarioError": "lang.errors",
    "Verdict": "verdicts.expect",
    "evaluate": "verdicts.expect",
    "load_scenario": "lang.loader",
    "parse_scenario": "lang.loader",
    "Certificate": "runtime.outcome",
    "Collapse": "runtime.outcome",
    "Event": "runtime.outcome",
    "Graph": "runtime.outcome",
    "Outcome": "runtime.outcome",
    "End": "compile.program",
    "EngineSettings": "engines.protocol",
    "Launch": "compile.program",
    "Place": "compile.program",
    "Program": "compile.program",
    "format_program": "compile.program",
    "Recorder": "runtime.recorder",
    "record_program": "runtime.recorder",
    "run_program": "runtime.run",
    "Scenario": "lang.schema",
    "Frame": "runtime.trajectory",
    "Trajectory": "runtime.trajectory",
    "load_trajectory": "runtime.trajectory",
    "StepLoop": "runtime.loop",
    "Subscriber": "runtime.loop",
    "run_in": "runtime.run",
    "RunOptions": "runtime.run",
    "outcome": "runtime.run",
    "World": "engines.protocol",
    "FakeWorld": "engines.fake",
    "Comparison": "verdicts.golden_compare",
    "compare_golden": "verdicts.golden_compare",
    "Tolerances": "verdicts.tolerances",
}

__all__ = [
    "MODE_DEFAULTS",
    "Certificate",
    "CheckResult",
    "Collapse",
    "Comparison",
    "End",
    "EngineSettings",
    "Event",
    "FakeWorld",
    "Frame",
    "Graph",
    "Launch",
    "Outcome",
    "Place",
    "Program",
    "Recorder",
    "RunOptions",
    "Scenario",
    "ScenarioError",
    "ScenarioErrors",
    "StepLoop",
    "Subscriber",
    "Tolerances",
    "Trajectory",
    "Verdict",
    "World",
    "check",
    "compare_golden",
    "compile_scenario",
    "evaluate",
    "format_program",
    "load_scenario",
    "load_trajectory",
    "outcome",
    "parse_scenario",
    "record_program",
    "run_in",
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
