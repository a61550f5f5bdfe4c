"""Sessions that run the shipped goldens at the lowest and at the highest versions pyproject.toml allows.

    nox -s lowest     # every ``>=X`` of [project.dependencies] and the mujoco and pytest extras, installed as ==X
    nox -s highest    # the newest release each range allows (no constraints file)
    nox -s pinned     # the versions of constraints.txt (what CI and the README install)
    nox -s lowest highest -- --goldens /tmp/goldens   # also write each session's goldens there
    nox -s fuzz -- 3600 [LOG]   # the grammar fuzzer (tests/test_grammar_fuzz.py) for an hour, both engines

Each session installs stackdsl with the ``mujoco`` and ``pytest`` extras in a new venv, prints the
versions it got, and runs the shipped scenarios against their golden snapshots (pybullet) and the
scenario library's verdicts on MuJoCo (tests/test_mujoco.py). With ``--goldens DIR`` it then writes
the goldens it measures into ``DIR/<session>/golden/`` (from a copy of the scenarios and goldens, so
the checkout's golden/ is never written), for ``docs/results/golden_diff.py`` to compare.

``fuzz`` is not one of these: it installs the ``mujoco`` and ``pytest`` extras at constraints.txt's
versions, with hypothesis, and runs the grammar fuzzer's long test for the seconds given (default
3600), logging every example and failure to LOG (default ``$TMPDIR/stackdsl-fuzz-<time>.log``, said
when it starts): docs/development.md, "The grammar fuzzer".

The lowest versions are derived here from pyproject.toml (:func:`floors`), so the file pip gets is
plain ``name==version`` lines any pip takes, and a floor that names no release fails the install.
Measured in docs/results/portability.md. Source: stackdsl's own.
"""

from __future__ import annotations

import math
import shutil
import tempfile
import time
import tomllib
from pathlib import Path

import nox
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

ROOT = Path(__file__).parent
#: The extras whose ranges the sessions measure, beside [project.dependencies].
EXTRAS = ("mujoco", "pytest", "parquet")
#: What the sessions print of what they installed.
VERSIONS = (
    "pybullet",
    "mujoco",
    "numpy",
    "scipy",
    "highspy",
    "shapely",
    "pydantic",
    "PyYAML",
    "Pint",
    "matplotlib",
    "rich",
    "pyarrow",
)

nox.options.sessions = ["lowest", "highest"]
nox.options.default_venv_backend = "venv"


def floors(pyproject: Path = ROOT / "pyproject.toml", extras: tuple[str, ...] = EXTRAS) -> list[str]:
    """``name==X`` for every requirement ``>=X`` of pyproject.toml's dependencies and ``extras``."""
    project = tomllib.loads(pyproject.read_text())["project"]
    requirements = project["dependencies"] + [r for extra in extras for r in project["optional-dependencies"][extra]]
    pins = []
    for text in requirements:
        requirement = Requirement(text)
        lower = [s.version for s in requirement.specifier if s.operator == ">="]
        if lower:
            pins.append(f"{canonicalize_name(requirement.name)}=={lower[0]}")
    return pins


def _run(session: nox.Session, constraints: list[str]) -> None:
    """Install, print the versions, run the goldens and the MuJoCo library test; write the goldens
    when ``--goldens DIR`` is given."""
    goldens = None
    if "--goldens" in session.posargs:
        goldens = Path(session.posargs[session.posargs.index("--goldens") + 1]).resolve() / session.name
    session.install(*constraints, "-e", f".[{','.join(EXTRAS)}]")
    session.run("python", "-c", _PRINT_VERSIONS, *VERSIONS)
    session.run("python", "-m", "pytest", "scenarios/", "-p", "no:cacheprovider", "-q")
    session.run(
        "python", "-m", "pytest", "tests/test_mujoco.py", "-p", "no:cacheprovider", "-q",
        "-m", "slow or not slow", "-k", "the_extension_on_mujoco",
    )  # fmt: skip
    if goldens is not None:
        tree = Path(session.create_tmp()) / "tree"
        shutil.rmtree(tree, ignore_errors=True)
        tree.mkdir()
        shutil.copy(ROOT / "pyproject.toml", tree)
        for folder in ("scenarios", "golden"):
            shutil.copytree(ROOT / folder, tree / folder)
        with session.chdir(tree):
            session.run("python", "-m", "pytest", "scenarios/", "-p", "no:cacheprovider", "-q", "--snapshot-update")
        shutil.rmtree(goldens, ignore_errors=True)
        shutil.copytree(tree / "golden", goldens / "golden")
        session.log(f"goldens written to {goldens / 'golden'}")


