"""The brick-graph plot (stackdsl.draw.graphplot): margins on hand-built graphs and real runs, and
the PNG for every kind of graph the shipped scenarios make, degenerate ones included."""

from __future__ import annotations

import functools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

import stackdsl
from stackdsl.draw import graphplot as _graphplot
from stackdsl.draw.graphplot import KAPLA_MM, footprint_mm, margins, plot_graph, support_polygon
from stackdsl.runtime.outcome import Edge, Graph, Node

ROOT = Path(__file__).resolve().parent.parent
RED = (214, 39, 40)  # the colour of a centre of mass outside its support polygon
GROUND = Node(
    id="ground",
    level=None,
    state="ground",
    position_mm=(0, 0, 0),
    quaternion_xyzw=(0, 0, 0, 1),
    com_above_mm=(0, 0, 0),
    mass_above_g=0,
)


def quaternion(yaw: float, pitch: float, roll: float) -> tuple[float, float, float, float]:
    x, y, z, w = Rotation.from_euler("ZYX", [yaw, pitch, roll], degrees=True).as_quat()
    return x, y, z, w


def brick(
    name: str, com: tuple[float, float], level: int | None = 1, state: str = "frozen", z: float = 4.0, yaw: float = 0.0
) -> Node:
    return Node(id=name, level=level, state=state, position_mm=(com[0], com[1], z), quaternion_xyzw=quaternion(yaw, 0, 0),
                com_above_mm=(com[0], com[1], z), mass_above_g=10.6)  # fmt: skip


def rect(x0: float, y0: float, x1: float, y1: float) -> tuple[tuple[float, float], ...]:
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def rests(upper: str, support: str, polygon: tuple[tuple[float, float], ...], share: float = 1.0) -> Edge:
    return Edge(upper=upper, support=support, area_mm2=0.0, load_share=share, polygon_mm=polygon)


@functools.cache
def outcome(name: str) -> stackdsl.Outcome:
    return stackdsl.run_program(stackdsl.compile_scenario(stackdsl.load_scenario(ROOT / "scenarios" / name)))


class Recording(_graphplot.Figure):
    """The Figure plot_graph draws on, kept to read its words back."""

    last: Recording | None = None

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        Recording.last = self

    def words(self) -> str:
        texts = [t.get_text() for t in self.texts] + [a.get_title() for a in self.axes] + [a.get_xlabel() for a in self.axes]
        texts += [t.get_text() for a in self.axes for t in a.texts]
        return "\n".join(texts)


def plot(graph: Graph, path: Path, monkeypatch: pytest.MonkeyPatch, **kwargs: Any) -> tuple[Recording, Image.Image]:
    monkeypatch.setattr(_graphplot, "Figure", Recording)
    plot_graph(graph, path, **kwargs)
    assert Recording.last is not None
    image = Image.open(path)
    image.load()
    assert image.format == "PNG"
    assert 900 <= image.width <= 3000 and 500 <= image.height <= 2000, image.size
    assert path.stat().st_size > 5_000
    return Recording.last, image


def red_pixels(image: Image.Image) -> int:
    """Pixels of exactly the colour of a centre of mass outside, right of the graph (whose legend has one)."""
    right = np.asarray(image.convert("RGB"))[:, int(_graphplot._GRAPH_W * 100) :]
    return int(np.all(right == RED, axis=-1).sum())


# margins on hand-built graphs ------------------------------------------------------------------


def test_margin_is_the_distance_to_the_nearest_side_inside():
    # A KAPLA brick lying on the ground: its support polygon is its own 120 x 24 mm face.
    g = Graph(nodes=(GROUND, brick("b", (0, 0))), edges=(rests("b", "ground", rect(-60, -12, 60, 12)),))
    assert margins(g) == {"b": pytest.approx(12.0)}
    off_centre = Graph(nodes=(GROUND, brick("b", (50, 5))), edges=g.edges)
    assert margins(off_centre)["b"] == pytest.approx(7.0)  # 10 mm to the end, 7 mm to the side


def test_margin_is_negative_outside():
    g = Graph(nodes=(GROUND, brick("b", (80, 0))), edges=(rests("b", "ground", rect(-60, -12, 60, 12)),))
    assert margins(g)["b"] == pytest.approx(-20.0)
    corner = Graph(nodes=(GROUND, brick("b", (63, 16))), edges=g.edges)
    assert margins(corner)["b"] == pytest.approx(-5.0)  # 3-4-5 from the corner


