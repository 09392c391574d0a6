"""`twincell check`: the self-check a user runs on a cell.

Every figure is measured against ground truth the code under check does not produce: MuJoCo
against Pinocchio, IK solutions against the FK of known configurations, the physics' tool and
table poses, and laser points against an analytic plane and sphere.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import mujoco
import numpy as np
from rich.table import Table

from cell.cell_errors import CellError
from cell.controller import Controller
from cell.irb2400_arm import nominal_kinematics
from cell.kinematics import Kinematics
from cell.layout import FixedPrimitive
from cell.sim.config import CellConfig
from cell.sim.factory import make_cell
from cell.sim.real import build_real_model
from cell.sim.simulation import Simulation
from cell.sim.truth import CellTruth
from models.robot import BODY_NAMES, FLANGE_SITE, Q_HOME, TABLE_TRAVEL, TOOLS
from registration.rigid import make_T, pose_error

FK_TOL_M = 1e-9
IK_SUCCESS_MIN = 0.99
IK_TOL_M = 1e-5
LASER_TOL_M = 1e-6
TABLE_TRAVEL_TOL_M = 1e-3
#: A carried tool's TCP must follow the flange (nominal FK of the joints) this closely [m].
TOOL_FOLLOW_TOL_M = 1e-4
#: A returned tool must be back in its slot this closely [m].
TOOL_RETURN_TOL_M = 1e-3
_R_DOWN = np.diag([1.0, -1.0, -1.0])
_SPHERE_RADIUS = 0.06
_T_TABLE_SPHERE = make_T(np.eye(3), np.array([0.1, 0.05, _SPHERE_RADIUS]))


@dataclass(frozen=True)
class CheckReport:
    """The self-check's figures (JSON keys of `twincell check --json`, with `passed`)."""

    mujoco_warnings: int
    fk_max_error_m: float
    ik_success_rate: float
    ik_max_error_m: float
    tool_changes: dict[str, str]
    table_travel_m: float
    laser_plane_max_error_m: float
    laser_sphere_max_error_m: float
    seconds: float

    def criteria(self) -> dict[str, bool]:
        """Each pass criterion and whether it holds."""
        travel = TABLE_TRAVEL[1] - TABLE_TRAVEL[0]
        return {
            "no MuJoCo warnings": self.mujoco_warnings == 0,
            f"FK error <= {FK_TOL_M:g} m": self.fk_max_error_m <= FK_TOL_M,
            f"IK success >= {IK_SUCCESS_MIN:g}": self.ik_success_rate >= IK_SUCCESS_MIN,
            f"IK error <= {IK_TOL_M:g} m": self.ik_max_error_m <= IK_TOL_M,
            "every tool change ok": all(v == "ok" for v in self.tool_changes.values()),
            f"table travel {travel:g} m +- {TABLE_TRAVEL_TOL_M:g}": abs(
                self.table_travel_m - travel
            )
            <= TABLE_TRAVEL_TOL_M,
            f"laser plane error <= {LASER_TOL_M:g} m": self.laser_plane_max_error_m <= LASER_TOL_M,
            f"laser sphere error <= {LASER_TOL_M:g} m": self.laser_sphere_max_error_m
            <= LASER_TOL_M,
        }

    @property
    def passed(self) -> bool:
        """Whether every criterion holds."""
        return all(self.criteria().values())


def random_controls_warnings(seed: int = 0, seconds: float = 2.0) -> int:
    """Step the nominal scene with random set-points (held 0.2 s each); MuJoCo warnings."""
    sim = Simulation(build_real_model(CellConfig().ideal()))
    rng = np.random.default_rng(seed)
    lo, hi = sim.model.actuator_ctrlrange.T
    for _ in range(round(seconds / 0.2)):
        sim.data.ctrl[:] = rng.uniform(lo, hi)
        sim.settle(0.2)
    return sim.warnings()


