"""An independent Monte Carlo of the random single-file stack: the reference for its sweeps.

Bricks of length L (KAPLA: 0.120 m) are stacked one on the other in a single file along x.
Brick 1 lies on the ground at x_1 = 0; brick k+1's centre is drawn uniformly over the brick
below, x_{k+1} = x_k + U(-L/2, L/2): the centres make a random walk. Bricks have equal masses.

Stability condition: a stack of N bricks stands when, for every brick j with 1 <= j < N,
the centre of mass of the bricks above it (j+1..N, equal masses: the mean of their x) lies
strictly within brick j's extent, |mean(x_{j+1..N}) - x_j| < L/2; the ground holds brick 1.
This is the classic centre-of-mass (overhang) condition for a stack in which each block rests
on the one below, the condition under which the harmonic stack balances (Paterson & Zwick,
"Overhang", Amer. Math. Monthly 116 (2009) 19-44). A centre of mass exactly on the edge
counts there as balanced; here it does not (strict inequality, as stackdsl asks). The
difference has probability 0 for a continuous draw; so has a brick drawn exactly at the edge,
whose own centre of mass is then on the edge of the brick below (numpy's uniform draws from
[-L/2, L/2), so -L/2 itself has probability about 2^-53 per draw: that brick then collapses
at its own level).

The collapse level of one random stack is the smallest N at which the stack of N bricks does
not stand: bricks are placed one at a time and building stops at the first collapse. N = 2
never collapses (brick 2's centre is over brick 1); P(N = 3) = 1/8 exactly: with u, v the
two steps in units of L, the stack fails when |u + v/2| >= 1/2, of probability
2·∫_0^{1/4} 2b db = 1/8.

Measured with this module (10^7 samples, ``default_rng([7, i])`` for i < 10): mean collapse
level 7.1134, 95 % CI [7.1110, 7.1157]; P(N = 3, 4, ..., 8) = 0.1249, 0.1494, 0.1416,
0.1233, 0.1025, 0.0828; median 6.

Nothing here is taken from stackdsl's simulation: it is the independent reference.
Units: metres. Source: the condition as cited; the code is stackdsl's own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import stats

#: KAPLA brick length in metres.
LENGTH = 0.120
#: Samples simulated at once by :func:`collapse_levels` (memory: CHUNK x 64 floats, twice).
CHUNK = 1 << 16
_WIDTH = 64  # bricks drawn at a time per sample


def interface_margins(x: Sequence[float] | np.ndarray, length: float = LENGTH) -> np.ndarray:
    """Margin at each interface of one stack with centres ``x`` (metres, bottom first, shape (N,)):
    entry j-1 is L/2 - |mean(x_{j+1..N}) - x_j| for j = 1..N-1, shape (N-1,), metres; positive
    when the bricks above brick j have their centre of mass strictly inside it.

    >>> interface_margins([0.0, 0.05, 0.1]).round(3).tolist()  # fails at the lowest interface
    [-0.015, 0.01]
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 1:
        raise ValueError(f"x must be one-dimensional, got shape {x.shape}")
    above = np.cumsum(x[::-1])[::-1][1:] / np.arange(len(x) - 1, 0, -1)  # mean of x[j+1:]
    return np.asarray(length / 2 - np.abs(above - x[:-1]))


def stands(x: Sequence[float] | np.ndarray, length: float = LENGTH) -> bool:
    """Whether the stack of bricks with centres ``x`` (metres, bottom first) stands: every
    interface margin is positive (module docstring). A single brick or none stands.

    >>> stands([0.0, 0.059]), stands([0.0, 0.061])
    (True, False)
    """
    return bool(np.all(interface_margins(x, length) > 0))


def collapse_level(x: Sequence[float] | np.ndarray, length: float = LENGTH) -> int | None:
    """Collapse level of bricks placed one at a time at centres ``x`` (metres, bottom first):
    the smallest N such that the first N bricks do not stand, or None when every prefix stands.
    Scalar loop, O(N^2); the reference for :func:`levels_of_walks`.

    >>> collapse_level([0.0, 0.05, 0.1]), collapse_level([0.0, 0.03, 0.0]), collapse_level([0.0, 0.061, 0.0])
    (3, None, 2)
    """
    for n in range(2, len(x) + 1):
        if not stands(x[:n], length):
            return n
    return None


