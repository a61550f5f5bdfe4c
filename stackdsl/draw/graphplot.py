"""A brick graph as a PNG: who rests on whom with what share of the load, and each brick's
centre of mass above against its support polygon.

Everything here is in the Graph's own units, millimetres (positions, polygons, margins) and
degrees (poses), not SI: the plot shows the numbers of the snapshot as they are.

A brick's support polygon is the convex hull of the contact areas of all its edges, the
report's "combined support area" (report 3.3.3); its centre of mass above is the centre of
mass of the brick and everything it carries (report 3.3.5). The report's basic test calls a
brick stable when that point's (x, y) lies inside that polygon; the margin says how far inside.
The graph records only the contacts a brick rests on: a leaning brick's partner (report 3.4)
is no edge, so a frozen leaning brick shows a negative margin.

Source: stackdsl's own (the plot, the margin, the layout); the quantities it shows are the
report's (3.3.3, 3.3.5, 3.3.6).
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import shapely
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import FancyArrowPatch, Rectangle
from matplotlib.patches import Polygon as PolygonPatch
from matplotlib.ticker import MaxNLocator
from scipy.spatial.transform import Rotation
from shapely.geometry import MultiPoint, Point, Polygon
from shapely.geometry.base import BaseGeometry
from shapely.geometry.polygon import orient
from shapely.ops import nearest_points

from ..runtime.outcome import Edge, Graph, Node
from ..util.files import written

#: Size (length, width, height) in mm of a brick ``plot_graph`` is given no size for: KAPLA.
KAPLA_MM = (120.0, 24.0, 8.0)
#: Load shares are written on the edges up to this many edges; above, only line widths show them.
MAX_SHARE_LABELS = 40
#: Brick ids are written next to the nodes up to this many bricks.
MAX_NODE_LABELS = 40

_COLOURS = {"frozen": "#4c72b0", "active": "#dd8452", "ground": "#8c8c8c"}
_INSIDE, _OUTSIDE, _CONTACT = "#2ca02c", "#d62728", "#1f4e8c"
_GRAPH_W, _PANEL_W, _PANEL_H = 7.5, 2.7, 2.6  # inches: the graph's column, a top view's cell
_LABEL_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none"}


def support_polygon(graph: Graph, brick: str) -> BaseGeometry | None:
    """The support polygon of ``brick``, (x, y) in mm: the convex hull of the contact
    polygons of every edge it rests on, the report's "combined support area" (report 3.3.3).

    Returns a shapely Polygon, or a LineString or Point when the contacts have no area, or
    None when the brick rests on nothing (no edge, or only edges without polygons).
    Source: report 3.3.3; the code is stackdsl's own.
    """
    return _hulls(graph).get(brick)


def margins(graph: Graph) -> dict[str, float]:
    """Signed horizontal distance in mm from each brick's centre of mass above to the edge of
    its support polygon (:func:`support_polygon`): positive inside, negative outside.

    Every brick (every node whose state is not "ground") gets an entry. A brick with no
    support polygon (no edge: it is falling, or held only by contacts the graph does not
    record) gets NaN. A support polygon without area (a line, a point) contains nothing: the
    margin is minus the distance to it. Only the (x, y) of the centre of mass counts; the
    ground and fixed bodies get no entry. Raises nothing.

    Source: stackdsl's own, measuring the report's basic stability test: the centre of mass
    above (report 3.3.5) against the combined support area (report 3.3.3).

    >>> n = Node(id="b", level=1, state="frozen", position_mm=(0, 0, 4), quaternion_xyzw=(0, 0, 0, 1),
    ...          com_above_mm=(0, 0, 4), mass_above_g=10.6)
    >>> e = Edge(upper="b", support="ground", area_mm2=2880, load_share=1, polygon_mm=((-60, -12), (60, -12), (60, 12), (-60, 12)))
    >>> margins(Graph(nodes=(n,), edges=(e,)))
    {'b': 12.0}
    """
    hulls = _hulls(graph)
    return {n.id: _margin(hulls.get(n.id), n.com_above_mm) for n in graph.nodes if n.state != "ground"}


def plot_graph(
    graph: Graph,
    path: str | os.PathLike[str],
    *,
    title: str = "",
    sizes: Mapping[str, Sequence[float]] | None = None,
    max_panels: int = 16,
) -> None:
    """Write a PNG picture of ``graph`` to ``path``.

    Left, the rests-on graph: a dot per brick, one row per level, the ground as a band at the
    bottom with the fixed bodies on it; across, the position along the bricks' main
    horizontal axis (x or y when it is within 20 deg of one; bricks at one spot pushed apart).
    An arrow from each brick to each support, as wide as its load share and labelled with it
    when there are at most :data:`MAX_SHARE_LABELS` edges (plain lines, width only, when
    more; the picture says so); dots coloured by state, hollow for a brick resting on
    nothing, ringed in red when the centre of mass above lies outside the support polygon.
    Right, top views of the bricks, most critical first (smallest :func:`margins`, then the
    bricks with no support), at most ``max_panels`` of them: the support polygon filled,
    each contact polygon outlined (with its support and load share when there are at most
    four), the brick's footprint (its box projected down) dashed, the centre of mass above
    as a dot, green inside, red outside, joined to the nearest point of the polygon's edge,
    and the margin in mm in the title. A line under them says how many bricks are left out
    and their least margin. A typical picture is 1800 x 1200 pixels.

    Args:
        graph: a brick graph in mm, e.g. ``outcome.final_graph``; empty is fine.
        path: where to write the PNG (overwritten).
        title: a title over the whole picture.
        sizes: brick id -> (length, width, height) in mm, for the footprints; a brick not
            in it is drawn as a KAPLA brick, :data:`KAPLA_MM` (the Graph carries no sizes).
        max_panels: at most this many top views, >= 0.

    Raises:
        ValueError: ``max_panels`` is negative.
        OSError: the file cannot be written.

    Source: stackdsl's own; the quantities drawn are the report's (3.3.3, 3.3.5, 3.3.6).
    """
    if max_panels < 0:
        raise ValueError(f"max_panels must be >= 0, got {max_panels}")
    bricks = [n for n in graph.nodes if n.state != "ground"]
    hulls = _hulls(graph)
    margin = {n.id: _margin(hulls.get(n.id), n.com_above_mm) for n in bricks}
    order = sorted(bricks, key=lambda n: (math.isnan(margin[n.id]), np.nan_to_num(margin[n.id]), n.level or 0, n.id))
    shown = order[:max_panels]
    cols = min(4, max(1, len(shown)))
    rows = max(1, math.ceil(len(shown) / cols))
    levels = {n.level for n in bricks if n.level is not None}
    width = _GRAPH_W + _PANEL_W * cols
    height = max(6.0, min(16.0, 2.5 + 0.4 * (len(levels) + 1)), 1.3 + _PANEL_H * rows)
    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    if title:
        fig.suptitle(title, fontsize=13, y=1 - 0.1 / height, va="top")
    top = height - (0.75 if title else 0.45)  # inches from the bottom
    graph_ax = fig.add_axes((0.8 / width, 1.45 / height, (_GRAPH_W - 1.3) / width, (top - 1.45) / height))
    handles = _draw_graph(graph_ax, graph, bricks, margin)
    if handles:
        where: dict[str, Any] = {"loc": "center", "bbox_to_anchor": (_GRAPH_W / 2 / width, 0.3 / height)}
        fig.legend(handles=handles, ncol=len(handles), fontsize=8, frameon=False, **where)
    cell = (top - 0.55) / rows
    for i, node in enumerate(shown):
        left, bottom = _GRAPH_W + _PANEL_W * (i % cols) + 0.45, top - cell * (i // cols + 1) + 0.3
        ax = fig.add_axes((left / width, bottom / height, (_PANEL_W - 0.65) / width, (cell - 0.85) / height))
        edges = [e for e in graph.edges if e.upper == node.id]
        _draw_panel(ax, node, edges, hulls.get(node.id), margin[node.id], (sizes or {}).get(node.id, KAPLA_MM))
    note = _left_out(order[len(shown) :], margin, len(bricks))
    fig.text((_GRAPH_W + _PANEL_W * cols / 2) / width, 0.25 / height, note, ha="center", va="center", fontsize=9)
    with written(path) as part:  # a failed write (a full disk) names the path and leaves no file
        fig.savefig(part, format="png")


def footprint_mm(node: Node, size: Sequence[float] = KAPLA_MM) -> np.ndarray:
    """The brick's top-view outline: the convex hull of its box's eight corners projected
    down, shape (k, 2), (x, y) in mm, counter-clockwise (k = 4 for a level brick, up to 6
    for a tilted one).

    ``size`` is (length, width, height) in mm along the brick's own x, y, z; the pose is the
    node's ``position_mm`` and ``quaternion_xyzw``. Source: stackdsl's own.

    >>> n = Node(id="b", level=1, state="frozen", position_mm=(0, 0, 4), quaternion_xyzw=(0, 0, 0.7071, 0.7071),
    ...          com_above_mm=(0, 0, 4), mass_above_g=10.6)
    >>> sorted(footprint_mm(n).round(1).tolist())
    [[-12.0, -60.0], [-12.0, 60.0], [12.0, -60.0], [12.0, 60.0]]
    """
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    rotation = Rotation.from_quat(node.quaternion_xyzw).as_matrix()
    corners = np.asarray(node.position_mm, dtype=float) + (signs * np.asarray(size, dtype=float) / 2) @ rotation.T
    hull = MultiPoint(corners[:, :2]).convex_hull
    if not isinstance(hull, Polygon):  # a brick of no width or length
        return np.asarray(shapely.get_coordinates(hull))
    return np.asarray(shapely.get_coordinates(orient(hull, 1.0).exterior))[:-1]


def _hulls(graph: Graph) -> dict[str, BaseGeometry]:
    points: dict[str, list[tuple[float, float]]] = {}
    for e in graph.edges:
        points.setdefault(e.upper, []).extend(e.polygon_mm)
    return {b: MultiPoint(p).convex_hull for b, p in points.items() if p}


def _margin(hull: BaseGeometry | None, com: Sequence[float]) -> float:
    if hull is None or hull.is_empty:
        return math.nan
    p = Point(float(com[0]), float(com[1]))
    if isinstance(hull, Polygon) and hull.area > 0 and shapely.contains(hull, p):
        return float(hull.exterior.distance(p))
    return -float(hull.distance(p))


def _left_out(rest: list[Node], margin: dict[str, float], total: int) -> str:
    if total == 0:
        return "no bricks"
    if not rest:
        return f"all {total} bricks shown, most critical first" if total > 1 else "the only brick"
    measured = [margin[n.id] for n in rest if not math.isnan(margin[n.id])]
    text = f"{len(rest)} more brick{'s' if len(rest) > 1 else ''} not shown"
    if measured:
        text += f", least margin among them {min(measured):+.1f} mm"
    if len(measured) < len(rest):
        text += f"; {len(rest) - len(measured)} of them with no support"
    return text


# the rests-on graph -------------------------------------------------------------------------


def _draw_graph(ax: Axes, graph: Graph, bricks: list[Node], margin: dict[str, float]) -> list[Line2D]:
    """Draw the rests-on graph on ``ax``; return the legend's entries."""
    fixtures = [n for n in graph.nodes if n.state == "ground" and n.id != "ground"]
    has_ground = any(n.id == "ground" for n in graph.nodes) or any(e.support == "ground" for e in graph.edges)
    if not bricks and not fixtures and not has_ground:
        ax.axis("off")
        ax.text(0.5, 0.5, "empty graph: nothing placed", ha="center", va="center", transform=ax.transAxes)
        return []
    spread, row, label = _layout(bricks, fixtures)
    lo, hi = min([*spread.values(), 0.0]) - 40.0, max([*spread.values(), 0.0]) + 40.0
    top = max([*row.values(), 1.0])
    unit = max(1.0, top / 15)  # the ground band's height and the margins grow with the rows
    ground = -0.5 * unit
    ax.set_xlim(lo, hi)
    ax.set_ylim(ground - 0.6 * unit, top + 0.7 * unit)
    ax.set_xlabel(label)
    ax.set_ylabel("level")
    if has_ground:
        band = Rectangle((lo, ground - 0.4 * unit), hi - lo, 0.4 * unit, facecolor="#d9c9a8", edgecolor="#8c7a55", hatch="//")
        ax.add_patch(band)
        ax.text(lo + 0.02 * (hi - lo), ground - 0.2 * unit, "ground", va="center", fontsize=8, zorder=2)
    few = _draw_edges(ax, graph.edges, spread, row, ground)
    ax.set_title(_graph_heading(len(graph.edges), few, bricks, margin), fontsize=10)
    _draw_nodes(ax, bricks, fixtures, spread, row, margin)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_yticks([t for t in ax.get_yticks() if 0.5 <= t <= top + 0.01] or [1])
    ax.grid(axis="y", color="#eeeeee", zorder=0)
    return _legend(bool(fixtures))


