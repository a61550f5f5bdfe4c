"""The README and docs/: the set-up commands first, CI in step, the examples run, no stale references,
every YAML example a scenario the parser takes."""

import doctest
import re
import subprocess
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAX_README_BYTES = 15_000  # a front page: the set-up commands, a tour, a cookbook; the reference is in docs/
MAX_LINE = 120
DOCS = ROOT / "docs"


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


def test_readme_is_short_with_short_lines():
    size = len(README.read_bytes())
    assert size <= MAX_README_BYTES, f"README.md is {size} bytes; move detail to docs/"
    long = [
        f"README.md:{n}: {len(line)} characters"
        for n, line in enumerate(README.read_text().splitlines(), 1)
        if len(line) > MAX_LINE
    ]
    assert long == []


def test_the_readme_cookbook_has_an_example_of_every_feature():
    cookbook = README.read_text().split("## Cookbook", 1)[1].split("\n## ", 1)[0]
    examples = [yaml.safe_load(block) for block in blocks(cookbook, "yaml")]
    keys = {key for example in examples for key in example}
    assert {"actions", "impacts", "require", "sweep", "golden", "skip", "xfail"} <= keys
    actions = {kind for example in examples for action in example.get("actions", []) for kind in action}
    assert actions == {"remove", "push", "shake"}
    structures = [example["structure"] for example in examples]
    assert any("tower" in s for s in structures if isinstance(s, dict))
    assert any("dominoes" in s for s in structures if isinstance(s, dict))
    assert any("on" in part or True in part for s in structures if isinstance(s, list) for part in s)  # YAML 1.1: on is True
    assert ".ci/nightly" in README.read_text()


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
    for path in markdown_pages():
        hits = re.findall(r".{0,30}\bissue \d.{0,30}", path.read_text(), flags=re.I)
        assert hits == [], f"{path.relative_to(ROOT)}: {hits}"


def test_every_relative_link_in_the_readme_exists():
    links = re.findall(r"\]\(([^)\s]+)\)", README.read_text())
    relative = [link.split("#", 1)[0] for link in links if not re.match(r"[a-z]+:|#", link)]
    assert relative, "the README links to docs/"
    assert [link for link in relative if not (ROOT / link).exists()] == []


def test_every_relative_link_in_docs_exists():
    for page in sorted(DOCS.rglob("*.md")):
        for link in re.findall(r"\]\(([^)\s]+)\)", page.read_text()):
            if not re.match(r"[a-z]+:|#", link):
                assert (page.parent / link.split("#", 1)[0]).exists(), f"{page.name}: {link}"


def test_the_readme_examples_run_as_written(tmp_path, monkeypatch):
    """The README's quickstart scenario file, then every ``pycon`` block of the README and docs/api.md as a doctest."""
    text = README.read_text()
    (scenario,) = [b for b in blocks(text, "yaml") if "name: small tower" in b]
    text += (DOCS / "api.md").read_text()
    (tmp_path / "my_scenarios").mkdir()
    (tmp_path / "my_scenarios" / "tower.yaml").write_text(scenario)
    monkeypatch.chdir(tmp_path)
    examples = blocks(text, "pycon")
    assert len(examples) >= 1  # (the stability example is a doctest of stability/__init__.py)
    runner = doctest.DocTestRunner(optionflags=doctest.NORMALIZE_WHITESPACE)
    for i, example in enumerate(examples):
        test = doctest.DocTestParser().get_doctest(example, {}, f"README.md or docs/api.md pycon block {i + 1}", str(README), 0)
        runner.run(test)
    assert runner.summarize(verbose=False).failed == 0


#: ``<!-- fragment -->`` before a ```yaml block: part of a scenario, checked over a minimal one;
#: ``<!-- fragment of PATH -->``: part of the repository's scenario PATH, checked over it.
FRAGMENT = re.compile(r"<!-- fragment(?: of (?P<base>\S+))? -->\n```yaml\n\Z")
MINIMAL = {"stackdsl": 1, "structure": {"tower": {"levels": 2}}}


