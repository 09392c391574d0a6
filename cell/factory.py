"""Make a simulated real cell: its controller (for planners) and its truth (for evaluators)."""

from __future__ import annotations

import mujoco
import numpy as np

from cell.build import build_model, draw_real_parameters
from cell.config import CellConfig
from cell.controller import Controller
from cell.devices import Encoders, TableAxis
from cell.drives import Drives
from cell.kinematics import Kinematics
from cell.sensors import IRSensor, LaserScanner
from cell.simulation import Simulation
from cell.toolchanger import ToolChanger
from cell.truth import CellTruth
from models.robot import IR, LASER, ROBOT_PATH


def nominal_kinematics() -> Kinematics:
    """Pinocchio kinematics of the built-in arm (its robot-only MJCF), tip frame `flange`."""
    return Kinematics.from_mjcf(ROBOT_PATH, "flange")


def _carry_loose_parts(sim: Simulation, config: CellConfig) -> None:
    """Loose parts are built where the table is at position 0; the axis starts at its
    positioning error: put them where they lie on the table, before any step."""
    dy = sim.table_q()
    for part in config.parts:
        qadr = int(sim.model.joint(f"{part.name}_free").qposadr[0])
        sim.data.qpos[qadr + 1] += dy
    mujoco.mj_forward(sim.model, sim.data)


def make_cell(config: CellConfig | None = None) -> tuple[Controller, CellTruth]:
    """Build the real cell described by `config` (default: default errors, seed 0).

    The controller sees the cell as a robot program would; the truth is for evaluation only.
    `make_cell(config.ideal())` gives the error-free cell.
    """
    config = config or CellConfig()
    params = draw_real_parameters(config)
    sim = Simulation(build_model(config, params), config.robot.q_home)
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 2]))
    table = TableAxis(
        sim, params.table_bias_m, config.table.repeat_sigma_m, rng, params.table_profile
    )
    _carry_loose_parts(sim, config)
    laser = LaserScanner(sim.model, sim.tcp_site[LASER.name], config.laser, rng, params.laser_scale)
    ir = IRSensor(sim.model, sim.tcp_site[IR.name], config.ir, rng)
    moves = np.random.default_rng(np.random.SeedSequence([config.seed, 3]))
    t = config.tools
    changer = ToolChanger(sim, t.changer_sigma_m, t.changer_sigma_rad, moves)
    drives = Drives(
        sim,
        config.robot.kinematics(params.deviations),
        config.drives,
        params.stiffness_nm_rad,
        lambda: changer.held,
        moves,
    )
    encoders = Encoders(drives.read_motors, config.encoder.sigma_rad, rng)
    sim.settle(0.2)
    controller = Controller(
        sim,
        config.robot.kinematics(),
        encoders,
        table,
        laser,
        ir,
        drives,
        changer,
        config.robot,
        config.rack_xyz,
    )
    return controller, CellTruth(config, params, sim, table, laser, ir)
