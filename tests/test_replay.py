"""The interactive replay: ``stackdsl replay``'s page and ``check --report``'s replay.html.

Without a browser: the page's data is the trajectory's, the vendored three.js is the pinned
release, the golden's ghosts are the bricks that differ. In headless Chromium with WebGL on
SwiftShader (tests/replay_browser.py; skipped with the reason when Chromium or playwright is
missing): the canvas draws, scrubbing shows the recorded poses, a clicked brick shows its
panel, the console stays clean. Run them with ``python -m pytest -n0 tests/test_replay.py``.
"""

from __future__ import annotations

import base64
import copy
import dataclasses
import hashlib
import io
import json
import re
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import stackdsl
from stackdsl.cli.main import main
from stackdsl.draw.replay import THREE_VERSION, ghosts, replay_data, replay_html, write_replay
from stackdsl.runtime.recorder import record_program
from stackdsl.verdicts.snapshot import dumps

sys.path.insert(0, str(Path(__file__).parent))
from replay_browser import browser, missing, open_replay
from shipped import shipped_goldens

ROOT = Path(__file__).resolve().parents[1]
SLANT = ROOT / "scenarios" / "slant_tower.yaml"
VENDOR = ROOT / "stackdsl" / "draw" / "vendor"
TOWER = "stackdsl: 1\nname: small tower\nstructure: {tower: {levels: 3}}\nexpect: {stands: true}\n"


@pytest.fixture(scope="module")
def slant():
    """The slant tower's run, recorded (it collapses at level 9), and its golden snapshot taken
    from this very run, as the plugin writes it (the shipped one matches it within tolerances)."""
    program = stackdsl.compile_scenario(stackdsl.load_scenario(SLANT))
    outcome, trajectory = record_program(program, source=str(SLANT.relative_to(ROOT)))
    golden = json.loads(dumps(outcome.golden()))
    return trajectory, golden


def _decode(text: str, dtype: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(text), dtype=dtype)


def test_the_pages_arrays_are_the_trajectorys(slant):
    trajectory, _ = slant
    data = replay_data(trajectory)
    assert data["ids"] == trajectory.ids.tolist() and data["levels"] == trajectory.levels.tolist()
    assert np.array_equal(_decode(data["times"], "<f8"), trajectory.times)
    assert np.array_equal(_decode(data["row_frame"], "<i4"), trajectory.row_frame)
    assert np.array_equal(_decode(data["row_body"], "<i4"), trajectory.row_body)
    assert np.array_equal(_decode(data["row_state"], "u1"), trajectory.row_state)
    assert np.allclose(_decode(data["row_position"], "<f4").reshape(-1, 3), trajectory.row_position, atol=1e-6)
    assert np.allclose(_decode(data["row_orientation"], "<f4").reshape(-1, 4), trajectory.row_orientation, atol=1e-6)
    assert [e["kind"] for e in data["events"]] == [e.kind for e in trajectory.events]
    assert set(data["graphs"]) == {"final", "collapse"}  # the slant tower collapses
    assert data["meta"]["backend"] == "pybullet" and data["meta"]["mode"] == "extension"
    node = data["graphs"]["final"]["bricks"]["L02.1"]
    assert [s for s, _, _ in node["rests_on"]] and all(0 <= share <= 1 for _, _, share in node["rests_on"])


def test_the_page_holds_everything_and_fetches_nothing(slant):
    trajectory, _ = slant
    page = replay_html(trajectory)
    assert "<script src" not in page and "<link" not in page and "import(" in page
    assert page.count("<script") == 4  # the data, three.js, the orbit controls, the page's own script
    # the inlined three.js is the vendored file, byte for byte
    inlined = re.search(r'id="three-gz">([^<]*)<', page)
    assert inlined is not None
    import gzip

    assert gzip.decompress(base64.b64decode(inlined.group(1))) == (VENDOR / "three.module.min.js").read_bytes()
    # no text of the run can close the data's script element
    assert "</script" not in json.dumps(replay_data(trajectory)).replace("<\\/", "")


@pytest.mark.parametrize("name", ["a <!-- b", "a </script> b", "{{three}} & {{data}}", "--> <b>"])
def test_the_pages_data_is_json_whatever_the_scenarios_name(slant, name):
    # a scenario or folder named with "<!--" left the page blank: its data was not JSON
    trajectory, _ = slant
    trajectory = dataclasses.replace(trajectory, meta={**trajectory.meta, "scenario": name, "file": f"{name}/t.yaml"})
    page = replay_html(trajectory)
    block = re.search(r'id="replay-data">(.*?)</script>', page, re.S)
    assert block is not None and "<" not in block.group(1) and ">" not in block.group(1)
    data = json.loads(block.group(1))
    assert data["meta"]["scenario"] == name and data["meta"]["file"] == f"{name}/t.yaml"
    # the title, the data's scenario and its file: a placeholder the name spells stays text
    assert page.count("<script") == 4 and page.count("{{") == name.count("{{") * 3


