"""What the lean peers share: how a peer's own loop watches its bricks for a collapse, and what
it reports.

A lean peer (:mod:`stackdsl.bench.lean_mujoco`, :mod:`stackdsl.bench.lean_pybullet`) runs a
compiled program's placements in the engine's own loop, as a user of that engine would write
it, without stackdsl's step loop. It looks at its bricks :data:`WATCH_RATE` times a second: a
placed brick with a corner more than the program's collapse threshold from where it was placed,
for :data:`WINDOW` seconds, has collapsed, at the highest level placed when it was first that
far. A brick that rocks past the threshold on landing and comes back within the window has not.
The run stops when the collapse is decided, or at the program's end.

Source: stackdsl's own.

>>> import numpy as np
>>> watch = CollapseWatch(np.array([[0.06, 0.012, 0.004]]), threshold=0.004)
>>> watch.place(0, level=1, position=np.zeros(3), rotation=np.eye(3))
>>> watch.look(0.1, np.array([[0.01, 0.0, 0.0]]), np.eye(3)[None])  # 10 mm away: watched
False
>>> watch.look(0.35, np.array([[0.01, 0.0, 0.0]]), np.eye(3)[None])  # still, 0.25 s on: decided
True
>>> watch.level
1
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

#: Hz: how often the collapse is checked (a video frame's rate).
WATCH_RATE = 60.0
#: Seconds a brick must stay beyond the collapse threshold to have collapsed.
WINDOW = 0.2
_CORNERS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)


@dataclass(frozen=True)
class LeanOutcome:
    """What a lean peer measured: the collapse level (None: stood), wall seconds, seconds
    of it inside the engine's step, simulated seconds and physics steps, wall seconds after the
    collapse was decided (``after_collapse``: a run told to settle after it); for a peer that runs
    to the scene's end (the actions family), each placed brick's displacement at the end
    (``moved``: id -> m, its farthest corner from where it was placed, in the ground's frame),
    the bricks tilted past their tipping angle (``toppled``) and those a hand pulled out
    (``removed``, left out of both)."""

    level: int | None
    wall: float
    engine: float
    simulated: float
    steps: int
    after_collapse: float = 0.0
    moved: dict[str, float] = field(default_factory=dict)
    toppled: tuple[str, ...] = ()
    removed: tuple[str, ...] = ()


class CollapseWatch:
    """The collapse watch of a lean peer's bricks, in placing order.

    Args:
        half_extents: shape (n, 3), metres: each brick's half size.
        threshold: metres a corner may move from where its brick was placed.
    """

    def __init__(self, half_extents: np.ndarray, threshold: float) -> None:
        self._local = _CORNERS[None, :, :] * np.asarray(half_extents, dtype=float)[:, None, :]  # (n, 8, 3)
        self._targets = np.zeros_like(self._local)
        self._threshold = threshold
        self.placed = 0
        self._top = 0
        self._since: float | None = None
        self._level = 0
        self._watched = np.ones(len(self._local), dtype=bool)

    def forget(self, index: int) -> None:
        """Watch brick ``index`` no more (a hand pulls it out)."""
        self._watched[index] = False

    def place(self, index: int, level: int, position: np.ndarray, rotation: np.ndarray) -> None:
        """Brick ``index`` (the next one) of ``level`` is in place at ``position`` (3,),
        turned by ``rotation`` (3, 3), where the engine has it after placing."""
        self._targets[index] = position + self._local[index] @ rotation.T
        self._top = max(self._top, level)
        self.placed = index + 1

    def look(self, time: float, positions: np.ndarray, rotations: np.ndarray) -> bool:
        """The placed bricks at ``time`` seconds: ``positions`` (placed, 3) and ``rotations``
        (placed, 3, 3). True once the collapse is decided."""
        n = self.placed
        if n == 0:
            return False
        corners = positions[:n, None, :] + np.einsum("nkj,nij->nki", self._local[:n], rotations[:n])
        moved = float(np.linalg.norm(corners - self._targets[:n], axis=2)[self._watched[:n]].max(initial=0.0))
        if moved <= self._threshold:
            self._since = None
            return False
        if self._since is None:
            self._since, self._level = time, self._top
            return False
        return time - self._since >= WINDOW - 1e-9

    def displacements(self, positions: np.ndarray, rotations: np.ndarray) -> np.ndarray:
        """Each placed brick's farthest corner from where it was placed (m), shape (placed,),
        from ``positions`` (placed, 3) and ``rotations`` (placed, 3, 3)."""
        n = self.placed
        corners = positions[:n, None, :] + np.einsum("nkj,nij->nki", self._local[:n], rotations[:n])
        return np.asarray(np.linalg.norm(corners - self._targets[:n], axis=2).max(axis=1, initial=0.0))

    @property
    def level(self) -> int | None:
        """The level the collapse began at (None: no brick is displaced now)."""
        return self._level if self._since is not None else None


def tipped(half_extents: np.ndarray, placed: np.ndarray, now: np.ndarray) -> np.ndarray:
    """Which bricks are tilted past their tipping angle, shape (n,) of bool: the axis that was
    vertical when placed has turned further than atan(least horizontal half-extent / vertical
    half-extent), both as placed (the rule of :meth:`stackdsl.runtime.bricks.Structure.toppled`).

    Args:
        half_extents: (n, 3), m. placed, now: (n, 3, 3), each brick's rotation as placed and now.

    >>> flat = np.eye(3)[None]
    >>> on_side = np.array([[[1.0, 0, 0], [0, 0, -1], [0, 1, 0]]])
    >>> tipped(np.array([[0.06, 0.012, 0.004]]), flat, flat).tolist(), tipped(np.array([[0.06, 0.012, 0.004]]), flat, on_side).tolist()
    ([False], [True])
    """
    half = np.einsum("nij,nj->ni", np.abs(placed), np.asarray(half_extents, dtype=float))  # as placed, in the world
    tip = np.arctan2(np.minimum(half[:, 0], half[:, 1]), half[:, 2])
    up = placed[:, 2, :]  # each brick's own axis that was vertical: the third row of its placed rotation
    tilt = np.arccos(np.clip(np.einsum("nij,nj->ni", now, up)[:, 2], -1.0, 1.0))
    return np.asarray(tilt > tip)