def _layout(bricks: list[Node], fixtures: list[Node]) -> tuple[dict[str, float], dict[str, float], str]:
    """Where each node is drawn: along the bricks' main axis (mm, those at one spot pushed apart)
    and on its row (fixtures on the ground's), by id; and the horizontal axis's label."""
    axis, label = _main_axis(bricks)
    nodes = [*bricks, *fixtures]
    row = {**_rows(bricks), **{n.id: 0.0 for n in fixtures}}
    across = {n.id: float(np.dot(n.position_mm[:2], axis)) for n in nodes}
    spread = _spread(nodes, row, across, {n.id: float(np.dot(n.position_mm[:2], (-axis[1], axis[0]))) for n in nodes})
    pushed = any(abs(spread[k] - across[k]) > 5.0 for k in spread)
    return spread, row, label + (" (bricks at one spot pushed apart)" if pushed else "")


def _graph_heading(edges: int, few: bool, bricks: list[Node], margin: dict[str, float]) -> str:
    """The graph's title: how its ``edges`` are drawn (arrows labelled with their load shares when
    ``few``, else plain lines), and what a red ring on a frozen brick means when one has it
    (``margin`` < 0)."""
    heading = "rests on: arrow to each support, width and label = load share"
    if not few:
        heading = f"rests on: a line down to each support, width = load share\n({edges} edges: shares not labelled)"
    if any(n.state == "frozen" and margin[n.id] < 0 for n in bricks):
        heading += "\nred-ringed frozen bricks lean (report 3.4) on something that is no edge"
    return heading


