"""Optional features without their extra: one line naming the pip install, exit 2, nothing run."""

from __future__ import annotations

import ast
import importlib.util
import py_compile
import subprocess
import sys
from pathlib import Path

import pytest

from stackdsl.cli.main import main
from stackdsl.util import extras

ROOT = Path(__file__).resolve().parents[1]
MUJOCO = "stackdsl: 1\nstructure: {tower: {levels: 2}}\nengine:\n  backend: mujoco\nexpect: {stands: true}\n"


@pytest.fixture
def without(monkeypatch):
    """Make the modules of the given extras unimportable (as if not installed)."""

    def hide(*names: str) -> None:
        for name in names:
            module, _ = extras.EXTRAS[name]
            monkeypatch.setitem(sys.modules, module, None)

    return hide


def one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


def test_an_installed_extra_is_found_and_a_hidden_one_is_not(without):
    assert extras.installed("mujoco") and extras.installed("dask")
    without("mujoco")
    assert not extras.installed("mujoco") and extras.installed("dask")


def test_a_mujoco_scenario_without_mujoco_points_at_its_backend(tmp_path, capsys, monkeypatch, without):
    path = tmp_path / "m.yaml"
    path.write_text(MUJOCO)
    without("mujoco")
    monkeypatch.setattr("stackdsl.batch.judge.run_program", lambda *a, **k: pytest.fail("simulated"))
    assert main(["check", str(path), "-j", "1"]) == 2
    first, *shown = capsys.readouterr().err.splitlines()  # the message, then the YAML line and a caret
    assert (
        first
        == f"{path}:4:12: engine.backend: MuJoCo is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: pip install -c constraints.txt '.[mujoco]')"
    )
    assert shown[0].strip() == "backend: mujoco"


def test_backend_mujoco_on_the_command_line_without_mujoco_names_the_option(capsys, monkeypatch, without):
    without("mujoco")
    monkeypatch.setattr("stackdsl.batch.judge.run_program", lambda *a, **k: pytest.fail("simulated"))
    four = str(ROOT / "scenarios" / "four_stack.yaml")
    for argv in (["run", four, "--backend", "mujoco"], ["compare", four, "--backend", "pybullet, mujoco", "-j", "1"]):
        assert main(argv) == 2
        assert (
            one_line(capsys)
            == "--backend: MuJoCo is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: pip install -c constraints.txt '.[mujoco]')"
        )


def test_compile_with_backend_mujoco_without_mujoco_names_the_argument(without):
    import stackdsl

    scenario = stackdsl.parse_scenario("stackdsl: 1\nstructure: {tower: {levels: 2}}\n", file="t.yaml")
    assert stackdsl.compile_scenario(scenario, backend="pybullet").engine.backend == "pybullet"
    without("mujoco")
    with pytest.raises(stackdsl.ScenarioError) as caught:
        stackdsl.compile_scenario(scenario, backend="mujoco")
    assert (
        str(caught.value)
        == "t.yaml: backend='mujoco' needs MuJoCo, which is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: pip install -c constraints.txt '.[mujoco]')"
    )


def test_a_mujoco_sweep_without_mujoco_points_at_its_backend_before_any_sample(tmp_path, capsys, without):
    path = tmp_path / "s.yaml"
    path.write_text(MUJOCO.replace("expect: {stands: true}", "sweep: {samples: 2}\nexpect: {p_stands: '>= 0.5'}"))
    without("mujoco")
    assert main(["sweep", str(path), "-j", "1", "--out", str(tmp_path / "out")]) == 2
    first, *_ = capsys.readouterr().err.splitlines()
    assert (
        first
        == f"{path}:4:12: engine.backend: MuJoCo is not installed: pip install 'stackdsl[mujoco]' (in a source checkout: pip install -c constraints.txt '.[mujoco]')"
    )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("hidden", "argv", "where"),
    [
        ("mujoco", ["bench", "freeze", "--levels", "2"], "stackdsl bench freeze"),
        ("mujoco", ["bench", "verdicts", "--count", "1", "--engines", "pybullet,mujoco"], "--engines"),
        ("mujoco", ["bench", "--quick", "--settings", "tuned,MuJoCo raw"], "--settings"),
        ("mujoco", ["bench", "height", "--settings", "MuJoCo tuned"], "--settings"),
        ("dask", ["bench", "sweep", "--samples", "1"], "stackdsl bench sweep"),
    ],
)
def test_a_bench_without_its_engine_names_the_extra(hidden, argv, where, tmp_path, capsys, monkeypatch, without):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    without(hidden)
    assert main(argv) == 2
    line = one_line(capsys)
    assert line.startswith(f"{where}: ") and line.endswith(
        f"pip install 'stackdsl[{hidden}]' (in a source checkout: pip install -c constraints.txt '.[{hidden}]')"
    )
    assert list(tmp_path.iterdir()) == []  # no output folder made


