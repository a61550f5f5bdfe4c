"""The README's and its pages' claims that a command can check, each checked by running it as written: where
goldens of a folder outside a project go (README.md), the sweep figures docs/sweeps.md quotes, and what check's -k
takes (docs/cli.md)."""

from __future__ import annotations

import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from stackdsl.cli.main import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
SWEEPS = (ROOT / "docs" / "sweeps.md").read_text()
CLI = (ROOT / "docs" / "cli.md").read_text()


def quickstart(folder: Path) -> None:
    (scenario,) = [b for b in re.findall(r"^```yaml\n(.*?)^```", README, flags=re.S | re.M) if "name: small tower" in b]
    (folder / "my_scenarios").mkdir()
    (folder / "my_scenarios" / "tower.yaml").write_text(scenario)


def golden_command() -> list[str]:
    """The README's command that writes the quickstart's golden."""
    (line,) = [x for x in README.splitlines() if "--snapshot-update" in x and "# writes " in x]
    return line.split("# writes ")[0].split()


@pytest.mark.slow  # 7-22 s: in .ci/nightly's slow part
@pytest.mark.parametrize("project", [True, False], ids=["in the clone", "no pyproject.toml above"])
def test_the_golden_goes_where_the_readme_says(tmp_path, monkeypatch, project):
    """The quickstart runs in the clone, beside stackdsl's pyproject.toml: the command's comment
    names that golden; the prose names the one of a folder with no pyproject.toml above."""
    monkeypatch.delenv("PYTEST_XDIST_WORKER", raising=False)  # the inner run is not an xdist worker
    quickstart(tmp_path)
    command = golden_command()
    if project:
        (tmp_path / "pyproject.toml").write_text("[project]\nname = 'mine'\n")
        (written,) = re.findall(r"here, in the clone[^`]*`pyproject.toml`[^`]*`([^`]+)`", README)
    else:
        (written,) = re.findall(r"with no `pyproject.toml` above, to `golden/` in the file's own folder \(`([^`]+)`\)", README)
    assert command[:3] == [".venv/bin/python", "-m", "pytest"]
    run = [sys.executable, *command[1:], "-p", "no:cacheprovider", "-n", "0"]
    done = subprocess.run(run, cwd=tmp_path, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout[-2000:]
    goldens = sorted(str(p.relative_to(tmp_path)) for p in tmp_path.rglob("*.json"))
    assert goldens == [written]


def test_the_golden_command_follows_the_install_of_what_it_needs():
    """The README's own set-up installs no pytest: the line before the golden command adds it,
    and the extra it names holds pytest and syrupy (what the plugin imports) and xdist (this
    checkout's pytest settings give -n)."""
    lines = README.splitlines()
    (at,) = [i for i, x in enumerate(lines) if "--snapshot-update" in x and "# writes " in x]
    assert re.match(r"\.venv/bin/pip install -c constraints\.txt '\.\[pytest\]'", lines[at - 1])
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert sorted(d.split(">")[0] for d in extras["pytest"]) == ["pytest", "pytest-xdist", "syrupy"]  # -n: addopts


def test_check_k_takes_pytests_expressions_and_more_than_one(tmp_path, capsys):
    text = "stackdsl: 1\nstructure: {{tower: {{levels: 2}}}}\nexpect: {{stands: true}}\n"
    for name in ("alpha", "beta", "gamma"):
        (tmp_path / f"{name}.yaml").write_text(text.format())
    assert "`-k` pytest's `-k` expressions" in CLI and "give `-k` again for more: any of them" in CLI
    assert main(["check", str(tmp_path), "-j", "1", "-k", "ALPHA or (ta and not gam)", "-k", "gam", "--json"]) == 0
    import json

    ran = [Path(r["file"]).stem for r in json.loads(capsys.readouterr().out)["results"]]
    assert ran == ["alpha", "beta", "gamma"]  # an expression each; a second -k adds, it does not replace
    assert main(["check", str(tmp_path), "-j", "1", "-k", "alpha or"]) == 2
    (line,) = capsys.readouterr().err.splitlines()  # one line
    assert (
        line == "-k: cannot read 'alpha or': at column 9: expected a word, 'not' or '(' after 'or'; got the end of the expression"
    )


def sweep_figures(text: str) -> tuple[str, str, str]:
    """(mean, low, high) of ``mean collapse level M, 95% CI [L, H]`` in ``text``."""
    found = re.search(r"mean collapse level ([0-9.]+), 95% CI \[([0-9.]+), ([0-9.]+)\]", text)
    assert found, text[-1000:]
    mean, low, high = found.groups()
    return mean, low, high


@pytest.mark.slow
def test_the_quoted_sweep_figures_are_what_the_command_gives(tmp_path):
    command = re.search(r"`(stackdsl sweep sweeps/random_single_file\.yaml --samples 2000 -j 2)`", SWEEPS)
    assert command, "docs/sweeps.md quotes the 2000-sample sweep with its command"
    quoted = sweep_figures(SWEEPS[command.end() : command.end() + 600])
    argv = [sys.executable, "-m", "stackdsl", *command[1].split()[1:], "--out", str(tmp_path / "out")]
    done = subprocess.run(
        argv, cwd=ROOT, capture_output=True, text=True, check=False, env={"STACKDSL_PROGRESS_SECONDS": "0", **_env()}
    )
    assert sweep_figures(done.stdout) == quoted


def _env() -> dict[str, str]:
    import os

    return {k: v for k, v in os.environ.items() if k != "STACKDSL_PROGRESS_SECONDS"}
