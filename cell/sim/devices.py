"""The real cell's devices with their hidden errors: joint encoders and the table axis."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell.sim.faults import FaultInjector
from cell.sim.simulation import MotionStoppedError, Simulation
from cell.trajectory import joint_trajectory
from models.robot import TABLE_TRAVEL


class Encoders:
    """Joint readings: the motors' angles (`motors()`, see cell.sim.drives) plus Gaussian noise
    `sigma_rad`, from two channels per joint (a safety encoder's redundant channels, each
    with its own noise); `faults` may make one reading of channel A jump (encoder_glitch)."""

    def __init__(
        self,
        motors: Callable[[], np.ndarray],
        sigma_rad: float,
        rng: np.random.Generator,
        faults: FaultInjector | None = None,
    ) -> None:
        self.motors = motors
        self.sigma_rad = sigma_rad
        self.rng = rng
        self.faults = faults
        self._glitch_in: int | None = None  # readings until the glitch

    def read(self) -> np.ndarray:
        """(6,) measured joint positions [rad] (channel A)."""
        return self.read_channels()[0]

    def read_channels(self) -> tuple[np.ndarray, np.ndarray]:
        """(6,), (6,) the joint positions [rad] as channels A and B measure them now."""
        q = self.motors()
        a, b = q.copy(), q
        if self.sigma_rad > 0.0:
            a += self.rng.normal(0.0, self.sigma_rad, q.shape)
            b = b + self.rng.normal(0.0, self.sigma_rad, q.shape)
        fault = None if self.faults is None else self.faults.armed("encoder_glitch")
        if fault is not None and self.faults is not None:
            if self._glitch_in is None:
                self._glitch_in = int(self.faults.rng.integers(5, 60))
            self._glitch_in -= 1
            if self._glitch_in <= 0:
                joint = int(self.faults.rng.integers(0, 6))
                a[joint] += fault.amount
                self.faults.fire(
                    "encoder_glitch", f"joint {joint + 1} read {fault.amount:g} rad off once"
                )
        return a, b


def table_profile(
    profile: np.ndarray, position_m: float, travel: tuple[float, float]
) -> np.ndarray:
    """(4,) the carriage's guideway errors at slide position `position_m` [m]: sideways and
    vertical deviation [m] (bows of amplitude profile[0], profile[1], zero on average over
    the travel) and pitch and yaw [rad] (linear over the travel, profile[2], profile[3] at
    its positive end)."""
    half = (travel[1] - travel[0]) / 2.0
    u = (position_m - (travel[0] + travel[1]) / 2.0) / half
    bow = u * u - 1.0 / 3.0
    return np.array([profile[0] * bow, profile[1] * bow, profile[2] * u, profile[3] * u])


class TableAxis:
    """The table's linear axis: it goes to the command plus a bias and a per-move error, its
    carriage deviates from a straight travel by its guideway's `profile` (see
    `table_profile`), and its readout reports the commanded frame (it sees none of it)."""

    def __init__(
        self,
        sim: Simulation,
        bias_m: float,
        repeat_sigma_m: float,
        rng: np.random.Generator,
        profile: np.ndarray | None = None,
    ) -> None:
        self.sim = sim
        self.bias_m = bias_m
        self.repeat_sigma_m = repeat_sigma_m
        self.rng = rng
        self.profile = np.zeros(4) if profile is None else np.asarray(profile, dtype=float)
        self.faults: FaultInjector | None = None
        self.lie_m = 0.0  # what a lying readout adds (table_stall, option lying)
        self.error_m = bias_m  # current positioning error (truth)
        self.target_m = 0.0
        sim.data.qpos[sim.table_qadr] = self.error_m
        sim.data.ctrl[sim.table_act] = self.error_m
        guide = self.guide(self.error_m)
        sim.data.ctrl[sim.guide_act] = guide
        sim.data.qpos[
            [sim.model.jnt_qposadr[sim.model.actuator_trnid[a, 0]] for a in sim.guide_act]
        ] = guide

    def guide(self, slide_m: float) -> np.ndarray:
        """(4,) the guideway errors with the slide at `slide_m` [m]."""
        return table_profile(self.profile, slide_m, TABLE_TRAVEL)

    def move(self, position_m: float, speed_m_s: float, settle_s: float) -> None:
        """Drive to `position_m` [m] at up to `speed_m_s`, then settle."""
        sim = self.sim
        start = float(sim.data.ctrl[sim.table_act])
        self.error_m = self.bias_m + (
            float(self.rng.normal(0.0, self.repeat_sigma_m)) if self.repeat_sigma_m > 0 else 0.0
        )
        self.target_m = position_m
        self.lie_m = 0.0
        goal = position_m + self.error_m
        fault = None if self.faults is None else self.faults.armed("table_stall")
        if fault is not None and self.faults is not None and abs(goal - start) > 1e-4:
            short = min(fault.amount, abs(goal - start)) * np.sign(goal - start)
            goal -= short
            if fault.option == "lying":
                self.lie_m = short
            self.faults.fire(
                "table_stall",
                f"stalled {abs(short) * 1e3:.1f} mm short of {position_m:g} m, readout "
                + ("lying" if fault.option == "lying" else "honest"),
            )
        q, qd = joint_trajectory(np.array([start]), np.array([goal]), np.array([speed_m_s]), sim.dt)
        guide = np.array([self.guide(float(s)) for s in q[:, 0]])
        actuators = np.r_[sim.table_act, sim.guide_act]
        try:
            sim.run(actuators, np.hstack([q + sim.table_ff * qd, guide]))
        except MotionStoppedError:  # the axis holds where it stopped
            sim.data.ctrl[sim.table_act] = sim.table_q()
            raise
        sim.settle(settle_s)

    def read(self) -> float:
        """The axis readout [m]: true slide position minus the error it does not know (and
        plus what a lying readout adds)."""
        return self.sim.table_q() - self.error_m + self.lie_m