def test_a_sweep_on_dask_without_distributed_names_the_extra(capsys, without):
    without("dask")
    assert main(["sweep", str(ROOT / "sweeps" / "random_single_file.yaml"), "--dask", "local:1", "--samples", "2"]) == 2
    assert one_line(capsys).endswith(
        "needs Dask's distributed, which is not installed: pip install 'stackdsl[dask]' (in a source checkout: pip install -c constraints.txt '.[dask]')"
    )


def test_an_mp4_without_ffmpeg_names_the_extra_before_anything_runs(tmp_path, capsys, monkeypatch, without):
    without("video")
    monkeypatch.setattr("stackdsl.runtime.recorder.record_program", lambda *a, **k: pytest.fail("simulated"))
    assert main(["animate", str(ROOT / "scenarios" / "four_stack.yaml"), "-o", str(tmp_path / "clip.mp4")]) == 2
    assert one_line(capsys).endswith(
        "an MP4 clip needs imageio-ffmpeg (the ffmpeg that writes MP4), which is not installed: pip install 'stackdsl[video]' (in a source checkout: pip install -c constraints.txt '.[video]')"
    )


def test_import_stackdsl_loads_no_heavy_library():
    code = (
        "import stackdsl, sys; "
        "print(sorted(m for m in ('scipy','pybullet','mujoco','matplotlib','distributed','numpy') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_bench_says_when_the_engines_are_not_the_measured_versions(tmp_path, monkeypatch):
    from stackdsl.bench import versions

    pins = tmp_path / "constraints.txt"
    pins.write_text("pybullet==0.0.1  # an old one\nmujoco==4.0.0\n")
    monkeypatch.setattr(versions, "installed_versions", lambda: {"pybullet": "3.2.7", "mujoco": "4.0.0"})
    assert versions.version_line(pins).endswith("NOT the versions of constraints.txt: pybullet 3.2.7 (measured with 0.0.1)")
    pins.write_text("pybullet==3.2.7\nmujoco==4.0.0\n")
    assert versions.version_line(pins).endswith("(the versions of constraints.txt)")
    assert "no constraints.txt" in versions.version_line(tmp_path / "absent.txt")
    # an installed copy (no checkout beside the package) compares with the working folder's
    monkeypatch.setattr(versions, "CONSTRAINTS", tmp_path / "no checkout" / "constraints.txt")
    monkeypatch.chdir(tmp_path)
    assert versions.constraints_file() == tmp_path / "constraints.txt"
    assert versions.version_line().endswith("(the versions of constraints.txt)")


def test_the_startup_bench_checks_a_scenario_of_its_own(tmp_path, monkeypatch):
    """An installed copy has no scenarios folder beside the package: the one-file check runs a
    scenario the bench writes, which stands."""
    from stackdsl.bench import startup

    ran: list[list[str]] = []
    monkeypatch.setattr(startup.subprocess, "run", lambda argv, **kw: ran.append(list(argv)))
    rows = startup.measure(repeats=1)
    checked = next(argv for argv in ran if "check" in argv)
    assert rows[-1].what == "stackdsl check vee_stands.yaml" and not Path(checked[checked.index("check") + 1]).exists()
    small = tmp_path / "vee_stands.yaml"
    small.write_text(startup.SMALL)
    assert main(["check", str(small), "-j", "1"]) == 0


def test_the_startup_bench_says_when_its_timings_include_compiling(tmp_path, monkeypatch):
    from stackdsl.bench.startup import bytecode_note

    package = tmp_path / "pkg"
    package.mkdir()
    (package / "a.py").write_text("x = 1\n")
    (package / "b.py").write_text("y = 2\n")
    monkeypatch.setenv("PYTHONDONTWRITEBYTECODE", "1")
    sources = sorted(package.glob("*.py"))
    assert "2 of the 2 modules a check imports have no up-to-date compiled bytecode" in (bytecode_note(sources) or "")
    for source in package.glob("*.py"):
        py_compile.compile(str(source), cfile=importlib.util.cache_from_source(str(source)))
    assert bytecode_note(sources) is None  # compiled: the timings are a user's
    (package / "c.py").write_text("z = 3\n")
    assert "1 of the 3 modules" in (bytecode_note(sorted(package.glob("*.py"))) or "")
    (package / "a.py").write_text("x = 10\n")  # edited since it was compiled: its bytecode is stale
    assert "2 of the 3 modules" in (bytecode_note(sorted(package.glob("*.py"))) or "")
    monkeypatch.delenv("PYTHONDONTWRITEBYTECODE")
    assert bytecode_note(sorted(package.glob("*.py"))) is None  # each start writes what it compiles


@pytest.mark.slow
def test_version_loads_nothing_heavy_and_the_startup_bench_runs(capsys):
    code = (
        "import sys; sys.argv = ['stackdsl', '--version']; from stackdsl._entry import main; main(); "
        "print(sorted(m for m in ('scipy','pybullet','mujoco','matplotlib','distributed','numpy','pydantic') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0].startswith("stackdsl ") and out[1] == "[]"
    assert main(["bench", "startup", "--repeats", "1"]) == 0
    versions, head, _, *rows = capsys.readouterr().out.splitlines()
    assert versions.startswith("engines: pybullet ") and head.startswith("| command | median wall | target |")
    from stackdsl.bench.startup import bytecode_note, imported_sources
    from stackdsl.cli import check

    note = bytecode_note(
        imported_sources(check)
    )  # under PYTHONDONTWRITEBYTECODE with modules never compiled: said after the table
    assert rows[3:] == ([] if note is None else [note])
    assert [r.split(" | ")[0] for r in rows[:3]] == [
        "| stackdsl --version",
        "| python -c 'import stackdsl'",
        "| stackdsl check vee_stands.yaml",
    ]
    assert all(float(r.split(" | ")[1].removesuffix(" s")) > 0 for r in rows[:3])


def _loaded_after(argv: list[str], names: tuple[str, ...]) -> list[str]:
    """Which of ``names`` are imported after ``stackdsl ARGV`` in a fresh interpreter."""
    code = (
        "import sys; from stackdsl.cli.main import main\n"
        f"try: main({argv!r})\nexcept SystemExit: pass\n"
        f"print(sorted(m for m in {names!r} if m in sys.modules))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    return ast.literal_eval(done.stdout.splitlines()[-1])  # the list printed last


@pytest.mark.slow
def test_help_loads_no_command_and_a_command_loads_no_other():
    heavy = ("numpy", "pydantic", "scipy", "stackdsl.lang.schema", "stackdsl.cli.check", "stackdsl.cli.bench")
    assert _loaded_after(["--help"], heavy) == []
    others = ("stackdsl.cli.bench", "stackdsl.bench.bench", "stackdsl.cli.sweep", "stackdsl.cli.check", "stackdsl.batch.judge")
    assert _loaded_after(["compile", "scenarios/vee_stands.yaml"], others) == []
    assert _loaded_after(["check", "scenarios/vee_stands.yaml", "-j", "1"], others) == [
        "stackdsl.batch.judge",
        "stackdsl.cli.check",
    ]


def test_bench_height_without_the_profiler_says_the_extra_or_no_profile(capsys, monkeypatch, without):
    without("profile")
    monkeypatch.setattr("stackdsl.bench.cost.measure_heights", lambda *a, **k: pytest.fail("measured"))
    assert main(["bench", "height", "--levels", "2"]) == 2
    assert one_line(capsys) == (
        "bench height: the profile needs pyinstrument (a sampling profiler), which is not installed: "
        "pip install 'stackdsl[profile]' (in a source checkout: pip install -c constraints.txt '.[profile]') (or --no-profile)"
    )


@pytest.mark.parametrize("command", ["check", "compare", "compile", "run", "render", "sweep", "replay", "export", "schema"])
def test_a_commands_help_loads_no_engine_and_no_stability_package(command):
    """``stackdsl check --help`` took 0.76 s, loading the compiler and scipy.optimize for a list of
    modes; a command's help loads only what its options name."""
    code = (
        "import sys, contextlib, io\n"
        "from stackdsl.cli.main import main\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n"
        f"        main([{command!r}, '--help'])\n"
        "    except SystemExit:\n"
        "        pass\n"
        "print(sorted(m for m in ('stability', 'scipy', 'pybullet', 'mujoco', 'shapely') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_the_options_name_the_engines_modes_and_rate_the_code_has():
    from stackdsl.cli import draw
    from stackdsl.cli.main import BACKENDS, MODES
    from stackdsl.engines.registry import BACKENDS as REGISTERED
    from stackdsl.engines.registry import backend
    from stackdsl.runtime.recorder import RATE

    assert BACKENDS == list(REGISTERED) and all(MODES == list(backend(b).settings.DEFAULTS) for b in BACKENDS)
    assert draw.RATE == RATE


def test_the_startup_bench_looks_at_the_modules_its_caller_imported():
    from stackdsl.batch import judge
    from stackdsl.bench.startup import imported_sources

    sources = imported_sources(judge)
    assert sources == sorted(sources) and Path(judge.__file__) in sources
    assert all(p.suffix == ".py" and {"stackdsl", "stability"} & set(p.parts) for p in sources)
