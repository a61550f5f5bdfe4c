"""Bad input, nothing lost: random and mutated scenario files only ever give a clean
ScenarioError (file:line:col) or a program; never a traceback, never a hang, and no golden
file is written. Files of odd kinds and encodings load cleanly; the command's exit codes
and positions agree with the API's; small random scenarios run to an Outcome."""

import contextlib
import inspect
import io
import tempfile
import warnings
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from stackdsl import Outcome, ScenarioError, compile_scenario, load_scenario, parse_scenario, run_program
from stackdsl.cli.main import main
from stackdsl.lang.unit_slips import UnitSlipWarning

ROOT = Path(__file__).resolve().parents[1]
SOURCES = [p.read_text() for p in sorted((ROOT / "scenarios").rglob("*.yaml"))]
GOLDEN = ROOT / "golden"
NASTY = [
    "1e999",
    "-0",
    "nan",
    "inf",
    "9" * 40,
    "no",
    "yes",
    "~",
    "null",
    "''",
    "[]",
    "{}",
    "&a",
    "*a",
    "!!python/object:os.system",
    "<<: *a",
    "\t",
    "0x1F",
    "1_000",
    "1/0 s",
    "5 furlongs",
    "-1 mm",
    "ä",
    "\u202e",
]


@st.composite
def mutated(draw) -> str:
    """A scenario from the library with a few random edits."""
    text = draw(st.sampled_from(SOURCES))
    for _ in range(draw(st.integers(1, 4))):
        if not text:
            break
        at = draw(st.integers(0, len(text) - 1))
        kind = draw(st.sampled_from(["delete", "insert", "nasty", "duplicate_line", "swap_number"]))
        if kind == "delete":
            text = text[:at] + text[at + draw(st.integers(1, 12)) :]
        elif kind == "insert":
            text = text[:at] + draw(st.text(alphabet=":{}[],-#&*!|>'\"% \n0123456789.eabcxyz", max_size=8)) + text[at:]
        elif kind == "nasty":
            text = text[:at] + draw(st.sampled_from(NASTY)) + text[at:]
        elif kind == "duplicate_line":
            lines = text.splitlines(keepends=True)
            i = draw(st.integers(0, len(lines) - 1))
            text = "".join(lines[: i + 1] + lines[i:])
        else:
            text = text.replace(draw(st.sampled_from("0123456789")), draw(st.sampled_from(NASTY)), 1)
    return text


plain = st.recursive(
    st.none() | st.booleans() | st.integers(-(10**6), 10**6) | st.floats(allow_nan=True) | st.text(max_size=10),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@st.composite
def structured(draw) -> str:
    """A document shaped like a scenario, with random values where fields belong."""
    doc = {"stackdsl": draw(st.sampled_from([1, 2, "1", None]))}
    for key in draw(
        st.lists(
            st.sampled_from(
                ["structure", "timing", "engine", "expect", "impacts", "materials", "brick_types", "stability", "seed", "name"]
            ),
            max_size=6,
        )
    ):
        doc[key] = draw(plain)
    if draw(st.booleans()):
        doc["structure"] = {
            "tower": {"levels": draw(st.integers(-5, 2000)), "shift": draw(st.sampled_from(["3 mm", 1e9, -2, "x"]))}
        }
    return yaml.safe_dump(doc)


def check(text: str) -> None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UnitSlipWarning)  # a bare -2 is read as metres, and said so: fine here
            scenario = parse_scenario(text, "fuzz.yaml")
        compile_scenario(scenario)
    except ScenarioError as err:
        assert err.file == "fuzz.yaml" and err.message
        assert err.line is None or err.line >= 1


