"""The real cell's devices with their hidden errors: joint encoders and the table axis."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from cell.simulation import Simulation
from cell.trajectory import joint_trajectory
from models.robot import TABLE_TRAVEL


class Encoders:
    """Joint readings: the motors' angles (`motors()`, see cell.drives) plus Gaussian noise
    `sigma_rad`."""

    def __init__(
        self, motors: Callable[[], np.ndarray], sigma_rad: float, rng: np.random.Generator
    ) -> None:
        self.motors = motors
        self.sigma_rad = sigma_rad
        self.rng = rng

    def read(self) -> np.ndarray:
        """(6,) measured joint positions [rad]."""
        q = self.motors()
        if self.sigma_rad > 0.0:
            q += self.rng.normal(0.0, self.sigma_rad, q.shape)
        return q


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
        q, qd = joint_trajectory(
            np.array([start]),
            np.array([position_m + self.error_m]),
            np.array([speed_m_s]),
            sim.dt,
        )
        guide = np.array([self.guide(float(s)) for s in q[:, 0]])
        actuators = np.r_[sim.table_act, sim.guide_act]
        sim.run(actuators, np.hstack([q + sim.table_ff * qd, guide]))
        sim.settle(settle_s)

    def read(self) -> float:
        """The axis readout [m]: true slide position minus the error it does not know."""
        return self.sim.table_q() - self.error_m
