"""Check results as text rows, as one JSON document, and as JUnit XML.

Source: stackdsl's own; the JUnit XML shape is the one pytest writes (``testsuites`` /
``testsuite`` / ``testcase`` with ``failure`` and ``skipped``), read by CI servers.
"""

from __future__ import annotations

import shlex
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from .._version import version
from ..lang.errors import excerpt, one_line
from ..util.files import written
from ..verdicts.check_result import CheckResult
from ..verdicts.expect import located_lines
from .guard import TIMEOUT

#: The header of check's table; :func:`row` lines up under it.
HEADER = f"{'':4}  {'scenario':<40} {'engine':<8} {'mode':<9} {'simulated':>9} {'wall':>7}  {'expected':<18} measured"
#: Indentation of the lines under a FAIL row.
INDENT = " " * 6
#: Why a scenario did not run when check stopped early.
NOT_RUN = "not run: stopped after the first failure"


def mode_label(r: CheckResult) -> str:
    """The mode, with the stability model when the extension ran with the equilibrium one."""
    return "ext/equil" if r.mode == "extension" and r.model == "equilibrium" else r.mode


def row(r: CheckResult) -> str:
    """One line of check's table: verdict, file, engine (the backend), mode, simulated and wall
    seconds, expected, and measured last (its length varies)."""
    file = one_line(r.file)  # a newline in a path would split the row
    file = file if len(file) <= 40 else "..." + file[-37:]
    # an expectation longer than its column ends with a bar: it would run into the measured text
    expected = f"{r.expected:<18}" if len(r.expected) < 18 else f"{r.expected} |"
    return (  # the verdict (CheckResult.verdict), as wide as XFAIL: INCONCLUSIVE pushes its row right
        f"{r.verdict:<5} {file:<40} {r.backend:<8} {mode_label(r):<9} "
        f"{r.simulated_time:>7.1f} s {r.wall_time:>5.1f} s  {expected} {r.measured}"
    ).rstrip()


def rerun_command(
    verb: str,
    file: str,
    *,
    mode: str | None = None,
    model: str | None = None,
    backend: str | None = None,
    seed: int | None = None,
    sample: int | None = None,
    cell: int | None = None,
    timeout: float | None = None,
    tail: Sequence[str] = (),
) -> str:
    """The ``stackdsl`` command that does ``verb`` (``run``, ``sweep``, ``replay``...) to ``file``
    as it was done here (shell-quoted): with every option given that changes the result, the
    engine's ``--mode``, ``--model`` and ``--backend``, ``--seed`` (a file's draws and placement
    error), ``--sample`` and ``--cell`` (which run of a random file), and ``--timeout`` when it is
    not the default (:data:`stackdsl.batch.guard.TIMEOUT`: a run it stopped would not stop),
    then ``tail`` (``-o DIR``). Every command that check, compare, sweep, run and the pytest
    plugin print to run a scenario again is made here.

    >>> rerun_command("run", "scenarios/slant tower.yaml", mode="raw", seed=4)
    "stackdsl run 'scenarios/slant tower.yaml' --mode raw --seed 4"
    >>> rerun_command("sweep", "sweeps/walk.yaml", timeout=100.0), rerun_command("run", "w.yaml", sample=3, timeout=5.0)
    ('stackdsl sweep sweeps/walk.yaml', 'stackdsl run w.yaml --sample 3 --timeout 5')
    """
    words = ["stackdsl", verb, file]
    given = (
        ("--mode", mode),
        ("--model", model),
        ("--backend", backend),
        ("--seed", seed),
        ("--sample", sample),
        ("--cell", cell),
    )
    for option, value in given:
        words += [option, str(value)] if value is not None else []
    words += ["--timeout", f"{timeout:g}"] if timeout is not None and timeout != TIMEOUT else []
    return shlex.join([*words, *tail])


def failure_lines(r: CheckResult, command: str) -> list[str]:
    """The indented lines under a row: under a FAIL or INCONCLUSIVE row, the result's explanation,
    then ``command`` (with ``--debug`` after an internal error, to show its traceback); under an
    XFAIL or XPASS row, the reason of the file's xfail mark (a strict XPASS: and what to do);
    none under PASS and SKIP (a SKIP row says its reason itself)."""
    verdict = r.verdict
    if verdict in ("PASS", "SKIP"):
        return []
    if verdict == "XFAIL":
        return [f"{INDENT}xfail: {r.xfail}"]
    if verdict == "XPASS":
        if not r.strict:
            return [f"{INDENT}xpass: {r.xfail}"]
        return [f"{INDENT}{xpass_strict(r)}", f"{INDENT}more: {command}"]
    if r.error:
        command = command.replace("stackdsl ", "stackdsl --debug ", 1)
    return [INDENT + line for line in _pointed(r)] + [f"{INDENT}more: {command}"]


