"""A grammar-based fuzzer: scenarios drawn from the language's JSON Schema (schema/scenario.schema.json,
made from the pydantic models of stackdsl/lang/), mostly valid, some mutated, each through load,
compile and a short run on both engines.

The strategies are built here from the schema by :func:`from_schema`, a small builder of our own
(hypothesis-jsonschema draws only schema-valid documents, with free text and numbers where the
loader wants brick ids, units and small counts, so almost none compiled): a node with ``examples``
or a ``default`` is drawn from them half the time, numbers stay near their lower bound, and the
``oneOf``-of-``required`` objects (a part's layout, an action's kind, a distribution) get exactly one
of their keys. Every section of a scenario can appear: parts (a list, a map, ``on``), actions,
distributions and ``per``, ``require``, ``sweep`` with a grid, marks, golden tolerances, engines.
:func:`mutated` then edits one to four places: a wrong type, an extreme number, odd unicode, a key
removed or unknown, a unit swapped. A quarter of the examples go through the Python builder
(``Scenario(**document)``) instead: what it accepts must read back from its ``to_yaml()`` to the
same scenario.

Each example (:func:`exercise`) must give, in this process, a :class:`ScenarioError` naming the
file with a line and a column, or a program; ``stackdsl compile`` must agree (exit 2 with the same
first line, or exit 0). A program then runs as ``stackdsl check -j 1 --timeout 20 --backend B`` for
B in pybullet and MuJoCo, each a subprocess under an address-space limit, killed after 120 s (a
hang): exit 0, 1 or 2 (an up-front refusal with file:line:col), no traceback, under 1.5 GB of
resident memory. Cases it found are in tests/hostile/ (``fuzz_*.yaml``).

The default suite runs :func:`test_fuzz_smoke` (a few examples, load and compile only); the long one
is marker ``slow``, its number of examples from ``STACKDSL_FUZZ_EXAMPLES`` (default 40). A run of a
given length is one command, ``nox -s fuzz -- 3600`` (noxfile.py; docs/development.md), which runs::

    STACKDSL_FUZZ_EXAMPLES=100000 STACKDSL_FUZZ_SECONDS=3600 STACKDSL_FUZZ_LOG=/tmp/fuzz.log \\
        nice -n 10 .venv/bin/python -m pytest -m slow -n 0 tests/test_grammar_fuzz.py -p no:cacheprovider

With ``STACKDSL_FUZZ_LOG`` set, a failing example does not stop the run: each example's line and
every failure's scenario are written to that file, and the test fails at the end if any failed.

Source: stackdsl's own.
"""

from __future__ import annotations

import contextlib
import copy
import io
import json
import math
import os
import re
import resource
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from stackdsl import ScenarioError, compile_scenario, load_scenario, parse_scenario
from stackdsl.cli.main import main
from stackdsl.lang.models import Scenario
from stackdsl.lang.unit_slips import UnitSlipWarning

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "schema" / "scenario.schema.json").read_text())
RUN_TIMEOUT = 20  # s, stackdsl check --timeout: the whole file's budget
OUTER_TIMEOUT = 120.0  # s: a run still going then is a hang
ADDRESS_LIMIT = 6 << 30  # bytes of address space a run may map (engines map more than they touch)
MEMORY_LIMIT = 1536 << 20  # bytes of peak resident memory a run may use
EXAMPLES = int(os.environ.get("STACKDSL_FUZZ_EXAMPLES", "40"))
LOG = os.environ.get("STACKDSL_FUZZ_LOG", "")
#: With STACKDSL_FUZZ_SECONDS, the run ends after that long (the example under way finishes).
SECONDS = float(os.environ.get("STACKDSL_FUZZ_SECONDS", "inf"))

# the strategy builder --------------------------------------------------------------------------

_NAMES = st.sampled_from(["a", "b", "left", "right", "top", "base", "L01.1", "L02.2", "d01", "x_1"])


def _ref(node: dict[str, Any]) -> dict[str, Any]:
    while "$ref" in node:
        name = node["$ref"].rsplit("/", 1)[-1]
        node = {**SCHEMA["$defs"][name], **{k: v for k, v in node.items() if k != "$ref"}}
    return node