def test_the_vendored_three_js_is_the_pinned_release():
    readme = (VENDOR / "README.md").read_text()
    assert f"**{THREE_VERSION}**" in readme
    for name in ("three.module.min.js", "OrbitControls.js"):
        digest = hashlib.sha256((VENDOR / name).read_bytes()).hexdigest()
        assert f"`{name}`" in readme and digest in readme, name
    assert f'const t="{THREE_VERSION.split(".")[1]}"' in (VENDOR / "three.module.min.js").read_text()[:400]
    assert "MIT License" in (VENDOR / "three.LICENSE").read_text()


def test_package_data_ships_the_page_and_three_js():
    """A non-editable install copies only what pyproject's package-data names."""
    import tomllib
    from fnmatch import fnmatch

    patterns = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]["stackdsl.draw"]
    needed = [p.relative_to(ROOT / "stackdsl" / "draw").as_posix() for p in (VENDOR.parent / "page").iterdir()]
    needed += [p.relative_to(VENDOR.parent).as_posix() for p in VENDOR.iterdir()]
    assert needed and all(any(fnmatch(n, p) for p in patterns) for n in needed), needed


def test_ghosts_are_the_golden_bricks_that_end_elsewhere(slant):
    trajectory, golden = slant
    assert ghosts(trajectory, None) == []
    same = ghosts(trajectory, golden)
    assert len(same) <= 2, same  # the golden was taken from this very run, to 0.1 mm and 0.1 deg
    moved = copy.deepcopy(golden)
    moved["final_graph"]["L03.1"]["position_mm"][0] += 25.0
    q = Rotation.from_euler("z", 30.0, degrees=True) * Rotation.from_quat(moved["final_graph"]["L04.2"]["quaternion_xyzw"])
    moved["final_graph"]["L04.2"]["quaternion_xyzw"] = q.as_quat().tolist()
    found = {g["id"]: g for g in ghosts(trajectory, moved)}
    assert {"L03.1", "L04.2"} <= set(found)
    assert "mm away" in found["L03.1"]["why"] and "turned" in found["L04.2"]["why"]
    assert found["L03.1"]["position"][0] == pytest.approx(moved["final_graph"]["L03.1"]["position_mm"][0] / 1000)


def test_replay_command_writes_the_page_and_refuses_a_file_as_its_folder(tmp_path, capsys):
    scenario = tmp_path / "tower.yaml"
    scenario.write_text(TOWER)
    assert main(["replay", str(scenario), "-o", str(tmp_path / "out")]) == 0
    page = tmp_path / "out" / "replay.html"
    assert f"wrote {page}" in capsys.readouterr().out and page.stat().st_size > 100_000
    record = tmp_path / "run.npz"
    assert main(["run", str(scenario), "--record", str(record)]) == 0
    assert main(["replay", str(record), "-o", str(tmp_path / "again")]) == 0
    (tmp_path / "file").write_text("")
    capsys.readouterr()
    assert main(["replay", str(record), "-o", str(tmp_path / "file")]) == 2
    assert "the replay goes to a folder" in capsys.readouterr().err
    assert main(["replay", str(record), "-o", str(tmp_path / "x"), "--golden", str(tmp_path / "none.json")]) == 2
    assert "golden snapshot" in capsys.readouterr().err


@pytest.mark.slow
def test_a_reports_replay_draws_the_scenarios_golden_as_ghosts_where_it_differs(tmp_path, monkeypatch):
    """check --report draws each run with draw_run, which finds the scenario's golden itself."""
    from stackdsl.draw.artefacts import draw_run, golden_of

    (tmp_path / "pyproject.toml").write_text("")
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "tower.yaml").write_text(TOWER)
    monkeypatch.chdir(tmp_path)
    program = stackdsl.compile_scenario(stackdsl.load_scenario("scenarios/tower.yaml"))
    outcome, trajectory = record_program(program, source="scenarios/tower.yaml")
    assert golden_of(trajectory) == tmp_path / "golden" / "scenarios" / "tower.json"
    written, failure, _ = draw_run(trajectory, tmp_path / "no-golden")
    assert failure == "" and written["replay"] == "replay.html"
    assert '"ghosts":[],"golden_bricks":null' in (tmp_path / "no-golden" / "replay.html").read_text()
    golden = outcome.golden()
    golden["final_graph"]["L03.2"]["position_mm"][2] += 40.0  # the golden's top brick 40 mm higher
    (tmp_path / "golden" / "scenarios").mkdir(parents=True)
    (tmp_path / "golden" / "scenarios" / "tower.json").write_text(json.dumps(golden))
    draw_run(trajectory, tmp_path / "golden-differs")
    page = (tmp_path / "golden-differs" / "replay.html").read_text()
    found = json.loads(re.search(r'id="replay-data">(.*?)</script>', page, re.S).group(1).replace("<\\/", "</"))["ghosts"]
    assert [g["id"] for g in found] == ["L03.2"] and "40.0 mm away" in found[0]["why"]
    assert '"golden_bricks":6' in page