def fk_max_error(kin: Kinematics, n: int = 1000, seed: int = 0) -> float:
    """Largest disagreement between MuJoCo and Pinocchio over `n` random configurations [m]:
    frame origins, and rotation matrices' entries (per metre of lever)."""
    sim = Simulation(build_real_model(CellConfig().ideal()))
    m, d = sim.model, sim.data
    rng = np.random.default_rng(seed)
    bodies = [m.body(b).id for b in BODY_NAMES]
    frames = [kin.frame_id(b) for b in BODY_NAMES]
    site, site_frame = m.site(FLANGE_SITE).id, kin.frame_id(FLANGE_SITE)
    import pinocchio as pin

    worst = 0.0
    for _ in range(n):
        q = kin.random_configuration(rng)
        d.qpos[sim.arm_qadr] = q
        mujoco.mj_kinematics(m, d)
        pin.framesForwardKinematics(kin.model, kin.data, q)
        for b, f in zip(bodies, frames, strict=True):
            oMf = kin.data.oMf[f]
            worst = max(
                worst,
                float(np.abs(d.xpos[b] - oMf.translation).max()),
                float(np.abs(d.xmat[b].reshape(3, 3) - oMf.rotation).max()),
            )
        oMf = kin.data.oMf[site_frame]
        worst = max(
            worst,
            float(np.abs(d.site_xpos[site] - oMf.translation).max()),
            float(np.abs(d.site_xmat[site].reshape(3, 3) - oMf.rotation).max()),
        )
    return worst


def ik_figures(kin: Kinematics, n: int = 200, seed: int = 1) -> tuple[float, float]:
    """IK success rate over `n` random reachable targets (FK of random configurations, 0.05
    rad inside the limits), seeded from home; and the largest position error of the solves."""
    rng = np.random.default_rng(seed)
    successes, worst = 0, 0.0
    for _ in range(n):
        T = kin.fk(kin.random_configuration(rng, margin=0.05))
        result = kin.ik(T, Q_HOME)
        if result.success:
            successes += 1
            _, p_err = pose_error(kin.fk(result.q), T)
            worst = max(worst, p_err)
    return successes / n, worst


def _tool_cycle(controller: Controller, truth: CellTruth, tool: str) -> str:
    """Pick `tool`, carry it to two poses above the table, return it; "ok" or the reason."""
    sim = truth.simulation
    try:
        controller.change_tool(tool)
        if controller.tool_in_hand != tool:
            return f"not in hand after the pick (in hand: {controller.tool_in_hand})"
        for p in ((1.0, -0.2, 0.9), (1.2, 0.2, 0.8)):
            controller.move_tcp(make_T(_R_DOWN, np.array(p)))
            T_pred = controller.kinematics.fk(truth.q()) @ controller.T_flange_tcp()
            _, err = pose_error(T_pred, truth.T_base_tcp(tool))
            if err > TOOL_FOLLOW_TOL_M:
                return f"TCP {err:.3g} m away from the flange's prediction while carried"
        controller.return_tool()
        _, err = pose_error(sim.site_T(sim.slot_site[tool]), sim.body_T(sim.tool_body[tool]))
        if controller.tool_in_hand is not None or err > TOOL_RETURN_TOL_M:
            return f"not back in its slot ({err:.3g} m away)"
    except CellError as exc:
        return f"error: {exc}"
    return "ok"


def tool_changes() -> tuple[dict[str, str], int]:
    """A full tool-change cycle in physics for every tool; results and MuJoCo warnings."""
    controller, truth = make_cell(CellConfig().ideal())
    results = {t.name: _tool_cycle(controller, truth, t.name) for t in TOOLS}
    return results, truth.simulation.warnings()


def table_travel() -> tuple[float, int]:
    """Travel of the table [m] between its two end positions, measured in physics."""
    controller, truth = make_cell(CellConfig().ideal())
    controller.move_table(TABLE_TRAVEL[0])
    lo = truth.table_position_m()
    controller.move_table(TABLE_TRAVEL[1])
    hi = truth.table_position_m()
    return hi - lo, truth.simulation.warnings()