def _draw_nodes(
    ax: Axes, bricks: list[Node], fixtures: list[Node], spread: dict[str, float], row: dict[str, float], margin: dict[str, float]
) -> None:
    """The bricks (dots) and fixed bodies (squares) at (``spread``, ``row``), coloured by state: a
    brick resting on nothing hollow, one whose centre of mass above lies outside (``margin`` < 0)
    ringed; each named when there are few."""
    nodes = [*bricks, *fixtures]
    for group, marker in ((bricks, "o"), (fixtures, "s")):
        outside = [margin.get(n.id, 0.0) < 0 for n in group]
        loose = [n.state != "ground" and math.isnan(margin.get(n.id, 0.0)) for n in group]
        fill = [_COLOURS.get(n.state, "#999999") for n in group]
        style: dict[str, Any] = {
            "facecolors": ["white" if f else c for f, c in zip(loose, fill)],
            "edgecolors": [_OUTSIDE if o else c if f else "black" for o, f, c in zip(outside, loose, fill)],
            "linewidths": [2.0 if o or f else 0.6 for o, f in zip(outside, loose)],
        }
        xs, ys = [spread[n.id] for n in group], [row[n.id] for n in group]
        ax.scatter(xs, ys, s=60 if len(nodes) <= 60 else 25, marker=marker, zorder=4, **style)
    if len(bricks) <= MAX_NODE_LABELS:
        for n in nodes:
            ax.annotate(n.id, (spread[n.id], row[n.id]), xytext=(5, 4), textcoords="offset points", fontsize=7, zorder=5)


