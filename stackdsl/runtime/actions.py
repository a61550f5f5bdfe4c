"""The hand and the shake table: a step-loop subscriber that carries out pulls, pushes and shakes.

* **Pull** (:class:`~stackdsl.compile.program.Remove`): the brick leaves the structure (it is no
  longer watched for a collapse), the stability extension *guides* it (it wakes, with what it
  carries, and the frozen bricks it touches wake as it reaches them:
  :meth:`stability.StabilityExtension.guide`), and before each step the world puts it on its path
  with its velocity (:meth:`~stackdsl.engines.protocol.World.guide`): a kinematic gripper whose
  friction drags what rests on it. At the end of the pull the hand takes it out of the scene.
* **Push** (:class:`~stackdsl.compile.program.Push`): a pusher body enters, is guided the same
  way along its direction, and is withdrawn at the end. Its path was worked out from where its
  target brick was placed: when the brick has moved since, the whole path is moved along the
  direction to start ``gap`` before the brick as it lies (:func:`_pusher_start`), and a pusher
  that would start inside a body or reach below the ground is not started (:func:`_blocked`).
* **Shake** (:class:`~stackdsl.compile.program.Shake`): the extension is asked whether the
  frozen stack stands under gravity tilted by the ground's peak acceleration, either way
  (:meth:`stability.StabilityExtension.withstands`). When it does and nothing else moves, the
  stack rides the table as one rigid body: nothing is simulated, and the ground, which ends
  whole periods later at rest where it started, need not move either. Otherwise the ground moves
  each step (:meth:`~stackdsl.engines.protocol.World.move_ground`), and nothing is frozen until
  it has stopped (a brick frozen while the ground moves would stay where it was in the world).
  When nothing else moves, each part of the frozen stack that the ground's friction moves as one
  rigid body (it slides on the table or is carried by it, and nothing in it slips or tips:
  :meth:`stability.StabilityExtension.shake`) is one body in the engine until it comes to rest
  after the shake; every other brick wakes. Fixtures are bolted to the table: each is guided along with the
  ground while it moves (:meth:`~stackdsl.engines.protocol.World.guide`, held) and fixed again
  where it was when the ground stops, so the environment moves as one rigid body, on every
  engine and in every mode, and the extension's proof (fixtures are ground to it) holds for it.

Without the extension acting (raw and tuned modes) the same motions happen, and a shake always
moves the ground. Source: stackdsl's own.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Collection
from dataclasses import dataclass, field

import numpy as np

from stability import JITTER, Box, Pose, StabilityExtension

from ..compile.actions import REACHES
from ..compile.clearance import deepest
from ..compile.overlap import touching
from ..compile.program import PULL_STEP, Action, Kinematic, Push, Remove, Shake, speed_words
from .bricks import BrickRecord
from .loop import StepLoop, Subscriber
from .outcome import Event
from .subscribers import Stability, Substeps

#: Where a hand puts what it took out of the scene: far from any scene, a slot each.
AWAY = np.array([-5000.0, -5000.0, 100.0])

#: Metres below its path at which a pulled brick that touches nothing has cleared what it lay
#: between and begun to fall: the hand takes it out of the scene then, as a hand holds what it
#: has pulled free (a 1 mm fall takes 14 ms, 3.4 steps at 240 Hz).
CLEARED = 0.001

#: Metres a hand carries a pulled brick in one glide at most (:meth:`Actions.glide`): its proof
#: is asked about the way at once, and a proved pull's contact areas are checked again each time a
#: quarter of one has gone (the middle block of a Jenga level, pulled along its 75 mm, passes a
#: 25 mm support in about 6 mm steps).
GLIDE = 0.005

#: Metres the surface of a push's target brick must have moved along the push, since it was
#: placed, for the pusher to start that much further on or back (less is a brick settling).
SHIFTED = 0.0001


@dataclass
class _Guided:
    """A body on a straight path: where it started (s, pose) and its velocity (m/s) until ``end_step``."""

    record: BrickRecord
    start: Pose
    since: float
    velocity: np.ndarray
    end_step: int
    kind: str


class Actions(Subscriber):
    """Carries out the program's pulls, pushes and shakes (see the module docstring).

    Args:
        stability: the run's stability subscriber (its extension guides bodies and is asked about
            shakes; ``acting``: whether it freezes and wakes).
        substeps: the run's substep control (None: the engine alone, no substeps).
        split_pulls: steps of at most :data:`PULL_STEP` while a pull lasts (the extension acting,
            on pybullet).
        past_threshold: whether a structure brick is past the collapse threshold now, the
            bricks of the ids given left out
            (:meth:`stackdsl.runtime.collapse.CollapseMonitor.past_threshold_besides`): from then
            on a pull's steps are the engine's own, not split. The ids given are those of the
            bricks a pusher drives (:meth:`stability.StabilityExtension.driven`).
    """

    def __init__(
        self,
        stability: Stability,
        substeps: Substeps | None = None,
        split_pulls: bool = False,
        past_threshold: Callable[[Collection[str]], bool] = lambda moved_by_hand: False,
    ) -> None:
        self.stability = stability
        self.substeps, self.split_pulls = substeps, split_pulls
        self._past_threshold = past_threshold
        self.guided: list[_Guided] = []
        self.shake: Shake | None = None  # the shake under way, when the ground moves
        self.away: list[BrickRecord] = []  # taken out of the scene this step: forgotten before the next
        self._taken = 0
        self._carried = False  # a pull under way drags bricks the engine moves (finer steps)
        self._on_path: dict[int, _Guided] = {}  # a pushed brick the extension's proof moves on the hand's path
        self._steady: _Window | None = None  # since when everything has lain still on the shaken ground
        self._every = 1  # steps between two looks at the shake's steady state
        self._quiet_from = 0  # the step from which no other action comes before the shake's end

    @property
    def quiet(self) -> bool:
        return not (self.guided or self.shake or self.away)

    def glide(self, loop: StepLoop, limit: int) -> int:
        """Carry a brick pulled under its proof along its path over the steps the proof covers,
        up to :data:`GLIDE` of it, and return how many (0: none). A pull whose proof keeps the
        bricks it slides between frozen has nothing in the engine but the pulled brick on its
        path, its height resting on what carries it: when the extension says nothing it watches
        can change on the way (:meth:`stability.StabilityExtension.glides`), and every other
        subscriber is quiet, the brick is put where its path has it then, at its own height and
        orientation (the hand turns it back to its path's as ever once stepped), moving with the
        hand (:meth:`~stackdsl.engines.protocol.World.carry`), without the steps between; the way
        it lags its path comes off the room. A pull's last steps, a pull that drags what the
        engine moves (finer steps), a push and a shake are stepped as ever. Source: stackdsl's
        own."""
        if len(self.guided) != 1 or self.shake is not None or self.away or self._on_path or self._carried:
            return 0
        g = self.guided[0]
        if g.kind != "pull" or not loop.world.carries or not self.stability.acting:
            return 0
        speed = float(np.linalg.norm(g.velocity))
        if speed <= 0.0 or any(not s.quiet for s in loop.subscribers if s is not self and s is not self.stability):
            return 0
        room = min(GLIDE, self.stability.extension.glide_room(g.record.body))
        if room <= 0.0:  # most steps of a pull the engine steps: no pose read for nothing
            return 0
        (x, y, z), turned = loop.world.pose_floats(g.record.body)
        here = g.start.position + g.velocity * (loop.step * loop.dt - g.since)
        behind = math.hypot(float(here[0]) - x, float(here[1]) - y)  # the brick lags its path by a step or so
        steps = min(int((room - behind) / (speed * loop.dt)), limit - loop.step - 1, g.end_step - loop.step - 1)
        if steps < 2:
            return 0
        then = g.start.position + g.velocity * ((loop.step + steps) * loop.dt - g.since)
        to = Pose(np.array([then[0], then[1], z + float(g.velocity[2]) * steps * loop.dt]), np.array(turned))
        if not self.stability.extension.glides(g.record.body, to):
            return 0
        loop.world.carry(g.record.body, to, (float(g.velocity[0]), float(g.velocity[1]), float(g.velocity[2])))
        return steps

    @property
    def under_way(self) -> bool:
        """A shake, a push or a pull is under way: a collapse meanwhile ends the run only once it
        is over (the ground back at rest where it started, the pusher withdrawn, the pulled brick
        taken out of the scene), so that nothing is judged mid-stroke (a brick half pulled out
        was left in the final scene, a brick lying on it judged where the cut left it)."""
        return self.shake is not None or bool(self.guided)

    def on_action(self, loop: StepLoop, action: Kinematic) -> None:
        if isinstance(action, Remove):
            self._remove(loop, action)
        elif isinstance(action, Push):
            self._push(loop, action)
        else:
            self._shake(loop, action)

    def _remove(self, loop: StepLoop, a: Remove) -> None:
        record = loop.structure.records[a.id]
        moved = loop.structure.displacement(record)  # before it leaves the structure's books
        loop.structure.detach(record)
        speed = float(np.linalg.norm(a.velocity))
        detail = f"pulled out at {speed_words(speed)}"
        if moved > loop.program.collapse_threshold:  # a brick the hand takes where it lies, not where it was placed
            detail += f", from where it lies, {moved * 1000:.3g} mm from its place"
        loop.events.append(Event(time=a.time, kind="remove", brick=a.id, detail=detail))
        self._guide(loop, record, a.time, a.velocity, a.end_step, "pull", f"pulled out by hand at {a.time:g} s")
        self._finer(loop)

    def _push(self, loop: StepLoop, a: Push) -> None:
        speed = float(np.linalg.norm(a.velocity))
        detail = f"{speed_words(speed)} into {a.target}"
        pose, lies, how = _pusher_start(loop, a)
        inside = _blocked(loop, a, pose)
        if inside is not None:
            moved = not np.allclose(pose.position, a.position, rtol=0.0, atol=1e-12)
            why = f"{'to start its gap before it, ' if moved else ''}{inside}"
            detail += f" ({lies})" if lies else ""
            loop.events.append(Event(time=a.time, kind="push", brick=a.id, detail=f"{detail}: not started: {why}"))
            return
        detail += f" ({lies}: {how})" if how else ""
        body = loop.world.create(a.brick, pose)
        record = BrickRecord(a.id, body, a.brick, None, pose, pose)
        loop.structure.add(record)
        self.stability.extension.add_brick(body, record.box, a.id, a.brick.friction)
        loop.events.append(Event(time=a.time, kind="push", brick=a.id, detail=detail))
        aimed = loop.structure.records.get(a.target)
        self._guide(loop, record, a.time, a.velocity, a.end_step, "push", "a pusher", aimed.body if aimed else None)
        self._finer(loop)

    def _guide(
        self,
        loop: StepLoop,
        record: BrickRecord,
        time: float,
        velocity: tuple[float, float, float],
        end: int,
        kind: str,
        why: str,
        aim: int | None = None,
    ) -> None:
        start = loop.world.pose(record.body)
        self.guided.append(_Guided(record, start, time, np.array(velocity), end, kind))
        speed = float(np.linalg.norm(velocity))
        hand = (float(velocity[0]), float(velocity[1]), float(velocity[2]))
        pull = hand if kind == "pull" and self.stability.acting else None
        self.stability.follow(loop, self.stability.extension.guide(record.body, time, why, speed, pull, hand, aim))

    def _shake(self, loop: StepLoop, a: Shake) -> None:
        extension, acting = self.stability.extension, self.stability.acting
        peak = a.peak_acceleration
        acceleration = (peak * a.direction[0], peak * a.direction[1])
        why = extension.withstands(acceleration) if acting else "the extension is not acting"
        # what else happens before the shake's end: a frozen stack cannot ride it unsimulated then
        # (a brick thrown mid-shake knocked bricks loose onto a table left still, whatever the phase)
        during = [b for b in loop.program.actions if a.step < b.step < a.end_step and b.kind != "end"]
        rides = acting and why is None and extension.quiet and not during
        if why is None and not rides:  # the frozen stack would stand, but something moves on it or comes
            why = _moving(extension.moving) if extension.moving or not during else _coming(during[0])
        detail = f"{a.amplitude * 1000:.3g} mm at {a.frequency:.3g} Hz, peak {peak:.3g} m/s^2: " + (
            "the frozen stack stands under gravity tilted by it and rides the table" + _limit(extension, acceleration)
            if rides
            else f"stepped in the engine ({why})"
        )
        loop.events.append(Event(time=a.time, kind="shake", brick="ground", detail=detail))
        if rides:
            return
        self._every = max(1, int(1.0 / (a.frequency * loop.dt * STEADY_LOOKS)))
        # the steady state is asked once no other action is to come before the shake's end
        self._quiet_from = max((b.step for b in during), default=a.step)
        if acting:
            extension.admitting = False
            reason = f"the ground shakes at {peak:.3g} m/s^2: {why}"
            if extension.quiet:  # each part that moves on the ground as one rigid body rides it merged
                self.stability.follow(loop, extension.shake(acceleration, loop.world.ground, a.time, reason))
            else:
                self.stability.follow(loop, extension.wake_all(a.time, reason))
        self.shake = a

    def _finer(self, loop: StepLoop) -> None:
        """The substeps a guided body needs, from the start of its path: while a pull lasts, steps
        of at most :data:`PULL_STEP` (``split_pulls``); a hand's path as fast as a thrown brick,
        substeps in which it moves at most the substep control's threshold, as a thrown brick
        does (a pusher at 10 m/s moved 42 mm a step, through an 8 mm domino it was to push; the
        control reads speeds before the hand sets its velocity, a step late)."""
        if self.substeps is None:
            return
        pulling = self.split_pulls and self._carrying()
        self._carried = pulling
        fastest = max((float(np.linalg.norm(g.velocity)) for g in self.guided), default=0.0)
        self.substeps.floor = max(
            math.ceil(loop.dt / PULL_STEP - 1e-9) if pulling else 1,
            math.ceil(fastest * loop.dt / self.substeps.threshold - 1e-9),
            1,
        )

    def _carrying(self) -> bool:
        """Whether a pull or a push under way drags bricks the engine moves
        (:meth:`stability.StabilityExtension.drags`): one whose proof keeps what it slides
        between frozen carries none, and needs no finer steps. Nor does one once a structure brick is past the collapse
        threshold: the finer steps are there for the drag that decides whether the structure
        stands, and with a brick past the threshold the collapse is dated and its level fixed;
        what follows is a fall, which the engine's own step simulates as it does any other
        (docs/actions.md, "Pull": a 12-level tower that a side pull fells, 5.4 to 5.8 s split to
        the pull's end, 3.0 to 3.6 s so). A pull whose fall statics proved is split as well until
        then: its drag before the fall dates the collapse (docs/actions.md, "A pull that fells
        the tower")."""
        if not self.guided or self._past_threshold(self.stability.extension.driven()):
            return False  # asked every step: nothing guided, no list of driven bricks
        drags = self.stability.extension.drags
        return any(g.kind in ("pull", "push") and drags(g.record.body) for g in self.guided)

    @staticmethod
    def _clear(loop: StepLoop, g: _Guided) -> bool:
        """Has the pulled brick of ``g`` cleared what it lay between: :data:`CLEARED` below its
        path and touching nothing? A pulled brick keeps its own vertical motion (it rests on what
        carries it), so once nothing carries it, it falls; a hand would hold it."""
        if g.kind != "pull":
            return False
        (_, _, z), _ = loop.world.pose_floats(g.record.body)
        path_z = g.start.position[2] + g.velocity[2] * (loop.now - g.since)
        return bool(z < path_z - CLEARED) and not loop.world.touches(g.record.body)

    def before_step(self, loop: StepLoop) -> None:
        t = loop.now
        if self.split_pulls and self.substeps is not None and self._carrying() != self._carried:
            self._carried = not self._carried  # a pull's proof was lost: finer steps from this one
            self._finer(loop)
            self.substeps.before_step(loop)
        for g in self.guided:
            pose = Pose(g.start.position + g.velocity * (t - g.since), g.start.orientation)
            x, y, z = g.velocity.tolist()
            loop.world.guide(g.record.body, pose, (x, y, z), hold=g.kind == "push")
        if self._on_path or (self.stability.acting and self.guided):
            self._drive_proved(loop)
        if self.shake is not None:
            offset, velocity = self.shake.at(t)
            loop.world.move_ground(offset, velocity)
            for body, home in self.stability.fixtures:  # bolted to the table: carried with it
                loop.world.guide(body, Pose(home.position + offset, home.orientation), velocity, hold=True)

    def _drive_proved(self, loop: StepLoop) -> None:
        """Move each brick a pusher drives under the extension's proof along the pusher's path from
        where it was when the proof began, its orientation held and its height its own, as a
        pulled brick (:meth:`stability.StabilityExtension.on_path`); let go of one whose proof is
        lost or whose push has ended, at rest where it is. A free block pushed by a finger between
        frozen levels of a Jenga tower rocked between them on MuJoCo, 0.5 deg and 80 mm/s up and
        down within 0.3 s, and was thrown 393 mm: the frozen bricks give no way as the weight they
        stand for does."""
        t = loop.now
        proved = self.stability.extension.on_path() if self.stability.acting else {}
        hands = {g.record.body: g for g in self.guided}
        for body in [b for b in self._on_path if b not in proved or proved[b] not in hands]:
            del self._on_path[body]
            record = loop.structure.by_body(body)
            if record is not None:
                loop.world.move(body, loop.world.pose(body), record.box.mass)
        for body, pusher in proved.items():
            if pusher not in hands:
                continue
            g = self._on_path.get(body)
            if g is None:
                if not any(c.other == body for c in loop.world.contact_points([pusher])):
                    continue  # woken as the finger nears it: on the path once the finger touches it
                record = loop.structure.by_body(body)
                if record is None:
                    continue
                hand = hands[pusher]
                g = self._on_path[body] = _Guided(record, loop.world.pose(body), t, hand.velocity, hand.end_step, "pull")
            pose = Pose(g.start.position + g.velocity * (t - g.since), g.start.orientation)
            x, y, z = g.velocity.tolist()
            loop.world.guide(body, pose, (x, y, z), hold=False)

    def after_step(self, loop: StepLoop) -> None:
        for record in self.away:  # out of the scene since the last step: no contact reads it now
            self.stability.extension.forget(record.body)
        self.away = []
        for g in [g for g in self.guided if loop.step >= g.end_step or self._clear(loop, g)]:
            self.guided.remove(g)
            self._taken += 1
            away = Pose(AWAY + [0.5 * self._taken, 0.0, 0.0], g.start.orientation)
            loop.world.move(g.record.body, away, 0.0)
            self.away.append(g.record)
            what = "withdrawn" if g.kind == "push" else "taken out of the scene"
            if loop.step < g.end_step:
                what += f", clear of the structure and falling ({(g.end_step - loop.step) * loop.dt:.2f} s before the pull's end)"
            loop.events.append(Event(time=loop.now, kind="release", brick=g.record.id, detail=what))
            self._finer(loop)
        if self.shake is not None:
            loop.structure.offset = self.shake.at(loop.now)[0]  # the collapse monitor reads displacements in the ground's frame
            if loop.step >= self.shake.end_step:
                self._stop_ground(loop)
            elif self.stability.acting and (
                (loop.step - self.shake.step) % self._every == 0 or (self._steady is not None and self._steady.stop is not None)
            ):
                self._steady_state(loop, self.shake)

    def _stop_ground(self, loop: StepLoop) -> None:
        """The shake is over: the ground at rest where it started, the fixtures fixed again."""
        loop.world.move_ground((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        for body, home in self.stability.fixtures:  # back where the table is back, fixed again
            loop.world.move(body, home, 0.0)
        loop.structure.offset = (0.0, 0.0, 0.0)
        self.stability.extension.admitting = True
        self.shake = None
        self._steady = None

    def _steady_state(self, loop: StepLoop, shake: Shake) -> None:
        """End ``shake`` at the end of a whole period when the periods left would carry
        everything on the ground as one rigid body: each body has lain still on the ground for a
        whole period (at each of :data:`STEADY_LOOKS` looks a period, its speeds relative to the
        ground's within :data:`stability.JITTER` times the rest thresholds, as the windowed rest
        test of a fallen brick allows an engine's jitter), and its pose relative to the ground
        has changed so little over that period that the periods left would move it by at most
        :data:`STEADY_DRIFT` and turn it by at most :data:`STEADY_TURN`; nothing else happens
        before the shake's end (no hand, no action). The shake's motion is periodic, so a state
        that repeats over one period repeats over the next; and at the end of each whole period
        the ground is back where it started, at rest, as the shake's end leaves it, with
        everything on it where the periods left would bring it back: the ground stops there.
        The bricks a fallen structure left lying on a shaken table were stepped to the shake's
        end (a brick on end toppled by a 3 s shake lay 2.9 s on the table). Source: stackdsl's
        own."""
        window = self._steady
        if window is not None and window.stop is not None and loop.step >= window.stop[0]:
            loop.events.append(Event(time=loop.now, kind="shake", brick="ground", detail=window.stop[1]))
            self._stop_ground(loop)
            return
        if (loop.step - shake.step) % self._every:
            return
        bodies = self._on_ground(loop, shake)
        if not bodies:
            self._steady = None
            return
        offset, velocity = shake.at(loop.now)
        config = self.stability.extension.config
        (vx, vy, vz), (wx, wy, wz) = loop.world.velocity_floats(bodies[0])  # a sliding part: one body says so
        gx, gy, _ = velocity
        if (
            math.hypot(vx - gx, vy - gy, vz) > JITTER * config.rest_speed
            or math.hypot(wx, wy, wz) > JITTER * config.rest_angular_speed
        ):
            self._steady = None
            return
        linear, angular = loop.world.velocities_of(bodies)
        relative = np.linalg.norm(linear - np.array(velocity), axis=1)
        spin = np.linalg.norm(angular, axis=1)
        if relative.max() > JITTER * config.rest_speed or spin.max() > JITTER * config.rest_angular_speed:
            self._steady = None
            return
        positions, quaternions = loop.world.poses_of(bodies)
        positions = positions - np.array(offset)
        if window is None or window.bodies != bodies:
            window = self._steady = _Window(bodies)
        window.seen.append((loop.now, positions, quaternions))
        period = 1.0 / shake.frequency - 1e-9
        while len(window.seen) > 1 and loop.now - window.seen[1][0] >= period:
            window.seen.popleft()  # the latest a whole period ago is kept
        began, then, turned = window.seen[0]
        if loop.now - began < period:
            return
        periods = (shake.end_time - loop.now) * shake.frequency
        drift = float(np.linalg.norm(positions - then, axis=1).max())
        dots = np.clip(np.abs(np.sum(quaternions * turned, axis=1)), 0.0, 1.0)
        turn = math.degrees(2.0 * float(np.arccos(dots.min())))
        if drift * periods > STEADY_DRIFT or turn * periods > STEADY_TURN:
            window.stop = None  # creeping: asked again at the next look, of the period before it
            return
        if window.stop is not None:
            return
        # the ground is back where it started, at rest, at the end of each whole period: stopped
        # there, it is where the shake's end leaves it, and so is everything lying on it
        whole = shake.time + math.ceil((loop.now - shake.time) * shake.frequency - 1e-9) / shake.frequency
        step = round(whole / loop.dt)
        if step >= shake.end_step:
            return  # it ends there anyway
        left = round((shake.end_time - whole) * shake.frequency)
        detail = (
            f"every body has lain still on the ground for a period ({1000 * drift:.2g} mm, {turn:.2g} deg): "
            f"{'the period' if left == 1 else f'the {left} periods'} left, to t={shake.end_time:.3f} s,"
            " would carry them with it; stopped where it started, at rest"
        )
        window.stop = (step, detail)

    def _on_ground(self, loop: StepLoop, shake: Shake) -> list[int]:
        """The bodies a steady shake would carry (:meth:`_steady_state`): every brick and
        projectile in the scene, each simulated by the engine (on its own or in a part riding the
        ground merged); empty when the steady state cannot be asked (a hand moves, a brick is
        frozen, or an action comes before the shake's end)."""
        if self.guided or self._on_path or loop.step <= self._quiet_from:
            return []
        removed = {id(r) for r in loop.structure.removed}
        records = [r for r in (*loop.structure.placed, *loop.structure.projectiles) if id(r) not in removed]
        riding = self.stability.extension.riding  # a part riding the ground merged: its bricks move with it
        if not records or not all(r.moving or r.body in riding for r in records):
            return []
        return [r.body for r in records]


#: Metres a body lying on a shaken ground may be carried off its place relative to the ground
#: over the periods a steady shake leaves out (:meth:`Actions._steady_state`), by its drift in one.
STEADY_DRIFT = 0.0005

#: Degrees it may so turn.
STEADY_TURN = 0.5

#: Times a period the steady state of a shake is looked at (a look reads every body's pose and
#: velocity: at every step, it cost a shaken single file of 5 riding the table a quarter of its run).
STEADY_LOOKS = 16


@dataclass
class _Window:
    """The ``bodies`` lying still on the shaken ground: at each look since they have, the time
    (s), their positions (m, (n, 3), relative to the ground) and orientations ((n, 4)
    quaternions), back to the latest a whole period ago; once they are steady, where the ground
    stops."""

    bodies: list[int]
    seen: deque[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=deque)
    stop: tuple[int, str] | None = None  # the step the ground stops at, and why in words


def _pusher_start(loop: StepLoop, a: Push) -> tuple[Pose, str, str]:
    """Where the pusher of ``a`` starts, how far its target brick lies from where it was placed
    when that moved the start, and how the start moved or that the path misses the brick, in words
    ("" when nothing).

    The compiler puts it ``gap`` before its target brick's surface as the brick was placed. When
    the brick has moved since (an earlier push, a pull that dragged it, a fall), the whole path is
    moved along the direction by as much as the brick's surface has along it (the first contact of
    the pusher's box swept along the line, with the brick where it is and where it was placed:
    :func:`~stackdsl.compile.overlap.touching`), so that it starts ``gap`` before the brick as it
    is, and moves its whole ``distance`` from there; a shift under :data:`SHIFTED` is left out.
    A brick the line no longer meets is said to be missed."""
    pose = Pose.from_euler(a.position, a.yaw, a.pitch, 0.0)
    target = loop.structure.records.get(a.target)
    if target is None or not target.structure or target not in loop.structure.placed:
        return pose, "", ""
    moved = loop.structure.displacement(target)
    direction = np.array(a.velocity) / np.linalg.norm(a.velocity)
    back = 2 * (sum(a.brick.half_extents) + sum(target.spec.half_extents))  # farther than any overlap
    here = loop.world.pose(target.body)
    first, _ = touching(
        pose.position - direction * back,
        pose.rotation,
        np.array(a.brick.half_extents),
        np.array([target.nominal.position, here.position]),
        np.array([target.nominal.rotation, here.rotation]),
        np.array([target.spec.half_extents] * 2),
        direction,
        deeper=REACHES,
    )
    was, now = (float(f) for f in first)
    said = f"it lies {moved * 1000:.3g} mm from where it was placed"
    if not math.isfinite(now):
        return (pose, said, "the pusher's path misses it") if moved > loop.program.collapse_threshold else (pose, "", "")
    shift = now - was
    if not math.isfinite(was) or abs(shift) < SHIFTED:
        return pose, "", ""
    way = "on" if shift > 0 else "back"
    return (
        Pose(pose.position + direction * shift, pose.orientation),
        said,
        f"the pusher starts {abs(shift) * 1000:.3g} mm further {way}, its gap before it, and moves its whole distance",
    )


def _blocked(loop: StepLoop, a: Push, pose: Pose) -> str | None:
    """Why the pusher of ``a`` cannot start at ``pose``: its box there would reach into a body in
    the world (deeper than :data:`~stackdsl.compile.clearance.TOLERANCE`) or below the ground,
    there or anywhere along its travel; None when it can. A kinematic pusher started inside a
    body throws it about, differently on each engine."""
    box = Box(np.array(a.brick.half_extents), a.brick.mass)
    travel = np.array(a.velocity) * (a.end_step - a.step) * loop.dt
    low = min(
        float(box.corners(pose)[:, 2].min()), float(box.corners(Pose(pose.position + travel, pose.orientation))[:, 2].min())
    )
    if low < -1e-6:
        return f"its pusher would reach {-low * 1000:.3g} mm below the ground"
    bodies = [(r.id, r.spec, loop.world.pose(r.body)) for r in loop.structure.records.values() if r.id != a.id]
    bodies += [(f.id, f.brick, Pose.from_euler(f.position, f.yaw, f.pitch, f.roll)) for f in loop.program.fixtures]
    inside = deepest(box, pose, bodies)
    if inside is None:
        return None
    return f"its pusher would start {inside[1] * 1000:.3g} mm inside {inside[0]}"


def _coming(action: Action) -> str:
    """Why a shake the frozen stack would withstand is simulated all the same: an action comes
    before its end.

    >>> from stackdsl.compile.program import End
    >>> _coming(End(step=2400, time=10.0))
    'the end comes at t=10.000 s, before it ends'
    """
    noun = {"launch": "impact", "remove": "pull", "place": "placing of"}.get(action.kind, action.kind)
    what = getattr(action, "id", None)
    return (
        f"{noun} {what} comes at t={action.time:.3f} s, before it ends"
        if what
        else f"the {noun} comes at t={action.time:.3f} s, before it ends"
    )


def _limit(extension: StabilityExtension, acceleration: tuple[float, float]) -> str:
    """How near a shake the frozen stack rides is to the first brick that fails the report's tests
    (:meth:`stability.StabilityExtension.shake_limit`), in words led by " ("; "" where that has no
    bound (a leaning contact: equilibrium decides)."""
    limit = extension.shake_limit(acceleration)
    if limit is None or not math.isfinite(limit[0]) or limit[0] <= 0.0:
        return ""
    return f" ({limit[1]} from {limit[0]:.3g} m/s^2: the peak is {100.0 * math.hypot(*acceleration) / limit[0]:.0f}% of it)"


def _moving(labels: tuple[str, ...], shown: int = 3) -> str:
    """Why a shake the frozen stack would withstand is simulated all the same: what moves.

    >>> _moving(("impact1",))
    'impact1 is moving'
    >>> _moving(("a", "b", "c", "d", "e"))
    'a, b, c and 2 more are moving'
    >>> _moving(())
    'something is moving'
    """
    if not labels:
        return "something is moving"
    if len(labels) == 1:
        return f"{labels[0]} is moving"
    if len(labels) <= shown:
        return f"{', '.join(labels[:-1])} and {labels[-1]} are moving"
    return f"{', '.join(labels[:shown])} and {len(labels) - shown} more are moving"
