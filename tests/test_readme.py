"""The README's set-up commands: two of them, first, and CI runs the test one."""

from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def setup_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = text.split("```sh\n", 1)[1].split("```", 1)[0]
    return [line for line in block.splitlines() if line.strip()]


def test_readme_opens_with_two_setup_commands():
    main_job, tests = setup_commands()
    assert "stackdsl check scenarios/" in main_job
    assert "pytest" in tests
    head = (ROOT / "README.md").read_text().split("```sh", 1)[0]
    assert head.count("\n") < 8  # the commands come first, after one sentence of what it is


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert setup_commands()[1] in ci