def _legend(fixtures: bool) -> list[Line2D]:
    """The legend's entries: the states, hollow and ringed bricks, and fixed bodies when there are ``fixtures``."""
    dot: dict[str, Any] = {"marker": "o", "linestyle": ""}
    handles = [
        Line2D([], [], color=_COLOURS["frozen"], label="frozen", **dot),
        Line2D([], [], color=_COLOURS["active"], label="active", **dot),
        Line2D([], [], markerfacecolor="white", markeredgecolor="#555555", label="rests on nothing", **dot),
        Line2D([], [], markerfacecolor="#ccc", markeredgecolor=_OUTSIDE, markeredgewidth=2, label="COM above outside", **dot),
    ]
    if fixtures:
        handles.append(Line2D([], [], marker="s", linestyle="", color=_COLOURS["ground"], label="fixed body"))
    return handles


def _draw_edges(ax: Axes, edges: Sequence[Edge], spread: dict[str, float], row: dict[str, float], ground: float) -> bool:
    """Arrows labelled with their load shares when there are few edges, plain lines (one
    collection, fast) when many; return True when the shares were labelled."""
    few = len(edges) <= MAX_SHARE_LABELS
    segments, widths, colours, styles = [], [], [], []
    for e in edges:
        if e.upper not in spread or (e.support not in spread and e.support != "ground"):
            continue
        start = (spread[e.upper], row[e.upper])
        end = (spread[e.upper], ground) if e.support == "ground" else (spread[e.support], row[e.support])
        share = max(0.0, min(1.0, e.load_share))
        width, colour, style = 0.5 + (4.0 if few else 2.5) * share, "#555555" if share else "#aaaaaa", "-" if share else "--"
        if few:
            arrow = FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=7, shrinkA=4, shrinkB=4, zorder=3)
            arrow.set(linewidth=width, color=colour, linestyle=style)
            ax.add_patch(arrow)
            x, y = start[0] + 0.45 * (end[0] - start[0]), start[1] + 0.45 * (end[1] - start[1])
            ax.text(x, y, f"{share:.2f}", fontsize=7, ha="center", va="center", zorder=6, bbox=_LABEL_BOX)
        else:
            segments.append([start, end])
            widths.append(width)
            colours.append(colour)
            styles.append(style)
    if segments:
        ax.add_collection(LineCollection(segments, linewidths=widths, colors=colours, linestyles=styles, zorder=3))
    return few


