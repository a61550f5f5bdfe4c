"""The HTML report of a check: one self-contained page beside each scenario's pictures.

``stackdsl check PATHS --report DIR`` writes ``DIR/index.html`` and a folder per scenario
(:mod:`stackdsl.draw.artefacts`: picture, clip, brick-graph plot, trajectory file). The page
has no script and loads nothing from elsewhere: its style is inline and its images are
the files beside it, so the folder can be copied, archived by a CI server or opened from
disk. Failures come first (an undecided sweep, a strict xfail that passed), then the scenarios
expected to fail (the file's xfail mark), the skipped ones with their reasons, the scenarios that
passed, and a summary table.

Source: stackdsl's own (the layout of pytest-html's report: a row per test, failures
first, the test's extras linked from its row).
"""

from __future__ import annotations

import datetime
import html
import os
import shlex
from collections.abc import Sequence
from pathlib import Path

from .._version import version
from ..runtime.outcome import Event
from ..runtime.trajectory import load_trajectory
from ..util.files import written
from ..verdicts.check_result import CheckResult
from ..verdicts.expect import describe
from .report import mode_label, summary

#: Events listed in a row's timeline at most (a 100-level tower has about 400).
TIMELINE_LIMIT = 600

STYLE = """
body { font: 14px/1.45 system-ui, sans-serif; margin: 1.5em auto; max-width: 72em; padding: 0 1em; color: #222; }
h1 { font-size: 1.5em; margin-bottom: 0.2em; }
h2 { font-size: 1.2em; margin: 1.6em 0 0.6em; border-bottom: 1px solid #ccc; }
.meta { color: #555; margin: 0; }
code { background: #f3f3f3; padding: 0 0.25em; border-radius: 3px; }
.verdict { font-weight: bold; padding: 0.1em 0.5em; border-radius: 3px; color: #fff; }
.pass { background: #2e7d32; } .fail { background: #c62828; } .inconclusive { background: #ef6c00; }
.skip { background: #757575; } .xfail { background: #6d4c41; } .xpass { background: #f9a825; color: #222; }
.scenario { display: flex; gap: 1.2em; padding: 0.9em 0; border-bottom: 1px solid #eee; }
.scenario.failed { background: #fff5f5; }
.thumb { width: 320px; height: 240px; object-fit: contain; background: #fafafa; border: 1px solid #ddd; flex: none; }
.nothumb { width: 320px; height: 240px; display: flex; align-items: center; justify-content: center;
           background: #fafafa; border: 1px solid #ddd; color: #777; flex: none; }
.body { flex: 1; min-width: 0; }
.body h3 { margin: 0 0 0.3em; font-size: 1.05em; overflow-wrap: anywhere; }
table.facts td { padding: 0 1em 0 0; vertical-align: top; }
table.facts td:first-child { color: #666; }
ul.why { color: #b71c1c; margin: 0.4em 0; }
.links a { margin-right: 1em; }
details { margin-top: 0.4em; }
table.timeline { border-collapse: collapse; font-size: 0.9em; }
table.timeline td { padding: 0 0.8em 0 0; white-space: nowrap; }
table.summary { border-collapse: collapse; width: 100%; }
table.summary th, table.summary td { text-align: left; padding: 0.2em 0.8em 0.2em 0; border-bottom: 1px solid #eee;
                                     overflow-wrap: anywhere; }
td.num, th.num { text-align: right; }
"""