def xpass_strict(r: CheckResult) -> str:
    """What a strict XPASS says: pytest's ``[XPASS(strict)] reason``, then what to do."""
    return (
        f"[XPASS(strict)] {r.xfail}: every expectation held, and the file's xfail mark is strict: "
        "remove the mark (or narrow its when) if the fix is meant"
    )


def _pointed(r: CheckResult) -> list[str]:
    """A failed result's lines: each failed expectation at the line that wrote it, then that
    line and a caret, as a parse error is shown, then why (the explanation). A sweep's
    explanation says each failed cell at its expectation's place: the line follows the first."""
    if not r.sweep:
        return [*located_lines(r.verdicts), *r.explanation]
    lines: list[str] = []
    for line in r.explanation:
        lines.append(line)
        at = next((v.at for v in r.verdicts if v.at is not None and line.startswith(f"{v.at}: ")), None)
        if at is not None and not any(previous.startswith(f"{at}: ") for previous in lines[:-1]):
            lines += excerpt(at.source_line, at.column)
    return lines


def counts(results: Sequence[CheckResult]) -> dict[str, int]:
    """How many results are of each kind, as pytest counts its outcomes: ``passed`` (PASS),
    ``failed`` (FAIL, and a strict XPASS, which fails the check), ``inconclusive``, ``skipped``,
    ``xfailed``, ``xpassed`` (not strict), and ``errors`` (internal errors, among the failed)."""
    verdicts = [r.verdict for r in results]
    strict = sum(r.verdict == "XPASS" and r.strict for r in results)
    return {
        "passed": verdicts.count("PASS"),
        "failed": verdicts.count("FAIL") + strict,
        "inconclusive": verdicts.count("INCONCLUSIVE"),
        "skipped": verdicts.count("SKIP"),
        "xfailed": verdicts.count("XFAIL"),
        "xpassed": verdicts.count("XPASS") - strict,
        "errors": sum(bool(r.error) for r in results),
    }


def summary(results: Sequence[CheckResult], total: int, wall: float) -> str:
    """``'29 scenarios: 28 passed, 1 failed (3.8 s wall)'``, with how many hit an internal
    error (counted among the failed) when any did, how many were inconclusive, skipped, xfailed
    and xpassed when any were (:func:`counts`), and how many did not run when fewer than
    ``total`` did."""
    n = counts(results)
    said = f"{n['passed']} passed, {n['failed']} failed"
    if n["errors"]:
        said += f" ({n['errors']} of them internal error{'s' if n['errors'] > 1 else ''})"
    said += "".join(f", {n[kind]} {kind}" for kind in ("inconclusive", "skipped", "xfailed", "xpassed") if n[kind])
    if len(results) < total:
        said += f", {total - len(results)} {NOT_RUN}"
    return f"{total} scenarios: {said} ({wall:.1f} s wall)"


def result_data(r: CheckResult, command: str) -> dict[str, Any]:
    """One result as plain JSON data (seconds, metres; ``command`` reruns it)."""
    return {
        "file": r.file,
        "scenario": r.scenario,
        "mode": r.mode,
        "model": r.model,
        "backend": r.backend,
        "passed": r.passed,
        "verdict": r.verdict,
        "skipped": r.skipped or None,
        "xfail": None if not r.xfail else {"reason": r.xfail, "strict": r.strict},
        "expected": r.expected,
        "measured": r.measured,
        "verdicts": [v.model_dump() for v in r.verdicts],
        "explanation": list(r.explanation),
        "certificate": r.certificate or None,
        "margin": r.margin,
        "error": r.error or None,
        "stopped": r.stopped or None,
        "collapse_level": r.collapse_level,
        "first_moved": None if r.first_moved_level is None else {"brick": r.first_moved, "level": r.first_moved_level},
        "moved_levels": list(r.moved_levels),
        "levels_placed": r.levels_placed,
        "simulated_time": r.simulated_time,
        "wall_time": r.wall_time,
        "drift": r.drift,
        "steps_per_brick": r.steps_per_brick,
        "command": command,
    }


