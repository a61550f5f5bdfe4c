"""The public names of both packages are what they should be (httpx style)."""

import importlib
import re
import subprocess
import sys

import pytest

import stability
import stackdsl


def test_stackdsl_exports():
    assert sorted(stackdsl.__all__) == sorted(
        [
            "MODE_DEFAULTS",
            "CheckResult",
            "Certificate",
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
    )


def test_stability_exports():
    assert sorted(stability.__all__) == sorted(
        [
            "CONTACT_GAP",
            "JITTER",
            "Box",
            "BrickGraph",
            "BrickState",
            "Certificate",
            "ContactArea",
            "ContactPoint",
            "ContactPolygon",
            "Engine",
            "Equilibrium",
            "FakeEngine",
            "GraphEdge",
            "GraphNode",
            "Load",
            "LoadNode",
            "OutOfTime",
            "Placed",
            "PlacedBox",
            "Placing",
            "Plane",
            "Pose",
            "RigidBlock",
            "StabilityConfig",
            "StabilityEvent",
            "StabilityExtension",
            "WarmStart",
            "balanced_tilted",
            "breaks_loose",
            "combined_hull",
            "contacts_of",
            "hull_xy",
            "contains",
            "equilibrium_margin",
            "face_overlap",
            "friction_share",
            "is_level",
            "kinetic_energy",
            "lean_polygon",
            "leaning_stands",
            "load_path",
            "load_paths_hold",
            "padded_hull",
            "pair_friction",
            "potential_energy",
            "propagate",
            "proven",
            "solve_equilibrium",
            "split_load",
            "still",
            "support_piece",
            "torque_split",
        ]
    )


def test_every_exported_name_exists_and_is_documented():
    for module in (stackdsl, stability):
        for name in module.__all__:
            obj = getattr(module, name)
            if callable(obj):
                assert obj.__doc__, f"{module.__name__}.{name} has no docstring"


def test_stability_knows_nothing_of_yaml():
    import ast
    import pathlib

    src = pathlib.Path(stability.__file__).parent
    for path in src.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [a.name for a in node.names] + [getattr(node, "module", None) or ""]
                assert not any(n.split(".")[0] in ("yaml", "stackdsl", "pydantic") for n in names), path.name


def test_every_stackdsl_export_loads_from_its_module():
    assert set(stackdsl.__all__) == set(stackdsl._HOME)
    for name in stackdsl.__all__:
        assert getattr(stackdsl, name) is getattr(importlib.import_module(f"stackdsl.{stackdsl._HOME[name]}"), name)
    assert set(stackdsl.__all__) <= set(dir(stackdsl))


def test_the_command_starts_without_the_heavy_modules():
    # Ctrl-C while the command loads must end as "interrupted", so the entry point loads
    # only the standard library before it guards the rest.
    code = "import sys, stackdsl._entry; print(sorted({'numpy', 'pybullet', 'shapely', 'pydantic'} & set(sys.modules)))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_check_takes_a_backend_and_refuses_unknown_overrides_before_running(tmp_path):
    """The command line's --backend, --mode and --model, as the library's arguments: an unknown
    one raises ValueError at once (it came back as an internal error result)."""
    import stackdsl

    (tmp_path / "t.yaml").write_text("stackdsl: 1\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n")
    (result,) = list(stackdsl.check(tmp_path, jobs=1, backend="mujoco"))
    assert result.backend == "mujoco" and result.passed
    for kwargs, said in (
        ({"mode": "fast"}, "unknown mode 'fast'"),
        ({"backend": "bullet"}, "unknown backend 'bullet'"),
        ({"model": "physics"}, "unknown stability model 'physics'"),
    ):
        with pytest.raises(ValueError, match=said):
            stackdsl.check(tmp_path, jobs=1, **kwargs)


@pytest.mark.parametrize(
    "kwargs, error, said",
    [
        ({"timeout": -1}, ValueError, "timeout must be a number of seconds >= 0 or None, not -1"),
        ({"timeout": float("nan")}, ValueError, "timeout must be a number of seconds >= 0 or None, not nan"),
        ({"timeout": "60"}, TypeError, "timeout must be a number of seconds >= 0 or None, not '60'"),
        ({"jobs": 0}, ValueError, "jobs must be at least 1, not 0"),
        ({"jobs": 1.5}, TypeError, "jobs must be a whole number of runs at the same time"),
    ],
)
def test_check_refuses_a_bad_timeout_or_jobs_before_it_reads_a_file(tmp_path, kwargs, error, said):
    """A negative timeout came back as the file's "internal error: ValueError ..." result with a
    traceback, and jobs=0 was raised only once the results were read: both raise at the call,
    before any file is read (the path does not even exist)."""
    import stackdsl
    from stackdsl.batch.check import compare

    with pytest.raises(error, match=re.escape(said)):
        stackdsl.check(tmp_path / "missing.yaml", **{"jobs": 1, **kwargs})
    with pytest.raises(error, match=re.escape(said)):
        compare([tmp_path / "missing.yaml"], **{"jobs": 1, **kwargs})


def test_parse_scenario_refuses_bytes_by_type():
    """Bytes were written out as YAML's !!binary and refused as such, at 1:1."""
    import stackdsl

    with pytest.raises(TypeError, match="not bytes"):
        stackdsl.parse_scenario(b"stackdsl: 1\n")  # type: ignore[arg-type]


def test_help_on_the_mode_defaults_tells_what_they_are_not_what_a_dict_is():
    import pydoc

    import stackdsl
    from stackdsl.compile.compiler import BACKEND_DEFAULTS

    shown = pydoc.render_doc(stackdsl.MODE_DEFAULTS, renderer=pydoc.plaintext)
    assert "The engine modes and what each sets" in shown and "dict() -> new empty dictionary" not in shown.split("Methods")[0]
    assert stackdsl.MODE_DEFAULTS == BACKEND_DEFAULTS["pybullet"]  # the same modes and values