def test_two_supports_give_their_convex_hull():
    # A brick across two others (a 4 stack): two 24 x 24 mm pads 96 mm apart; the centre of mass
    # lies in the gap between them, inside their hull, 12 mm from its long sides.
    pads = (rests("top", "a", rect(-60, -12, -36, 12), 0.5), rests("top", "b", rect(36, -12, 60, 12), 0.5))
    g = Graph(nodes=(GROUND, brick("top", (0, 0), level=2)), edges=pads)
    assert margins(g)["top"] == pytest.approx(12.0)
    hull = support_polygon(g, "top")
    assert hull is not None and hull.area == pytest.approx(120 * 24)
    leaning_out = Graph(nodes=(GROUND, brick("top", (0, 30), level=2)), edges=pads)
    assert margins(leaning_out)["top"] == pytest.approx(-18.0)


def test_no_support_is_nan_and_bodies_of_the_ground_have_no_margin():
    wall = Node(id="wall", level=None, state="ground", position_mm=(10, 0, 100), quaternion_xyzw=(0, 0, 0, 1),
                com_above_mm=(10, 0, 100), mass_above_g=0)  # fmt: skip
    g = Graph(nodes=(GROUND, wall, brick("falling", (0, 0), state="active", z=50)), edges=())
    m = margins(g)
    assert list(m) == ["falling"] and math.isnan(m["falling"])
    assert support_polygon(g, "falling") is None
    assert margins(Graph(nodes=(), edges=())) == {}


def test_a_support_without_area_contains_nothing():
    # A line contact (two points) under the centre of mass: on it, margin 0; beside it, minus the distance.
    line = (rests("b", "ground", ((-10.0, 0.0), (10.0, 0.0))),)
    assert margins(Graph(nodes=(brick("b", (0, 0)),), edges=line))["b"] == pytest.approx(0.0)
    assert margins(Graph(nodes=(brick("b", (0, 3)),), edges=line))["b"] == pytest.approx(-3.0)


def test_footprint_of_a_turned_and_of_a_tilted_brick():
    turned = footprint_mm(brick("b", (5, 7), yaw=90))
    assert np.ptp(turned, axis=0) == pytest.approx([24.0, 120.0])
    assert turned.mean(axis=0) == pytest.approx([5.0, 7.0])
    # A V brick: 70 deg from horizontal; seen from above it is 120 cos 70 + 8 sin 70 mm long.
    v = Node(id="v", level=1, state="frozen", position_mm=(0, 0, 57.7), quaternion_xyzw=quaternion(0, -70, 0),
             com_above_mm=(0, 0, 57.7), mass_above_g=10.6)  # fmt: skip
    length = 120 * math.cos(math.radians(70)) + 8 * math.sin(math.radians(70))
    assert np.ptp(footprint_mm(v), axis=0) == pytest.approx([length, 24.0])
    assert np.ptp(footprint_mm(v, (60.0, 10.0, 4.0)), axis=0) == pytest.approx([length / 2, 10.0])
    assert KAPLA_MM == (120.0, 24.0, 8.0)


# margins on real runs ----------------------------------------------------------------------------


def test_four_stack_every_margin_positive():
    m = margins(outcome("four_stack.yaml").final_graph)
    assert len(m) == 60
    assert min(m.values()) > 10.0  # each centre of mass within 2 mm of the middle of its 24 mm-wide hull


def test_slant_tower_collapse_has_a_centre_of_mass_outside():
    o = outcome("slant_tower.yaml")
    assert o.collapse is not None and o.collapse_graph is not None
    g = o.collapse_graph
    m = margins(g)
    state = {n.id: n.state for n in g.nodes}
    moving = [b for b in m if state[b] == "active"]
    assert moving and min(m[b] for b in moving) < 0  # the group that gave way
    assert all(m[b] > 0 for b in m if state[b] == "frozen")  # what still stands


# pictures -------------------------------------------------------------------------------------


@pytest.mark.slow
def test_plot_a_standing_tower_has_no_red(tmp_path, monkeypatch):
    g = outcome("four_stack.yaml").final_graph
    fig, image = plot(g, tmp_path / "four.png", monkeypatch, title="four stack", max_panels=8)
    words = fig.words()
    assert "four stack" in words and "118 edges: shares not labelled" in words
    ninth = sorted(margins(g).values())[8]
    assert f"52 more bricks not shown, least margin among them {ninth:+.1f} mm" in words
    assert len(fig.axes) == 1 + 8
    assert red_pixels(image) == 0


@pytest.mark.slow
def test_plot_a_collapse_shows_red_and_the_shares(tmp_path, monkeypatch):
    g = outcome("slant_tower.yaml").collapse_graph
    assert g is not None
    fig, image = plot(g, tmp_path / "slant.png", monkeypatch, max_panels=6)
    words = fig.words()
    share = next(e.load_share for e in g.edges if (e.upper, e.support) == ("L09.1", "L08.2"))
    assert 0.6 < share < 0.75  # L09.1 passes most of its load to L08.2
    assert "shares not labelled" not in words and f"{share:.2f}" in words
    worst = min(margins(g).values())
    assert f"margin {worst:+.1f} mm" in fig.axes[1].get_title()  # the most critical brick comes first
    assert red_pixels(image) > 20


