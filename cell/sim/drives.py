"""The arm's drives: between the motors, where the controller commands and the encoders
read, and the links, where the tool is.

The controller commands motor angles. A link stops short of its motor by
- the gearbox's torsion under the gravity torque of the arm and its payload (joints 2, 3),
- half the joint's lost motion, on the side the joint came from,
- a small random spread redrawn at every move (the arm's pose repeatability),
- a slow zero drift as the arm warms up, linear or approaching its warm state (off by
  default),
so the encoders (on the motors) read the commanded angles while the links, and the tool,
are elsewhere. All of it is the real cell's (cell.sim.config.DriveErrors); the controller knows
none of it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import numpy as np
import pinocchio as pin

from cell.kinematics import Kinematics, payload_model
from cell.sim.config import DriveErrors
from cell.sim.simulation import MotionStoppedError, Simulation

Reading = TypeVar("Reading")

#: The gravity torques are computed every this many set-points of a move and interpolated.
_EVERY = 10
#: A joint "moved" (its lost motion switches side) when it travelled at least this [rad].
_MOVED_RAD = 1e-7


class Drives:
    """The real arm's drives in `sim` (see the module's docstring): `stiffness_nm_rad` (2,)
    the real stiffness of joints 2 and 3 (0: rigid), the real arm's `kinematics` (for its
    gravity torques), `tool_in_hand` tells the payload."""

    def __init__(
        self,
        sim: Simulation,
        kinematics: Kinematics,
        errors: DriveErrors,
        stiffness_nm_rad: np.ndarray,
        tool_in_hand: Callable[[], str | None],
        rng: np.random.Generator,
    ) -> None:
        self.sim = sim
        self.errors = errors
        self._kinematics = kinematics
        self._compliance = np.zeros(6)
        k = np.asarray(stiffness_nm_rad, dtype=float)
        self._compliance[1:3] = np.where(k > 0.0, 1.0 / np.where(k > 0.0, k, 1.0), 0.0)
        self._half_lost = np.asarray(errors.hysteresis_rad, dtype=float) / 2.0
        self._drift = np.zeros(6)
        self._drift[1:3] = errors.drift_rad_per_s
        self._warmup = np.asarray(errors.warmup_rad, dtype=float)
        self._tool_in_hand = tool_in_hand
        self._rng = rng
        self._models: dict[str | None, tuple[pin.Model, pin.Data]] = {}
        self.direction = np.zeros(6)  # side each joint last came from (+1, -1; 0: not yet)
        self.jitter = np.zeros(6)
        self.motor = sim.q_home.copy()  # the motors' set-point [rad]
        self.hold()

    # -- the links' offsets from the motors ------------------------------------------------
    def _gravity(self, q: np.ndarray) -> np.ndarray:
        tool = self._tool_in_hand()
        if tool not in self._models:
            model = payload_model(self._kinematics, tool)
            self._models[tool] = (model, model.createData())
        model, data = self._models[tool]
        return np.asarray(pin.computeGeneralizedGravity(model, data, np.asarray(q, float)))

    def offset(self, q: np.ndarray) -> np.ndarray:
        """(6,) motor angle minus link angle [rad] at joints `q` (6,) now."""
        t = self.sim.time
        out = self._half_lost * self.direction + self.jitter + self._drift * t
        if self._warmup.any():
            errors = self.errors
            out = out + self._warmup * -np.expm1(-(errors.warm_s + t) / errors.warmup_tau_s)
        if self._compliance.any():
            out = out + self._compliance * self._gravity(q)
        return out

    def offsets(self, q: np.ndarray) -> np.ndarray:
        """(K, 6) offsets along a move's set-points `q` (K, 6), the gravity torques computed
        every few set-points and interpolated."""
        k = len(q)
        at = np.unique(np.r_[np.arange(0, k, _EVERY), k - 1])
        sampled = np.array([self.offset(q[i]) for i in at])
        rows = np.arange(k)
        return np.stack([np.interp(rows, at, sampled[:, j]) for j in range(6)], axis=1)

    # -- commands ---------------------------------------------------------------------------
    def run(
        self,
        q: np.ndarray,
        qd: np.ndarray,
        read: Callable[[], Reading] | None = None,
        every: int = 1,
        new_move: bool = True,
    ) -> list[Reading]:
        """Run motor set-points `q` (K, 6) [rad] and velocities `qd` (K, 6) [rad/s], one
        per physics step, as one move (its own repeatability draw; with `new_move` False, the
        next slice of the move before: a streamed reference); the links' servos get them
        less the offsets. `read()`, if given, is called
        after every `every` steps and after the last; its readings are returned."""
        q = np.asarray(q, dtype=float)
        if not len(q):
            return []
        moved = q[-1] - self.motor
        turned = np.abs(moved) >= _MOVED_RAD
        self.direction = np.where(turned, np.sign(moved), self.direction)
        if new_move and self.errors.repeat_sigma_rad > 0.0:
            self.jitter = self._rng.normal(0.0, self.errors.repeat_sigma_rad, 6)
        sim = self.sim
        setpoints = q - self.offsets(q) + sim.arm_ff * qd
        step = every if read is not None else len(q)
        readings = []
        for start in range(0, len(q), step):
            end = min(start + step, len(q))
            try:
                sim.run(sim.arm_act, setpoints[start:end])
            except MotionStoppedError as stop:  # the motors stand at the last set-point given
                self.motor = q[start + stop.steps - 1].copy()
                raise MotionStoppedError(str(stop), start + stop.steps, stop.halt) from None
            self.motor = q[end - 1].copy()
            if read is not None:
                readings.append(read())
        return readings

    def hold(self) -> None:
        """Hold the motors at their set-point (after the payload or the time changed)."""
        sim = self.sim
        sim.data.ctrl[sim.arm_act] = self.motor - self.offset(self.motor)

    def read_motors(self) -> np.ndarray:
        """(6,) the motors' angles [rad]: the links' plus their offsets (noise-free)."""
        q = self.sim.arm_q()
        return q + self.offset(q)
