"""A V of two leaning KAPLA legs on a shaken table: the statics limit, padded and bare, against the engines.

For each angle of the V (a one-level ``card_house``), the largest horizontal acceleration (m/s^2)
under which rigid-block equilibrium of the frozen V holds (found by bisection,
:func:`stability.solve_equilibrium` under the tilted gravity), on the contact areas the extension
freezes it with (the line where the legs meet padded ``contact_pad`` each side, as the report's
centre-of-mass test takes it) and on their bare contact points, which the shake's check uses
(``stability._shake._leaning``, at ``stability._shake.LEANING_MARGIN`` times the shake's
acceleration). Then, for each amplitude of a 3 Hz shake of 3 s, the verdict of each setting
named (``stands`` or ``falls``; an extension's ``stands`` is ``stands (rode)`` where the frozen
stack rode the table, no step of it in the engine). With LEVELS,FREQUENCY,DURATION, a card house
of that many levels, shaken so (Hz, s).

    python docs/results/shake_leaning.py [ANGLES] [AMPLITUDES_MM] [SETTINGS] [LEVELS,FREQUENCY,DURATION]
    # e.g. python docs/results/shake_leaning.py 22,24 0.1,0.2,0.3,0.4,0.5,0.7 ext-pb,ext-mj,tuned-pb,tuned-mj,raw-pb
    # a two-level card house at 20 deg, 10 s at 2 Hz:
    # python docs/results/shake_leaning.py 20 0.38,0.5,0.633,0.8,1.27 ext-pb,ext-mj,tuned-pb,tuned-mj 2,2,10

Output: docs/results/shake-table.md ("A V on its bare contacts").
Source: stackdsl's own.
"""

from __future__ import annotations

import math
import sys

SCENE = """stackdsl: 1
structure: {{card_house: {{levels: {levels}, angle: {angle}}}}}
timing: {{settle: 2 s}}
actions:
  - shake: {{amplitude: {amplitude} mm, frequency: {frequency} Hz, duration: {duration} s, direction: [1, 0], at: after level {top}}}
expect: {{stands: true}}
"""
SHAKE = {"levels": 1, "frequency": 3.0, "duration": 3.0, "top": 1}
"""The card house and its shake: levels, Hz, seconds, and its top level (a level of Vs, then one of flat bricks)."""
SETTINGS = {
    "ext-pb": ("extension", "pybullet"),
    "ext-mj": ("extension", "mujoco"),
    "tuned-pb": ("tuned", "pybullet"),
    "tuned-mj": ("tuned", "mujoco"),
    "raw-pb": ("raw", "pybullet"),
}


def limits(angle: int) -> tuple[float, float]:
    """The V's limits (m/s^2), padded and bare, once it has frozen at rest."""
    from stability import ContactPolygon, RigidBlock, solve_equilibrium
    from stability._equilibrium import bare_contacts, connected_part
    from stackdsl import compile_scenario, parse_scenario
    from stackdsl.runtime.loop import StepLoop, Subscriber
    from stackdsl.runtime.run import run_in, world_for
    from stackdsl.runtime.subscribers import Stability

    found: list[float] = []

    def limit(blocks: dict[int, RigidBlock], polygons: list[ContactPolygon[int]], g: float) -> float:
        low, high = 0.0, 2.0
        if solve_equilibrium(blocks, polygons, gravity=g, quick=False, sideways=(high, 0.0)).stands:
            return math.inf
        for _ in range(30):
            mid = (low + high) / 2
            holds = all(
                solve_equilibrium(blocks, polygons, gravity=g, quick=False, sideways=(s * mid, 0.0)).stands for s in (1, -1)
            )
            low, high = (mid, high) if holds else (low, mid)
        return low

    class Frozen(Subscriber):
        def after_step(self, loop: StepLoop) -> None:
            ext = next(s for s in loop.subscribers if isinstance(s, Stability)).extension
            stack = ext._stack
            if found or len(stack.frozen) < 2:
                return
            frozen = stack.in_order()
            blocks = {r.body: RigidBlock(r.box.mass, stack.pose(r).position) for r in frozen}
            part, polygons = connected_part(blocks, stack.frozen_contacts(blocks), set(blocks))
            found.extend(
                [limit(part, polygons, stack.config.gravity), limit(part, bare_contacts(polygons), stack.config.gravity)]
            )

    program = compile_scenario(parse_scenario(SCENE.format(angle=angle, amplitude=0.1, **SHAKE), "v.yaml"), "extension")
    with world_for(program) as world:
        run_in(world, program, subscribers=(Frozen(),))
    return (found[0], found[1]) if found else (math.nan, math.nan)


def verdict(angle: int, amplitude: float, setting: str) -> str:
    """``stands``, ``stands (rode)`` or ``falls``: the V shaken at ``amplitude`` mm in ``setting``."""
    from stackdsl import compile_scenario, parse_scenario, run_program

    mode, backend = SETTINGS[setting]
    text = SCENE.format(angle=angle, amplitude=amplitude, **SHAKE)
    outcome = run_program(compile_scenario(parse_scenario(text, "v.yaml"), mode, backend=backend))
    if outcome.collapse is not None:
        return "falls"
    rode = any(e.kind == "shake" and "rides the table" in e.detail for e in outcome.events)
    return "stands (rode)" if rode else "stands"


def main(argv: list[str]) -> None:
    angles = [int(a) for a in (argv[1] if len(argv) > 1 else "22,24").split(",")]
    amplitudes = [float(a) for a in (argv[2] if len(argv) > 2 else "0.1,0.2,0.3,0.4,0.5,0.7").split(",")]
    settings = (argv[3] if len(argv) > 3 else ",".join(SETTINGS)).split(",")
    if len(argv) > 4:
        levels, frequency, duration = (float(v) for v in argv[4].split(","))
        SHAKE.update(levels=int(levels), frequency=frequency, duration=duration, top=2 * int(levels) - 1)
    print(f"{SHAKE['levels']}-level card house, {SHAKE['frequency']:g} Hz for {SHAKE['duration']:g} s\n")
    if SHAKE["levels"] == 1:  # the limits of one V
        print("| V | limit, padded (m/s^2) | limit, bare (m/s^2) |")
        print("|---|---:|---:|")
        for angle in angles:
            padded, bare = limits(angle)
            print(f"| {angle} deg | {padded:.3f} | {bare:.3f} |", flush=True)
        print()
    print(f"| V | amplitude (mm) | a (m/s^2) | {' | '.join(settings)} |")
    print(f"|---|---:|---:|{'---|' * len(settings)}")
    for angle in angles:
        for amplitude in amplitudes:
            a = amplitude / 1000 * (2 * math.pi * float(SHAKE["frequency"])) ** 2
            row = " | ".join(verdict(angle, amplitude, s) for s in settings)
            print(f"| {angle} deg | {amplitude:g} | {a:.3f} | {row} |", flush=True)


if __name__ == "__main__":
    main(sys.argv)
