"""MuJoCo as a plant (world/plant.py): robots with mass move under the tick's commands, and the
engine judges what they touched.

Each tick the plant turns every agent's commanded point velocity into its robot's set-points —
a holonomic base's velocity, or a differential drive's two wheel speeds (the (v, ω) that moves
its point by exactly the command over the tick along an arc, world/unicycle.py, scaled down
together when a wheel would exceed its speed limit) — and steps the engine through the tick's
physics steps. At every physics step, each motor's PI loop pushes its joint's velocity towards
the set-point it has (one ``latency`` old), within its torque or force limit (no integration
while saturated); a robot that has had no command for ``command_timeout`` s holds a set-point of
zero, as a robot's own command timeout does. The plant owns simulated time: one tick per
:meth:`Engine.send`, whatever the wall clock does, so a lockstep run stays deterministic.

What the laws call an agent's point is read from its body every tick (a unicycle's is l ahead of
its axle's midpoint). At every physics step the plant also records (world/physics/judge.py)
the contacts the engine reports between robots, obstacles and people, and the least distances
of the points to the obstacles and to each other, so a physics run's summary is judged along
the engine's motion, not at ticks.
"""

from __future__ import annotations

from collections import deque
from typing import Any

import mujoco
import numpy as np

from shoal.bus.messages import PlantRecord
from shoal.geometry.vectors import FloatArray
from shoal.world.dynamics import Drive, Dynamics
from shoal.world.physics.judge import Judge
from shoal.world.physics.model import layout
from shoal.world.plant import Movers, Observed, PlantError
from shoal.world.scenario import Scenario
from shoal.world.unicycle import wheel_command

_DIVERGED = (
    mujoco.mjtWarning.mjWARN_BADQACC,
    mujoco.mjtWarning.mjWARN_BADQPOS,
    mujoco.mjtWarning.mjWARN_BADQVEL,
)
PINNED = "4.0.1"  # pyproject.toml's pin: physics runs are bit-exact within one MuJoCo version

_WARNED: list[str] = []  # MuJoCo's warnings in this process, newest last


def _warned(text: str) -> None:
    """MuJoCo's warnings come here, not into a MUJOCO_LOG.TXT in the user's folder: the plant
    says what went wrong itself (:meth:`Engine._check_finite`)."""
    _WARNED.append(text)
    del _WARNED[:-8]


mujoco.set_mju_user_warning(_warned)


