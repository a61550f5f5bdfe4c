"""A hand on MuJoCo: the grip on a held brick, its blow on what it strikes, and the friction of
what it struck while that slides (:class:`Hands`, owned by a
:class:`~stackdsl.engines.mujoco.world.MuJoCoWorld`).

A pusher, a pulled brick and a fixture on a shaking table are *guided* bricks: the world drives
their free bodies along their paths. One a hand holds is :data:`GUIDED_MASS` heavy, its weight
compensated (:meth:`Hands.grip`). MuJoCo's contact starts a slip only with a normal velocity, so
a pushed brick flew: a hand strikes what it will meet before MuJoCo steps (:meth:`Hands.blows`),
and the friction of what it struck is asked for no more than it can give while that slides
(:meth:`Hands.solve`). With no hand at work and nothing it struck still sliding, the world's
step is ``mj_step``'s, bit for bit.

Source: stackdsl's own, on MuJoCo 4.0's Python bindings (its documentation, "Computation").
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

#: kg of a guided brick's free body while it is guided (a hand's grip), its inertia scaled too.
GUIDED_MASS = 100.0
#: What MuJoCo's friction is asked to take off a sliding contact's slip in a step, beyond what a
#: blow lets it (see :meth:`Hands.solve`), in units of what Coulomb's friction takes off a brick
#: under its own weight, ``mu g dt``.
FRICTION_REACH = 2.0
#: m/s: a contact slipping faster than this slides (its friction is limited, and a struck brick
#: with such a contact is still struck); slower, MuJoCo's own reference holds it, whose lift is
#: at most ``mu`` times this.
SLIP_SPEED = 0.1
#: Times at most a step's constraint forces are solved while some limited contact's friction
#: stayed within its cone (short of :data:`FRICTION_FULL` of ``mu N``: friction was asked too
#: little), its limit raised :data:`FRICTION_RETRY` times each time.
FRICTION_TRIES = 4
FRICTION_RETRY = 4.0
FRICTION_FULL = 0.95
#: m a held body's geom looks ahead for what it will strike, beyond what it travels in a step
#: (MuJoCo reports those contacts without acting on them: its ``gap``); see :meth:`Hands.blows`.
BLOW_SKIN = 0.0005
#: m/s: a held body already touching a brick strikes it again (:meth:`Hands.blows`) only
#: when closing faster than this; slower (a brick the hand carries lags it by its friction,
#: ``mu g dt`` a step; one that rests on a shaken fixture), MuJoCo's contact holds it, with
#: what else it touches: blows every step at the foot of a domino a finger pushes along
#: tilted it back, and it no longer fell at 70 mm/s (59.3 mm/s by its closed form).
BLOW_SPEED = SLIP_SPEED
#: m/s: the contacts of a pulled brick (guided by its own mass, not held: a Jenga pull) are
#: limited (:meth:`Hands.solve`) while they slip faster than this. A pull is slow (20 to 40
#: mm/s), and MuJoCo's friction, asked to stop the slip under the level above within the step,
#: lifted that level onto the pulled block: a 9-level Jenga tower of friction 0.05 pulled at
#: its third level rode off on the block to 1.8 m, and one of 0.4 dragged 7.8 mm (Coulomb's
#: friction holds the level above on the two other blocks at any friction: 0.4 and 2.2 mm now).
PULL_SLIP_SPEED = 0.01


@dataclass(frozen=True)
class Grip:
    """A held brick's free body's own constants, given back when the hand lets go: mass (kg),
    inertia (kg m^2, principal), and MuJoCo's ``body_invweight0`` (2,), ``dof_invweight0`` (6,)
    and ``dof_M0`` (6,). Source: stackdsl's own."""

    mass: float
    inertia: np.ndarray
    body_invweight0: np.ndarray
    dof_invweight0: np.ndarray
    dof_M0: np.ndarray

    @classmethod
    def of(cls, m: Any, bid: int, dof: int) -> Grip:
        """The constants of body ``bid`` (its free joint's first dof ``dof``) in model ``m``, as they are."""
        return cls(
            float(m.body_mass[bid]),
            m.body_inertia[bid].copy(),
            m.body_invweight0[bid].copy(),
            m.dof_invweight0[dof : dof + 6].copy(),
            m.dof_M0[dof : dof + 6].copy(),
        )