def _number(node: dict[str, Any], integer: bool) -> st.SearchStrategy[Any]:
    low = node.get("minimum", node.get("exclusiveMinimum"))
    high = node.get("maximum", node.get("exclusiveMaximum"))
    if integer:
        lo = math.ceil(low) if low is not None else -3
        hi = math.floor(high) if high is not None else lo + 1000
        if "exclusiveMinimum" in node and lo == node["exclusiveMinimum"]:
            lo += 1
        if "exclusiveMaximum" in node and hi == node["exclusiveMaximum"]:
            hi -= 1
        near = st.integers(lo, min(hi, lo + 4)) if lo <= hi else st.just(lo)
        return st.one_of(near, near, near, st.integers(lo, hi)) if lo <= hi else near
    lo_f = float(low) if low is not None else -10.0
    hi_f = float(high) if high is not None else lo_f + 100.0
    exclude = {"exclude_min": "exclusiveMinimum" in node, "exclude_max": "exclusiveMaximum" in node}
    near = st.floats(lo_f, min(hi_f, lo_f + 2.0), **exclude)
    return st.one_of(near, near, st.floats(lo_f, hi_f, **exclude))


def _weighted(branches: list[tuple[int, st.SearchStrategy[Any]]]) -> st.SearchStrategy[Any]:
    """One of ``branches``, each as often as its weight says."""
    return st.one_of([b for weight, b in branches for _ in range(weight)])


def _is_constraint(branch: dict[str, Any]) -> bool:
    """A ``oneOf``/``anyOf`` branch that only says which keys an object must have."""
    return set(branch) <= {"properties", "required"} and all(
        set(v) <= {"not", "type", "properties", "required"} for v in branch.get("properties", {}).values()
    )


def _object(node: dict[str, Any], depth: int) -> st.SearchStrategy[dict[str, Any]]:
    properties: dict[str, Any] = node.get("properties", {})
    required = list(node.get("required", []))
    # oneOf/anyOf of ``required`` alone: the keys of one branch (a part's layout, an action's kind,
    # a target's level and side or its point); with oneOf, none of the other branches' keys
    constraints = [b for b in node.get("oneOf", node.get("anyOf", [])) if _is_constraint(b)]
    exclusive = "oneOf" in node
    extra = node.get("additionalProperties")

    @st.composite
    def build(draw: st.DrawFn) -> dict[str, Any]:
        out: dict[str, Any] = {}
        keys = list(required)
        others: set[str] = set()
        if constraints:
            chosen = draw(st.sampled_from(constraints))
            keys += [k for k in chosen.get("required", []) if k not in keys]
            if exclusive:
                others = {k for b in constraints if b is not chosen for k in b.get("required", [])} - set(keys)
        optional = [k for k in properties if k not in keys and k not in others]
        if "per" in optional and draw(st.integers(0, 5)):  # 'per' is for a tower's shift and yaw_jitter alone
            optional.remove("per")
        if optional:
            keys += draw(st.lists(st.sampled_from(optional), max_size=min(3, len(optional)), unique=True))
        for key in keys:
            out[key] = draw(strategy(properties.get(key, {}), depth + 1, not_null=True))
        if isinstance(extra, dict) and not properties:  # a map of names (materials, parts, a grid)
            low = node.get("minProperties", 0)
            for _ in range(draw(st.integers(low, max(low, 2)))):
                out[draw(_NAMES)] = draw(strategy(extra, depth + 1))
        return out

    return build()


_UNIT = re.compile(r"^\s*[-+]?[0-9.]+(?:e[-+]?[0-9]+)?\s*([A-Za-zµ°/^*·]+[A-Za-zµ°/^*·0-9]*)\s*$")
_NUMBERS = st.one_of(
    st.sampled_from([0, 1, 2, 3, 5, 10, 20, 50, 100, 0.5, 0.25, -1, -5, -20]), st.floats(-100, 100).map(lambda x: round(x, 2))
)


def _units(known: list[Any]) -> list[str]:
    """The units of the quantities among a field's examples ('2 mm' -> 'mm')."""
    out = []
    for value in known:
        for item in value if isinstance(value, list) else [value]:
            m = _UNIT.match(item) if isinstance(item, str) else None
            if m and m[1] not in out:
                out.append(m[1])
    return out


