"""Evaluation against the simulated truth: the ONLY module of `scenarios` that reads it.

The evaluator holds the cell's truth and the real entity of the object (virtual model plus
model error). Planning code hands it moments to record ("the tool is touching target k now")
and asks it, after the run, how far the achieved tool tips were from the true targets and how
far the registration was from the true pose. The rerun recording also asks it for the true
body poses, to show the real cell as it moved.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from cell import Kinematics, nominal_T_base_slot
from cell.sim import CellTruth
from models.model import ObjectModel
from models.robot import TOOLS
from registration import pose_error, transform_points
from scenarios.offline.calibration import CalibrationResult
from scenarios.results.evaluations import (
    CalibrationFigures,
    PickEvaluation,
    PoseEvaluation,
    TargetEvaluation,
    TcpError,
)
from scenarios.results.events import (
    MISSED,
    NOT_INJECTED,
    FaultOutcome,
    Injection,
    SupervisionEvent,
)


@dataclass(frozen=True)
class KinematicsEvaluation:
    """A kinematic model's TCP error against the real arm over a sample of configurations.

    The tool is mounted as a fetch from its rack slot with that model leaves it (the tool
    changer locks the tool where the flange meets it). `mean_m`, `max_m`: distance of the
    real TCP from the model's [m]; `aligned_mean_m`, `aligned_max_m`: the same after the best
    rigid motion of all the model's TCPs (what a registration made with the same kinematics
    absorbs) [m]; `configurations` the sample's size.
    """

    mean_m: float
    max_m: float
    aligned_mean_m: float
    aligned_max_m: float
    configurations: int


#: The symptoms (the codes of the controller's supervision and of the stages' checks) by
#: which each fault can show. A fault is detected by the first of them seen after it fired.
SYMPTOMS: dict[str, tuple[str, ...]] = {
    "tool_lock_fail": ("lock_sensor", "tcp_check", "verification", "match_refused", "collision"),
    "laser_dropout_burst": ("laser_gap", "match_refused", "verification"),
    "laser_spurious": ("scan_outliers", "match_refused", "verification"),
    "table_stall": (
        "table_in_position",
        "scan_outliers",
        "match_refused",
        "verification",
        "collision",
    ),
    "object_bump": ("verification", "collision"),
    "encoder_glitch": ("joint_plausibility", "scan_outliers", "match_refused", "verification"),
    "obstacle": ("collision",),
    "payload": ("load", "collision"),
}


class Evaluator:
    """Reads the truth of one run: the cell's `truth`, the object's real entity and its name."""

    def __init__(self, truth: CellTruth, real: ObjectModel, object_name: str) -> None:
        self._truth = truth
        self._real = real
        self._name = object_name
        self._touches: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        self._scratch: mujoco.MjData | None = None

    # -- moments recorded during the run --------------------------------------------------------
    def record_touch(self, target: str, tool: str) -> None:
        """Remember the true TCP of `tool` and the true object pose now (target `target`)."""
        self._touches[target] = (
            self._truth.T_base_tcp(tool).copy(),
            self._truth.T_base_object(self._name).copy(),
        )

    def pose_error(self, T_base_object_estimate: np.ndarray) -> PoseEvaluation:
        """Error of an estimated object pose (4, 4) in the base frame, against the truth now."""
        T_true = self._truth.T_base_object(self._name)
        rot, trans = pose_error(T_base_object_estimate, T_true)
        return PoseEvaluation(float(np.rad2deg(rot)), float(trans))

    def pick(
        self, rest: str, closed: str, lifted: str, placed: str, grip_frame: str = "grasp"
    ) -> PickEvaluation:
        """The pick measured from four recorded moments (names given to `record_touch`): the
        part at `rest` before the fingers close, `closed` in the closed fingers, `lifted` at
        the top of the lift, `placed` back at rest after the put-down (the table must not
        move between `rest` and `placed`: the poses are compared in the base frame). Slip is
        measured at the origin of the real part's frame `grip_frame` (between the fingers),
        so that the part turning about the grip is not counted as slip."""
        T_rest, T_placed = self._touches[rest][1], self._touches[placed][1]
        p_grip = np.append(self._real.frame(grip_frame).T_part_frame[:3, 3], 1.0)
        p_grip_tcp = [
            np.linalg.solve(T_tcp, T_object @ p_grip)[:3]
            for T_tcp, T_object in (self._touches[closed], self._touches[lifted])
        ]
        rot, trans = pose_error(T_placed, T_rest)
        return PickEvaluation(
            float(self._touches[lifted][1][2, 3] - T_rest[2, 3]),
            float(np.linalg.norm(p_grip_tcp[1] - p_grip_tcp[0])),
            trans,
            float(np.rad2deg(rot)),
        )

    def true_points_base(self, points_object: np.ndarray) -> np.ndarray:
        """Points (K, 3) given in the object frame, placed at the object's true pose now."""
        return transform_points(self._truth.T_base_object(self._name), points_object)

    def frame_error(self, touch: str, frame: str) -> float:
        """Distance [m] of the TCP recorded at `touch` from the origin of the real object's
        operation frame `frame` at its true pose then."""
        T_tcp, T_object = self._touches[touch]
        p_frame = self._real.frame(frame).T_part_frame[:3, 3]
        return float(np.linalg.norm(T_tcp[:3, 3] - transform_points(T_object, p_frame[None])[0]))

    def targets(
        self,
        touch_offset_m: float,
        virtual: ObjectModel,
        T_base_object_estimate: np.ndarray,
        prefix: str = "",
    ) -> tuple[TargetEvaluation, ...]:
        """Every recorded touch against the real object's burr hole of the same name (the
        touch named `prefix` + the hole's name): the true touch point is the real entry moved
        back by `touch_offset_m` along the real axis. `virtual` (the planner's model) and the
        estimated pose (4, 4) give the registration's share of each error."""
        out = []
        virtual_holes = {h.name: h for h in virtual.burr_holes}
        for hole in self._real.burr_holes:
            if prefix + hole.name not in self._touches:
                continue
            T_tcp, T_object = self._touches[prefix + hole.name]
            R, t = T_object[:3, :3], T_object[:3, 3]
            axis = R @ hole.direction
            p_entry = R @ hole.p_entry + t
            p_true = p_entry - touch_offset_m * axis
            p_tip = T_tcp[:3, 3]
            z_tool = T_tcp[:3, 2]
            angle = float(np.degrees(np.arccos(np.clip(z_tool @ axis, -1.0, 1.0))))
            p_deep_true = p_entry + hole.depth * axis
            p_deep_achieved = p_tip + (hole.depth + touch_offset_m) * z_tool
            v = virtual_holes[hole.name]
            p_corrected = transform_points(
                T_base_object_estimate, (v.p_entry - touch_offset_m * v.direction)[None]
            )[0]
            out.append(
                TargetEvaluation(
                    prefix + hole.name,
                    float(np.linalg.norm(p_tip - p_true)),
                    angle,
                    float(np.linalg.norm(p_deep_achieved - p_deep_true)),
                    float(np.linalg.norm(p_corrected - p_true)),
                    p_true,
                    p_tip.copy(),
                )
            )
        return tuple(out)

    def motor_angles(self) -> np.ndarray:
        """(6,) the arm's motors' true angles [rad] (what a controller's encoders measure,
        before their noise)."""
        return self._truth.motor_angles()

    # -- for the recording ------------------------------------------------------------------------
    def body_poses(self) -> dict[str, np.ndarray]:
        """(4, 4) true pose of every body of the real cell, by name (world = robot base),
        computed on a copy of the simulation's state: the real cell is only read."""
        sim = self._truth.simulation
        model = sim.model
        if self._scratch is None:
            self._scratch = mujoco.MjData(model)
        data = self._scratch
        data.qpos[:] = sim.data.qpos
        data.mocap_pos[:] = sim.data.mocap_pos
        data.mocap_quat[:] = sim.data.mocap_quat
        mujoco.mj_kinematics(model, data)
        poses = {}
        for b in range(1, model.nbody):
            T = np.eye(4)
            T[:3, :3] = data.xmat[b].reshape(3, 3)
            T[:3, 3] = data.xpos[b]
            poses[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)] = T
        return poses

    def enter(self, stage: str) -> None:
        """The run enters `stage`: the real cell's faults due then happen (cell.sim.faults)."""
        self._truth.faults.enter(stage)

    def faults(self, detections: tuple[SupervisionEvent, ...]) -> tuple[FaultOutcome, ...]:
        """Each fault of the run: what was injected and when, and the stage whose
        supervision or check saw it first (a detection of a symptom the fault can cause,
        at or after its injection), or "missed"; "not injected" if its occasion never came."""
        out = []
        for name, fault in self._truth.faults.faults.items():
            fired = self._truth.faults.fired.get(name)
            if fired is None:
                out.append(
                    FaultOutcome(name, fault.amount, fault.stage, fault.option, None, NOT_INJECTED)
                )
                continue
            seen = next(
                (
                    d
                    for d in detections
                    if d.code in SYMPTOMS[name] and d.time_s >= fired.time_s - 1e-9
                ),
                None,
            )
            out.append(
                FaultOutcome(
                    name,
                    fault.amount,
                    fault.stage,
                    fault.option,
                    Injection(fired.stage, fired.time_s, fired.detail),
                    MISSED if seen is None else seen.stage,
                    None if seen is None else seen.code,
                    self._target_move(name),
                )
            )
        return tuple(out)

    def _target_move(self, fault: str) -> float | None:
        """How far the fault `fault` moved the real object's farthest target [m] (the
        object moved on the table by a push), or None if it moves no object."""
        moved = self._truth.faults.T_table_moved.get(self._name)
        if fault != "object_bump" or moved is None or not self._real.burr_holes:
            return None
        T_after = np.linalg.inv(self._truth.T_base_table()) @ self._truth.T_base_object(self._name)
        T_before = np.linalg.inv(moved) @ T_after
        p = np.array([h.p_entry for h in self._real.burr_holes])
        after = p @ T_after[:3, :3].T + T_after[:3, 3]
        before = p @ T_before[:3, :3].T + T_before[:3, 3]
        return float(np.linalg.norm(after - before, axis=1).max())

    def watch(self, bodies: Any, laser: Any, ir: Any = None) -> None:
        """Let a recording witness the real cell: `bodies(data)` while it moves, `laser(data,
        origin, directions, ranges)` at every laser line, `ir` at every IR reading (see
        cell.CellTruth.watch)."""
        self._truth.watch(bodies, laser, ir=ir)

    @property
    def mujoco_data(self) -> mujoco.MjData:
        """The real cell's MuJoCo state now (read only: for the recording)."""
        return self._truth.simulation.data

    @property
    def mujoco_model(self) -> mujoco.MjModel:
        """The real cell's MuJoCo model (geometry for the recording)."""
        return self._truth.simulation.model

    # -- the arm ----------------------------------------------------------------------------------
    def kinematics_error(
        self, kinematics: Kinematics, q_samples: np.ndarray, tool: str
    ) -> KinematicsEvaluation:
        """TCP error of `kinematics` (a planner's model of the arm) against the real arm at
        the motor angles `q_samples` (K, 6) [rad], with `tool` fetched from its slot with
        that model: the real links where the real joints' compliance puts them, the tool's
        real TCP (see KinematicsEvaluation)."""
        spec = {t.name: t for t in TOOLS}[tool]
        truth = self._truth
        real = truth.kinematics()
        T_base_slot = nominal_T_base_slot(tool, truth.config.rack_xyz)
        q_slot = kinematics.for_tool(None).solve(T_base_slot, truth.config.robot.q_home)
        T_flange_tool = np.linalg.solve(real.fk(truth.link_angles(q_slot, None)), T_base_slot)
        T_tcp_real = T_flange_tool @ truth.T_tool_tcp(tool)
        model = kinematics.for_tool(tool)
        q = np.asarray(q_samples, dtype=float).reshape(-1, 6)
        p_model = np.array([(model.fk(qi) @ spec.T_tool_tcp)[:3, 3] for qi in q])
        p_real = np.array([(real.fk(truth.link_angles(qi, tool)) @ T_tcp_real)[:3, 3] for qi in q])
        a, b = p_model - p_model.mean(axis=0), p_real - p_real.mean(axis=0)
        U, _, Vt = np.linalg.svd(a.T @ b)
        D = np.diag([1.0, 1.0, float(np.sign(np.linalg.det(Vt.T @ U.T)))])
        aligned = np.linalg.norm(b - a @ (Vt.T @ D @ U.T).T, axis=1)
        raw = np.linalg.norm(p_real - p_model, axis=1)
        return KinematicsEvaluation(
            float(raw.mean()), float(raw.max()), float(aligned.mean()), float(aligned.max()), len(q)
        )


def calibration_report(
    evaluator: Evaluator,
    nominal: Kinematics,
    calibration: CalibrationResult | None,
    q_job: np.ndarray,
    tool: str,
) -> CalibrationFigures:
    """The calibration's figures and, from the truth, the TCP error of `tool` on the nominal
    and the calibrated arm at the job's configurations `q_job` (K, 6)."""
    nominal_error = evaluator.kinematics_error(nominal, q_job, tool)
    calibrated = None
    if calibration is not None:
        e = evaluator.kinematics_error(calibration.kinematics, q_job, tool)
        calibrated = TcpError(e.mean_m, e.max_m)
    return CalibrationFigures(
        None if calibration is None else calibration.summary(),
        TcpError(nominal_error.mean_m, nominal_error.max_m),
        calibrated,
        nominal_error.configurations,
    )
