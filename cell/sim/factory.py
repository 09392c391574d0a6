"""Make a simulated real cell: its controller (for planners) and its truth (for evaluators)."""

from __future__ import annotations

import mujoco
import numpy as np
import trimesh

from cell.layout import FixedMesh, LooseMesh
from cell.scene_builder import T_TABLEBODY_TABLE
from cell.sim.config import CellConfig
from cell.sim.devices import Encoders, TableAxis
from cell.sim.drives import Drives
from cell.sim.faults import FaultInjector
from cell.sim.real import build_real_model, draw_real_parameters
from cell.sim.sensors import IRSensor, LaserScanner
from cell.sim.sim_controller import Devices, SimController
from cell.sim.simulation import Simulation
from cell.sim.toolchanger import ToolChanger
from cell.sim.truth import CellTruth
from models.robot import IR, LASER
from registration.rigid import R_to_quat_wxyz, quat_wxyz_to_R


def _carry_loose_parts(sim: Simulation, config: CellConfig) -> None:
    """Loose parts are built where the table is at position 0; the axis starts at its
    positioning error: put them where they lie on the table, before any step."""
    dy = sim.table_q()
    for part in config.parts:
        qadr = int(sim.model.joint(f"{part.name}_free").qposadr[0])
        sim.data.qpos[qadr + 1] += dy
    mujoco.mj_forward(sim.model, sim.data)


def _stream(config: CellConfig, kind: int) -> np.random.SeedSequence:
    """The seed of one of the cell's run-to-run noise streams: its sensors' and the table's
    (`kind` 2), the moves' (3); another `noise_draw` draws them anew on the same cell."""
    draw = [config.noise_draw] if config.noise_draw else []
    return np.random.SeedSequence([config.seed, kind, *draw])


def make_cell(config: CellConfig | None = None) -> tuple[SimController, CellTruth]:
    """Build the real cell described by `config` (default: default errors, seed 0).

    The controller sees the cell as a robot program would; the truth is for evaluation only.
    `make_cell(config.ideal())` gives the error-free cell.
    """
    config = config or CellConfig()
    params = draw_real_parameters(config)
    sim = Simulation(build_real_model(config, params), config.robot.q_home)
    rng = np.random.default_rng(_stream(config, 2))
    table = TableAxis(
        sim, params.table_bias_m, config.table.repeat_sigma_m, rng, params.table_profile
    )
    _carry_loose_parts(sim, config)
    faults = FaultInjector(config.faults, config.seed)
    faults.clock = lambda: sim.time
    table.faults = faults
    laser = LaserScanner(sim.model, sim.tcp_site[LASER.name], config.laser, rng, params.laser_scale)
    laser.faults = faults
    _bind_object(sim, config, faults, laser)
    ir = IRSensor(sim.model, sim.tcp_site[IR.name], config.ir, rng)
    moves = np.random.default_rng(_stream(config, 3))
    t = config.tools
    changer = ToolChanger(sim, t.changer_sigma_m, t.changer_sigma_rad, moves)
    changer.faults = faults
    drives = Drives(
        sim,
        config.robot.kinematics(params.deviations),
        config.drives,
        params.stiffness_nm_rad,
        lambda: changer.held,
        moves,
    )
    encoders = Encoders(drives.read_motors, config.encoder.sigma_rad, rng, faults)
    sim.settle(0.2)
    controller = SimController(
        sim,
        config.robot.kinematics(),
        Devices(encoders, table, laser, ir, drives, changer),
        config.robot,
        config.rack_xyz,
        clock_start_utc=config.clock_start_utc,
    )
    for fault in config.faults:  # what stands in the cell from the start
        if fault.name in ("obstacle", "payload") and fault.stage is None:
            what = (
                f"a {fault.amount * 1e3:.0f} mm box stands at {fault.where_table} m (table)"
                if fault.name == "obstacle"
                else f"the {fault.option or 'screwer'} weighs {fault.amount:g} kg more"
            )
            faults.fire(fault.name, what)
    return controller, CellTruth(config, params, sim, table, laser, ir, faults, drives.read_motors)


def _upper_surface(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(K, 3) the object's vertices on its top fifth whose surface faces up (the outside of
    a shell, not its inside), in its frame: where a reflective patch can lie."""
    mesh = trimesh.Trimesh(np.asarray(vertices), np.asarray(faces), process=False)
    v, n = np.asarray(mesh.vertices), np.asarray(mesh.vertex_normals)
    return v[(v[:, 2] >= np.quantile(v[:, 2], 0.8)) & (n[:, 2] > 0.5)]


def _bind_object(
    sim: Simulation, config: CellConfig, faults: FaultInjector, laser: LaserScanner
) -> None:
    """The object on the table that faults act on (the first mesh object): the laser's
    spurious patch lies on it, an object_bump pushes it."""
    fixed = [o for o in config.fixtures if isinstance(o, FixedMesh)]
    loose = [p for p in config.parts if isinstance(p, LooseMesh)]
    if not fixed and not loose:
        return
    obj = fixed[0] if fixed else loose[0]
    m = sim.model
    geom = int(m.geom(obj.name).id)
    laser.patch_object = (geom, _upper_surface(obj.vertices, obj.faces))
    centre = obj.T_table_object[:3, :3] @ np.asarray(obj.vertices).mean(axis=0)
    centre += obj.T_table_object[:3, 3]

    def push(T_move: np.ndarray) -> None:
        """Move the object by T_move (4, 4, table frame) about its centre."""
        T = np.eye(4)
        T[:3, 3] = centre
        T_table = T @ T_move @ np.linalg.inv(T)
        if fixed:
            names = [obj.name] + [f"{obj.name}_hull{i}" for i in range(len(obj.convex_pieces))]
            for name in names:
                g = int(m.geom(name).id)
                T_g = np.eye(4)
                T_g[:3, :3] = quat_wxyz_to_R(m.geom_quat[g])
                T_g[:3, 3] = m.geom_pos[g]
                T_new = T_TABLEBODY_TABLE @ T_table @ np.linalg.inv(T_TABLEBODY_TABLE) @ T_g
                m.geom_pos[g] = T_new[:3, 3]
                m.geom_quat[g] = R_to_quat_wxyz(T_new[:3, :3])
            faults.T_table_moved[obj.name] = T_table
        else:
            qadr = int(m.joint(f"{obj.name}_free").qposadr[0])
            T_b = sim.body_T(int(m.body(obj.name).id))
            T_base_table = sim.site_T(int(m.site("table_top").id))
            T_new = T_base_table @ T_table @ np.linalg.inv(T_base_table) @ T_b
            sim.data.qpos[qadr : qadr + 3] = T_new[:3, 3]
            sim.data.qpos[qadr + 3 : qadr + 7] = R_to_quat_wxyz(T_new[:3, :3])
        mujoco.mj_forward(m, sim.data)

    faults.push = push
