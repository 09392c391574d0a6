"""The real cell's hidden parameters (the truth), drawn from its configuration, and its
MuJoCo model: the scene of its layout (cell.scene_builder) with the real arm, the real tool TCPs and
what its faults leave in the cell.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from cell.layout import FixedPrimitive
from cell.scene_builder import build_model
from cell.sim.config import CellConfig
from models.robot import TOOLS
from registration.rigid import make_T


@dataclass(frozen=True, eq=False)
class RealParameters:
    """The real cell's hidden parameters drawn from the config (the truth).

    Attributes:
        deviations: the real arm's kinematic deviations from the nominal (see cell.robot_arm).
        table_bias_m: the table axis' constant positioning error [m].
        stiffness_nm_rad: (2,) the real stiffness of joints 2 and 3 [N m/rad] (0: rigid).
        T_tool_tcp: each tool's true TCP in its frame (4, 4) (the laser's: its optical frame,
            where its rays start).
        laser_scale: the laser's relative range scale error.
        table_profile: (4,) the table axis' sideways and vertical bow [m] and its pitch and
            yaw at the travel's positive end [rad] (see cell.sim.devices.table_profile).
    """

    deviations: np.ndarray
    table_bias_m: float
    stiffness_nm_rad: np.ndarray = field(default_factory=lambda: np.zeros(2))
    T_tool_tcp: dict[str, np.ndarray] = field(default_factory=dict)
    laser_scale: float = 0.0
    table_profile: np.ndarray = field(default_factory=lambda: np.zeros(4))


def _small_transform(rng: np.random.Generator, sigma_m: float, sigma_rad: float) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(rng.normal(0.0, 1.0, 3) * sigma_rad).as_matrix()
    T[:3, 3] = rng.normal(0.0, 1.0, 3) * sigma_m
    return T


def draw_real_parameters(config: CellConfig) -> RealParameters:
    """Draw the real cell's hidden parameters from `config.seed` (each group from its own
    random stream, so that switching one error source off leaves the others' draws)."""
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 1]))
    deviations = config.robot.draw_deviations(
        rng, config.arm.length_sigma_m, config.arm.offset_sigma_rad
    )
    if config.arm.thermal_strain:  # the links grown with the arm's temperature
        deviations = deviations + config.robot.grown(config.arm.thermal_strain)
    bias = float(rng.normal(0.0, 1.0)) * config.table.bias_sigma_m
    drives = config.drives
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 11]))
    spread = 1.0 + rng.normal(0.0, 1.0, 2) * drives.stiffness_spread
    stiffness = np.asarray(drives.stiffness_nm_rad, dtype=float) * np.maximum(spread, 0.2)
    tools = config.tools
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 12]))
    T_tool_tcp = {}
    for spec in TOOLS:
        if spec.name == "laser":
            sigma_m, sigma_rad = tools.laser_mount_sigma_m, tools.laser_mount_sigma_rad
        else:
            sigma_m, sigma_rad = tools.tcp_sigma_m, tools.tcp_sigma_rad
        T_tool_tcp[spec.name] = spec.T_tool_tcp @ _small_transform(rng, sigma_m, sigma_rad)
    laser_scale = float(rng.normal(0.0, 1.0)) * tools.laser_scale_sigma
    table = config.table
    rng = np.random.default_rng(np.random.SeedSequence([config.seed, 13]))
    profile = rng.normal(0.0, 1.0, 4) * np.array(
        [table.straightness_sigma_m] * 2 + [table.pitch_sigma_rad, table.yaw_sigma_rad]
    )
    return RealParameters(deviations, bias, stiffness, T_tool_tcp, laser_scale, profile)


def fault_fixtures(config: CellConfig) -> tuple[FixedPrimitive, ...]:
    """The bodies a fault leaves in the cell: an obstacle's box on the table."""
    return tuple(
        FixedPrimitive(
            "obstacle",
            "box",
            (f.amount / 2,) * 3,
            make_T(np.eye(3), np.asarray(f.where_table, dtype=float)),
            rgba=(0.85, 0.2, 0.2, 1.0),
        )
        for f in config.faults
        if f.name == "obstacle" and f.where_table is not None and f.amount > 0
    )


def build_real_model(config: CellConfig, params: RealParameters | None = None) -> mujoco.MjModel:
    """Compile the real cell's MuJoCo model: its robot's arm deviated by `params.deviations`,
    its tools' TCP sites at their true places (default: the nominal cell), the bodies its
    faults leave (an obstacle's box, a payload the tooldata does not know)."""
    payloads = {f.option or "screwer": f.amount for f in config.faults if f.name == "payload"}
    return build_model(
        config.layout(),
        None if params is None else params.deviations,
        None if params is None else params.T_tool_tcp,
        fault_fixtures(config),
        payloads,
    )
