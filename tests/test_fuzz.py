"""Bad input, nothing lost: random and mutated scenario files only ever give a clean
ScenarioError (file:line:col) or a program; never a traceback, never a hang, and no golden
file is written."""

from pathlib import Path

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stackdsl import ScenarioError, compile_scenario, parse_scenario

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
        scenario = parse_scenario(text, "fuzz.yaml")
        compile_scenario(scenario)
    except ScenarioError as err:
        assert err.file == "fuzz.yaml" and err.message
        assert err.line is None or err.line >= 1


@settings(max_examples=300, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_scenarios_give_clean_errors(text):
    check(text)


@settings(max_examples=200, deadline=5000, suppress_health_check=[HealthCheck.too_slow])
@given(structured())
def test_random_documents_give_clean_errors(text):
    check(text)


def test_fuzzing_writes_no_golden_file():
    before = {p: p.stat().st_mtime_ns for p in GOLDEN.rglob("*")}
    for text in SOURCES[:3]:
        check(text.replace("levels", "levles"))
    assert {p: p.stat().st_mtime_ns for p in GOLDEN.rglob("*")} == before