def _main_axis(bricks: list[Node]) -> tuple[np.ndarray, str]:
    """The unit (x, y) direction along which the bricks spread most (snapped to x or y
    within 20 deg) and its axis label."""
    xy = np.array([n.position_mm[:2] for n in bricks], dtype=float).reshape(-1, 2)
    axis = np.array([1.0, 0.0])
    if len(xy) >= 2 and np.ptp(xy, axis=0).max() > 1e-6:
        _, _, vt = np.linalg.svd(xy - xy.mean(axis=0), full_matrices=False)
        axis = vt[0] if vt[0][np.argmax(np.abs(vt[0]))] > 0 else -vt[0]
    angle = math.degrees(math.atan2(axis[1], axis[0]))
    for snap, name in ((0.0, "x (mm)"), (90.0, "y (mm)")):  # the largest component is positive: -45 < angle < 135
        if abs(angle - snap) <= 20.0:
            return np.array([math.cos(math.radians(snap)), math.sin(math.radians(snap))]), name
    return axis, f"position along {angle:.0f} deg from x (mm)"


def _rows(bricks: list[Node]) -> dict[str, float]:
    """The row of each brick, in levels: its level, or for a brick without one (a
    projectile) its height interpolated between the levels' mean heights."""
    by_level: dict[int, list[float]] = {}
    for n in bricks:
        if n.level is not None:
            by_level.setdefault(n.level, []).append(n.position_mm[2])
    levels = sorted(by_level)
    heights = [float(np.mean(by_level[lv])) for lv in levels]
    out = {}
    for n in bricks:
        if n.level is not None:
            out[n.id] = float(n.level)
        elif len(levels) >= 2 and bool(np.all(np.diff(heights) > 0)):
            out[n.id] = float(np.interp(n.position_mm[2], heights, levels))
        else:
            out[n.id] = float(levels[-1] + 1 if levels else 1)
    return out