_PRINT_VERSIONS = """
import sys
from importlib.metadata import PackageNotFoundError, version
def of(name):
    try:
        return version(name)
    except PackageNotFoundError:
        return "not installed"
print("versions:", ", ".join(f"{name} {of(name)}" for name in sys.argv[1:]))
"""


@nox.session
def lowest(session: nox.Session) -> None:
    """The lowest version every range allows (each ``>=X`` pinned to ``==X``)."""
    pins = Path(session.create_tmp()) / "lowest.txt"
    pins.write_text("\n".join(floors()) + "\n")
    session.log(f"{pins}: {', '.join(floors())}")
    _run(session, ["-c", str(pins)])


@nox.session
def highest(session: nox.Session) -> None:
    """The newest release every range allows."""
    _run(session, ["--upgrade"])


@nox.session
def pinned(session: nox.Session) -> None:
    """The versions of constraints.txt."""
    _run(session, ["-c", str(ROOT / "constraints.txt")])


#: Seconds the ``fuzz`` session runs the fuzzer when none are given.
FUZZ_SECONDS = 3600


@nox.session
def fuzz(session: nox.Session) -> None:
    """The grammar fuzzer for ``SECONDS`` (``nox -s fuzz -- SECONDS [LOG]``; default an hour): every
    example through load, compile and a short run on pybullet and MuJoCo, each line and failure in LOG."""
    try:
        seconds, log = _fuzz_arguments(session.posargs)
    except ValueError as exc:
        session.error(str(exc))  # one line, and the session fails
    session.install("-c", str(ROOT / "constraints.txt"), "-e", ".[mujoco,pytest]", "hypothesis")
    session.log(f"fuzzing for {seconds:g} s; every example and failure in {log}")
    session.run(
        "python", "-m", "pytest", "tests/test_grammar_fuzz.py", "-m", "slow", "-n", "0", "-p", "no:cacheprovider", "-q",
        "-k", "both_engines",
        env={"STACKDSL_FUZZ_SECONDS": f"{seconds:g}", "STACKDSL_FUZZ_EXAMPLES": "1000000", "STACKDSL_FUZZ_LOG": str(log)},
    )  # fmt: skip


def _fuzz_arguments(posargs: list[str]) -> tuple[float, Path]:
    """``nox -s fuzz -- [SECONDS] [LOG]``: the seconds (a finite number above 0) and the log file's
    absolute path.

    Raises:
        ValueError: more than two arguments, or SECONDS that is not a finite number above 0.
    """
    if len(posargs) > 2:
        raise ValueError(f"give at most SECONDS and LOG, not {len(posargs)} arguments: {' '.join(posargs)}")
    try:
        seconds = float(posargs[0]) if posargs else float(FUZZ_SECONDS)
    except ValueError:
        seconds = math.nan
    if not 0 < seconds < math.inf:
        raise ValueError(f"SECONDS must be a number of seconds above 0, not {posargs[0]!r}")
    name = f"stackdsl-fuzz-{time.strftime('%Y%m%d-%H%M%S')}.log"
    log = Path(posargs[1]) if len(posargs) > 1 else Path(tempfile.gettempdir()) / name
    return seconds, log.resolve()