def _brick(golden: dict, brick: str, **fields: object) -> dict:
    edited = copy.deepcopy(golden)
    edited["final_graph"][brick].update(fields)
    return edited


#: Hand-edited goldens stackdsl cannot draw ghosts from: (edit of the run's own golden, what the one line says).
BAD_GOLDENS = {
    "text for a position": (lambda g: _brick(g, "L01.1", position_mm=["a", None, 1]), "L01.1.position_mm[0]: expected a number"),
    "an infinite position": (lambda g: _brick(g, "L01.1", position_mm=[1e999, 0, 0]), "expected a finite number, not Infinity"),
    "a NaN position": (lambda g: _brick(g, "L01.2", position_mm=[float("nan"), 0, 0]), "expected a finite number, not NaN"),
    "a position 1e300 mm away": (lambda g: _brick(g, "L01.1", position_mm=[0, 0, 1e300]), "position_mm[2]: out of range"),
    "two numbers for a position": (lambda g: _brick(g, "L01.1", position_mm=[1, 2]), "position_mm: expected 3 numbers"),
    "a zero quaternion": (lambda g: _brick(g, "L01.1", quaternion_xyzw=[0, 0, 0, 0]), "quaternion_xyzw has length 0"),
    "a huge quaternion": (lambda g: _brick(g, "L01.1", quaternion_xyzw=[0, 0, 0, 1e308]), "quaternion_xyzw has length 1e+308"),
    "text for a quaternion": (lambda g: _brick(g, "L01.1", quaternion_xyzw="x"), "quaternion_xyzw: expected a list"),
    "a state that is a number": (lambda g: _brick(g, "L01.1", state=3), "state: expected text"),
    "no orientation": (
        lambda g: {**g, "final_graph": {b: {"position_mm": f["position_mm"]} for b, f in g["final_graph"].items()}},
        "a brick needs its orientation",
    ),
    "a brick that is a number": (lambda g: {**g, "final_graph": {**g["final_graph"], "L01.1": 5}}, "L01.1: expected an object"),
    "final_graph a string": (lambda g: {**g, "final_graph": "x"}, "final_graph: expected an object"),
    "final_graph a list": (lambda g: {**g, "final_graph": [1, 2]}, "final_graph: expected an object"),
    "final_graph null": (lambda g: {**g, "final_graph": None}, "final_graph: expected an object"),
    "no final_graph": (lambda g: {k: v for k, v in g.items() if k != "final_graph"}, "final_graph: missing"),
    "a collapse_graph of text": (lambda g: {**g, "collapse_graph": "x"}, "collapse_graph: expected an object"),
    "a scenario name that is a number": (lambda g: {**g, "scenario": 4}, "scenario: expected text"),
    "a list, not an object": (lambda g: [g], "it is a JSON array, not an object"),
    "a folder": (lambda g: Path("."), "not a golden snapshot stackdsl can draw: it is not a regular file"),
    "nested 100000 deep": (lambda g: "[" * 100_000 + "]" * 100_000, "nested more than 16 levels deep"),
    "nested 20 deep": (lambda g: {**g, "extra": json.loads("[" * 20 + "]" * 20)}, "nested more than 16 levels deep"),
    "another scenario's name": (lambda g: {**g, "scenario": "4 stack"}, "the golden snapshot of scenario '4 stack'"),
    "no brick of this run": (
        lambda g: {**g, "final_graph": {f"X{b}": f for b, f in g["final_graph"].items()}},
        "none of the golden snapshot's bricks (XL01.1",
    ),
}


@pytest.fixture(scope="module")
def tower_run(tmp_path_factory):
    """A project with a 3-level tower, its run recorded and its golden snapshot (as the plugin writes it)."""
    folder = tmp_path_factory.mktemp("golden")
    (folder / "pyproject.toml").write_text("")
    (folder / "scenarios").mkdir()
    scenario = folder / "scenarios" / "tower.yaml"
    scenario.write_text(TOWER)
    program = stackdsl.compile_scenario(stackdsl.load_scenario(scenario))
    outcome, trajectory = record_program(program, source=str(scenario))
    record = folder / "tower.npz"
    trajectory.save(record)
    return folder, scenario, record, outcome.golden()


