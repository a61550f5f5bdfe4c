"""Why the dominoes' reach (searches/dominoes_reach.yaml) is not a closed form: the falling
domino's foot cannot hold, whatever the friction coefficient, and the row stops toppling where a
low blow stops toppling the next domino, not where the falling one stops reaching it.

1. A domino (height h, thickness t) tipping about a front edge that holds is a rod of length
   L = sqrt(h^2 + t^2) about its end (moment of inertia m L^2 / 3, centre of mass L / 2 from the
   edge). With theta the angle of the line from the edge to the centre of mass from vertical (0
   where it starts to fall), energy gives omega^2 = (3 g / L)(1 - cos theta) and the moment
   alpha = (3 g / 2 L) sin theta, so the edge must push with a normal force
   N = m g (1 - 3 cos theta)^2 / 4 and a friction force F = (3 / 4) m g sin theta (3 cos theta - 2):
   F / N changes sign at cos theta = 2 / 3 (48.2 deg) and grows without bound as N falls to 0 at
   cos theta = 1 / 3 (70.5 deg). No friction coefficient holds the edge there (the falling rod;
   derived here: the centre of mass's acceleration, r alpha along the tangent and r omega^2 towards
   the edge, r = L / 2, times m, is F and N - m g; :func:`held_edge`, which
   :func:`slid_reach` checks while the foot sticks). Held, the top would reach the next domino's back face while the spacing is
   under h + t (it lies flat h ahead of the edge; the back top corner's sqrt(h^2 + t^2) is reached
   only past flat, under the floor).
2. The same block integrated with Coulomb friction at its foot (sticking, then sliding once
   |F| > mu N; :func:`slid_reach`): how far its foot slides before its top lands, and the spacing
   its top then reaches, t + h + the slide.
3. Both engines (extension mode), one domino of the shipped file alone: how far its top reached
   when it landed and where its foot ended; and the shipped search's threshold with that friction
   coefficient on both domino and ground.

Run: python docs/results/domino_reach.py [MU ...]  (default 0.5 1 5; about a minute). Output:
docs/results/search.md, "The dominoes".
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from stackdsl import compile_scenario, load_scenario
from stackdsl.runtime.loop import StepLoop, Subscriber
from stackdsl.runtime.run import run_program

H, T, G = 0.120, 0.008, 9.81
SEARCH = Path(__file__).resolve().parents[2] / "searches" / "dominoes_reach.yaml"


def held_edge(theta: float) -> tuple[float, float]:
    """N / (m g) and F / (m g) at a front edge that holds, at ``theta`` (rad; the module's 1)."""
    c, s = math.cos(theta), math.sin(theta)
    return (1 - 3 * c) ** 2 / 4, 0.75 * s * (3 * c - 2)


def slid_reach(mu: float, dt: float = 1e-5) -> tuple[float, float, float | None]:
    """The block of the module's 2 from balanced on its edge (1 mrad past, at rest): the spacing
    its top reaches when it lands (m), how far its foot slid (m), and the tilt (deg) where it began
    to slide (None: it never did). Planar rigid body; unknowns the accelerations, F and N."""
    m, inertia = 1.0, (H * H + T * T) / 12
    phi = math.atan(T / H) + 1e-3  # the domino's tilt from vertical
    rx, rz = T / 2 * math.cos(phi) - H / 2 * math.sin(phi), -T / 2 * math.sin(phi) - H / 2 * math.cos(phi)
    x, z, vx, vz, w = -rx, -rz, 0.0, 0.0, 0.0  # the centre of mass, the foot at the origin
    sliding, began = 0.0, None
    while True:
        rx, rz = T / 2 * math.cos(phi) - H / 2 * math.sin(phi), -T / 2 * math.sin(phi) - H / 2 * math.cos(phi)
        a = np.array([[m, 0, 0, -1, 0], [0, m, 0, 0, -1], [0, 0, inertia, -rz, rx], [0, 1, -rx, 0, 0], [0.0] * 5])
        b = np.array([0, -m * G, 0, rz * w * w, 0.0])
        if not sliding:
            a[4], b[4] = [1, 0, rz, 0, 0], rx * w * w  # the foot's horizontal acceleration is 0
            ax, az, al, f, n = np.linalg.solve(a, b)
            if abs(f) > mu * n:
                sliding, began = -math.copysign(1.0, f), math.degrees(phi)
        if sliding:
            foot_speed = vx + rz * w
            sliding = math.copysign(1.0, foot_speed) if abs(foot_speed) > 1e-7 else sliding
            a[4] = [0, 0, 0, 1, mu * sliding]  # F = -mu N in the direction it slides
            ax, az, al, f, n = np.linalg.solve(a, b)
        x, z, phi = x + dt * vx, z + dt * vz, phi + dt * w
        vx, vz, w = vx + dt * ax, vz + dt * az, w + dt * al
        top = x + T / 2 * math.cos(phi) + H / 2 * math.sin(phi)
        if phi >= math.pi / 2 or z - T / 2 * math.sin(phi) + H / 2 * math.cos(phi) <= 0:
            foot = x + T / 2 * math.cos(phi) - H / 2 * math.sin(phi)
            return T + top, foot, began


class Reach(Subscriber):
    """The first domino's top front edge, how far ahead of its placed front face when it first comes
    within 0.5 mm of the ground (m), and where its front bottom edge ended (m, the same way)."""

    def __init__(self) -> None:
        self.reach = -1.0
        self.landed = False
        self.foot = 0.0

    def after_step(self, loop: StepLoop) -> None:
        record = loop.structure.placed[0] if loop.structure.placed else None
        if record is None:
            return
        position, quaternion = loop.world.poses_of([record.body])
        turned = Rotation.from_quat(quaternion[0]) * Rotation.from_quat(record.placed_xyzw).inv()
        placed = np.asarray(record.corners)
        corners = turned.apply(placed - np.asarray(record.placed_xyz)) + position[0]
        front = placed[:, 0].max()
        top = placed[:, 2] > placed[:, 2].max() - 1e-6
        foot = (placed[:, 2] < placed[:, 2].min() + 1e-6) & (placed[:, 0] > front - 1e-6)
        if not self.landed:
            self.reach = max(self.reach, float(corners[top, 0].max() - front))
            self.landed = bool(corners[top, 2].min() < 0.0005)
        self.foot = float(corners[foot, 0].mean() - front)


def with_friction(mu: float, count: int | None = None) -> str:
    """The shipped search file, both domino and ground of friction coefficient ``mu`` (and ``count``
    dominoes: 1 leaves out the search and the expectation)."""
    data = yaml.safe_load(SEARCH.read_text())
    data["materials"] = {"grip": {"friction": mu}}
    data["brick_types"]["domino"] = {"size": ["120 mm", "24 mm", "8 mm"], "material": "grip"}
    data["structure"]["dominoes"]["brick"] = "domino"
    data["ground"] = {"material": "grip"}
    if count is not None:
        data["structure"]["dominoes"]["count"] = count
        del data["search"], data["expect"]
    return yaml.safe_dump(data, sort_keys=False)


def engine_row(mu: float, engine: str, folder: Path) -> str:
    alone = folder / f"alone-{mu:g}.yaml"
    alone.write_text(with_friction(mu, 1))
    watch = Reach()
    run_program(compile_scenario(load_scenario(alone), backend=engine), subscribers=(watch,))
    row = folder / f"row-{mu:g}.yaml"
    row.write_text(with_friction(mu))
    out = folder / f"search-{mu:g}-{engine}"
    command = [sys.executable, "-m", "stackdsl", "search", str(row), "-j", "1", "--backend", engine, "--out", str(out)]
    subprocess.run(command, capture_output=True, check=False)
    found = json.loads((out / "search.json").read_text())
    low, high = found["interval"] or (math.nan, math.nan)
    return (
        f"| {mu:g} | {engine} | {(T + watch.reach) * 1000:.2f} | {watch.foot * 1000:.2f} | "
        f"{low:.2f} to {high:.2f} ({found['runs']} runs) |"
    )


def main(mus: list[float]) -> None:
    print("| theta (deg) | N / m g | F / m g | friction the edge needs |")
    print("|---:|---:|---:|---:|")
    for deg in (20, 35, 48.19, 55, 60, 65, 70, 70.5):
        n, f = held_edge(math.radians(deg))
        print(f"| {deg:g} | {n:.4f} | {f:+.4f} | {abs(f) / n if n > 0 else math.inf:.2f} |")
    print("\n| mu | slides from tilt (deg) | foot's slide (mm) | spacing its top reaches, t + h + slide (mm) |")
    print("|---:|---:|---:|---:|")
    for mu in mus:
        reach, foot, began = slid_reach(mu)
        print(f"| {mu:g} | {began:.1f} | {foot * 1000:.2f} | {reach * 1000:.2f} |")
    print(
        "\n| mu | engine | one domino: spacing its top reached when it landed (mm) | its foot ended (mm) | the row's threshold (mm) |"
    )
    print("|---:|---|---:|---:|---|")
    with tempfile.TemporaryDirectory() as folder:
        for mu in mus:
            for engine in ("pybullet", "mujoco"):
                print(engine_row(mu, engine, Path(folder)), flush=True)


if __name__ == "__main__":
    main([float(a) for a in sys.argv[1:]] or [0.5, 1.0, 5.0])