def _string(node: dict[str, Any], units: list[str]) -> st.SearchStrategy[str]:
    pattern = node.get("pattern")
    if pattern is None:
        plain = st.text(
            st.characters(codec="utf-8", exclude_categories=("Cc", "Cs")), min_size=max(1, node.get("minLength", 0)), max_size=12
        )
        return _weighted([(3, st.sampled_from(["a", "x", "kapla", "pine", "a reason", "tower"])), (1, plain)])
    regex = st.from_regex(pattern, fullmatch=True)
    if "A-Za-z\u00b5" in pattern or "A-Za-zµ" in pattern:  # a quantity: a number and a unit of the field's kind
        unit = st.sampled_from(units or ["mm", "m", "s", "deg", "m/s", "kg", "Hz"])
        return _weighted([(5, st.builds(lambda n, u: f"{n} {u}", _NUMBERS, unit)), (1, regex)])
    if pattern.startswith(("^[A-Za-z", "^[ \\t\\r\\n]*[A-Za-z")):  # a name or an id
        return _weighted([(3, _NAMES), (1, regex)])
    return regex


def strategy(
    node: dict[str, Any], depth: int = 0, units: list[str] | None = None, not_null: bool = False
) -> st.SearchStrategy[Any]:
    """Values for the JSON Schema ``node`` (of :data:`SCHEMA`): from its examples or default half the
    time, else drawn from its type, bounds and pattern (a quantity in the units of its examples);
    at depth 8 and more, its examples only. ``not_null``: a null branch is rarely taken (an optional
    field written as null is its default)."""
    node = _ref(node)
    if "allOf" in node:  # the schema's allOf is one $ref with siblings (a part named in a list)
        merged = {k: v for k, v in node.items() if k != "allOf"}
        for item in node["allOf"]:
            item = _ref(item)
            merged = {**item, **merged, "required": [*item.get("required", []), *merged.get("required", [])]}
        return strategy(merged, depth, units, not_null)
    known = [*node.get("examples", []), *([node["default"]] if "default" in node else [])]
    units = _units(known) or units or []
    if "const" in node:
        return st.just(node["const"]).map(copy.deepcopy)
    if "enum" in node:
        return st.sampled_from(node["enum"])
    drawn: st.SearchStrategy[Any] | None = None
    branches = [] if "properties" in node else (node.get("anyOf") or node.get("oneOf"))
    if branches:
        rest = {k: v for k, v in node.items() if k not in ("anyOf", "oneOf", "examples", "default")}
        weighted = []
        for b in branches:
            target = _ref(b)
            if not_null and target.get("type") == "null":
                continue
            weight = 1 if target.get("type") == "null" or "uniform" in target.get("properties", {}) else 4
            weighted.append((weight, strategy({**rest, **b}, depth + 1, units)))
        drawn = _weighted(weighted)
    elif isinstance(node.get("type"), list):
        types = [t for t in node["type"] if not (not_null and t == "null")]
        drawn = _weighted([(1 if t == "null" else 4, strategy({**node, "type": t}, depth, units)) for t in types])
    elif node.get("type") == "object" or "properties" in node:
        drawn = _object(node, depth)
    elif node.get("type") == "array":
        if "prefixItems" in node:
            drawn = st.tuples(*(strategy(i, depth + 1, units) for i in node["prefixItems"])).map(list)
        else:
            low = node.get("minItems", 0)
            high = min(node.get("maxItems", low + 3), low + 3)
            drawn = st.lists(strategy(node.get("items", {}), depth + 1, units), min_size=low, max_size=high)
    elif node.get("type") == "string":
        drawn = _string(node, units)
    elif node.get("type") in ("integer", "number"):
        drawn = _number(node, node["type"] == "integer")
    elif node.get("type") == "boolean":
        drawn = st.booleans()
    elif node.get("type") == "null":
        drawn = st.none()
    examples = st.sampled_from(known).map(copy.deepcopy)  # the schema's own objects stay as they are
    if not_null:
        examples = examples.filter(lambda v: v is not None) if any(v is not None for v in known) else st.nothing()
    if drawn is None or (depth >= 8 and known):
        return examples if known else st.one_of(st.none(), st.integers(0, 3), st.just("1 mm"))
    return st.one_of(examples, drawn) if known else drawn


#: A short run: few bricks, quick timing (a drawn timing keeps its other fields).
SHORT_TIMING = {"interval": "0.2 s", "settle": "0.2 s"}


