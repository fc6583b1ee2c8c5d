"""What a robot with mass can reach (docs/safety.md, Robots with mass): the bounds a robot's body
keeps, and from them, for one robot, where it can be over the next step and how far it still
goes once told to stop.

A robot is told a velocity u_j at tick j (time j·dt); its motors act on it a latency L later, so
the command *in force* c(t) is u_j over [j·dt + L, (j+1)·dt + L) (0 before the first). Its
velocity w(t) does not jump to c(t): the tracking error e = w − c jumps by |u_j − u_{j−1}| when
a command comes into force and, the plant's bound, then decays at least as

    d|e|/dt ≤ −min(a, |e|/τ)

(``braking`` a m/s², the least the loop decelerates a large error; ``lag`` τ s, its time
constant once the error is small). A pure acceleration limit is τ = 0, a first-order loop
a = ∞, a saturated loop both. From those two numbers and the commands the robot was sent, its
*envelope* E(t) ≥ |e(t)| is known at every instant, and so is its *tube*: from a pose s(t_p),

    s(t) ∈ ball( p(t), δ(t) ),   p(t) = s(t_p) + ∫ c,   δ(t) = ∫ E   (both from t_p to t),

whatever the robot's velocity at t_p within the envelope. Everything here is scalar arithmetic
on floats, the same in every process.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from shoal.bus.types import Vector
from shoal.world.dynamics import Dynamics

# s: a pose older than this is not trusted; its robot brakes (a zero command it reaches within
# its bounds) until a younger one arrives.
HORIZON = 0.5
# The tracking error of a PI velocity loop tuned kp = 2J/τ, ki = J/τ² (world/physics/engine.py)
# after a step Δ is Δ·(1 − t/τ)·e^(−t/τ): it overshoots, and only Δ·e^(−t/(2τ)) bounds it. The
# lag of a robot's bound is this many of its loop's time constants.
LAG_PER_LOOP_TIME = 2.0
# s: two instants this close are one (k·dt − age and j·dt + L computed in floats).
_SAME_TIME = 1e-12


@dataclass(frozen=True, slots=True)
class Bounds:
    """What the robot's body keeps (module docstring): ``latency`` L s, ``braking`` a m/s²
    (inf: no limit), ``lag`` τ s (0: none), and the ``horizon`` s beyond which its pose is not
    trusted; ``memoryless`` below. ``Bounds()`` is a robot that moves as commanded, the instant
    it is told."""

    latency: float = 0.0
    braking: float = math.inf
    lag: float = 0.0
    horizon: float = HORIZON
    # Whether the loop's error depends on itself alone (a P loop, an acceleration limit), so
    # that the law above holds from any instant and a measured velocity can restart the
    # envelope. A PI loop's integral remembers: its error crosses zero and comes back (the
    # physics plant's, after a step), and only the bound from each command's jump holds.
    memoryless: bool = False

    @staticmethod
    def of(dynamics: Dynamics | None) -> Bounds:
        """The bounds of a robot with ``dynamics`` (None: the kinematic plant's ideal robot)."""
        if dynamics is None:
            return Bounds()
        return Bounds(
            latency=dynamics.latency,
            braking=dynamics.braking,
            lag=LAG_PER_LOOP_TIME * dynamics.loop_time,
        )

    @property
    def ideal(self) -> bool:
        """A robot that moves as commanded, the instant it is told: every envelope is 0."""
        return self.latency == 0.0 and self.braking == math.inf and self.lag == 0.0

    def decay(self, e: float, h: float) -> float:
        """The envelope ``h`` s after it was ``e`` m/s, with no command coming into force."""
        if e <= 0.0:
            return 0.0
        a, tau = self.braking, self.lag
        knee = a * tau if a != math.inf else math.inf  # below it the loop's own rate rules
        if e > knee:
            linear = (e - knee) / a
            if h <= linear:
                return e - a * h
            e, h = knee, h - linear
        if tau == 0.0:
            return 0.0
        return e * math.exp(-h / tau)

    def area(self, e: float, h: float) -> float:
        """m: ∫ of the envelope over ``h`` s (``math.inf``: until it dies out) from ``e`` m/s —
        how far the robot can be from where its commands in force take it, gathered over that
        time. From ``e`` ≥ a·τ to the end: e²/2a + a·τ²/2; below: e·τ."""
        if e <= 0.0 or h <= 0.0:
            return 0.0
        a, tau = self.braking, self.lag
        knee = a * tau if a != math.inf else math.inf
        out = 0.0
        if e > knee:
            linear = (e - knee) / a
            if h <= linear:
                return e * h - a * h * h / 2.0
            out = (e * e - knee * knee) / (2.0 * a)
            e, h = knee, h - linear
        if tau == 0.0:
            return out
        if h == math.inf:
            return out + e * tau
        return out + e * tau * -math.expm1(-h / tau)


@dataclass(frozen=True, slots=True)
class Start:
    """Where a robot's next step starts, as its layer knows it at tick k: the step is the
    command u_k in force, over [k·dt + L, (k+1)·dt + L).

    ``position`` p m, where its commands take it from its last pose; ``tube`` δ m, how far it
    can be from p then; ``envelope`` E m/s, the bound on its tracking error just before u_k
    comes into force; ``before`` u_{k−1} m/s, the command in force until then, and ``last`` its
    speed; ``drift`` m, how far p is from the pose (what the robot senses is sensed from its
    pose)."""

    position: Vector
    tube: float
    envelope: float
    before: Vector
    last: float
    drift: float


class Track:
    """One robot's commands and its envelope, as its layer sent them: enough to say where it can
    be from any pose younger than the horizon (:meth:`start`), and how much margin a step at up
    to a speed v needs (:meth:`margin`)."""

    def __init__(self, bounds: Bounds, dt: float, dim: int) -> None:
        self.bounds, self.dt, self.dim = bounds, dt, dim
        self.keep = math.ceil((bounds.horizon + bounds.latency) / dt) + 2
        # Per command sent, oldest first: (tick j, u_j, the envelope just after it came into force).
        self.sent: list[tuple[int, Vector, float]] = []
        self.dropped = False  # whether older commands were let go
        # The youngest pose used so far: (its time, s; where; its measured velocity or None).
        # A pose older than it (poses can arrive out of order) is not used: what the layer
        # certified from the younger one stays certified only if it goes on from there.
        self.freshest: tuple[float, Vector, Vector | None] | None = None

    def record(self, k: int, u: Vector) -> None:
        """The command ``u`` went out at tick ``k`` (after every earlier one)."""
        zero = (0.0,) * self.dim
        before, envelope = (self.sent[-1][1], self.sent[-1][2]) if self.sent else (zero, 0.0)
        if self.sent:
            envelope = self.bounds.decay(envelope, self.dt * (k - self.sent[-1][0]))
        jump = math.dist(u, before)
        self.sent.append((k, u, envelope + jump))
        if len(self.sent) > self.keep:
            del self.sent[0]
            self.dropped = True

    def start(
        self, k: int, pose: Vector, age: float, velocity: Vector | None = None
    ) -> Start | None:
        """Where the step of tick ``k`` starts, from the robot's ``pose`` ``age`` s old at k·dt
        (every command up to tick k − 1 recorded) and, if measured with it, its ``velocity``
        then (for a memoryless loop the envelope from then on starts at its exact tracking
        error); None when the pose
        is older than the horizon, or from before the oldest command kept."""
        b, dt = self.bounds, self.dt
        t_pose, t_start = k * dt - age, k * dt + b.latency
        if self.freshest is not None and self.freshest[0] > t_pose + _SAME_TIME:
            t_pose, pose, velocity = self.freshest  # a pose older than one already used
        else:
            self.freshest = (t_pose, pose, velocity)
        if not 0.0 <= k * dt - t_pose <= b.horizon + _SAME_TIME:
            return None
        if self.dropped and t_pose < self.sent[0][0] * dt + b.latency:
            return None  # the commands in force then are no longer kept
        position = list(pose)
        tube = 0.0
        pieces = self.sent
        e = math.nan  # the envelope at the start of the current piece of the window
        before: Vector = ()
        if velocity is not None and b.memoryless:  # the exact error then bounds it from then on
            e, before = self._measured(t_pose, velocity)
        # u_j is in force over [j·dt + L, next command's j'·dt + L); the last one until t_start.
        for index, (j, u, jumped) in enumerate(pieces):
            begin = j * dt + b.latency
            end = pieces[index + 1][0] * dt + b.latency if index + 1 < len(pieces) else t_start
            lo, hi = max(begin, t_pose), min(end, t_start)
            if hi <= lo + _SAME_TIME:
                continue  # not in the window (or only by rounding)
            if math.isnan(e):  # the first piece of the window
                e = b.decay(jumped, lo - begin)
            elif lo > t_pose + _SAME_TIME or before != u:  # its jump onto the envelope so far
                e = min(e + math.dist(u, before), b.decay(jumped, lo - begin))
            tube += b.area(e, hi - lo)
            e = b.decay(e, hi - lo)
            before = u
            for c in range(self.dim):
                position[c] += u[c] * (hi - lo)
        if not pieces:
            envelope = last = 0.0
            u = (0.0,) * self.dim
        else:
            j, u, jumped = pieces[-1]
            envelope = b.decay(jumped, t_start - (j * dt + b.latency))
            if not math.isnan(e):
                envelope = min(envelope, e)
            last = math.hypot(*u)  # in force until the step starts
        at = tuple(position)
        return Start(at, tube, envelope, u, last, math.dist(at, pose))

    def _measured(self, t: float, velocity: Vector) -> tuple[float, Vector]:
        """The envelope at ``t`` from the ``velocity`` measured then: the tracking error
        against the command in force at ``t`` (0 before the first), no more than the envelope
        the commands alone give; and that command."""
        b, dt = self.bounds, self.dt
        u: Vector = (0.0,) * self.dim
        e = 0.0
        for j, sent, jumped in self.sent:
            begin = j * dt + b.latency
            if begin > t + _SAME_TIME:
                break
            u, e = sent, b.decay(jumped, t - begin)
        return min(e, math.dist(velocity, u)), u

    def margin(self, start: Start, v: float, jump: float | None = None) -> float:
        """m: how far the robot can be from where its commands take it, over the step of a
        command u_k of speed ≤ ``v`` and all the way to rest if it is told to stop after it: the
        tube at the step's start, what the envelope gathers over the step after u_k comes into
        force (a ``jump`` |u_k − u_{k−1}|, at most |u_{k−1}| + v when not given), and, with 0
        in force from the step's end (a jump of at most v), until it dies out."""
        b = self.bounds
        e = start.envelope + (start.last + v if jump is None else jump)
        return start.tube + b.area(e, self.dt) + b.area(b.decay(e, self.dt) + v, math.inf)
