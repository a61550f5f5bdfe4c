"""The expectation still: (a block that does not rock or slide), its signed margin, and the
threshold searches on it that find the onset of motion on a shake table against the closed forms
g b / h (rocking) and mu g (sliding) (searches/shake_rocking_onset.yaml, searches/shake_sliding_onset.yaml)."""

import json
import math
from pathlib import Path

import pytest

from stackdsl import compile_scenario, parse_scenario, run_program
from stackdsl.cli.main import main
from stackdsl.lang.expectations import Expect, Still
from stackdsl.verdicts.expect import evaluate

ROOT = Path(__file__).resolve().parents[1]
G = 9.81
W = 2 * math.pi * 2.0  # rad/s: the shipped searches shake at 2 Hz
ROCKING = G * 0.015 / 0.045 / W**2 * 1000  # mm: g b / h, 20.71 mm
SLIDING = 0.5 * G / W**2 * 1000  # mm: mu g, 31.06 mm


def test_the_margin_is_the_nearer_bounds_share_left():
    still = Expect.model_validate({"still": {"tilt": "0.2 deg", "slip": "0.1 mm"}}).still
    assert still is not None and still.tilt == pytest.approx(0.2) and still.slip == pytest.approx(1e-4)
    assert still.margin(math.radians(0.1), 0.0) == pytest.approx(0.5)
    assert still.margin(math.radians(0.1), 0.15e-3) == pytest.approx(-0.5)  # the slip is past its bound
    with pytest.raises(ValueError, match="'tilt', the largest 'slip'"):
        Still.model_validate({})


def post(amplitude_mm: float) -> str:
    text = (ROOT / "searches" / "shake_rocking_onset.yaml").read_text()
    text = text.replace("amplitude: 10 mm", f"amplitude: {amplitude_mm} mm").split("search:")[0]
    return text + "expect: {still: {tilt: 0.05 deg}}\n"


def test_a_block_below_its_rocking_onset_keeps_still_and_above_it_does_not():
    verdicts = {}
    for ratio in (0.9, 1.1):
        program = compile_scenario(parse_scenario(post(ratio * ROCKING)))
        outcome = run_program(program)
        assert outcome.collapse is None  # it rocks at 1.1, and does not overturn
        assert outcome.peak_tilt is not None and outcome.peak_slip is not None
        (verdict,) = evaluate(parse_scenario(post(ratio * ROCKING)).expect, outcome, program.collapse_threshold)
        verdicts[ratio] = (verdict.passed, math.degrees(outcome.peak_tilt))
    assert verdicts[0.9][0] and verdicts[0.9][1] < 0.2
    assert not verdicts[1.1][0] and verdicts[1.1][1] > 0.5


def onset(tmp_path: Path, file: str, *more: str) -> dict:
    out = tmp_path / "out"
    assert main(["search", str(ROOT / "searches" / file), "-j", "1", "--out", str(out), *more]) == 0
    return json.loads((out / "search.json").read_text())


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
@pytest.mark.parametrize(
    "file, closed_form",
    [("shake_rocking_onset.yaml", ROCKING), ("shake_sliding_onset.yaml", SLIDING)],
    ids=["rocking", "sliding"],
)
def test_a_shakes_onset_is_found_within_one_percent_of_its_closed_form(tmp_path, backend, file, closed_form):
    # rocking at g b / h, sliding at mu g
    found = onset(tmp_path, file, "--backend", backend)
    low, high = found["interval"]
    assert low <= closed_form * 1.01 and high >= closed_form * 0.99 and high - low <= 0.2
    assert found["runs"] * 10 <= found["grid_runs"]