def _spread(nodes: list[Node], row: dict[str, float], across: dict[str, float], side: dict[str, float]) -> dict[str, float]:
    """Push the nodes of each row apart to a readable gap, keeping their order and mean."""
    if not nodes:
        return {}
    gap = 0.12 * (max(across.values()) - min(across.values()) + 120.0)
    rows: dict[float, list[str]] = {}
    for n in nodes:
        rows.setdefault(round(row[n.id], 3), []).append(n.id)
    out = {}
    for ids in rows.values():
        ids.sort(key=lambda k: (across[k], side[k]))
        placed = [across[ids[0]]]
        for k in ids[1:]:
            placed.append(max(across[k], placed[-1] + gap))
        shift = float(np.mean([across[k] for k in ids]) - np.mean(placed))
        out.update({k: p + shift for k, p in zip(ids, placed)})
    return out


# the top views ----------------------------------------------------------------------------


def _draw_panel(ax: Axes, node: Node, edges: list[Edge], hull: BaseGeometry | None, margin: float, size: Sequence[float]) -> None:
    com = np.array(node.com_above_mm[:2], dtype=float)
    if hull is not None and not hull.is_empty:
        ring = np.asarray(shapely.get_coordinates(hull.buffer(0.6) if hull.area == 0 else hull))
        ax.add_patch(PolygonPatch(ring, closed=True, facecolor="#cfe0f3", edgecolor="none", zorder=1))
    for e in edges:
        poly = np.asarray(e.polygon_mm, dtype=float).reshape(-1, 2)
        if not len(poly):
            continue
        ax.add_patch(PolygonPatch(poly, closed=True, fill=False, edgecolor=_CONTACT, linewidth=1.0, zorder=2))
        x, y = poly.mean(axis=0)
        if np.ptp(poly, axis=0).max() < 4.0:  # a padded point contact: too small to see
            ax.plot([x], [y], marker="+", markersize=8, color=_CONTACT, zorder=2)
        if len(edges) <= 4:
            below = bool(np.hypot(x - com[0], y - com[1]) < 15.0)  # keep the label off the centre of mass
            at, shift, va = ((x, poly[:, 1].min()), (0, -2), "top") if below else ((x, y), (0, 0), "center")
            text = f"{e.support} {e.load_share:.2f}"
            ax.annotate(
                text, at, xytext=shift, textcoords="offset points", va=va, ha="center", fontsize=6, color=_CONTACT, zorder=5
            )
    ax.add_patch(PolygonPatch(footprint_mm(node, size), fill=False, edgecolor="black", linestyle="--", linewidth=0.8))
    colour = "black" if math.isnan(margin) else _INSIDE if margin >= 0 else _OUTSIDE
    if hull is not None and not math.isnan(margin):
        a, b = nearest_points(hull.exterior if isinstance(hull, Polygon) else hull, Point(*com))
        ax.plot([a.x, b.x], [a.y, b.y], color=colour, linewidth=1.0, zorder=3)
    dot = "#bbbbbb" if math.isnan(margin) else colour
    ax.plot([com[0]], [com[1]], marker="o", markersize=7, color=dot, markeredgecolor="black", zorder=4)
    ax.margins(0.08)
    ax.set_aspect("equal", adjustable="datalim")
    ax.tick_params(labelsize=6)
    ax.xaxis.set_major_locator(MaxNLocator(4))
    ax.yaxis.set_major_locator(MaxNLocator(4))
    status = "rests on nothing" if math.isnan(margin) else f"margin {margin:+.1f} mm"
    if node.state == "frozen" and margin < 0:
        status += "\nfrozen all the same: leaning (report 3.4)"
    level = f"level {node.level}" if node.level is not None else "no level"
    ax.set_title(f"{node.id} · {level} · {node.state} · {node.mass_above_g:g} g above\n{status}", fontsize=7.5, color=colour)