def laser_errors() -> tuple[float, float, int]:
    """Noise-free laser scans of the table top (a plane) and of a sphere fixed on the table;
    the largest point error [m] of each against the analytic surface."""
    sphere = FixedPrimitive("check_sphere", "sphere", (_SPHERE_RADIUS,), _T_TABLE_SPHERE)
    controller, truth = make_cell(CellConfig(fixtures=(sphere,)).ideal())
    controller.change_tool("laser")
    # Plane: a line on the table top away from the sphere.
    plane_points = []
    for y in (-0.2, -0.15):
        controller.move_linear(make_T(_R_DOWN, np.array([1.0, y, 0.7])))
        points, _ = controller.laser_points_base(controller.read_laser())
        plane_points.append(points)
    P = np.concatenate(plane_points)
    z_top = truth.T_base_table()[2, 3]
    plane_err = float(np.abs(P[:, 2] - z_top).max()) if len(P) else np.inf
    # Sphere: lines across it; the points on it are those above the table top.
    c = truth.T_base_object("check_sphere")[:3, 3]
    sphere_points = []
    for dy in (-0.03, 0.0, 0.03):
        controller.move_linear(make_T(_R_DOWN, np.array([c[0], c[1] + dy, 0.75])))
        points, _ = controller.laser_points_base(controller.read_laser())
        sphere_points.append(points[points[:, 2] > z_top + 1e-3])
    S = np.concatenate(sphere_points)
    sphere_err = (
        float(np.abs(np.linalg.norm(S - c, axis=1) - _SPHERE_RADIUS).max()) if len(S) else np.inf
    )
    return plane_err, sphere_err, truth.simulation.warnings()


def run_check() -> CheckReport:
    """Run every part of the self-check on the default cell (nominal, noise-free)."""
    t0 = time.perf_counter()
    kin = nominal_kinematics()
    warnings = random_controls_warnings()
    fk_err = fk_max_error(kin)
    rate, ik_err = ik_figures(kin)
    tools, w_tools = tool_changes()
    travel, w_table = table_travel()
    plane_err, sphere_err, w_laser = laser_errors()
    return CheckReport(
        mujoco_warnings=warnings + w_tools + w_table + w_laser,
        fk_max_error_m=fk_err,
        ik_success_rate=rate,
        ik_max_error_m=ik_err,
        tool_changes=tools,
        table_travel_m=travel,
        laser_plane_max_error_m=plane_err,
        laser_sphere_max_error_m=sphere_err,
        seconds=time.perf_counter() - t0,
    )


def render(report: CheckReport) -> Table:
    """A rich table of the figures and the pass criteria."""
    table = Table(title="twincell check: the default cell (nominal, noise-free)")
    table.add_column("figure")
    table.add_column("value", justify="right")
    rows = [
        ("MuJoCo warnings", f"{report.mujoco_warnings}"),
        ("FK max error MuJoCo vs Pinocchio", f"{report.fk_max_error_m:.3g} m"),
        ("IK success rate (200 targets)", f"{report.ik_success_rate:.3f}"),
        ("IK max position error", f"{report.ik_max_error_m:.3g} m"),
        *((f"tool change: {k}", v) for k, v in report.tool_changes.items()),
        ("table travel", f"{report.table_travel_m:.6f} m"),
        ("laser plane max error", f"{report.laser_plane_max_error_m:.3g} m"),
        ("laser sphere max error", f"{report.laser_sphere_max_error_m:.3g} m"),
        ("seconds", f"{report.seconds:.1f}"),
    ]
    for name, value in rows:
        table.add_row(name, value)
    table.add_section()
    for name, ok in report.criteria().items():
        table.add_row(name, "[green]pass[/green]" if ok else "[red]FAIL[/red]")
    return table


__all__ = ["CheckReport", "render", "run_check"]