@pytest.mark.slow
@settings(max_examples=300, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_scenarios_give_clean_errors(text):
    check(text)


@pytest.mark.slow
@settings(max_examples=200, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(structured())
def test_random_documents_give_clean_errors(text):
    check(text)


def test_fuzzing_writes_no_golden_file():
    before = {p: p.stat().st_mtime_ns for p in GOLDEN.rglob("*")}
    for text in SOURCES[:3]:
        check(text.replace("levels", "levles"))
    assert {p: p.stat().st_mtime_ns for p in GOLDEN.rglob("*")} == before


# files of odd kinds and encodings ------------------------------------------------------------------

ENCODINGS = ["utf-8", "utf-8-sig", "utf-16", "utf-16-le", "utf-16-be", "utf-32", "latin-1", "cp1252"]
KINDS = ["regular", "symlink", "folder", "missing", "dangling symlink", "empty"]


@st.composite
def odd_file(draw) -> tuple[str, bytes]:
    """(kind, content): a scenario, maybe mutated, in some encoding and line ends, maybe cut or spliced."""
    text = draw(st.one_of(st.sampled_from(SOURCES), mutated()))
    text = text.replace("\n", draw(st.sampled_from(["\n", "\r\n", "\r"])))
    data = text.encode(draw(st.sampled_from(ENCODINGS)), errors="replace")
    if draw(st.booleans()):  # cut anywhere, also inside a multi-byte character
        data = data[: draw(st.integers(0, len(data)))]
    if draw(st.booleans()):  # splice in raw bytes
        at = draw(st.integers(0, len(data)))
        data = data[:at] + draw(st.binary(max_size=6)) + data[at:]
    return draw(st.sampled_from(KINDS)), data


def make(folder: Path, kind: str, data: bytes) -> Path:
    path = folder / "odd.yaml"
    if kind in ("regular", "symlink", "empty"):
        target = folder / "target.yaml" if kind == "symlink" else path
        target.write_bytes(b"" if kind == "empty" else data)
        if kind == "symlink":
            path.symlink_to(target.name)
    elif kind == "folder":
        path.mkdir()
    elif kind == "dangling symlink":
        path.symlink_to("nowhere.yaml")
    return path


@pytest.mark.slow
@settings(max_examples=150, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(odd_file())
def test_files_of_odd_kinds_and_encodings_load_cleanly(case):
    kind, data = case
    with tempfile.TemporaryDirectory() as folder:
        path = make(Path(folder), kind, data)
        try:
            load_scenario(path)
        except ScenarioError as err:
            assert err.file == str(path) and err.message
            lines = max(1, len(data.splitlines()))
            assert err.line is None or 1 <= err.line <= lines + 1, (err.line, lines)
            assert err.column is None or err.column >= 1
            assert "Traceback" not in str(err)
        else:
            assert kind in ("regular", "symlink")


# the command: exit codes, and the same positions as the API ------------------------------------------


def command(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


# the command costs some 0.2 s of start-up an example: few examples (the API is fuzzed above)
@pytest.mark.slow
@settings(max_examples=25, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(st.one_of(mutated(), structured()))
def test_compile_command_exits_0_or_2_at_the_apis_position(text):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "fuzz.yaml"
        path.write_text(text)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UnitSlipWarning)  # said on stderr by the command too
                compile_scenario(load_scenario(path))
            expected = None
        except ScenarioError as exc:
            expected = exc
        status, out, err = command("compile", str(path))
    assert "Traceback" not in err
    err = _without_warnings(err)  # a mutated number may be a unit slip, said on a line of its own
    if expected is None:
        assert (status, err) == (0, "") and out
    else:
        assert status == 2 and not out
        first = err.splitlines()[0]
        assert first == str(expected).splitlines()[0]
        where = str(path) if expected.line is None else f"{path}:{expected.line}:{expected.column}"
        assert first.startswith(f"{where}: ")
        if expected.line is not None:
            assert 1 <= expected.line <= len(text.splitlines()) + 1
            assert 1 <= expected.column <= len((text.splitlines() or [""])[min(expected.line, len(text.splitlines())) - 1]) + 1


# small random scenarios run to an Outcome ------------------------------------------------------------

BUDGET = 60.0  # wall seconds a run may take where the runtime takes a timeout; these take about one


@st.composite
def small(draw) -> str:
    """A valid-looking scenario of at most 6 bricks and a few simulated seconds, in any mode."""
    interval = draw(st.sampled_from(["0.25 s", "0.5 s", "1 s"]))
    doc = {
        "stackdsl": 1,
        "structure": {
            "tower": {
                "levels": draw(st.integers(1, 3)),
                "bricks_per_layer": draw(st.integers(1, 2)),
                "spacing": draw(st.sampled_from(["48 mm", "96 mm", "100 mm"])),
                "turn": draw(st.sampled_from([0, 30, 90, -45])),
                "shift": f"{draw(st.integers(-40, 40))} mm",
            }
        },
        "timing": {"interval": interval, "settle": draw(st.sampled_from([0, "0.5 s", "1 s"]))},
        "engine": {"mode": draw(st.sampled_from(["raw", "tuned", "extension"]))},
        "stability": {"model": draw(st.sampled_from(["report", "equilibrium"]))},
        "allow": ["floating"],
    }
    if draw(st.booleans()):
        doc["impacts"] = [
            {
                "target": {"level": 1, "side": draw(st.sampled_from(["+x", "-x", "+y", "-y"]))},
                "speed": f"{draw(st.sampled_from([0.5, 2, 10]))} m/s",
                "at": "after level 1",
            }
        ]
    return yaml.safe_dump(doc)


def run_small(program):
    if "timeout" in inspect.signature(run_program).parameters:
        return run_program(program, timeout=BUDGET)
    return run_program(program)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@given(small())
def test_small_random_scenarios_run_to_an_outcome(text):
    try:
        program = compile_scenario(parse_scenario(text, "small.yaml"))
    except ScenarioError:
        assume(False)
    assert len(program.placements) <= 6 and program.duration <= 6.0
    outcome = run_small(program)
    assert isinstance(outcome, Outcome)
    assert outcome.simulated_time <= program.duration + 1e-9
    assert outcome.collapse is None or 1 <= outcome.collapse.level <= 3


def _without_warnings(err: str) -> str:
    """stderr without the language's warnings: each a ``file:line:col: warning: ...`` line and
    the indented source and caret lines under it."""
    kept, in_warning = [], False
    for line in err.splitlines(keepends=True):
        if ": warning: " in line:
            in_warning = True
        elif not line.startswith(" "):
            in_warning = False
        if not in_warning:
            kept.append(line)
    return "".join(kept)
