"""When a brick is at rest: the report's test, and a windowed one for fallen bricks.

A placed brick is at rest when its linear and angular speeds have stayed under the rest
thresholds for the rest duration (report 3.3.2, with stackdsl's duration). A brick that has
been woken (debris of a collapse) is at rest when, over each window of one rest duration, it
has moved no farther and turned no more than a brick under the thresholds could (rest speed x
window, rest angular speed x window), and its speeds have stayed under :data:`JITTER` times
the thresholds.

Why fallen bricks need the window: pybullet keeps the bricks of a fallen pile in a two-step
jitter. The bottom brick of a fallen single-file stack alternates 20 and 4 mm/s from one step
to the next while its pose stays within 0.1 mm, so the whole pile is under the thresholds at
once only by chance, 1.2 to 1.8 s after it has landed, and until then every step costs the
full simulation of the pile. Placed bricks keep the report's test: a brick that lands on the
stack has no such jitter, and the stack's goldens rest on it. One that has not come to rest
:data:`stability._extension.LINGER` rest durations after it was placed is judged by the
windowed test too: on a near tie (its centre of mass 0.25 mm inside its support) pybullet
rocked a placed brick by 0.02 deg with a spike of 0.13 rad/s every 20 steps, which restarted
the report's test every time, and it stayed active to the end of the run. Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._config import StabilityConfig
from ._geometry import Pose

JITTER = 10.0
"""A fallen brick's speeds may reach this many times the rest thresholds at an instant."""


@dataclass
class RestClock:
    """The rest test of one brick: since when it has been at rest (s, or None) and, for a
    fallen brick, where its current window started.

    Attributes:
        since: seconds; the start of the present spell at rest, or None while it moves.
        fallen: the brick was woken at least once: the windowed test applies.
        windowed: the windowed test applies to a placed brick too (one that has stayed
            active too long: :meth:`stability.StabilityExtension.update`).
        window: the pose and time (s) at which the present window began (fallen bricks).

    Source: report 3.3.2 (placed bricks), stackdsl's own (fallen bricks).

    >>> import numpy as np
    >>> from stability._config import StabilityConfig
    >>> clock, still = RestClock(fallen=True), Pose(np.zeros(3))
    >>> fast = 0.02  # 20 mm/s: above the 5 mm/s threshold
    >>> [clock.tick(fast, 0.0, lambda: still, i / 240, StabilityConfig()) for i in range(14)][-1]
    True
    >>> placed = RestClock()  # the report's test: one step above the threshold starts again
    >>> [placed.tick(fast, 0.0, lambda: still, i / 240, StabilityConfig()) for i in range(14)][-1]
    False
    """

    since: float | None = None
    fallen: bool = False
    windowed: bool = False
    window: tuple[Pose, float] | None = None

    def tick(self, speed: float, angular_speed: float, pose: Callable[[], Pose], time: float, config: StabilityConfig) -> bool:
        """Advance the clock to ``time`` (s) with the brick's speeds now (m/s and rad/s);
        ``pose`` reads its pose, asked only when a window closes. Returns whether the brick
        has been at rest for the rest duration."""
        lenient = self.fallen or self.windowed
        cap = JITTER if lenient else 1.0
        if speed > cap * config.rest_speed or angular_speed > cap * config.rest_angular_speed:
            self.since = self.window = None
            return False
        if self.since is None:
            self.since = time
            self.window = (pose(), time) if lenient else None
        if self.window is not None and time - self.window[1] >= config.rest_duration - 1e-9:
            start, began = self.window
            now, span = pose(), time - began
            if not still(start, now, config.rest_speed * span, config.rest_angular_speed * span):
                self.since, self.window = time, (now, time)
                return False
            self.window = (now, time)
        return self.rested(time, config)

    def rested(self, time: float, config: StabilityConfig) -> bool:
        """At rest for the rest duration at ``time`` s."""
        return self.since is not None and time - self.since >= config.rest_duration - 1e-9

    def stop(self) -> None:
        """Forget the present spell at rest (the brick was woken)."""
        self.since = self.window = None


def still(start: Pose, end: Pose, distance: float, angle: float) -> bool:
    """``end`` within ``distance`` metres and ``angle`` radians of ``start``.

    >>> import numpy as np
    >>> still(Pose(np.zeros(3)), Pose.from_euler([0.0002, 0, 0], yaw=0.1), 0.00025, 0.0025)
    True
    """
    moved = end.position - start.position
    if float(moved @ moved) > distance**2:
        return False
    # the angle of the turn from start to end: trace(R_s^T R_e) = 1 + 2 cos(angle), read off
    # the poses' cached rotation matrices (scipy's Rotation costs ten times as much, and a
    # settling heap closes hundreds of windows a second)
    return (float(np.sum(start.rotation * end.rotation)) - 1.0) / 2.0 >= math.cos(angle)