@st.composite
def scenarios(draw: st.DrawFn) -> dict[str, Any]:
    """A scenario document from the schema: a structure always, each other section sometimes."""
    top = SCHEMA["properties"]
    doc: dict[str, Any] = {"stackdsl": 1, "structure": draw(strategy(top["structure"]))}
    for key in draw(st.lists(st.sampled_from([k for k in top if k not in ("stackdsl", "structure")]), max_size=5, unique=True)):
        doc[key] = draw(strategy(top[key]))
    for key, chance in (("actions", 4), ("sweep", 5), ("require", 5)):
        if key not in doc and draw(st.integers(0, chance - 1)) == 0:
            doc[key] = draw(strategy(top[key]))
    if "require" in doc and draw(st.integers(0, 3)):  # mostly conditions a draw can meet
        doc["require"] = draw(st.lists(REQUIRE, min_size=1, max_size=3))
    if draw(st.integers(0, 4)) > 0:
        timing = doc.get("timing") if isinstance(doc.get("timing"), dict) else {}
        doc["timing"] = {**timing, **SHORT_TIMING}
    if isinstance(doc.get("sweep"), dict) and draw(st.booleans()):
        doc["sweep"]["samples"] = draw(st.integers(1, 3))
    return _tame(doc, draw)


#: Conditions that hold, or may: a failing ``require`` costs the compiler 1000 draws.
REQUIRE = st.sampled_from(
    [
        "levels >= 1",
        "bricks > 0",
        "gap >= 0 mm",
        "overhang >= 0 mm",
        "com_offset < 10 m",
        "max_overhang < 1 m or bricks > 1",
        "not levels > 1000",
    ]
)


def _tame(node: Any, draw: st.DrawFn) -> Any:
    """Mostly small: an action 'after level N' of the examples' 12 becomes level 1 and their brick
    ids (L05.2) ids of the first levels, three times in four."""
    if isinstance(node, dict):
        return {k: _tame(v, draw) for k, v in node.items()}
    if isinstance(node, list):
        return [_tame(v, draw) for v in node]
    if isinstance(node, str) and re.search(r"after level \d|^L\d\d\.\d$", node) and draw(st.integers(0, 3)):
        return re.sub(r"level \d+", "level 1", re.sub(r"^L\d\d", "L01", node))
    return node


# mutations ------------------------------------------------------------------------------------

WRONG = [None, True, 0, -1, 1.5, "", "x", [], {}, [1, 2], {"a": 1}, "1 parsec", "3 s", "120 mm"]
EXTREME = [1e308, -1e308, 5e-324, 2**63, -(2**63), 10**40, float("nan"), float("inf"), -0.0, 1e-9, 999999]
UNICODE = ["é", "\u202etxt", "\u0000", "𝟙𝟚𝟛 mm", "１２０ mm", "a\u0301", "🧱", "\ufeffx", "Ｌ01.1", "\u2028", "x" * 300]


def _paths(node: Any, here: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    out = [here] if here else []
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*here, k))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*here, i))
    return out


@st.composite
def mutated(draw: st.DrawFn) -> dict[str, Any]:
    """A schema scenario with one to four edits: a wrong type, an extreme number, odd unicode, a key
    removed, an unknown key, a unit swapped, an item doubled."""
    doc = copy.deepcopy(draw(scenarios()))
    for _ in range(draw(st.integers(1, 4))):
        paths = _paths(doc)
        path = draw(st.sampled_from(paths))
        parent: Any = doc
        for step in path[:-1]:
            parent = parent[step]
        key = path[-1]
        kind = draw(st.sampled_from(["wrong", "extreme", "unicode", "delete", "unknown", "unit", "double"]))
        if kind == "wrong":
            parent[key] = draw(st.sampled_from(WRONG))
        elif kind == "extreme":
            parent[key] = draw(st.sampled_from(EXTREME))
        elif kind == "unicode":
            parent[key] = draw(st.sampled_from(UNICODE))
        elif kind == "delete":
            del parent[key]
        elif kind == "unknown" and isinstance(parent, dict):
            parent[draw(st.sampled_from(["levles", "id", "at", "tower", "sweep", "é", "<<"]))] = draw(st.sampled_from(WRONG))
        elif kind == "unit" and isinstance(parent[key], str):
            parent[key] = re.sub(
                r"[A-Za-zµ°/]+", draw(st.sampled_from(["s", "m", "kg", "deg", "m/s", "Hz", "parsec", ""])), parent[key], count=1
            )
        elif kind == "double" and isinstance(parent, list):
            parent.insert(key, parent[key])
        if not doc.get("structure") and draw(st.booleans()):
            break
    return doc