@pytest.mark.slow
def test_plot_leaning_bricks_and_fixtures(tmp_path, monkeypatch):
    for name in ("vee_stands.yaml", "lean_wall_stands.yaml", "card_house.yaml"):
        fig, image = plot(outcome(name).final_graph, tmp_path / f"{name}.png", monkeypatch, max_panels=6)
        assert "lean (report 3.4)" in fig.words()
        assert red_pixels(image) > 20


def test_plot_a_fixture_is_in_the_legend(tmp_path, monkeypatch):
    fig, _ = plot(outcome("lean_wall_stands.yaml").final_graph, tmp_path / "wall.png", monkeypatch)
    assert "fixed body" in [t.get_text() for t in fig.legends[0].get_texts()]
    assert "wall" in fig.words()


@pytest.mark.slow
def test_plot_a_tall_tower_caps_the_panels(tmp_path, monkeypatch):
    # A synthetic 4 stack of 100 levels (200 bricks): as tall_100 builds it, without the 1.5 s run.
    def centre(level: int, side: float) -> tuple[float, float]:
        return (0.0, side) if level % 2 else (side, 0.0)

    nodes, edges = [GROUND], []
    for level in range(1, 101):
        for i, side in ((1, -48.0), (2, 48.0)):
            x, y = centre(level, side)
            nodes.append(brick(f"L{level:03}.{i}", (x, y), level=level, z=8 * level - 4, yaw=0 if level % 2 else 90))
            if level == 1:
                edges.append(rests(nodes[-1].id, "ground", rect(-60, y - 12, 60, y + 12)))
            for j, below in ((1, -48.0), (2, 48.0)) if level > 1 else ():
                bx, by = centre(level - 1, below)  # the pad where the two bricks cross
                edges.append(
                    rests(nodes[-1].id, f"L{level - 1:03}.{j}", rect(x + bx - 12, y + by - 12, x + bx + 12, y + by + 12), 0.5)
                )
    fig, _ = plot(Graph(nodes=tuple(nodes), edges=tuple(edges)), tmp_path / "tall.png", monkeypatch, max_panels=6)
    words = fig.words()
    assert len(fig.axes) == 1 + 6
    assert "194 more bricks not shown, least margin among them +12.0 mm" in words
    assert "398 edges: shares not labelled" in words


@pytest.mark.slow
def test_plot_degenerate_graphs(tmp_path, monkeypatch):
    fig, _ = plot(Graph(nodes=(), edges=()), tmp_path / "empty.png", monkeypatch)
    assert "empty graph: nothing placed" in fig.words() and "no bricks" in fig.words()
    fig, _ = plot(Graph(nodes=(GROUND,), edges=()), tmp_path / "ground.png", monkeypatch)
    assert "no bricks" in fig.words()
    # Falling bricks (no edge), a projectile without a level, a point contact, a sliver, a one-point
    # contact, an edge without a polygon to a body the graph does not hold.
    nodes = (GROUND, brick("a", (0, 0)), brick("b", (0, 0), level=2, state="active", z=30),
             brick("p", (90, 0), level=None, state="active", z=12), brick("c", (0, 60), level=1),
             brick("d", (0, 60), level=2, z=12), brick("e", (0, -60), level=4, z=28))  # fmt: skip
    edges = (rests("a", "ground", rect(-60, -12, 60, 12)), rests("p", "a", ((59.0, 0.0), (60.0, 1.0), (61.0, 0.0), (60.0, -1.0))),
             rests("c", "ground", ((-60.0, 60.0), (60.0, 60.0), (60.0, 60.01), (-60.0, 60.01))),
             rests("d", "c", ((0.0, 61.0),)), rests("e", "nowhere", ()))  # fmt: skip
    g = Graph(nodes=nodes, edges=edges)
    m = margins(g)
    assert m["d"] == pytest.approx(-1.0) and m["c"] == pytest.approx(0.0, abs=0.01) and math.isnan(m["e"])
    fig, image = plot(g, tmp_path / "loose.png", monkeypatch, sizes={"a": (100.0, 20.0, 10.0)})
    words = fig.words()
    assert "rests on nothing" in words and "no level" in words
    assert [a.get_title()[:3] for a in fig.axes[-2:]] == ["b ·", "e ·"]  # the bricks with no support come last
    assert red_pixels(image) > 20  # p's centre of mass is 30 mm from its point contact


def test_plot_rejects_a_negative_panel_count(tmp_path):
    with pytest.raises(ValueError, match="max_panels"):
        plot_graph(Graph(nodes=(), edges=()), tmp_path / "x.png", max_panels=-1)