class Hands:
    """The guided bricks of a MuJoCo world, and the bricks its hands struck that still slide.

    Args:
        mj: the ``mujoco`` module.
        gravity: m/s^2, the run's.

    State owned here: :attr:`guided` (brick id -> its :class:`Grip` while a hand holds it, None
    while it is only guided), :attr:`struck` (brick ids) and :attr:`least_reach` (m/s^2, set by
    :meth:`compiled`). The world passes its arrays in (``frozen`` per brick; ``free_geom`` per
    brick; ``geom_body``, geom -> stackdsl body id), as they change at each compile.

    >>> import mujoco
    >>> hands = Hands(mujoco, 9.81)
    >>> hands.busy, hands.holding()
    (False, [])
    """

    def __init__(self, mj: Any, gravity: float) -> None:
        self._mj, self._gravity = mj, gravity
        self.guided: dict[int, Grip | None] = {}
        self.struck: set[int] = set()
        self.least_reach = 0.0

    def compiled(self, m: Any) -> None:
        """The least friction coefficient of model ``m`` (its geoms' and its pairs'), as what the
        least friction can take off in a step: :meth:`solve` leaves MuJoCo alone below it."""
        frictions = np.concatenate([m.geom_friction[:, 0], m.pair_friction[:, 0]])
        self.least_reach = FRICTION_REACH * self._gravity * float(frictions.min())

    def holding(self) -> list[int]:
        """Brick ids a hand holds (guided with a :class:`Grip`), in the order they were taken."""
        return [body for body, grip in self.guided.items() if grip is not None]

    @property
    def busy(self) -> bool:
        """Whether a step must run MuJoCo's stages one by one: a brick is guided (held or
        pulled), or a brick a hand struck still slides."""
        return bool(self.struck or self.guided)

    @staticmethod
    def grip(m: Any, bid: int, dof: int, grip: Grip) -> None:
        """Body ``bid`` (first dof ``dof``) :data:`GUIDED_MASS` heavy, its inertia scaled with its
        mass, its weight compensated. MuJoCo's contact softness is scaled by each body's
        ``invweight0``, which the compiler derives from the mass: scaled too, or the light brick's
        stiff contacts act on a hundred kilograms (a pusher touching a domino was thrown 8 mm in
        one tuned step and the simulation blew up). Source: stackdsl's own (MuJoCo's
        ``mj_setConst`` gives the same constants, from the model's reference pose)."""
        scale = GUIDED_MASS / grip.mass
        m.body_mass[bid], m.body_inertia[bid] = GUIDED_MASS, grip.inertia * scale
        m.body_invweight0[bid] = grip.body_invweight0 / scale
        m.dof_invweight0[dof : dof + 6] = grip.dof_invweight0 / scale
        m.dof_M0[dof : dof + 6] = grip.dof_M0 * scale
        m.body_subtreemass[bid] = GUIDED_MASS
        m.body_subtreemass[0] += GUIDED_MASS - grip.mass
        m.body_gravcomp[bid] = 1.0

    @staticmethod
    def release(m: Any, bid: int, dof: int, grip: Grip) -> None:
        """Body ``bid`` (first dof ``dof``) let go of: its own constants (``grip``) and weight back."""
        m.body_mass[bid], m.body_inertia[bid], m.body_invweight0[bid] = grip.mass, grip.inertia, grip.body_invweight0
        m.dof_invweight0[dof : dof + 6], m.dof_M0[dof : dof + 6] = grip.dof_invweight0, grip.dof_M0
        m.body_subtreemass[bid] = grip.mass
        m.body_subtreemass[0] -= GUIDED_MASS - grip.mass
        m.body_gravcomp[bid] = 0.0

    def solve(self, m: Any, d: Any, frozen: np.ndarray, geom_body: np.ndarray) -> None:
        """Solve the step's constraint forces (``mj_fwdConstraint``), asking the friction of a
        contact a hand started sliding to take off no more slip in the step than it can.

        With elliptic cones MuJoCo gives a contact's friction rows the reference acceleration
        ``-b v`` (``v`` the slip, ``b = 2 / (dmax timeconst)``, one over the step on tuned and
        extension contacts): stop the slip within the step. Friction cannot while the brick
        slides, and MuJoCo's convex contact turns what it was asked and could not do into a
        normal velocity, ``mu`` times it (its documentation: "the only way to initiate slip is to
        generate some motion in the normal direction"): a KAPLA brick set sliding along the ground
        at 1 m/s skipped like a stone, 8 mm high (19 mm at 1.5 m/s). So the
        reference asks for no more than ``mu`` times the normal velocity the contact can take off
        in the step: :data:`FRICTION_REACH` times what gravity gives a brick, plus the share of
        the contact's approach speed that reaches its friction (the friction row's mobility over
        the normal row's, ``efc_diagA``: a blow at the end of a brick turns it as much as it
        moves it). Where friction then stayed within its cone (a brick carrying another sliding on
        it needs three times its own weight's), it is asked more and the forces are solved again
        (:data:`FRICTION_TRIES`). A pushed brick then rises 0.4 mm or less and stops within a few
        mm of ``v^2 / (2 mu g)`` past the pusher's stroke.

        Only the contacts of the hands (:meth:`holding`) and of the bricks they struck (:meth:`blows`),
        while these slide or fly, are limited, and only while they slip faster than
        :data:`SLIP_SPEED`, and those of a pulled brick from :data:`PULL_SLIP_SPEED`; a brick a hand struck that stands, leans or rolls (a pushed domino as
        it falls) is no longer struck. MuJoCo's own contact everywhere else: limited on every
        sliding contact, rows of KAPLA dominoes 120 to 126 mm apart stopped at 13 to 17 of 20 in
        extension mode and one 124 mm apart at 15 on tuned MuJoCo (each falls whole on every
        engine as it is), a fallen domino sliding 4 mm farther on than MuJoCo's landing (and
        pybullet's) lets it. With no hand and no struck brick, or every friction row asking less
        than the least reach, a step is MuJoCo's own, bit for bit. Pyramidal cones (raw MuJoCo) mix each friction row with the normal one:
        never limited. Source: stackdsl's own, on MuJoCo's reference acceleration (its
        documentation, "Computation", eq:aref) and ``mjContact``."""
        aref, hands, pulled = d.efc_aref, self.holding(), [b for b, grip in self.guided.items() if grip is None]
        if not (self.struck or hands or pulled) or d.nefc == 0 or np.abs(aref).max() <= self.least_reach:
            self._mj.mj_fwdConstraint(m, d)  # no row asks for more than the least friction can give (2 us)
            return
        contact, velocity = d.contact, d.efc_vel
        address = contact.efc_address
        acting = (address >= 0) & (contact.dim >= 3)
        address, mu, bodies = address[acting], contact.friction[acting, 0], geom_body[contact.geom[acting]]
        slip = np.sqrt(velocity[address + 1] ** 2 + velocity[address + 2] ** 2)
        if not hands:  # a struck brick is one while it slides or flies: not once it stands, leans or rolls
            touching = np.zeros(len(frozen) + 1, dtype=bool)
            sliding = np.zeros(len(frozen) + 1, dtype=bool)
            touching[bodies.ravel()] = True
            sliding[bodies[slip > SLIP_SPEED].ravel()] = True
            self.struck = {b for b in self.struck if sliding[b] or not (touching[b] or frozen[b - 1])}
        held = np.zeros(len(frozen) + 1, dtype=bool)
        held[[*self.struck, *hands]] = True
        held[0] = False
        mine = held[bodies].any(axis=1) & (slip > SLIP_SPEED)
        if pulled:  # what lies on a pulled brick, or under it, slips slowly: limited from PULL_SLIP_SPEED
            dragged = np.zeros(len(frozen) + 1, dtype=bool)
            dragged[pulled] = True
            mine |= dragged[bodies].any(axis=1) & (slip > PULL_SLIP_SPEED)
        address, mu = address[mine], mu[mine]
        first, second = aref[address + 1], aref[address + 2]  # the two tangent directions
        asked = np.sqrt(first * first + second * second)
        approach = np.maximum(0.0, -velocity[address])  # m/s the contact closes: its normal row's
        mobility = d.efc_diagA  # a row's velocity per unit force: how much of a blow friction can use
        impact = approach * mobility[address + 1] / mobility[address] / m.opt.timestep
        reach = mu * (FRICTION_REACH * self._gravity + impact)
        over = np.flatnonzero(asked > reach)
        rows, first, second, asked, reach, mu = (a[over] for a in (address, first, second, asked, reach, mu))
        force = d.efc_force
        for _ in range(FRICTION_TRIES):
            scale = np.minimum(1.0, reach / asked)
            aref[rows + 1], aref[rows + 2] = first * scale, second * scale
            self._mj.mj_fwdConstraint(m, d)
            friction = np.sqrt(force[rows + 1] ** 2 + force[rows + 2] ** 2)
            short = (friction < FRICTION_FULL * mu * force[rows]) & (scale < 1.0)  # its limit met short of Coulomb's
            if not short.any():
                return
            reach = np.where(short, reach * FRICTION_RETRY, reach)

    def blows(self, m: Any, d: Any, frozen: np.ndarray, free_geom: np.ndarray, geom_body: np.ndarray) -> bool:
        """A held body (:meth:`holding`: a pusher, a fixture on a shaking table) that will strike a free
        brick within this step strikes it now, as a rigid hand strikes a rigid brick: inelastic,
        with Coulomb friction at the point of contact. The brick's velocity changes before MuJoCo
        steps, by the share of the step after they touch, so that the two meet at its end, and
        the brick is struck (:meth:`solve`). Left to MuJoCo's contact, the blow
        started the brick's slip within the step, which MuJoCo does only with a normal velocity
        ``mu`` times it: a KAPLA brick lying on the ground, pushed end on at 1 m/s, left it at
        0.68 m/s and went on at 1.37 m/s, 28 mm high and 2.4 times as far as it slides. The blow
        ignores what else the brick touches (the ground, a brick on it), whose impulses in so
        short a blow are their weight's, and which MuJoCo then resolves. The candidates are the
        contacts in the hand's ``gap`` (``MuJoCoWorld.guide``), which MuJoCo finds but does not act on,
        and those it touches closing faster than :data:`BLOW_SPEED` (a hand that reached a
        brick's face at the end of a step); returns whether a velocity changed. Source:
        stackdsl's own (the impulse of an inelastic frictional impact at a point, any mechanics
        text; MuJoCo's ``mj_jac`` and ``mj_solveM`` give the brick's mobility at that point)."""
        n, hands = d.ncon, self.holding()
        if n == 0 or not hands:
            return False
        own = {int(free_geom[b - 1]): b for b in hands}
        struck = _contacts_struck(d.contact, n, own, frozen, free_geom, geom_body)
        changed = False
        for (hand, body), found in struck.items():
            if self._strike(m, d, hand, body, found, free_geom):
                self.struck.add(body)
                changed = True
        return changed

    def _strike(self, m: Any, d: Any, hand: int, body: int, found: list[tuple[int, float]], free_geom: np.ndarray) -> bool:
        """Hand ``hand`` strikes brick ``body`` at the contacts ``found`` (their indices in
        ``d.contact``, each with the sign that turns its normal from the hand into the brick), if
        they meet within this step: the brick's velocity changes in ``d.qvel`` by the impulse that
        moves its point with the hand's (inelastic), or by Coulomb's limit when that would slide
        on the hand; returns whether it did."""
        contact, step = d.contact, float(m.opt.timestep)
        rows = [k for k, _ in found]
        point = contact.pos[rows].mean(axis=0)
        normal = (contact.frame[rows, :3] * np.array([sign for _, sign in found])[:, None]).sum(axis=0)
        normal /= np.linalg.norm(normal)  # from the hand into the brick
        gap = float(contact.dist[rows].min())
        mu = float(contact.friction[rows, 0].max())
        at_brick, at_hand = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        self._mj.mj_jac(m, d, at_brick, None, point, int(m.geom_bodyid[free_geom[body - 1]]))
        self._mj.mj_jac(m, d, at_hand, None, point, int(m.geom_bodyid[free_geom[hand - 1]]))
        relative = (at_hand - at_brick) @ d.qvel  # the hand's point's velocity on the brick's
        closing = float(relative @ normal)
        if closing <= 0.0 or gap >= closing * step or (gap <= 0.0 and closing <= BLOW_SPEED):
            return False  # parting, or not meeting within this step
        mobility = np.zeros((3, m.nv))
        self._mj.mj_solveM(m, d, mobility, at_brick)  # rows: M^-1 times each row of the Jacobian
        k_matrix = at_brick @ mobility.T  # velocity of the brick's point per unit impulse there
        share = 1.0 - max(0.0, gap) / (closing * step)  # of the step after they touch
        impulse = np.linalg.solve(k_matrix, share * relative)  # the point moves with the hand's
        normal_part = float(impulse @ normal)
        if np.linalg.norm(impulse - normal_part * normal) > mu * normal_part:  # slides on the hand
            slip = relative - closing * normal
            length = float(np.linalg.norm(slip))
            direction = normal + (mu * slip / length if length > 1e-12 else 0.0)
            impulse = direction * (share * closing / float(normal @ k_matrix @ direction))
        d.qvel[:] += mobility.T @ impulse
        return True