def write_report(
    results: Sequence[CheckResult],
    folder: str | Path,
    *,
    total: int,
    wall: float,
    commands: Sequence[str],
    argv: Sequence[str] = (),
    title: str = "stackdsl check",
) -> Path:
    """Write ``folder/index.html`` for ``results`` (in file order), whose pictures are
    already in their folders under ``folder``; its path.

    Args:
        results: one per scenario run; ``commands``: the ``stackdsl run`` command of each.
        total: scenarios selected (more than ``len(results)`` when check stopped early).
        wall: seconds the whole check took; argv: the command line, shown on the page;
        title: the page's heading (``stackdsl search`` writes one too).

    Raises:
        OSError: the page cannot be written.
    """
    out = Path(folder)
    pairs = list(zip(results, commands, strict=True))
    failed = [(r, c) for r, c in pairs if not r.held]
    passed = [(r, c) for r, c in pairs if r.verdict == "PASS"]
    marked = [(r, c) for r, c in pairs if r.held and r.verdict in ("XFAIL", "XPASS")]
    skipped = [(r, c) for r, c in pairs if r.verdict == "SKIP"]
    now = datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    command = shlex.join(["stackdsl", *argv]) if argv else title
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(title)}: {len(failed)} failed, {len(passed)} passed</title>",
        f"<style>{STYLE}</style></head><body>",
        f"<h1>{_e(title)}</h1>",
        f'<p class="meta">{_e(_counts(results, total, wall))}</p>',
        f'<p class="meta"><code>{_e(command)}</code> &middot; stackdsl {_e(version())} &middot; {_e(now)}</p>',
    ]
    if failed:
        parts.append(f'<h2 id="failed">Failed ({len(failed)})</h2>')
        parts += [_row(r, c, out) for r, c in failed]
    if marked:  # the file's xfail mark: failed as expected, or passed (not strict)
        parts.append(f'<h2 id="xfail">Expected to fail ({len(marked)})</h2>')
        parts += [_row(r, c, out) for r, c in marked]
    if skipped:
        parts.append(f'<h2 id="skipped">Skipped ({len(skipped)})</h2>')
        parts += [_row(r, c, out) for r, c in skipped]
    if passed:
        parts.append(f'<h2 id="passed">Passed ({len(passed)})</h2>')
        parts += [_row(r, c, out) for r, c in passed]
    parts += ['<h2 id="summary">Summary</h2>', _summary(results, total, wall), "</body></html>"]
    page = out / "index.html"
    with written(page) as part:
        part.write_text("\n".join(parts) + "\n", encoding="utf-8")
    return page


def remove_stale_folders(folder: str | Path, keep: set[str]) -> int:
    """Remove the folders of an earlier report in ``folder`` that this one did not write: those
    not in ``keep`` that hold nothing but a run's files (:data:`stackdsl.draw.artefacts.FILES`), so
    that no folder a person put there is touched. Returns how many were removed."""
    import shutil

    from ..draw.artefacts import FILES

    removed = 0
    for sub in Path(folder).iterdir():
        if sub.name in keep or not sub.is_dir() or sub.is_symlink():
            continue
        names = {f.name for f in sub.iterdir()}
        if names and names <= set(FILES.values()) and all((sub / n).is_file() for n in names):
            shutil.rmtree(sub)
            removed += 1
    return removed


def _e(text: object) -> str:
    return html.escape(str(text), quote=True)


def _counts(results: Sequence[CheckResult], total: int, wall: float) -> str:
    """check's summary line (:func:`stackdsl.batch.report.summary`), the wall time after a ';'."""
    return summary(results, total, wall).replace(f" ({wall:.1f} s wall)", f"; {wall:.1f} s wall")


def _anchor(r: CheckResult) -> str:
    return "s-" + (Path(r.folder).name if r.folder else "".join(c if c.isalnum() else "-" for c in r.file))


def _link(r: CheckResult, kind: str, folder: Path) -> str | None:
    """The page-relative address of a run's file of ``kind``, or None when it was not written."""
    name = dict(r.artefacts).get(kind)
    if not name or not r.folder:
        return None
    path = Path(r.folder) / name
    try:
        return Path(os.path.relpath(path, folder)).as_posix()
    except ValueError:  # another drive (Windows)
        return path.resolve().as_uri()


def _badge(r: CheckResult) -> str:
    """The verdict as a coloured word (:attr:`CheckResult.verdict`); a strict XPASS in the colour of a failure."""
    word = r.verdict
    kind = "fail" if word == "XPASS" and not r.held else word.lower()
    return f'<span class="verdict {kind}">{word}</span>'


def _row(r: CheckResult, command: str, folder: Path) -> str:
    """One result's section: its picture, verdict, facts, why it failed, links to its files
    and the command that reruns it (``command``), and its timeline."""
    located = [] if r.sweep else [v.lines()[0] for v in r.verdicts if not v.passed and v.at is not None]
    why = "".join(f"<li>{_e(line)}</li>" for line in [*located, *r.explanation])  # where each failed expectation is written
    problems = [p for p in (r.draw_error,) if p]
    return "\n".join(
        [
            f'<section class="scenario{"" if r.held else " failed"}" id="{_e(_anchor(r))}">',
            _thumb(r, folder),
            '<div class="body">',
            f"<h3>{_badge(r)} {_e(r.file)} <small>{_e(r.scenario)}</small></h3>",
            f'<table class="facts">{_facts(r)}</table>',
            f'<ul class="why">{why}</ul>' if why else "",
            f'<p class="links">{" ".join(_links(r, folder))} <code>{_e(command)}</code></p>',
            "".join(f'<p class="meta">{_e(p)}</p>' for p in problems),
            _timeline(r),
            "</div></section>",
        ]
    )