def as_yaml(doc: dict[str, Any]) -> str:
    return yaml.safe_dump(doc, allow_unicode=True, sort_keys=False, width=1 << 20)


# one example through load, compile and both engines ----------------------------------------------

_WHERE = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): ")


class Failure(AssertionError):
    """An example broke a rule: ``text`` is the scenario, ``what`` which rule and how."""


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (ADDRESS_LIMIT, ADDRESS_LIMIT))
    os.setsid()


def run_check(path: Path, backend: str) -> tuple[int | None, str, int]:
    """``stackdsl check -j 1 --timeout 20 --backend BACKEND PATH`` as a subprocess: (exit status,
    None when killed as a hang; stderr; peak resident bytes)."""
    env = {**os.environ, "TMPDIR": str(path.parent), "MPLBACKEND": "Agg"}
    env.pop("STACKDSL_TRACEBACK", None)
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "stackdsl",
                "check",
                "-j",
                "1",
                "--timeout",
                str(RUN_TIMEOUT),
                "--backend",
                backend,
                str(path),
            ],
            stdout=subprocess.DEVNULL,
            stderr=err,
            stdin=subprocess.DEVNULL,
            env=env,
            preexec_fn=_limit,
        )
        start, status = time.monotonic(), None
        while True:
            pid, raw, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                status = os.waitstatus_to_exitcode(raw)
                break
            if time.monotonic() - start > OUTER_TIMEOUT:
                os.killpg(proc.pid, signal.SIGKILL)
                _, _, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.02)
        proc.returncode = -9 if status is None else status
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        err.seek(0)
        return status, err.read().decode("utf-8", "replace"), usage.ru_maxrss * 1024


def _cli_compile(path: Path) -> tuple[int, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            status = main(["compile", str(path)])
        except SystemExit as exc:
            status = int(exc.code or 0)
    return status, err.getvalue()


def _timeless(message: str) -> str:
    """``message`` without what depends on the clock: the draws a require took and their seconds
    ('none of 749 draws met every condition in 30.0 s, stopped by ...')."""
    return re.sub(r"none of \d+ draws met every condition.*", "none of N draws met every condition", message)


def _located(path: Path, message: str) -> bool:
    """Whether ``message`` starts with ``PATH:LINE:COL: ``."""
    m = _WHERE.match(message)
    return bool(m) and m["file"] == str(path)


def exercise(text: str, folder: Path, engines: bool = True) -> str:
    """Load, compile and (``engines``) run ``text`` as ``folder/fuzz.yaml``; returns what happened
    ("error", "builder", "ran pybullet 0 mujoco 1"...). Raises :class:`Failure` on a broken rule."""
    path = folder / "fuzz.yaml"
    path.write_text(text, encoding="utf-8")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UnitSlipWarning)
            program = compile_scenario(load_scenario(path))
    except ScenarioError as err:
        if err.line is None and err.field:
            raise Failure(f"an error without a position: {err}") from err
        status, stderr = _cli_compile(path)
        first = (_without_warnings(stderr).splitlines() or [""])[0]
        if status != 2 or _timeless(first) != _timeless(str(err).splitlines()[0]):
            raise Failure(f"compile: exit {status}, {first!r}; the API said {str(err).splitlines()[0]!r}") from err
        return "error"
    except Exception as exc:  # any other exception is the bug this looks for
        raise Failure(f"{type(exc).__name__}: {exc}") from exc
    del program
    if not engines:
        return "compiled"
    seen = []
    for backend in ("pybullet", "mujoco"):
        status, stderr, peak = run_check(path, backend)
        seen.append(f"{backend} {status} {peak >> 20} MiB")
        if status is None:
            raise Failure(f"{backend}: a hang, killed after {OUTER_TIMEOUT:.0f} s; stderr: {stderr[-300:]}")
        if "Traceback" in stderr or status not in (0, 1, 2):
            raise Failure(f"{backend}: exit {status}; stderr: {stderr[-600:]}")
        if status == 2 and not _located(path, _without_warnings(stderr)):
            raise Failure(f"{backend}: exit 2 without file:line:col: {stderr[:300]}")
        if peak > MEMORY_LIMIT:
            raise Failure(f"{backend}: {peak >> 20} MiB of resident memory")
        leftovers = sorted(p.name for p in folder.iterdir() if p.name != "fuzz.yaml")
        if leftovers:
            raise Failure(f"{backend}: left {leftovers} behind")
    return "ran " + ", ".join(seen)


