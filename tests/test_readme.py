"""The README and docs/: the set-up commands first, CI in step, the examples run, no stale references."""

import doctest
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_README_LINES = 262  # "about 250 lines at most": room for the speed-against-error table of both engines, the quick check


def setup_commands() -> list[str]:
    text = README.read_text()
    block = text.split("```sh\n", 1)[1].split("```", 1)[0]
    return [line for line in block.splitlines() if line.strip()]


def blocks(text: str, language: str) -> list[str]:
    """The fenced code blocks of ``language`` in a markdown text."""
    return re.findall(rf"^```{language}\n(.*?)^```", text, flags=re.S | re.M)


def test_readme_opens_with_two_setup_commands():
    main_job, tests = setup_commands()
    assert "stackdsl check scenarios/" in main_job
    assert "pytest" in tests
    head = README.read_text().split("```sh", 1)[0]
    assert head.count("\n") < 8  # the commands come first, after one sentence of what it is


def test_ci_runs_the_readme_test_command():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert setup_commands()[1] in ci


def test_readme_is_short():
    lines = README.read_text().splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines; move detail to docs/"


def tracked_text_files() -> list[Path]:
    names = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True).stdout.decode().split("\0")
    files = []
    for name in filter(None, names):
        path = ROOT / name
        if not path.is_file():  # deleted in the working tree
            continue
        data = path.read_bytes()
        if b"\0" in data:  # binary (the benchmark's plots)
            continue
        files.append(path)
    return files


def test_no_tracked_file_cites_the_engineers_brief():
    if not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    needles = ["DESIGN" + ".md", "shared" + "/"]  # spelled apart so that this file does not match itself
    found = [
        f"{path.relative_to(ROOT)}:{n}: {line.strip()}"
        for path in tracked_text_files()
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), 1)
        if any(needle in line for needle in needles)
    ]
    assert found == []


def test_readme_and_docs_mention_no_issue_numbers():
    for path in [README, *sorted((ROOT / "docs").glob("*.md"))]:
        hits = re.findall(r".{0,30}\bissue \d.{0,30}", path.read_text(), flags=re.I)
        assert hits == [], f"{path.relative_to(ROOT)}: {hits}"


def test_every_relative_link_in_the_readme_exists():
    links = re.findall(r"\]\(([^)\s]+)\)", README.read_text())
    relative = [link.split("#", 1)[0] for link in links if not re.match(r"[a-z]+:|#", link)]
    assert relative, "the README links to docs/"
    assert [link for link in relative if not (ROOT / link).exists()] == []


def test_every_relative_link_in_docs_exists():
    for page in sorted((ROOT / "docs").glob("*.md")):
        for link in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if not re.match(r"[a-z]+:|#", link):
                assert (page.parent / link.split("#", 1)[0]).exists(), f"{page.name}: {link}"


def test_the_readme_examples_run_as_written(tmp_path, monkeypatch):
    """The quickstart's scenario file, then every ``pycon`` block of the README as a doctest."""
    text = README.read_text()
    (scenario,) = [b for b in blocks(text, "yaml") if "name: small tower" in b]
    (tmp_path / "my_scenarios").mkdir()
    (tmp_path / "my_scenarios" / "tower.yaml").write_text(scenario)
    monkeypatch.chdir(tmp_path)
    examples = blocks(text, "pycon")
    assert len(examples) >= 1  # (the stability example is a doctest of stability/__init__.py)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    for i, example in enumerate(examples):
        test = doctest.DocTestParser().get_doctest(example, {}, f"README.md pycon block {i + 1}", str(README), 0)
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0
