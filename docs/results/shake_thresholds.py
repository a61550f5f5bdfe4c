"""Single blocks on a shake table against the closed forms of docs/actions.md: each block's final
slip and largest tilt at peak accelerations from 0.8 to 1.5 of its threshold, 2 Hz, two periods,
on both engines, the engine alone (tuned) and with the extension.

    python docs/results/shake_thresholds.py [pybullet,mujoco]

The blocks are not those of tests/test_shake.py: a squat one that slides (a > mu g) and a tall
one that tips (a > g b / h); a_peak = A (2 pi f)^2. Output: docs/results/shake-table.md.
"""

from __future__ import annotations

import math
import sys

import numpy as np
from scipy.spatial.transform import Rotation

import stackdsl
from stackdsl.runtime.recorder import record_program

G, FREQUENCY = 9.81, 2.0
BLOCKS = {  # name: (size in mm, friction coefficient, threshold in m/s^2)
    "squat 60 x 60 x 30 mm, mu 0.3 (slides at mu g)": ((60, 60, 30), 0.3, 0.3 * G),
    "tall 30 x 30 x 90 mm, mu 0.6 (tips at g b / h)": ((30, 30, 90), 0.6, G * 15 / 45),
}
RATIOS = (0.8, 0.9, 0.95, 1.0, 1.05, 1.1, 1.15, 1.2, 1.3, 1.5)
SCENE = """stackdsl: 1
materials: {{m: {{density: 600 kg/m^3, friction: {mu}}}}}
brick_types: {{blk: {{size: [{x} mm, {y} mm, {z} mm], material: m}}}}
ground: {{material: m}}
structure: {{bricks: [{{id: b, at: [0, 0, {half} mm], brick: blk}}]}}
timing: {{settle: 1 s}}
engine: {{backend: {backend}}}
actions:
  - shake: {{amplitude: {amplitude:.4f} mm, frequency: 2 Hz, duration: 1 s, at: 1 s}}
"""


def measure(backend: str, mode: str, size: tuple[int, int, int], mu: float, amplitude: float) -> tuple[float, float]:
    """The block's slip at the end (mm) and its largest tilt (deg) while it is recorded."""
    text = SCENE.format(mu=mu, x=size[0], y=size[1], z=size[2], half=size[2] / 2, backend=backend, amplitude=amplitude * 1000)
    _, trajectory = record_program(stackdsl.compile_scenario(stackdsl.parse_scenario(text, "block.yaml"), mode))
    tilt = 0.0
    for frame in trajectory.frames():
        if not np.isnan(frame.orientations[0]).any():
            up = Rotation.from_quat(frame.orientations[0]).apply([0.0, 0.0, 1.0])
            tilt = max(tilt, math.degrees(math.acos(min(1.0, float(up[2])))))
    end = trajectory.at(trajectory.end).positions[0]
    return 1000 * math.hypot(end[0], end[1]), tilt


def main(backends: list[str]) -> None:
    omega2 = (2 * math.pi * FREQUENCY) ** 2
    for name, (size, mu, threshold) in BLOCKS.items():
        print(f"\n{name}: {threshold:.3f} m/s^2, A = {threshold / omega2 * 1000:.2f} mm at 2 Hz\n")
        settings = [(b, m) for b in backends for m in ("tuned", "extension")]
        print("| a / threshold | " + " | ".join(f"{b} {m}" for b, m in settings) + " |")
        print("|---:|" + "---:|" * len(settings))
        for ratio in RATIOS:
            cells = [measure(b, m, size, mu, ratio * threshold / omega2) for b, m in settings]
            print(f"| {ratio:.2f} | " + " | ".join(f"{s:.1f} mm, {t:.1f} deg" for s, t in cells) + " |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1].split(",") if len(sys.argv) > 1 else ["pybullet", "mujoco"])
