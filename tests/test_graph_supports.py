"""Every frozen brick of the brick graph rests on what carries it, a leaning one too.

A brick the debris rule freezes in a pile, lying on its neighbours by contacts steeper than
the support angle (a domino fallen across the next ones, a slanted tower's brick on the ones
beside it), was held by rigid-block equilibrium on those contacts: the graph lists them, and
never shows a frozen brick resting on nothing (stackdsl's own,
:meth:`stability._admission.Admission.plan`).
"""

import json
import sys
from pathlib import Path

import pytest

from stackdsl import compile_scenario, load_scenario, parse_scenario, run_program

sys.path.insert(0, str(Path(__file__).parent))
from shipped import shipped_goldens

ROOT = Path(__file__).resolve().parents[1]

ARC = """\
stackdsl: 1
name: a dozer pushes a domino arc over
brick_types:
  dozer: {size: [150 mm, 300 mm, 100 mm]}
structure:
  dominoes: {count: 20, spacing: 50 mm, radius: 400 mm}
timing: {interval: 0.2 s, settle: 4 s}
actions:
  - push: {target: {brick: D01, offset: [-4 mm, 0, 0]}, direction: [1, 0, 0], at: after level 1, speed: 0.5 m/s, distance: 60 mm, gap: 20 mm, pusher: dozer}
expect:
  toppled: all
"""


def _unsupported(graph: dict[str, dict[str, object]]) -> list[str]:
    return [b for b, n in graph.items() if n["state"] == "frozen" and not n["rests_on"]]


def test_a_slanted_towers_bricks_frozen_leaning_rest_on_the_bricks_beside_them():
    graph = run_program(compile_scenario(load_scenario(ROOT / "scenarios" / "slant_tower.yaml"))).golden()["final_graph"]
    assert _unsupported(graph) == []
    # L04.2 lies across L03.1 and L03.2 at about 32 degrees, its centre below theirs
    lean = graph["L04.2"]
    assert lean["state"] == "frozen" and set(lean["rests_on"]) == {"L03.1", "L03.2"}
    assert sum(e["load_share"] for e in lean["rests_on"].values()) == pytest.approx(1.0, abs=0.01)
    assert graph["L03.1"]["mass_above_g"] > lean["mass_above_g"] / 2


def test_a_domino_frozen_across_its_fallen_neighbours_rests_on_them():
    outcome = run_program(compile_scenario(parse_scenario(ARC)))
    graph = outcome.golden()["final_graph"]
    assert sum(n["state"] == "frozen" for n in graph.values()) == 20
    assert _unsupported(graph) == []
    for node in graph.values():
        assert all(0.0 <= e["load_share"] <= 1.0 for e in node["rests_on"].values())


@pytest.mark.parametrize("path", shipped_goldens(), ids=lambda p: p.stem)  # not a user's own goldens beside them
def test_no_golden_snapshot_shows_a_frozen_brick_resting_on_nothing(path):
    data = json.loads(path.read_text())
    assert _unsupported(data["final_graph"]) == []


def test_bricks_woken_by_an_impact_rest_on_the_level_below_in_the_collapse_graph():
    """A tower struck at level 6: the bricks it wakes lie on the frozen level below, but the
    engine has no contact yet between a brick woken this step and the frozen brick under it
    (two bodies of mass 0 had none), so the collapse graph said levels 5 and 6 rested on
    nothing. Every structure brick lying face to face on another (ground for level 1) in the
    collapse graph rests on something there."""
    text = """stackdsl: 1
structure:
  tower: {levels: 8, bricks_per_layer: 2, spacing: 96 mm, turn: 90}
impacts:
  - {id: hammer, target: {level: 6, side: +x}, speed: 4 m/s, at: after level 8}
timing: {interval: 0.5 s, settle: 2 s}
"""
    outcome = run_program(compile_scenario(parse_scenario(text)))
    assert outcome.collapse is not None and outcome.collapse_graph is not None
    graph = outcome.collapse_graph
    supported = {e.upper for e in graph.edges}
    woken = [n for n in graph.nodes if n.level is not None and n.state == "active"]
    assert woken, "the impact woke bricks"
    # a brick still where it was placed (within 1 mm) lies on what it was placed on; one the hammer
    # moved (L06.1, 15 mm along x and tilted 1.3 deg as it rocks) need not lie face to face
    still = [n for n in woken if (n.displaced_mm or 0.0) < 1.0 and abs(n.position_mm[2] - (n.level - 0.5) * 8.0) < 1.0]
    assert still and all(n.id in supported for n in still), [n.id for n in still if n.id not in supported]
