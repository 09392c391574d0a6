"""The real cell's devices with their hidden errors: joint encoders and the table axis."""

from __future__ import annotations

import numpy as np

from cell.simulation import Simulation
from cell.trajectory import joint_trajectory


class Encoders:
    """Joint readings: true position plus Gaussian noise `sigma_rad`."""

    def __init__(self, sim: Simulation, sigma_rad: float, rng: np.random.Generator) -> None:
        self.sim = sim
        self.sigma_rad = sigma_rad
        self.rng = rng

    def read(self) -> np.ndarray:
        """(6,) measured joint positions [rad]."""
        q = self.sim.arm_q()
        if self.sigma_rad > 0.0:
            q += self.rng.normal(0.0, self.sigma_rad, q.shape)
        return q


class TableAxis:
    """The table's linear axis: it goes to the command plus a bias and a per-move error, and
    its readout reports the commanded frame (it does not see its own positioning error)."""

    def __init__(
        self, sim: Simulation, bias_m: float, repeat_sigma_m: float, rng: np.random.Generator
    ) -> None:
        self.sim = sim
        self.bias_m = bias_m
        self.repeat_sigma_m = repeat_sigma_m
        self.rng = rng
        self.error_m = bias_m  # current positioning error (truth)
        self.target_m = 0.0
        sim.data.qpos[sim.table_qadr] = self.error_m
        sim.data.ctrl[sim.table_act] = self.error_m

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
        sim.run(np.array([sim.table_act]), q + sim.table_ff * qd)
        sim.settle(settle_s)

    def read(self) -> float:
        """The axis readout [m]: true slide position minus the error it does not know."""
        return self.sim.table_q() - self.error_m