def json_document(
    command: str, results: Sequence[CheckResult], commands: Sequence[str], total: int, wall: float
) -> dict[str, Any]:
    """Every result of one ``stackdsl`` command as one JSON document: the version, the
    command, a summary (``total``, ``passed``, ``failed``, ``inconclusive``, ``skipped``,
    ``xfailed``, ``xpassed`` (:func:`counts`), ``errors`` (internal errors, among the failed),
    ``not_run``, ``wall_time`` in s)
    and the results in the order given (``commands``: one rerun command each)."""
    return {
        "stackdsl": version(),
        "command": command,
        "summary": {
            "total": total,
            **counts(results),
            "not_run": total - len(results),
            "wall_time": round(wall, 3),
        },
        "results": [result_data(r, c) for r, c in zip(results, commands, strict=True)],
    }


def junit_xml(
    results: Sequence[CheckResult], commands: Sequence[str], not_run: Sequence[str], wall: float, path: str | Path
) -> None:
    """Write JUnit XML to ``path``, in the shape pytest writes: one testcase per scenario run
    (classname ``stackdsl.<backend>.<mode>``, name the file, time its wall seconds), an
    ``error`` with the traceback for each internal error, a ``failure`` with the explanation and
    the rerun command for each other run that did not hold (``type`` its verdict: ``FAIL``,
    ``INCONCLUSIVE``, or ``XPASS`` for a strict xfail that passed, whose message is pytest's
    ``[XPASS(strict)] reason``), a ``skipped`` of ``type`` ``stackdsl.skip`` for a run the file's
    skip mark holds on and ``stackdsl.xfail`` for an XFAIL (pytest's ``pytest.skip`` and
    ``pytest.xfail``; the message the reason), and a ``skipped`` testcase for each file in
    ``not_run``. A non-strict XPASS is a testcase that passed, as in pytest's."""
    n = counts(results)
    suites = ET.Element("testsuites")
    suite = ET.SubElement(
        suites,
        "testsuite",
        name="stackdsl check",
        tests=str(len(results) + len(not_run)),
        failures=str(n["failed"] - n["errors"] + n["inconclusive"]),
        errors=str(n["errors"]),
        skipped=str(n["skipped"] + n["xfailed"] + len(not_run)),
        time=f"{wall:.3f}",
    )
    ET.SubElement(ET.SubElement(suite, "properties"), "property", name="stackdsl", value=version())
    for r, command in zip(results, commands, strict=True):
        case = ET.SubElement(
            suite, "testcase", classname=f"stackdsl.{r.backend}.{r.mode}", name=r.file, time=f"{r.wall_time:.3f}"
        )
        verdict = r.verdict
        if r.error:
            error = ET.SubElement(case, "error", message=r.error)
            error.text = r.traceback or None
        elif verdict == "SKIP":
            skipped = ET.SubElement(case, "skipped", type="stackdsl.skip", message=r.skipped)
            skipped.text = f"{r.file}: {r.skipped}"
        elif verdict == "XFAIL":
            skipped = ET.SubElement(case, "skipped", type="stackdsl.xfail", message=r.xfail)
            skipped.text = "\n".join([f"expected {r.expected}, measured {r.measured}", *_pointed(r)])
        elif verdict == "XPASS" and r.strict:
            failure = ET.SubElement(case, "failure", type="XPASS", message=f"[XPASS(strict)] {r.xfail}")
            failure.text = "\n".join([xpass_strict(r), f"more: {command}"])
        elif not r.held:
            first = next((v for v in r.verdicts if not v.passed and v.at is not None), None)
            at = first.at if first is not None else None
            said = f"expected {r.expected}, measured {r.measured}"
            if verdict == "INCONCLUSIVE":
                said = f"INCONCLUSIVE: {said}"  # not decided either way, as the failure's text says
            failure = ET.SubElement(case, "failure", type=verdict, message=f"{at}: {said}" if at else said)
            failure.text = "\n".join([*_pointed(r), f"more: {command}"])
    for file in not_run:
        case = ET.SubElement(suite, "testcase", classname="stackdsl", name=file, time="0")
        ET.SubElement(case, "skipped", message=NOT_RUN)
    ET.indent(suites)
    with written(path) as part:
        ET.ElementTree(suites).write(part, encoding="utf-8", xml_declaration=True)