def _write(path: Path, golden: object) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    if isinstance(golden, Path):  # not a file: a folder in its place
        path.mkdir()
        return path
    path.write_text(golden if isinstance(golden, str) else json.dumps(golden))
    return path


@pytest.mark.slow
@pytest.mark.parametrize("case", BAD_GOLDENS, ids=list(BAD_GOLDENS))
def test_a_golden_stackdsl_cannot_use_is_bad_input_given_or_found(case, tower_run, tmp_path, capsys):
    """Given to --golden or found at the scenario's own golden path: exit 2, one line naming the
    file and what is wrong, and no page; check --report draws the replay without it and says why."""
    folder, _, record, golden = tower_run
    edit, what = BAD_GOLDENS[case]
    given = _write(tmp_path / "given.json", edit(golden))
    assert main(["replay", str(record), "-o", str(tmp_path / "a"), "--golden", str(given)]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"{given}: ") and what in line, line
    assert not (tmp_path / "a" / "replay.html").exists()
    default = folder / "golden" / "scenarios" / "tower.json"
    _write(default, edit(golden))
    try:
        assert main(["replay", str(record), "-o", str(tmp_path / "b")]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert line.startswith(f"{default}: ") and what in line, line
        assert not (tmp_path / "b" / "replay.html").exists()
        from stackdsl.draw.artefacts import draw_run

        written, failure, _ = draw_run(stackdsl.load_trajectory(record), tmp_path / "report")
        assert written["replay"] == "replay.html" and failure.startswith("replay drawn without its golden: ")
        assert what in failure
    finally:
        default.rmdir() if default.is_dir() else default.unlink()


def test_the_runs_own_golden_draws_and_a_changed_scene_is_warned_of(tower_run, tmp_path, capsys):
    _, _, record, golden = tower_run
    given = _write(tmp_path / "own.json", golden)
    assert main(["replay", str(record), "-o", str(tmp_path / "a"), "--golden", str(given)]) == 0
    assert capsys.readouterr().err == ""
    taller = copy.deepcopy(golden)
    taller["final_graph"]["L04.1"] = {**golden["final_graph"]["L03.1"], "level": 4}  # the scene had 4 levels
    given = _write(tmp_path / "taller.json", taller)
    assert main(["replay", str(record), "-o", str(tmp_path / "b"), "--golden", str(given)]) == 0
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line == (
        f"{given}: warning: 1 of the golden snapshot's 7 bricks is not in this run (L04.1): the scene changed since it "
        "was taken; it is drawn as a ghost"
    )
    assert '"id":"L04.1"' in (tmp_path / "b" / "replay.html").read_text()


#: A sweep of two random single-file stacks three levels high: one sample a run of about 0.1 s.
SWEEP = (
    "stackdsl: 1\nname: small walk\nstructure: {tower: {levels: 3, bricks_per_layer: 1, turn: 0, "
    "shift: {uniform: [-60 mm, 60 mm], per: layer}}}\ntiming: {settle: 0.2 s}\nsweep: {samples: 2}\n"
    "expect: {collapse: {mean: 2 ± 2}}\n"
)


def test_a_sweeps_golden_is_compared_with_the_sample_replayed_not_refused(tmp_path, capsys, monkeypatch):
    """A sweep's golden (each sample's collapse level, as the pytest plugin writes it) has no
    final_graph: replay runs the sample asked for, says what the golden holds of it, and exits 0."""
    from stackdsl.runtime.run import run_program

    (tmp_path / "pyproject.toml").write_text("")
    scenario = tmp_path / "scenarios" / "walk.yaml"
    scenario.parent.mkdir()
    scenario.write_text(SWEEP)
    template = stackdsl.load_scenario(scenario).template
    outcome = run_program(stackdsl.compile_scenario(template.scenario(0, 1)))
    level = outcome.collapse.level if outcome.collapse else None
    wrong = 3 if level is None else None
    golden = {"scenario": "small walk", "mode": "extension", "samples": 2, "cell 0": {"grid": {}, "collapse_levels": [1, level]}}
    default = _write(tmp_path / "golden" / "scenarios" / "walk.json", golden)
    monkeypatch.chdir(tmp_path)
    assert main(["replay", "scenarios/walk.yaml", "--sample", "1", "-o", "out"]) == 0
    said = capsys.readouterr()
    assert "replaying sample 1 of 2" in said.err
    assert f"golden: {default} is a sweep's golden snapshot" in said.out and "sample 1 of cell 0" in said.out
    assert said.out.splitlines()[0].endswith("here: the same"), said.out
    page = (tmp_path / "out" / "replay.html").read_text()
    assert '"ghosts":[],"golden_bricks":null,"golden_note":' in page and "is a sweep" in page
    other = _write(tmp_path / "other.json", {**golden, "cell 0": {"grid": {}, "collapse_levels": [1, wrong]}})
    assert main(["replay", "scenarios/walk.yaml", "--sample", "1", "-o", "out", "--golden", str(other)]) == 0
    assert capsys.readouterr().out.splitlines()[0].endswith("here: they differ")
    assert main(["replay", "scenarios/walk.yaml", "-o", "out", "--mode", "raw"]) == 0  # another mode: said, not compared
    assert "taken in extension mode and this run is in raw mode: not compared" in capsys.readouterr().out
    broken = _write(tmp_path / "broken.json", {**golden, "cell 0": {"collapse_levels": ["x"]}})
    assert main(["replay", "scenarios/walk.yaml", "-o", "out", "--golden", str(broken)]) == 2
    assert "cell 0.collapse_levels[0]: expected a whole number" in capsys.readouterr().err


def test_every_shipped_golden_reads_as_its_scenarios(slant):
    from stackdsl.draw.replay import read_golden

    trajectory, _ = slant
    assert read_golden(ROOT / "golden" / "scenarios" / "slant_tower.json", trajectory) is not None
    for path in shipped_goldens():  # not the goldens a user keeps beside them (a sweep's cannot be drawn)
        assert isinstance(read_golden(path), dict), path


@pytest.mark.slow
def test_a_reports_drawing_keeps_to_the_runs_deadline_and_reads_no_fifo_golden(tmp_path, monkeypatch):
    """draw_run leaves out the clip past its deadline (check --report's --timeout), draws the
    rest, and draws the replay without ghosts when the golden is a FIFO rather than block on it."""
    import os
    import threading
    import time

    from stackdsl.draw.artefacts import draw_run

    (tmp_path / "pyproject.toml").write_text("")
    (tmp_path / "scenarios").mkdir()
    (tmp_path / "scenarios" / "tower.yaml").write_text(TOWER)
    (tmp_path / "golden" / "scenarios").mkdir(parents=True)
    os.mkfifo(tmp_path / "golden" / "scenarios" / "tower.json")
    monkeypatch.chdir(tmp_path)
    program = stackdsl.compile_scenario(stackdsl.load_scenario("scenarios/tower.yaml"))
    _, trajectory = record_program(program, source="scenarios/tower.yaml")
    done: list = []
    drawing = threading.Thread(target=lambda: done.append(draw_run(trajectory, tmp_path / "r", time.perf_counter())), daemon=True)
    drawing.start()
    drawing.join(timeout=60)
    assert done, "draw_run blocked"
    written, failure, _ = done[0]
    assert set(written) == {"trajectory", "picture", "graph", "replay"}
    assert failure.startswith("replay drawn without its golden: ") and "not a regular file" in failure  # said first
    assert '"ghosts":[],"golden_bricks":null' in (tmp_path / "r" / "replay.html").read_text()
    (tmp_path / "golden" / "scenarios" / "tower.json").unlink()
    written, failure, _ = draw_run(trajectory, tmp_path / "r2", time.perf_counter())
    assert "clip" not in written and failure.startswith("clip not drawn: TimeoutError")


# -- in the browser -------------------------------------------------------------------------
needs_browser = pytest.mark.skipif(bool(missing()), reason=missing() or "ready")


@pytest.fixture(scope="module")
def chromium():
    with browser() as launched:
        yield launched


@pytest.fixture(scope="module")
def slant_page(slant, tmp_path_factory):
    trajectory, golden = slant
    moved = copy.deepcopy(golden)
    moved["final_graph"]["L03.1"]["position_mm"][0] += 25.0
    return write_replay(trajectory, tmp_path_factory.mktemp("replay") / "replay.html", moved)


@needs_browser
def test_the_canvas_draws_the_bricks_in_their_state_colours(chromium, slant_page):
    opened = open_replay(chromium, slant_page)
    opened.call("seek", 18.0)  # after the collapse: fallen bricks (red) and frozen ones (blue)
    opened.page.wait_for_timeout(200)
    from PIL import Image

    shot = np.asarray(Image.open(io.BytesIO(opened.page.locator("#view canvas").screenshot())).convert("RGB")).astype(int)
    background = np.array([250, 250, 252])
    drawn = np.abs(shot - background).sum(axis=2) > 30
    assert drawn.mean() > 0.2, drawn.mean()  # the ground and the bricks, not a blank canvas
    red = (shot[..., 0] > 150) & (shot[..., 1] < 80) & (shot[..., 2] < 80)
    blue = (shot[..., 2] > 120) & (shot[..., 0] < 110)
    assert red.sum() > 500 and blue.sum() > 200, (red.sum(), blue.sum())
    assert opened.console == []


@needs_browser
def test_scrubbing_moves_every_brick_to_its_recorded_pose(chromium, slant, slant_page):
    trajectory, _ = slant
    opened = open_replay(chromium, slant_page)
    times = [0.0, 3.5, 16.06, trajectory.collapse_time + 0.1, trajectory.collapse_time + 0.37, trajectory.end]
    for t in times:
        # through the timeline's own slider, as a person drags it
        opened.page.evaluate(
            "(t) => { const s = document.getElementById('scrub'); s.value = String(t); s.dispatchEvent(new Event('input')); }", t
        )
        poses = opened.call("poses()")
        frame = trajectory.at(t)
        assert opened.call("frame()") == trajectory.frame_index(t)
        for i, brick in enumerate(trajectory.ids.tolist()):
            if np.isnan(frame.positions[i, 0]):
                assert poses[brick] is None, (t, brick)
                continue
            assert np.allclose(poses[brick]["position"], frame.positions[i], atol=1e-6), (t, brick)
            assert np.allclose(poses[brick]["quaternion"], frame.orientations[i], atol=1e-6), (t, brick)
            assert poses[brick]["state"] == frame.state_names[i], (t, brick)
    # the slider's times are the page's: a step to the next event lands on it
    opened.call("seek", 0.5)
    assert opened.call("nextEvent()") == pytest.approx(next(e.time for e in trajectory.events if e.time > 0.5 + 1e-6))
    assert opened.console == []


@needs_browser
def test_clicking_a_brick_shows_its_panel(chromium, slant, slant_page):
    opened = open_replay(chromium, slant_page)
    # the page opens at the collapse with the brick that moved first selected
    said = f"L09.1 at t = {slant[0].collapse_time:.3f} s"
    assert opened.call("selected()") == "L09.1" and said in opened.page.locator("#panel").inner_text()
    opened.call("select", None)
    assert opened.page.locator("#panel").is_hidden()
    opened.call("seek", 12.5)  # levels 1 to 6 stand, frozen
    target = "L06.1"
    x, y = opened.call("screenPosition", target)
    opened.page.mouse.click(x, y)
    panel = opened.page.locator("#panel")
    panel.wait_for(state="visible")
    assert opened.call("selected()") == target
    text = panel.inner_text()
    assert f"{target} at t = 12.500 s" in text and "level\t6" in text and "frozen" in text
    assert "rests on" in text and "load share" in text and "L05." in text
    assert opened.console == []


@needs_browser
def test_playback_slows_down_at_the_collapse_and_the_ghosts_are_listed(chromium, slant, slant_page):
    trajectory, _ = slant
    opened = open_replay(chromium, slant_page)
    assert "L03.1" in opened.call("ghosts()")
    assert "L03.1" in opened.page.locator("#ghost-list").inner_text()
    opened.call("seek", trajectory.collapse_time)
    assert opened.call("rate()") == pytest.approx(0.2)
    opened.call("seek", 0.5)  # a quiet wait between placements
    assert opened.call("rate()") == pytest.approx(10)
    opened.call("play()")
    # it plays on from 0.5 s: wait for a frame past it (a loaded machine may draw none in 0.5 s)
    opened.page.wait_for_function("() => window.stackdslReplay.time() > 0.5", timeout=10_000)
    opened.call("pause()")
    assert opened.call("time()") > 0.5
    # a tenth of a wall second of playback: ten times faster through the wait between two
    # placements, but it stops at the next placement's frame, not past it
    opened.call("seek", 0.9)
    assert opened.call("advance", 0.1) == pytest.approx(1.0)
    # and it stops at the collapse, where it slows down
    opened.call("seek", trajectory.collapse_time - 0.02)
    assert opened.call("advance", 0.1) == pytest.approx(trajectory.collapse_time)
    assert opened.call("advance", 0.1) == pytest.approx(trajectory.collapse_time + 0.02)
    assert opened.console == []


@needs_browser
def test_dragging_orbits_and_the_wheel_zooms(chromium, slant_page):
    opened = open_replay(chromium, slant_page)
    box = opened.page.locator("#view canvas").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2

    def camera():
        c = opened.call("camera()")
        return np.array(c["position"]), np.array(c["target"])

    start, target = camera()
    opened.page.mouse.move(x, y)
    opened.page.mouse.down()
    opened.page.mouse.move(x + 150, y + 40, steps=8)
    opened.page.mouse.up()
    turned, same_target = camera()
    assert np.allclose(same_target, target) and not np.allclose(turned, start)
    assert np.linalg.norm(turned - target) == pytest.approx(np.linalg.norm(start - target), rel=1e-6)  # an orbit
    assert opened.call("selected()") == "L09.1"  # a drag is not a click: the selection stays
    opened.page.mouse.wheel(0, -400)
    opened.page.wait_for_timeout(100)
    nearer, _ = camera()
    assert np.linalg.norm(nearer - target) < 0.9 * np.linalg.norm(turned - target)
    assert opened.console == []


# A brick beside a KAPLA bolted to the table, shaken 30 mm at 1 Hz along y (raw: the ground moves).
SHAKEN = (
    "stackdsl: 1\nname: shaken fixture\nstructure:\n  bricks:\n    - {id: a, at: [0, 0, 4 mm]}\n"
    "    - {id: bolted, at: [200 mm, 0, 4 mm], fixed: true}\n"
    "timing: {settle: 0.2 s}\nactions: [{shake: {amplitude: 30 mm, frequency: 1 Hz, duration: 1 s, at: 1 s, direction: [0, 1]}}]\n"
)


@pytest.fixture(scope="module")
def shaken(tmp_path_factory):
    """The shaken run, recorded, and its replay page."""
    _, trajectory = record_program(stackdsl.compile_scenario(stackdsl.parse_scenario(SHAKEN), "raw"))
    return trajectory, write_replay(trajectory, tmp_path_factory.mktemp("shaken") / "replay.html")


def test_the_page_moves_the_fixtures_with_the_grounds_offset(shaken):
    """The page stored the fixtures once and drew them at rest while a shake moved the table
    and the bricks on it: it now has the ground's offset at each frame, which carries them."""
    trajectory, _ = shaken
    data = replay_data(trajectory)
    offset = _decode(data["ground_offset"], "<f4").reshape(-1, 3)
    assert offset.shape == (len(trajectory.times), 3)
    assert np.allclose(offset, trajectory.ground_offset, atol=1e-7)
    assert float(np.abs(offset[:, 1]).max()) == pytest.approx(0.06, abs=0.003) and not offset[:, 0].any()
    assert data["fixtures"][0]["position"] == pytest.approx([0.2, 0.0, 0.004])  # at rest: the page adds the offset


@needs_browser
def test_the_replay_draws_the_fixtures_carried_by_the_shake(chromium, shaken):
    trajectory, page = shaken
    opened = open_replay(chromium, page)
    farthest = int(np.argmax(np.abs(trajectory.ground_offset[:, 1])))
    for k in (0, farthest // 2, farthest, len(trajectory.times) - 1):
        opened.call("seek", float(trajectory.times[k]))
        assert opened.call("frame()") == k
        assert np.allclose(opened.call("fixtures()")["bolted"], trajectory.fixture_positions_at(k)[0], atol=1e-6), k
        assert np.allclose(opened.call("groundOffset()"), trajectory.ground_offset[k], atol=1e-6), k
    assert opened.console == []


# A pyramid with a middle brick of its base pulled out slowly: the collapse begins (4.66 s) seconds
# before it is decided (7.75 s, when the hand lets go), and is dated back to its beginning.
# L01.2 pulled: L02.1 is left on L01.1 alone, half over its edge. (L01.3, the middle one, was
# pulled until every engine and mode was found to leave that pyramid standing: the extension on
# pybullet had fallen only where its woken bricks had no contact yet with those under them.)
PULLED = (
    "stackdsl: 1\nname: pyramid with a brick pulled\nstructure:\n  pyramid: {base: 5, joint: 1 mm}\n"
    "actions:\n  - remove: {brick: L01.2, at: after level 5, speed: 40 mm/s, direction: [0, 1, 0]}\n"
    "timing: {interval: 0.3 s, settle: 2 s}\n"
)


@pytest.fixture(scope="module")
def pulled():
    """The pulled pyramid's run, recorded."""
    _, trajectory = record_program(stackdsl.compile_scenario(stackdsl.parse_scenario(PULLED)))
    return trajectory


@pytest.mark.slow
def test_the_collapse_graph_is_labelled_with_the_moment_it_was_taken(pulled):
    """The page labelled the collapse graph with the time the collapse was decided, 3.1 s after
    the moment it was taken (when the collapse began), and showed it around the wrong time."""
    collapse = pulled.meta["collapse"]
    assert collapse["decided"] - collapse["time"] > 1.0  # the case: decided long after it began
    graph = replay_data(pulled)["graphs"]["collapse"]
    assert graph["time"] == pytest.approx(collapse["time"], abs=1e-9) == pulled.meta["collapse_graph_time"]
    assert "began" in graph["label"] and "decided" not in graph["label"]
    # the graph's poses are the run's at that time: the pulled brick, moving at 40 mm/s, too
    frame = pulled.at(graph["time"])
    ids = pulled.ids.tolist()
    for node in pulled.graphs["collapse"].nodes:
        if node.id not in ids:  # the ground
            continue
        position = frame.positions[ids.index(node.id)] * 1000
        assert np.allclose(node.position_mm, position, atol=0.06), (node.id, node.position_mm, position)


@pytest.mark.slow
def test_a_file_without_the_graphs_time_labels_it_with_the_collapses(pulled):
    meta = {k: v for k, v in pulled.meta.items() if k != "collapse_graph_time"}
    old = dataclasses.replace(pulled, meta=meta)
    assert replay_data(old)["graphs"]["collapse"]["time"] == pytest.approx(pulled.meta["collapse"]["time"])


def test_every_event_and_the_collapse_has_a_frame_of_its_own(pulled):
    """The collapse is dated back to when its brick passed the threshold, and the wakes of a pull
    happen as it starts: the recorder kept no frame then, so a jump to them showed the frame before."""
    for e in pulled.events:
        k = pulled.frame_index(e.time)
        assert pulled.times[k] == pytest.approx(e.time, abs=1e-9), (e.kind, e.brick, e.time, pulled.times[k])
    collapse = pulled.meta["collapse"]
    at = pulled.at(collapse["time"])
    assert at.state_names[pulled.ids.tolist().index(collapse["brick"])] == "fallen"  # past the threshold, as the event says


def _without_frame(trajectory, k):
    """``trajectory`` as if frame ``k`` had not been taken (a file recorded before the collapse had
    its own frame): a body's row at ``k`` moves to frame ``k + 1`` where it has none."""
    frame, body = trajectory.row_frame, trajectory.row_body
    at_next = set(body[frame == k + 1].tolist())
    keep = (frame != k) | ~np.isin(body, list(at_next))
    frame = np.where(frame[keep] >= k + 1, frame[keep] - 1, frame[keep])
    frame = np.where((frame == k) & ~np.isin(body[keep], list(at_next)), k, frame)  # moved to old k + 1, now k
    order = np.argsort(frame, kind="stable")
    return dataclasses.replace(
        trajectory,
        times=np.delete(trajectory.times, k),
        ground_offset=np.delete(trajectory.ground_offset, k, axis=0),
        row_frame=frame[order].astype(np.int32),
        row_body=body[keep][order],
        row_position=trajectory.row_position[keep][order],
        row_orientation=trajectory.row_orientation[keep][order],
        row_state=trajectory.row_state[keep][order],
    )


@needs_browser
def test_the_page_opens_on_a_frame_that_shows_the_collapse(chromium, pulled, tmp_path):
    collapse = pulled.meta["collapse"]
    k = pulled.frame_index(collapse["time"])
    older = _without_frame(pulled, k)  # a recording with no frame at the collapse: the next frame shows it
    assert older.times[k - 1] < collapse["time"] < older.times[k]
    for trajectory in (pulled, older):
        opened = open_replay(chromium, write_replay(trajectory, tmp_path / f"replay{len(trajectory.times)}.html"))
        assert opened.call("selected()") == collapse["brick"]
        assert opened.call("frameTime()") >= collapse["time"] - 1e-9
        assert opened.call("poses()")[collapse["brick"]]["state"] == "fallen"
        # a jump to each event lands on a frame at or after it, and the next jump goes on from the event
        opened.call("seek", 0.0)
        seen = []
        for _ in range(len({e.time for e in trajectory.events if e.time > 1e-6})):
            opened.call("nextEvent()")
            seen.append(opened.call("time()"))
        shown = sorted({e.time for e in trajectory.events if e.time > 1e-6})
        assert len(seen) == len(shown)
        for t, e in zip(seen, shown):
            assert t >= e - 1e-9 and opened.call("seekEvent", e) is not None
        assert opened.console == []


def test_a_golden_larger_than_16_mib_is_refused_by_its_size_before_it_is_read(tmp_path, capsys, monkeypatch):
    # a 50 MB golden took 792 MB and 15 s before replay refused it; 16 MiB at most (a 15 MiB one peaks at 224 MB)
    monkeypatch.setattr("stackdsl.runtime.recorder.record_program", lambda *a, **k: pytest.fail("simulated"))
    big = tmp_path / "big.json"
    with open(big, "wb") as f:
        f.truncate((16 << 20) + 1)  # sparse: nothing to read but its size
    monkeypatch.setattr(Path, "read_text", lambda *a, **k: pytest.fail("read"))
    assert main(["replay", str(ROOT / "scenarios" / "vee_stands.yaml"), "-o", str(tmp_path / "r"), "--golden", str(big)]) == 2
    assert "big.json: not a golden snapshot stackdsl can draw: it is larger than 16 MiB" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()