def exercise_builder(doc: dict[str, Any]) -> str:
    """``Scenario(**doc)``: a refusal is a ValueError (pydantic's ValidationError is one); what it
    accepts reads back from its ``to_yaml()`` to the same scenario, compiled alike."""
    try:
        built = Scenario(**doc)
    except (ValueError, TypeError):
        return "builder refused"
    except Exception as exc:
        raise Failure(f"the builder raised {type(exc).__name__}: {exc}") from exc
    text = built.to_yaml()
    try:
        again = parse_scenario(text)
    except ScenarioError as err:
        raise Failure(f"the builder accepted what its to_yaml() makes the loader refuse: {err}") from err
    if again.template is not None:  # random or a sweep: the file's sample 0, seeded from the file's seed
        return "builder random"
    if again.model_dump() != built.model_dump():
        raise Failure("to_yaml() reads back to another scenario")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UnitSlipWarning)
            compiled = compile_scenario(built)
    except ScenarioError:
        with pytest.raises(ScenarioError):
            compile_scenario(again)
        return "builder compile error"
    except Exception as exc:
        raise Failure(f"compiling a built scenario raised {type(exc).__name__}: {exc}") from exc
    if compile_scenario(again).model_dump() != compiled.model_dump():
        raise Failure("the scenario read back from to_yaml() compiles to another program")
    return "builder ok"


def _without_warnings(err: str) -> str:
    """stderr less the language's warnings (a ``: warning: `` line and the indented lines under it)
    and the command's notes (``stackdsl compile: showing sample 0 ...``)."""
    kept, inside = [], False
    for line in err.splitlines(keepends=True):
        if re.match(r"stackdsl \w+: ", line):
            continue
        if ": warning: " in line:
            inside = True
        elif not line.startswith(" "):
            inside = False
        if not inside:
            kept.append(line)
    return "".join(kept)


# the tests ------------------------------------------------------------------------------------

examples = st.one_of(
    scenarios().map(lambda d: ("file", d)),
    mutated().map(lambda d: ("file", d)),
    scenarios().map(lambda d: ("builder", d)),
)


class TimeUp(BaseException):
    """STACKDSL_FUZZ_SECONDS have passed: the run stops here (a BaseException, which hypothesis lets
    through at once; as an Exception it was a failure, and hypothesis went on generating)."""


def _one(case: tuple[str, dict[str, Any]], engines: bool, failures: list[str], until: float = math.inf) -> None:
    kind, doc = case
    start = time.monotonic()
    if start > until:
        raise TimeUp
    with tempfile.TemporaryDirectory(prefix="stackdsl-fuzz-") as folder:
        text = as_yaml(doc)
        try:
            what = exercise_builder(doc) if kind == "builder" else exercise(text, Path(folder), engines)
        except Failure as failure:
            if not LOG:
                raise
            failures.append(f"{failure}\n--- scenario ({kind}) ---\n{text}")
            what = f"FAILED: {str(failure)[:200]}"
    if LOG:
        with open(LOG, "a", encoding="utf-8") as log:
            log.write(f"{time.strftime('%H:%M:%S')} {time.monotonic() - start:6.1f} s {kind}: {what}\n")
            if what.startswith("FAILED"):
                log.write(failures[-1] + "\n=====\n")


def test_fuzz_smoke(tmp_path):
    """A few examples, load and compile only (no engine): the strategies draw and exercise runs."""
    failures: list[str] = []

    @settings(max_examples=5, deadline=None, database=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(examples.filter(lambda case: "require" not in case[1]))  # a require never met takes 1000 draws
    def one(case: tuple[str, dict[str, Any]]) -> None:
        _one(case, engines=False, failures=failures)

    one()
    assert not failures, failures[0]


@pytest.mark.slow
def test_fuzz_generated_scenarios_end_cleanly_on_both_engines():
    failures: list[str] = []
    phases = [Phase.generate] if LOG else [Phase.generate, Phase.shrink]

    until = time.monotonic() + SECONDS

    @settings(max_examples=EXAMPLES, deadline=None, database=None, phases=phases, suppress_health_check=list(HealthCheck))
    @given(examples)
    def one(case: tuple[str, dict[str, Any]]) -> None:
        _one(case, engines=True, failures=failures, until=until)

    with contextlib.suppress(TimeUp):
        one()
    assert not failures, f"{len(failures)} failing examples; the first:\n{failures[0]}"