def levels_of_walks(x: np.ndarray, length: float = LENGTH) -> np.ndarray:
    """Collapse level of each row of ``x`` (shape (S, M): S stacks of M brick centres, metres,
    bottom first), vectorised over rows: shape (S,), int64, 0 for a row whose M bricks all
    stand. Same condition as :func:`collapse_level`. Raises ValueError unless x is 2-D.

    >>> levels_of_walks(np.array([[0.0, 0.05, 0.1], [0.0, 0.03, 0.0]])).tolist()
    [3, 0]
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2:
        raise ValueError(f"x must be two-dimensional (stacks, bricks), got shape {x.shape}")
    out = np.zeros(len(x), dtype=np.int64)
    rows = np.arange(len(x))
    cs = np.cumsum(x, axis=1)
    for n in range(2, x.shape[1] + 1):
        if rows.size == 0:
            break
        # brick j (0-based j < n-1) carries bricks j+1..n-1: their mean is (cs[n-1] - cs[j]) / (n-1-j)
        above = (cs[rows, n - 1 : n] - cs[rows, : n - 1]) / np.arange(n - 1, 0, -1)
        ok = np.all(np.abs(above - x[rows, : n - 1]) < length / 2, axis=1)
        out[rows[~ok]] = n
        rows = rows[ok]
    return out


def collapse_levels(samples: int, rng: np.random.Generator, length: float = LENGTH, max_levels: int = 1000) -> np.ndarray:
    """Collapse levels of ``samples`` random single-file stacks (module docstring), shape
    (samples,), int64, each >= 3 (almost surely). Steps U(-L/2, L/2) are drawn from ``rng``
    64 bricks at a time per sample, CHUNK samples at a time; a stack still standing after
    64 bricks gets 64 more, up to ``max_levels``. The result depends on ``rng`` only.

    Raises ValueError on samples < 0, max_levels < 2 or length <= 0; RuntimeError when a stack
    still stands at ``max_levels`` bricks (with the default 1000 it has never happened: the
    tail falls by about a factor 1.3 a level).
    """
    if samples < 0 or max_levels < 2 or not length > 0:
        raise ValueError(f"need samples >= 0, max_levels >= 2, length > 0; got {samples}, {max_levels}, {length}")
    out = np.empty(samples, dtype=np.int64)
    for start in range(0, samples, CHUNK):
        count = min(CHUNK, samples - start)
        steps = rng.uniform(-length / 2, length / 2, size=(count, min(_WIDTH, max_levels) - 1))
        x = np.concatenate([np.zeros((count, 1)), np.cumsum(steps, axis=1)], axis=1)
        levels = levels_of_walks(x, length)
        standing = np.flatnonzero(levels == 0)
        x = x[standing]  # the walks of the standing stacks, row i belonging to standing[i]
        while standing.size:
            if x.shape[1] >= max_levels:
                raise RuntimeError(f"{standing.size} stack(s) still stand at max_levels={max_levels} bricks")
            more = min(_WIDTH, max_levels - x.shape[1])
            steps = rng.uniform(-length / 2, length / 2, size=(standing.size, more))
            x = np.concatenate([x, x[:, -1:] + np.cumsum(steps, axis=1)], axis=1)
            levels[standing] = levels_of_walks(x, length)
            keep = levels[standing] == 0
            standing, x = standing[keep], x[keep]
        out[start : start + count] = levels
    return out


def mean_collapse_level(samples: int, seed: int, length: float = LENGTH) -> tuple[float, float, float]:
    """(mean, low, high): the mean collapse level of ``samples`` random stacks drawn with
    ``numpy.random.default_rng(seed)`` and its 95 % Student-t interval
    (:func:`scipy.stats.t.interval`). Raises ValueError with fewer than 2 samples.

    >>> [round(v, 2) for v in mean_collapse_level(20000, seed=3)]
    [7.12, 7.06, 7.17]
    """
    if samples < 2:
        raise ValueError(f"need at least 2 samples, got {samples}")
    levels = collapse_levels(samples, np.random.default_rng(seed), length)
    mean = float(levels.mean())
    low, high = stats.t.interval(0.95, samples - 1, loc=mean, scale=float(stats.sem(levels)))
    return mean, float(low), float(high)