def _contacts_struck(
    contact: Any, n: int, own: dict[int, int], frozen: np.ndarray, free_geom: np.ndarray, geom_body: np.ndarray
) -> dict[tuple[int, int], list[tuple[int, float]]]:
    """The contacts among MuJoCo's first ``n`` (acted on, or in a hand's gap) between a hand (a geom
    of ``own``, mapped to its body) and a free brick that is not frozen, grouped by (hand, brick)
    body: each contact's index with the sign that turns its normal from the hand into the brick."""
    geoms = contact.geom[:n]
    mine = np.isin(geoms, list(own)).any(axis=1) & (contact.exclude[:n] <= 1)  # acted on, or in a gap
    struck: dict[tuple[int, int], list[tuple[int, float]]] = {}
    for k in np.flatnonzero(mine).tolist():
        g1, g2 = (int(g) for g in contact.geom[k])
        if (g1 in own) == (g2 in own):
            continue  # no hand, or two hands
        hand, other, sign = (own[g1], g2, 1.0) if g1 in own else (own[g2], g1, -1.0)
        body = int(geom_body[other])
        if body == 0 or frozen[body - 1] or other != free_geom[body - 1]:
            continue  # the ground, or a frozen brick: static
        struck.setdefault((hand, body), []).append((k, sign))
    return struck