def _thumb(r: CheckResult, folder: Path) -> str:
    """The result's picture, linked to itself, or why there is none."""
    picture = _link(r, "picture", folder)
    if not picture:
        return f'<div class="nothumb">{_e(r.draw_error or r.error or ("not run" if r.skipped else "no picture"))}</div>'
    when = "at the collapse" if r.collapse_level is not None else "at the end"
    return (
        f'<a href="{_e(picture)}"><img class="thumb" src="{_e(picture)}" alt="{_e(r.scenario)} {when}" '
        f'title="{_e(r.scenario)}, {when}"></a>'
    )


def _facts(r: CheckResult) -> str:
    """The rows of the result's facts table: its marks, what was expected and measured, the
    engine and mode, the certificate, and the simulated and wall seconds."""
    marks = [("skipped", r.skipped)] if r.skipped else []
    if r.xfail:
        marks.append(("xfail", r.xfail + (" (strict: a pass fails the check)" if r.strict else "")))
    facts = [
        *marks,
        ("expected", r.expected),
        ("measured", r.measured),
        ("engine", r.backend),
        ("mode", mode_label(r)),
        *((("certificate", r.certificate),) if r.certificate else ()),
        ("simulated", f"{r.simulated_time:.1f} s"),
        ("wall", f"{r.wall_time:.2f} s" + (f" (drawing {r.draw_time:.1f} s)" if r.draw_time else "")),
    ]
    return "".join(f"<tr><td>{_e(k)}</td><td>{_e(v)}</td></tr>" for k, v in facts)


def _links(r: CheckResult, folder: Path) -> list[str]:
    """Links to the result's files there are: its replay, clip, graph, trajectory, a sweep's
    samples and plots, a search's other files (``file NAME``: search.json, counterexample files)."""
    kinds = [("3D replay", "replay"), ("clip", "clip"), ("brick graph", "graph"), ("trajectory (.npz)", "trajectory")]
    kinds += [("samples (.csv)", "samples"), ("samples (.parquet)", "parquet"), ("samples (.jsonl)", "jsonl")]
    kinds += [(name, kind) for kind, name in r.artefacts if kind.startswith("plot ")]  # a sweep's plots
    kinds += [(kind[5:], kind) for kind, _ in r.artefacts if kind.startswith("file ")]  # a search's answer and counterexamples
    return [f'<a href="{_e(href)}">{_e(label)}</a>' for label, kind in kinds if (href := _link(r, kind, folder))]


def _timeline(r: CheckResult) -> str:
    """The run's events (from its trajectory file) in a closed ``details`` element."""
    name = dict(r.artefacts).get("trajectory")
    if not name:
        return ""
    try:
        events: Sequence[Event] = load_trajectory(Path(r.folder) / name).events
    except (OSError, ValueError) as exc:
        return f'<p class="meta">timeline not read: {_e(exc)}</p>'
    shown = events[:TIMELINE_LIMIT]
    rows = "".join(
        f"<tr><td>{e.time:.3f} s</td><td>{_e(e.kind)}</td><td>{_e(e.brick)}</td>"
        f"<td>{'' if e.level is None else f'level {e.level}'}</td><td>{_e(e.detail)}</td></tr>"
        for e in shown
    )
    more = f"<p>({len(events) - len(shown)} more events in the trajectory file)</p>" if len(events) > len(shown) else ""
    return f'<details><summary>timeline ({len(events)} events)</summary><table class="timeline">{rows}</table>{more}</details>'


def _summary(results: Sequence[CheckResult], total: int, wall: float) -> str:
    head = (
        "<tr><th>verdict</th><th>scenario</th><th>engine</th><th>mode</th><th>expected</th><th>measured</th>"
        '<th class="num">simulated</th><th class="num">wall</th></tr>'
    )
    rows = "".join(
        f'<tr><td>{_e(r.verdict)}</td><td><a href="#{_e(_anchor(r))}">{_e(r.file)}</a></td>'
        f"<td>{_e(r.backend)}</td><td>{_e(mode_label(r))}</td><td>{_e(r.expected)}</td><td>{_e(r.measured)}</td>"
        f'<td class="num">{r.simulated_time:.1f} s</td><td class="num">{r.wall_time:.2f} s</td></tr>'
        for r in sorted(results, key=lambda r: (r.held, r.verdict != "PASS"))  # failures first, passes last
    )
    ran = [r for r in results if not r.skipped]
    collapsed = sum(r.collapse_level is not None for r in ran)
    line = (
        f"{_counts(results, total, wall)}; {collapsed} collapsed ({describe(None)}: {len(ran) - collapsed}); "
        f"{sum(r.simulated_time for r in results):.1f} s simulated in {sum(r.wall_time for r in results):.1f} s of runs"
    )
    return f'<p>{_e(line)}</p><table class="summary">{head}{rows}</table>'