def yaml_examples(path: Path) -> list[tuple[int, str, str | None]]:
    """(line, text, base) of every ```yaml block of a markdown page; ``base`` is None for a whole scenario,
    "" for a fragment over a minimal scenario, else the path of the scenario it is part of."""
    text = path.read_text()
    found = []
    for match in re.finditer(r"^```yaml\n(.*?)^```", text, flags=re.S | re.M):
        before = text[: match.start() + len("```yaml\n")]
        fragment = FRAGMENT.search(before[-300:])
        base = None if fragment is None else fragment.group("base") or ""
        found.append((text.count("\n", 0, match.start()) + 2, match.group(1), base))
    return found


def example_problem(text: str, base: str | None) -> str | None:
    """What is wrong with one YAML example (None: nothing): a whole scenario must parse and compile,
    a fragment must parse over its base."""
    from stackdsl import ScenarioError, compile_scenario, parse_scenario

    try:
        if base is None:
            compile_scenario(parse_scenario(text))
        else:
            data = dict(MINIMAL) if base == "" else yaml.safe_load((ROOT / base).read_text())
            data.update(yaml.safe_load(text))
            parse_scenario(data)
    except ScenarioError as exc:
        return str(exc).splitlines()[0]
    return None


def markdown_pages() -> list[Path]:
    return [README, *sorted(DOCS.rglob("*.md"))]


def test_every_yaml_example_in_the_readme_and_docs_is_a_scenario():
    problems, count = [], 0
    for page in markdown_pages():
        for line, text, base in yaml_examples(page):
            count += 1
            problem = example_problem(text, base)
            if problem is not None:
                problems.append(f"{page.relative_to(ROOT)}:{line}: {problem}")
    assert count >= 15  # the README's cookbook and the docs' examples are seen
    assert problems == []


def test_the_example_check_finds_a_bad_example(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "```yaml\nstackdsl: 1\nstructure: {tower: {levles: 3}}\n```\n"
        "<!-- fragment -->\n```yaml\nskip: {when: backend == mujoco}\n```\n"
        "<!-- fragment of scenarios/four_stack.yaml -->\n```yaml\nexpect: {collapse: 1001}\n```\n"
        "<!-- fragment -->\n```yaml\nexpect: {stands: true}\n```\n"
    )
    examples = yaml_examples(page)
    assert [base for _, _, base in examples] == [None, "", "scenarios/four_stack.yaml", ""]
    problems = [example_problem(text, base) for _, text, base in examples]
    assert "levles" in (problems[0] or "")
    assert "reason" in (problems[1] or "")
    assert problems[2] is not None
    assert problems[3] is None


def test_every_results_page_opens_with_the_command_that_regenerates_it():
    for page in sorted((DOCS / "results").glob("*.md")):
        if page.name == "README.md":  # the index
            continue
        lines = page.read_text().splitlines()
        body = lines[1:]
        first_block = next(i for i, line in enumerate(body) if line.startswith("```"))
        before = [line for line in body[:first_block] if line.strip()]
        assert len(before) <= 1 and not any(line.startswith("#") for line in before), f"{page.name}: {before}"
        assert body[first_block] in ("```sh", "```bash"), f"{page.name}: its first block is not a command"


def test_ci_builds_the_docs_strictly_after_the_static_gate():
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    build = ci.index(".venv/bin/mkdocs build --strict")
    assert build > ci.index(".venv/bin/lint-imports")


def test_every_docs_page_is_in_the_site_nav():
    nav = (ROOT / "mkdocs.yml").read_text().split("\nnav:", 1)[1]
    listed = set(re.findall(r"([\w/.-]+\.md)\s*$", nav, flags=re.M))
    pages = {str(p.relative_to(DOCS)) for p in DOCS.rglob("*.md")}
    assert pages - listed == set()
