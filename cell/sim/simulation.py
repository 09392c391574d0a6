"""The physics of the cell: MuJoCo model and data, indices, stepping with servo set-points.

This is the real cell's engine room. The controller drives it; only the evaluator and the
tests look inside. Python work per physics step is one set-point write and one `mj_step`.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from models.robot import FLANGE_SITE, JOINT_NAMES, Q_HOME, TABLE_GUIDE_JOINTS, TOOLS

#: Steps between two calls of the motion supervision (4 ms at the 2 ms step).
GUARD_EVERY = 2


class MotionStoppedError(Exception):
    """A move stopped by the motion supervision after `steps` of its set-points; the
    message says why."""

    def __init__(self, message: str, steps: int, halt: bool = False) -> None:
        super().__init__(message)
        self.steps = steps
        #: Stopped by the clock (a program stop asked from outside), not by the supervision.
        self.halt = halt


class Simulation:
    """A compiled cell model with its data, reset to the `home` keyframe."""

    def __init__(self, model: mujoco.MjModel, q_home: np.ndarray | None = None) -> None:
        self.model = model
        self.q_home = np.array(Q_HOME if q_home is None else q_home, dtype=float)
        self.data = mujoco.MjData(model)
        m = model
        self.dt = float(m.opt.timestep)
        self.arm_qadr = np.array([m.joint(n).qposadr[0] for n in JOINT_NAMES])
        self.arm_dofadr = np.array([m.joint(n).dofadr[0] for n in JOINT_NAMES])
        self.arm_act = np.array([m.actuator(n).id for n in JOINT_NAMES])
        # Servo: force = kp (ctrl - q) - kv qdot, so ctrl = q_ref + kv/kp qdot_ref tracks both.
        self.arm_ff = -m.actuator_biasprm[self.arm_act, 2] / m.actuator_gainprm[self.arm_act, 0]
        self.table_qadr = int(m.joint("table_slide").qposadr[0])
        self.table_act = int(m.actuator("table_slide").id)
        self.guide_act = np.array([m.actuator(n).id for n in TABLE_GUIDE_JOINTS])
        self.guide_qadr = np.array([m.joint(n).qposadr[0] for n in TABLE_GUIDE_JOINTS])
        self.table_ff = float(
            -m.actuator_biasprm[self.table_act, 2] / m.actuator_gainprm[self.table_act, 0]
        )
        self.finger_act = np.array([m.actuator("finger_left").id, m.actuator("finger_right").id])
        self.finger_qadr = np.array(
            [m.joint("finger_left").qposadr[0], m.joint("finger_right").qposadr[0]]
        )
        self.spindle_act = int(m.actuator("screwer_spindle").id)
        self.link6 = int(m.body("link6").id)
        self.flange_site = int(m.site(FLANGE_SITE).id)
        self.tool_body = {t.name: int(m.body(t.body).id) for t in TOOLS}
        self.tcp_site = {t.name: int(m.site(t.tcp_site).id) for t in TOOLS}
        self.slot_site = {t.name: int(m.site(f"slot_{t.name}").id) for t in TOOLS}
        self.rack_body = int(m.body("rack").id)
        self.rack_eq = {t.name: int(m.equality(f"rack_{t.name}").id) for t in TOOLS}
        self.flange_eq = {t.name: int(m.equality(f"flange_{t.name}").id) for t in TOOLS}
        self.home_key = int(m.key("home").id)
        self._watcher: Callable[[mujoco.MjData], None] | None = None
        #: The controller's motion supervision: called every `GUARD_EVERY` steps of a move;
        #: a message stops the move (`MotionStoppedError` is raised after that step).
        self.guard: Callable[[], str | None] | None = None
        #: The clock the cell's time is paced by: called with the simulated time [s] every
        #: `GUARD_EVERY` steps (a served twin keeps it locked to the wall clock); a message
        #: halts a move where it is (`MotionStoppedError` with `halt`).
        self.clock: Callable[[float], str | None] | None = None
        self._watch_every = 1
        self._since = 0
        self.reset()

    def watch(self, watcher: Callable[[mujoco.MjData], None] | None, period_s: float) -> None:
        """Call `watcher(data)` every `period_s` [s] of simulated time while the cell moves
        (None: stop). A witness of the real cell (a recording), never a controller's sense."""
        self._watcher = watcher
        self._watch_every = max(1, round(period_s / self.dt))
        self._since = 0

    def reset(self) -> None:
        """Home keyframe, servos holding home, table at 0, gripper open, spindle still."""
        m, d = self.model, self.data
        mujoco.mj_resetDataKeyframe(m, d, self.home_key)
        d.ctrl[:] = 0.0
        d.ctrl[self.arm_act] = self.q_home
        d.ctrl[self.finger_act] = m.actuator_ctrlrange[self.finger_act, 1]
        d.qpos[self.finger_qadr] = d.ctrl[self.finger_act]
        mujoco.mj_forward(m, d)

    # -- stepping -----------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        """Advance `n` physics steps with the current set-points."""
        n = int(n)
        if self.clock is not None:
            self._paced(n)
            return
        if self._watcher is None:
            if n > 0:
                mujoco.mj_step(self.model, self.data, nstep=n)
            return
        while n > 0:
            k = min(n, self._watch_every - self._since)
            mujoco.mj_step(self.model, self.data, nstep=k)
            n -= k
            self._tick(k)

    def _paced(self, n: int) -> None:
        """`n` steps in slices of `GUARD_EVERY`, the clock called after each (a hold is not
        halted: its message is dropped)."""
        clock, watcher = self.clock, self._watcher
        while n > 0 and clock is not None:
            k = min(n, GUARD_EVERY)
            mujoco.mj_step(self.model, self.data, nstep=k)
            n -= k
            if watcher is not None:
                self._tick(k)
            clock(self.time)

    def settle(self, seconds: float) -> None:
        """Hold the current set-points for `seconds` [s]."""
        self.step(round(seconds / self.dt))

    def run(self, actuators: np.ndarray, setpoints: np.ndarray) -> None:
        """Step once per row of `setpoints` (K, len(actuators)), writing it as the set-point."""
        m, d, ctrl = self.model, self.data, self.data.ctrl
        watched = self._watcher is not None
        guard, clock = self.guard, self.clock
        for k, row in enumerate(setpoints):
            ctrl[actuators] = row
            mujoco.mj_step(m, d)
            if watched:
                self._tick(1)
            if k % GUARD_EVERY == 0:
                reason = None if guard is None else guard()
                if reason is not None:
                    raise MotionStoppedError(reason, k + 1)
                reason = None if clock is None else clock(float(d.time))
                if reason is not None:
                    raise MotionStoppedError(reason, k + 1, halt=True)

    def _tick(self, steps: int) -> None:
        self._since += steps
        if self._since >= self._watch_every and self._watcher is not None:
            self._since = 0
            self._watcher(self.data)

    # -- state (truth: only the controller's sensor models and evaluators read these) ----------
    @property
    def time(self) -> float:
        """Simulated time [s]."""
        return float(self.data.time)

    def arm_q(self) -> np.ndarray:
        """(6,) true joint positions [rad]."""
        return self.data.qpos[self.arm_qadr].copy()

    def arm_setpoint(self) -> np.ndarray:
        """(6,) current position set-points of the arm servos [rad] (velocity term removed)."""
        return self.data.ctrl[self.arm_act].copy()

    def table_q(self) -> float:
        """True table slide position [m]."""
        return float(self.data.qpos[self.table_qadr])

    def site_T(self, site: int) -> np.ndarray:
        """(4, 4) world pose of site `site`."""
        T = np.eye(4)
        T[:3, :3] = self.data.site_xmat[site].reshape(3, 3)
        T[:3, 3] = self.data.site_xpos[site]
        return T

    def body_T(self, body: int) -> np.ndarray:
        """(4, 4) world pose of body `body`."""
        T = np.eye(4)
        T[:3, :3] = self.data.xmat[body].reshape(3, 3)
        T[:3, 3] = self.data.xpos[body]
        return T

    def warnings(self) -> int:
        """Number of MuJoCo warnings raised since the last reset (all kinds)."""
        return int(sum(w.number for w in self.data.warning))