class Engine:
    """The scenario's robots in MuJoCo (module docstring); ``robots`` each agent's dynamics
    (world/dynamics.py ``of_agents``)."""

    simulated = True

    def __init__(self, scenario: Scenario, robots: tuple[Dynamics, ...]) -> None:
        s = scenario
        self.scenario, self.robots, self.dt, self.dim = s, robots, s.dt, s.dim
        plan = layout(s, robots)
        self.xml, self.substeps, self.timestep = plan.xml, plan.substeps, plan.timestep
        self.model = mujoco.MjModel.from_xml_string(plan.xml)
        self.data = mujoco.MjData(self.model)
        self._address(s, plan.motors)
        self._gains()
        self.data.qpos[self.base_qpos] = s.initial_positions[
            self.bases
        ]  # a base's slides: its point
        mujoco.mj_forward(self.model, self.data)
        nu = self.model.nu
        self.setpoint, self.integral = np.zeros(nu), np.zeros(nu)
        self.queue: deque[tuple[int, FloatArray]] = deque()  # (physics step sent, set-points)
        self.step_count = 0
        self.heard = np.zeros(nu, dtype=np.int64)  # the physics step of each motor's last command
        self.judge = Judge(s, self.model, lambda qpos: self.points_of(qpos)[0])

    # -- the model's addresses and the loops' gains --------------------------------------------

    def _address(self, s: Scenario, motors: tuple[tuple[int, str], ...]) -> None:
        """Index arrays: the bases' and the wheeled robots' agents, their joints' positions,
        and each motor's joint velocity and agent, so that a physics step is a few array ops."""
        m = self.model
        kinds = [r.drive for r in self.robots]
        self.bases = np.array(
            [i for i, k in enumerate(kinds) if k == Drive.HOLONOMIC], dtype=np.int64
        )
        self.wheeled = np.array(
            [i for i, k in enumerate(kinds) if k == Drive.DIFFERENTIAL], dtype=np.int64
        )
        axes = "xyz"[: s.dim]
        self.base_qpos = np.array(
            [[m.joint(f"{a}{i + 1}").qposadr[0] for a in axes] for i in self.bases], dtype=np.int64
        ).reshape(-1, s.dim)
        free = [m.joint(f"free{i + 1}").qposadr[0] for i in self.wheeled]
        self.free_qpos = np.asarray(free, dtype=np.int64)[:, None] + np.arange(7)
        free_dof = [m.joint(f"free{i + 1}").dofadr[0] for i in self.wheeled]
        self.free_dof = np.asarray(free_dof, dtype=np.int64)[:, None] + np.arange(6)
        self.base_dof = np.array(
            [[m.joint(f"{a}{i + 1}").dofadr[0] for a in axes] for i in self.bases], dtype=np.int64
        ).reshape(-1, s.dim)
        yaws = [f"yaw{i + 1}" for i in self.bases] if s.dim == 2 else []
        self.yaw_qpos = np.array([m.joint(j).qposadr[0] for j in yaws], dtype=np.int64)
        self.yaw_dof = np.array([m.joint(j).dofadr[0] for j in yaws], dtype=np.int64)
        self.owner = np.array([i for i, _ in motors], dtype=np.int64)
        self.ctrl_dof = np.array(
            [m.joint(f"{j}{i + 1}").dofadr[0] for i, j in motors], dtype=np.int64
        )
        row = {(i, j): a for a, (i, j) in enumerate(motors)}
        self.base_rows = np.array([[row[i, a] for a in axes] for i in self.bases], dtype=np.int64)
        self.base_rows = self.base_rows.reshape(-1, s.dim)
        self.left = np.array([row[i, "left"] for i in self.wheeled], dtype=np.int64)
        self.right = np.array([row[i, "right"] for i in self.wheeled], dtype=np.int64)
        wheels = [self.robots[i] for i in self.wheeled]
        self.rim = np.array([r.wheel_radius for r in wheels], dtype=np.float64)
        self.half_axle = np.array([r.axle for r in wheels], dtype=np.float64) / 2
        self.top_speed = np.array([r.max_wheel_speed for r in wheels], dtype=np.float64)
        lookaheads = s.lookaheads
        self.unicycles = lookaheads is not None
        self.lookaheads = np.zeros(s.n) if lookaheads is None else lookaheads.copy()
        self.wheeled_ell = self.lookaheads[self.wheeled]
        self.start_headings = s.initial_headings.copy()

    def _gains(self) -> None:
        """Each motor's PI gains for a double pole at −1/τ of its velocity loop, kp = 2J/τ and
        ki = J/τ², with J the inertia it moves (a base's mass; half a wheeled robot's mass at the
        wheel's rim), its limit, and its latency and timeout in physics steps."""
        nu = self.model.nu
        self.kp, self.ki, self.limit = np.zeros(nu), np.zeros(nu), np.zeros(nu)
        self.latency = np.zeros(nu, dtype=np.int64)
        self.timeout = np.zeros(nu, dtype=np.int64)
        for a in range(nu):
            r = self.robots[self.owner[a]]
            if r.drive == Drive.DIFFERENTIAL:
                assert r.wheel_radius is not None and r.max_torque is not None
                inertia, self.limit[a] = 0.5 * r.mass * r.wheel_radius**2, r.max_torque
            else:
                inertia, self.limit[a] = r.mass, r.max_force
            self.kp[a] = 2.0 * inertia / r.loop_time
            self.ki[a] = inertia / r.loop_time**2
            self.latency[a] = round(r.latency / self.timestep)
            self.timeout[a] = max(1, round(r.command_timeout / self.timestep))
        self.longest_latency = int(self.latency.max(initial=0))
        self.first_timeout = int(self.timeout.min(initial=1))
        self.floor = -self.limit
        self.base_cap = self.limit[self.base_rows[:, 0]] if len(self.bases) else np.zeros(0)
        self.changes: set[int] = set()  # physics steps at which some motor's set-point changes

    # -- the plant protocol ----------------------------------------------------------------------

    def wait_ready(self, timeout: float) -> None:
        return None

    def observe(self) -> Observed:
        points, theta = self._points()
        velocities = None
        if not len(self.wheeled):  # a base's point moves with its slides: their rates, exactly
            velocities = self.data.qvel[self.base_dof].copy()
        if not self.unicycles:
            return Observed(points, None, frozenset(), velocities=velocities)
        headings = self.start_headings.copy()
        headings[self.wheeled] = theta
        return Observed(points, headings, frozenset(), velocities=velocities)

    def _points(self) -> tuple[FloatArray, FloatArray]:
        """Every agent's point (n, dim) now, and the wheeled robots' headings (in
        ``self.wheeled`` order)."""
        points, theta = self.points_of(self.data.qpos[None, :])
        return points[0], theta[0]

    def points_of(self, qpos: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The agents' points (k, n, dim) and the wheeled robots' headings (k, wheeled) at each
        of ``qpos`` (k, nq), the engine's positions at k instants: a base's slides; a wheeled
        robot's point l ahead of its axle at the yaw of its chassis. One array pass for any
        number of instants: the judge reads a whole tick's physics steps at once."""
        points = np.empty((qpos.shape[0], self.scenario.n, self.dim))
        points[:, self.bases] = qpos[:, self.base_qpos]
        if not len(self.wheeled):
            return points, np.zeros((qpos.shape[0], 0))
        pose = qpos[:, self.free_qpos]
        w, x, y, z = pose[..., 3], pose[..., 4], pose[..., 5], pose[..., 6]
        theta = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        points[:, self.wheeled, 0] = pose[..., 0] + self.wheeled_ell * np.cos(theta)
        points[:, self.wheeled, 1] = pose[..., 1] + self.wheeled_ell * np.sin(theta)
        return points, theta

    def send(
        self, velocities: FloatArray, headings: FloatArray | None, movers: Movers | None = None
    ) -> None:
        """One tick of ``velocities`` (n, dim) m/s for the agents' points: the robots' set-points
        (module docstring), then the tick's physics steps."""
        self._command(self._setpoints(velocities, headings))
        self.run(self.substeps, velocities, movers)

    def run(
        self, steps: int, commanded: FloatArray | None = None, movers: Movers | None = None
    ) -> None:
        """``steps`` physics steps on the set-points the motors have, each judged; the people
        walk ``movers`` meanwhile; ``commanded`` (n, dim), the points' velocities the steps
        were to achieve (for the tracking error; None: not tracked)."""
        self.judge.begin(self.data.qpos, commanded, steps)
        for sub in range(steps):
            if movers is not None:
                self._walk(movers, (sub + 1) / steps)
            self._physics_step()
            self.judge.physics_step(self.data, sub)
        self._check_finite()
        self.judge.end(steps * self.timestep)

    def _check_finite(self) -> None:
        """:class:`PlantError` if the engine diverged: MuJoCo resets a state that has gone
        non-finite or huge (and warns), which would put robots back at their starts unseen."""
        d = self.data
        bad = [w for w in _DIVERGED if d.warning[w].number > 0]
        if bad or not np.isfinite(d.qpos).all():
            t = self.step_count * self.timestep
            raise PlantError(
                f"the physics diverged at {t:.3f} s of simulated time (MuJoCo: "
                f"{', '.join(w.name for w in bad) or 'non-finite positions'}"
                f"{'; ' + _WARNED[-1].strip() if _WARNED else ''}): a physics step too long "
                "for the robots' loops or masses (dynamics.timestep, loop_time, mass)"
            )

    def stop(self) -> None:
        """Zero set-points from now (the engine does not step until the next :meth:`send`)."""
        self._command(np.zeros(self.model.nu))

    def idle(self, ticks: int) -> None:
        """Let ``ticks`` ticks pass with no command (the robots' own timeouts stop them)."""
        for _ in range(ticks * self.substeps):
            self._physics_step()

    def record(self, tick: int) -> PlantRecord:
        """The bodies, motors and contacts of the tick just stepped (bus/messages.py)."""
        d, two = self.data, self.dim == 2
        bodies = np.empty((self.scenario.n, self.dim))
        velocities = np.empty((self.scenario.n, self.dim))
        bodies[self.bases] = d.qpos[self.base_qpos]
        velocities[self.bases] = d.qvel[self.base_dof]
        poses = self.body_poses() if two else None
        if len(self.wheeled):
            bodies[self.wheeled] = d.qpos[self.free_qpos[:, :2]]
            velocities[self.wheeled] = d.qvel[self.free_dof[:, :2]]
        turns = np.empty(self.scenario.n)
        if two:
            turns[self.bases] = d.qvel[self.yaw_dof]
            turns[self.wheeled] = d.qvel[self.free_dof[:, 5]]
        return PlantRecord(
            tick,
            bodies=tuple(map(tuple, bodies.tolist())),
            velocities=tuple(map(tuple, velocities.tolist())),
            motor_speeds=tuple(d.qvel[self.ctrl_dof].tolist()),
            motor_efforts=tuple(d.ctrl.tolist()),
            yaws=() if poses is None else tuple(poses[:, 2].tolist()),
            turn_rates=tuple(turns.tolist()) if two else (),
            contacts=self.judge.stretch_contacts(),
        )

    # -- robots driven by twists (a ROS 2 fleet on the wall clock: tools/ros2/physics.py) -----

    def hold(self, agent: int, twist: tuple[float, float, float]) -> None:
        """Agent ``agent``'s (0-based) robot takes a Twist in its own frame — linear x, linear
        y, angular z — as a driver does: a wheeled robot its linear x and angular z (its wheel
        speeds scaled down together to their limit), a base its linear x and y (its yaw is
        free). Its other motors, and every other robot's, keep their set-points."""
        vx, vy, wz = twist
        out = np.zeros(self.model.nu)
        motors = self.owner == agent
        row = np.flatnonzero(self.wheeled == agent)
        if row.size:
            k = int(row[0])
            out[self.left[k]], out[self.right[k]] = self._wheel_speeds(vx, wz, k)
        else:
            yaw = self.body_poses()[agent, 2]
            c, s = np.cos(yaw), np.sin(yaw)
            world = (c * vx - s * vy, s * vx + c * vy, 0.0)[: self.dim]
            out[motors] = world
        self._command(out, motors)

    def body_poses(self) -> FloatArray:
        """(n, 3) every robot's body: x, y (m) and yaw (rad) — a wheeled robot's axle midpoint,
        a base's centre (its free yaw joint's angle)."""
        d, out = self.data, np.zeros((self.scenario.n, 3))
        out[self.bases, :2] = d.qpos[self.base_qpos[:, :2]]
        out[self.bases, 2] = d.qpos[self.yaw_qpos]
        if len(self.wheeled):
            pose = d.qpos[self.free_qpos]
            w, x, y, z = pose[:, 3], pose[:, 4], pose[:, 5], pose[:, 6]
            out[self.wheeled, :2] = pose[:, :2]
            out[self.wheeled, 2] = np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
        return out

    def body_twists(self) -> FloatArray:
        """(n, 3) every robot's measured velocity in its own frame: linear x, y (m/s) and
        angular z (rad/s), as its odometry reports it."""
        d, poses = self.data, self.body_poses()
        world = np.zeros((self.scenario.n, 3))
        world[self.bases, :2] = d.qvel[self.base_dof[:, :2]]
        world[self.bases, 2] = d.qvel[self.yaw_dof]
        world[self.wheeled, :2] = d.qvel[self.free_dof[:, :2]]
        world[self.wheeled, 2] = d.qvel[self.free_dof[:, 5]]  # the free joint's angular z
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        return np.stack([c * world[:, 0] + s * world[:, 1], -s * world[:, 0] + c * world[:, 1],
                         world[:, 2]], axis=1)  # fmt: skip

    def report(self) -> dict[str, Any]:
        """The summary of a physics run: which plant and presets, and the judgement of the
        engine's motion (world/physics/judge.py), which replaces the ticks' own."""
        presets = sorted({r.preset for r in self.robots})
        return {
            "plant": "mujoco",
            "dynamics": ", ".join(presets),
            "physics_step": self.timestep,
            **self.judge.report(),
        }

    # -- one physics step --------------------------------------------------------------------------

    def _setpoints(self, velocities: FloatArray, headings: FloatArray | None) -> FloatArray:
        out = np.zeros(self.model.nu)
        out[self.base_rows] = velocities[self.bases]
        if len(self.wheeled):
            assert headings is not None
            w = self.wheeled
            v, turn = wheel_command(velocities[w], headings[w], self.lookaheads[w], self.dt)
            out[self.left], out[self.right] = self._wheel_speeds(v, turn, slice(None))
        return out

    def _wheel_speeds(self, v: Any, turn: Any, rows: Any) -> tuple[Any, Any]:
        """The left and right wheel speeds (rad/s) of the wheeled robots ``rows`` (an index of
        ``self.wheeled``) for speed ``v`` m/s and turn rate ``turn`` rad/s, both scaled down
        together at the wheels' limit (the same curvature)."""
        left = (v - turn * self.half_axle[rows]) / self.rim[rows]
        right = (v + turn * self.half_axle[rows]) / self.rim[rows]
        fastest = np.maximum(np.maximum(np.abs(left), np.abs(right)), 1e-300)
        scale = np.minimum(1.0, self.top_speed[rows] / fastest)
        return scale * left, scale * right

    def _command(self, setpoints: FloatArray, motors: Any = slice(None)) -> None:
        """New set-points for ``motors`` (an index of the actuators; default all of them),
        acted on once each motor's latency has passed; the others keep theirs."""
        now = self.step_count
        latest = self.queue[-1][1].copy() if self.queue else np.zeros(self.model.nu)
        latest[motors] = setpoints[motors]
        self.queue.append((now, latest))
        self.changes.update(now + int(lag) for lag in np.unique(self.latency))
        self.heard[motors] = now

    def _physics_step(self) -> None:
        """The motors' PI loops on the set-points they have now, then one engine step. Kept to
        a few array operations: it runs a thousand times per simulated second."""
        d, now = self.data, self.step_count
        if now in self.changes:
            self._due(now)
        if now - int(self.heard.min(initial=now)) >= self.first_timeout:
            self.setpoint[now - self.heard >= self.timeout] = 0.0
        error = self.setpoint - d.qvel[self.ctrl_dof]
        raw = self.kp * error + self.ki * self.integral
        force = np.minimum(np.maximum(raw, self.floor), self.limit)
        if len(self.bases):  # a base's force vector within its norm, not each axis
            rows = raw[self.base_rows]
            size = np.sqrt(np.einsum("ij,ij->i", rows, rows))
            scale = self.base_cap / np.maximum(size, self.base_cap)
            force[self.base_rows] = rows * scale[:, None]
        error[force != raw] = 0.0  # no integration while saturated
        self.integral += error * self.timestep
        d.ctrl[:] = force
        mujoco.mj_step(self.model, d)
        self.step_count += 1

    def _due(self, now: int) -> None:
        """Each motor's set-point: the newest sent at least its latency ago."""
        self.changes.discard(now)
        while len(self.queue) > 1 and self.queue[1][0] + self.longest_latency <= now:
            self.queue.popleft()
        for sent, values in self.queue:
            due = sent + self.latency <= now
            self.setpoint[due] = values[due]

    def _walk(self, movers: Movers, fraction: float) -> None:
        """The people at ``fraction`` of the tick along their straight step."""
        start, end = movers
        for row, k in enumerate(self.scenario.mover_ids):
            body = self.model.body(f"person{k}").mocapid[0]
            a, b = start[row], end[row]
            where = [x + fraction * (y - x) for x, y in zip(a, b, strict=True)]
            if self.dim == 2:
                where.append(self.data.mocap_pos[body][2])
            self.data.mocap_pos[body] = where
