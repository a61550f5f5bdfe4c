"""The quick set: ``python -m pytest -m quick`` proves an install works in under 30 s on 2 cores
(the README's note under its set-up commands). It is:

* the item of ``scenarios/bridge.yaml`` (conftest.py): the file loaded, compiled, run on
  pybullet, its expectations checked and its golden snapshot compared, by the pytest plugin;
* a tower run on MuJoCo (tests/test_mujoco.py, ``test_a_frozen_tower_on_mujoco_keeps_its_heights``);
* the installed ``stackdsl`` command checking a shipped scenario (here).

:data:`QUICK` names them; a test keeps the set to them, so that it stays quick.
"""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The quick set's items, as ``pytest --collect-only -q -m quick`` lists them.
QUICK = [
    "scenarios/bridge.yaml::bridge",
    "tests/test_mujoco.py::test_a_frozen_tower_on_mujoco_keeps_its_heights",
    "tests/test_quick.py::test_the_installed_command_checks_a_shipped_scenario",
]


@pytest.mark.quick
def test_the_installed_command_checks_a_shipped_scenario():
    """The console script of this environment (beside its Python), as a user types it."""
    script = Path(sys.executable).parent / "stackdsl"
    command = [str(script)] if script.is_file() else [sys.executable, "-m", "stackdsl"]
    done = subprocess.run(
        [*command, "check", "scenarios/vee_stands.yaml", "-j", "1"], cwd=ROOT, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert done.stdout.splitlines()[-1].startswith("1 scenarios: 1 passed, 0 failed")


@pytest.mark.slow  # a collection of the whole suite, 10-20 s: in .ci/nightly's slow part
def test_the_quick_set_is_what_its_docstring_says():
    listed = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-m", "quick", "-p", "no:cacheprovider", "-n", "0"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert sorted(line for line in listed.stdout.splitlines() if "::" in line) == sorted(QUICK), listed.stdout[-2000:]


def test_the_readme_gives_the_quick_command_right_under_its_two_set_up_commands():
    readme = (ROOT / "README.md").read_text().splitlines()
    fence = readme.index("```sh")
    closing = readme.index("```", fence + 1)
    assert closing - fence - 1 == 2  # the two set-up commands, alone in their block
    note = readme[closing + 1]
    assert "`.venv/bin/python -m pytest -m quick`" in note and "under 30 s" in note and len(note) <= 120
