"""check --report: one HTML page, failures first, every picture and link on disk, and in
headless Chromium every image loads with a clean console."""

from __future__ import annotations

import html.parser
import importlib.util
import sys
from pathlib import Path

import pytest

from stackdsl.cli.main import main

STANDS = "stackdsl: 1\nname: small tower\nstructure: {tower: {levels: 2}}\nexpect: {stands: true}\n"
# the top brick's centre of mass 0.5 mm beyond the lower brick's end: it falls, so "stands" fails
FALLS = """stackdsl: 1
name: overhang
structure:
  bricks:
    - {id: base, at: [0, 0, 4 mm]}
    - {id: top, at: [60.5 mm, 0, 12 mm]}
expect: {stands: true}
"""


class Page(html.parser.HTMLParser):
    """The images, links, section ids and text of a page, in order."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.links: list[str] = []
        self.sections: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a["src"])
        elif tag == "a":
            self.links.append(a["href"])
        elif tag == "section":
            self.sections.append(a.get("class", ""))

    def handle_data(self, data):
        self.text.append(data)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """A report of two scenarios, one that holds and one that fails, and check's exit status."""
    root = tmp_path_factory.mktemp("report")
    (root / "scenarios").mkdir()
    (root / "scenarios" / "a_stands.yaml").write_text(STANDS)
    (root / "scenarios" / "b_falls.yaml").write_text(FALLS)
    out = root / "out"
    status = main(["check", str(root / "scenarios"), "-j", "1", "--report", str(out)])
    return out, status


def parse(page: Path) -> Page:
    p = Page()
    p.feed(page.read_text())
    return p


@pytest.mark.slow
def test_the_report_has_a_row_per_scenario_failures_first(report):
    out, status = report
    assert status == 1  # the report changes nothing of check's verdicts
    page = parse(out / "index.html")
    assert page.sections == ["scenario failed", "scenario"]
    text = " ".join(page.text)
    assert text.index("b_falls.yaml") < text.index("a_stands.yaml")
    assert "2 scenarios: 1 passed, 1 failed" in text
    # each row: expected and measured, and the timeline of the run
    assert "collapse 2" in text and "stands" in text
    assert text.count("timeline (") == 2 and "place" in text and "freeze" in text
    # each verdict with its proof
    assert "stands, equilibrium" in text and "collapse, " in text and text.count("certificate") >= 2


@pytest.mark.slow
def test_every_picture_and_link_of_the_report_is_on_disk(report):
    out, _ = report
    page = parse(out / "index.html")
    assert len(page.images) == 2  # a picture per scenario
    files = [link for link in page.links if not link.startswith("#")]
    assert {Path(link).name for link in files} == {"clip.gif", "graph.png", "picture.png", "trajectory.npz", "replay.html"}
    assert len(files) == 10
    for src in page.images + files:
        assert (out / src).is_file() and (out / src).stat().st_size > 0, src
    # the summary links each row
    anchors = [link[1:] for link in page.links if link.startswith("#")]
    assert len(anchors) == 2 and all(f'id="{a}"' in (out / "index.html").read_text() for a in anchors)


def test_the_page_is_self_contained(report):
    out, _ = report
    text = (out / "index.html").read_text()
    assert "<script" not in text and "http://" not in text and "https://" not in text
    assert all(not src.startswith("/") for src in parse(out / "index.html").images)  # relative: the folder can move


@pytest.mark.slow
def test_a_picture_that_cannot_be_drawn_leaves_the_verdict_and_the_other_files(tmp_path, monkeypatch, capsys):
    import stackdsl.draw.render

    def broken(*args, **kwargs):
        raise RuntimeError("no renderer today")

    monkeypatch.setattr(stackdsl.draw.render, "picture", broken)
    (tmp_path / "a.yaml").write_text(STANDS)
    status = main(["check", str(tmp_path / "a.yaml"), "-j", "1", "--report", str(tmp_path / "out")])
    assert status == 0
    assert "picture not drawn: RuntimeError: no renderer today" in capsys.readouterr().out
    text = (tmp_path / "out" / "index.html").read_text()
    assert "picture not drawn" in text and "clip.gif" in text and "graph.png" in text


def test_a_report_folder_that_is_a_file_is_bad_input(tmp_path, capsys):
    (tmp_path / "a.yaml").write_text(STANDS)
    (tmp_path / "out").write_text("")
    assert main(["check", str(tmp_path / "a.yaml"), "--report", str(tmp_path / "out")]) == 2
    assert "--report: the report goes to a folder, and this is a file" in capsys.readouterr().err


def _browser_missing() -> str:
    sys.path.insert(0, str(Path(__file__).parent))
    from browser_check import chromium

    if chromium() is None:
        return "Chromium is not installed: apt-get install -y chromium (Debian), then python -m pytest tests/test_report.py"
    if importlib.util.find_spec("playwright") is None:
        return "playwright is not installed (pip install -e '.[test]')"
    return ""


@pytest.mark.skipif(bool(_browser_missing()), reason=_browser_missing() or "ready")
def test_in_headless_chromium_every_image_loads_and_the_console_is_clean(report, tmp_path):
    from browser_check import check_page

    out, _ = report
    seen = check_page(out / "index.html", screenshot=tmp_path / "shot.png")
    assert len(seen.images) == 2 and not seen.broken, seen.images
    assert seen.console == [] and seen.failed_requests == []
    assert (tmp_path / "shot.png").stat().st_size > 10_000


@pytest.mark.skipif(bool(_browser_missing()), reason=_browser_missing() or "ready")
def test_the_browser_check_sees_a_broken_image_and_a_console_error(tmp_path):
    from browser_check import check_page

    (tmp_path / "bad.html").write_text("<html><body><img src='missing.png'><script>console.error('boom')</script></body></html>")
    seen = check_page(tmp_path / "bad.html")
    assert seen.broken == ["missing.png"] and any("boom" in line for line in seen.console) and not seen.ok
