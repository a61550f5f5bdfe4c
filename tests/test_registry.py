"""The one registry of engines: found by name, asked for capabilities, and no layer above the
engines compares engine names."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

from stackdsl.engines.backend import Backend
from stackdsl.engines.registry import BACKENDS, UnknownBackend, backend, names
from stackdsl.lang.schema import BACKEND_FIELDS

PACKAGE = Path(__file__).resolve().parents[1] / "stackdsl"


def test_an_unknown_backend_is_refused_with_the_known_names():
    with pytest.raises(UnknownBackend) as caught:
        backend("bullet")
    assert isinstance(caught.value, KeyError)
    assert str(caught.value) == f"unknown backend 'bullet'; known: {', '.join(names())}"
    assert names()[:3] == ["pybullet", "mujoco", "statics"]


@pytest.mark.parametrize("name", names())
def test_each_backend_is_found_by_its_name_with_its_own_settings(name):
    found = backend(name)
    assert isinstance(found, Backend) and found.name == name and backend(name) is found
    assert found.settings.model_fields["backend"].default == name
    assert list(found.settings.DEFAULTS) == ["raw", "tuned", "extension"]


def test_the_backends_capabilities():
    pybullet, mujoco, statics = (backend(n) for n in ("pybullet", "mujoco", "statics"))
    assert names()[0] == "pybullet"  # the default engine
    assert (pybullet.extra, pybullet.split_pulls, pybullet.dynamics) == (None, True, True)
    assert (mujoco.extra, mujoco.split_pulls, mujoco.dynamics) == ("mujoco", False, True)
    assert (statics.extra, statics.split_pulls, statics.dynamics, statics.max_drop) == (None, False, False, 0.001)
    # the scenario language's fields of one engine are that backend's own settings (left out on another)
    assert all(set(fields) <= set(backend(n).own_fields) for n, fields in BACKEND_FIELDS.items())
    assert statics.own_fields == () and "friction_anchors" not in mujoco.own_fields


def test_the_registry_names_the_engines_without_loading_one():
    code = (
        "import sys\n"
        "from stackdsl.engines.registry import names\n"
        "names()\n"
        "print(sorted(m for m in sys.modules if m.startswith(('stackdsl.engines.', 'pybullet', 'mujoco', 'stability'))))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "['stackdsl.engines.registry']"


#: ``== "mujoco"``, ``"pybullet" !=``, ``in ("mujoco", ...)``: a comparison with an engine's name.
def comparisons(text: str, engines: list[str]) -> list[str]:
    """The lines of ``text`` that compare something with one of ``engines`` written as a string."""
    name = "|".join(re.escape(e) for e in engines)
    quoted = rf"""["'](?:{name})["']"""
    pattern = re.compile(rf"(?:==|!=|\bin|\bis)\s*[\[(]?\s*{quoted}|{quoted}\s*(?:==|!=|\bin\b|\bnot in\b)")
    return [line.strip() for line in text.splitlines() if pattern.search(line)]


def test_the_comparison_finder_finds_comparisons_and_no_mere_mentions():
    found = comparisons(
        'if backend == "mujoco":\n'
        "x = 'pybullet' != b\n"
        'if "statics" in names:\n'
        'if b in ("mujoco", "x"):\n'
        'missing("mujoco")\n'
        'NAME = "pybullet"\n',
        names(),
    )
    assert found == ['if backend == "mujoco":', "x = 'pybullet' != b", 'if "statics" in names:', 'if b in ("mujoco", "x"):']


def test_no_layer_above_the_engines_compares_engine_names():
    engines = PACKAGE / "engines"
    found = [
        f"{path.relative_to(PACKAGE)}: {line}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if engines not in path.parents
        for line in comparisons(path.read_text(), list(BACKENDS))
    ]
    assert found == []


def test_every_engine_the_scenario_language_names_is_a_registered_backend():
    from typing import get_args

    from stackdsl.lang.schema import Engine
    from stackdsl.lang.schema_marks import RUN_WORDS

    written = get_args(Engine.model_fields["backend"].annotation)
    assert set(written) <= set(names()) and set(RUN_WORDS["backend"]) <= set(names())
    assert Engine.model_fields["backend"].default == names()[0]


def test_an_engines_import_is_prepared_before_a_runs_clock_starts(monkeypatch):
    """A backend's ``prepare`` (its engine's import, once a process) runs before ``run_program``
    starts timing: a slow import does not count in the run's wall time. MuJoCo's import took
    0.17 s, eight times a small run, and ``stackdsl compare``'s first mode on it paid it."""
    import dataclasses
    import time

    from stackdsl import compile_scenario, parse_scenario, run_program

    calls = []

    def slow() -> None:
        calls.append(time.perf_counter())
        time.sleep(0.5)

    slowed = dataclasses.replace(backend("pybullet"), prepare=slow)
    monkeypatch.setattr("stackdsl.runtime.run.backend", lambda name: slowed)
    program = compile_scenario(parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 1}}\n", "one.yaml"))
    outcome = run_program(program)
    assert len(calls) == 1 and outcome.wall_time < 0.5


@pytest.mark.parametrize("name", [n for n in names() if backend(n).dynamics])
def test_each_engine_that_steps_prepares_its_import(name):
    """In a fresh process, importing stackdsl imports neither the engine nor its world adapter;
    the backend's ``prepare`` imports both (what ``run_program`` keeps out of its clock)."""
    if backend(name).extra is not None:
        pytest.importorskip(backend(name).extra)
    probe = (
        "import sys, stackdsl\n"
        "from stackdsl.engines.registry import backend\n"
        f"mods = ({name!r}, 'stackdsl.engines.{name}.world')\n"
        "before = [m in sys.modules for m in mods]\n"
        f"backend({name!r}).prepare()\n"
        "print(before, [m in sys.modules for m in mods])\n"
    )
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[False, False] [True, True]", out
