"""The rerun recording of a run (run.rrd, or a live viewer with --spawn): the run's story as
it happened, checked to look right in the real viewer.

Entities (base frame = world; timelines `sim_time`, the cell's clock, and `icp`):
- `world/cell/...`: the real cell, named (`arm/link3`, `table`, `tools/laser`, the object
  under its model's name, `fixtures/calibration_sphere1`); static bodies once, moving ones
  whenever they moved (scene.py);
- `world/laser/rays`, `world/ir/ray`: the laser's rays and the IR sensor's ray as they went,
  while they read (scan.py);
- `world/cell/table/frame`: the table frame the cell model believes; under it `model` (the
  virtual model: nominal, then registered; its targets with it), `calibration/points` and
  `calibration/centres` (the calibration's fit), `scan/line`, `scan/passes/pNN`,
  `scan/registered` (coloured by residual), `icp/...` (match.py) and `verify/...` (the
  verification's strips and its decision at each target: verification.py);
- `world/targets/...`: corrected, achieved, true, magnified error lines, predicted-TRE
  ellipsoids (targets.py); `plots/...`, `legend/residual`, `log` (one entry per phase and
  per decision).
Every result appears at the time it was computed, never before. The default layout is
layout.py's.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import rerun as rr
from scipy.spatial.transform import Rotation

from models.model import ObjectModel
from models.robot.visuals import LinkVisual
from registration import MatchResult
from registration.quality import target_covariance
from scenarios.offline.calibration import CalibrationResult
from scenarios.offline.scan_passes import ScanData
from scenarios.offline.scan_plan import ScanPlan
from scenarios.outputs.residuals import colour_scale, residual_colours
from scenarios.program.program_types import OfflineProgram
from scenarios.realcell.evaluation import TargetEvaluation
from scenarios.realcell.recording.match import colour_bar, log_icp, log_registered
from scenarios.realcell.recording.recorded_budget import log_budget
from scenarios.realcell.recording.recorded_scan import LaserRays, log_scan
from scenarios.realcell.recording.recorded_scene import CellScene, mesh_archetype
from scenarios.realcell.recording.recorded_targets import log_targets
from scenarios.realcell.recording.recorded_verification import log_tool_check, log_verification
from scenarios.realcell.recording.stream import ICP, Stream, pose
from scenarios.realcell.recording.viewer_layout import blueprint, serve_blueprint
from scenarios.results.budget_result import ErrorBudget
from scenarios.results.verification_result import TcpCheck, Verification

#: The table frame the cell model believes: the table's top, where the object stands.
TABLE = "world/cell/table/frame"
#: Colours of the chosen scan passes, in order.
PASS_COLOURS = (
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (23, 190, 207),
)  # fmt: skip


class Recording:
    """A run's recording written to `path` (unless not `to_file`) and sent to a spawned
    viewer if `spawn`, listed in the viewer as `name`."""

    def __init__(
        self,
        path: Path,
        spawn: bool = False,
        name: str = "twincell run",
        to_file: bool = True,
        served: bool = False,
    ) -> None:
        self._served = served  # a served cell's layout (layout.serve_blueprint)
        self.stream = Stream(Path(path), name, serve_blueprint() if served else blueprint(),
                             spawn, to_file)  # fmt: skip
        self.stream.static("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        self._scene: CellScene | None = None
        self._rays = LaserRays()
        self._ir = LaserRays("world/ir/ray", (60, 230, 120))
        self._object: str | None = None
        self._T_world_top = np.eye(4)
        self._T_body_top = np.eye(4)
        self._T_table_nominal = np.eye(4)
        self._size = 0.0
        self._centre_model = np.zeros(3)

    @property
    def path(self) -> Path:
        return self.stream.path

    # -- the cell ---------------------------------------------------------------------------
    def start_cell(self, model: mujoco.MjModel, data: mujoco.MjData, object_name: str,
                   object_entity: str, visuals: tuple[LinkVisual, ...] = ()) -> None:  # fmt: skip
        """The cell's geometry and static bodies, and the table frame under the table;
        `object_name` is the real object's geom or body, shown as `object_entity`; the arm
        drawn with the link meshes `visuals` if any (models.robot.visuals)."""
        self._object = f"world/cell/{object_entity}"
        aliases = {object_name: object_entity, "table_top": "table_top"}
        self._scene = CellScene(model, aliases, visuals)
        self._scene.log_geometry(self.stream, data)
        site = model.site("table_top")
        T = np.eye(4)
        w, x, y, z = model.site_quat[site.id]
        T[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
        T[:3, 3] = model.site_pos[site.id]
        self.stream.static(TABLE, pose(T))
        self._T_body_top = T
        self._T_world_top = np.eye(4)
        self._T_world_top[:3, :3] = data.site_xmat[site.id].reshape(3, 3)
        self._T_world_top[:3, 3] = data.site_xpos[site.id]
        self._scene.sample(data)

    def bodies(self, data: mujoco.MjData) -> None:
        """Witness: the physics at a sample time."""
        if self._scene is not None:
            self._scene.sample(data)

    def laser(
        self, data: mujoco.MjData, origin: np.ndarray, directions: np.ndarray, ranges: np.ndarray
    ) -> None:
        """Witness: one laser line (world frame, measured ranges)."""
        self.bodies(data)
        self._rays.sample(float(data.time), origin, directions, ranges)

    def ir(
        self, data: mujoco.MjData, origin: np.ndarray, directions: np.ndarray, ranges: np.ndarray
    ) -> None:
        """Witness: one IR reading (world frame, measured range)."""
        self.bodies(data)
        self._ir.sample(float(data.time), origin, directions, ranges)

    # -- the story --------------------------------------------------------------------------
    def phase(self, time_s: float, name: str, detail: str = "") -> None:
        """A phase of the run begins at `time_s` [s]."""
        self.stream.at(sim_time=time_s)
        text = f"== {name} ==" + (f" {detail}" if detail else "")
        self.stream.log("log", rr.TextLog(text, level="INFO", color=[90, 170, 255]))

    def text(self, time_s: float, message: str) -> None:
        """A line of the run's progress: a decision, a refusal, a measurement."""
        self.stream.at(sim_time=time_s)
        warns = ("refused", "warning", "aborted")
        level = "WARN" if message.startswith(warns) else "INFO"
        self.stream.log("log", rr.TextLog(message, level=level))

    # -- the object -------------------------------------------------------------------------
    def log_model(self, virtual: ObjectModel, T_table_nominal: np.ndarray) -> None:
        """The virtual model (once, with its targets) at its nominal place from t = 0, and
        the layout's cameras on it."""
        self.stream.static(
            f"{TABLE}/model/mesh",
            mesh_archetype(virtual.mesh.vertices, virtual.mesh.faces, [110, 200, 130, 255]),
        )
        if virtual.burr_holes:
            self.stream.static(
                f"{TABLE}/model/targets",
                rr.Points3D(
                    [h.p_entry for h in virtual.burr_holes], radii=0.0008, colors=[[60, 90, 255]]
                ),
            )
        self._centre_model = virtual.mesh.vertices.mean(axis=0)
        self.stream.at(sim_time=0.0)
        self.stream.log(f"{TABLE}/model", pose(T_table_nominal))
        self._T_table_nominal = T_table_nominal
        self._size = float(np.ptp(virtual.mesh.vertices, axis=0).max())
        self._aim()

    def _aim(self) -> None:
        """The layout, its close-up's camera on the object where the table now holds it."""
        T = self._T_world_top @ self._T_table_nominal
        centre = T[:3, :3] @ self._centre_model + T[:3, 3]
        eye_object = (centre + self._size * np.array([0.7, -0.9, 0.8]), centre)
        eye_cell = (centre + np.array([1.0, -1.9, 1.2]), 0.5 * centre)
        if self._served:
            self.stream.send_blueprint(serve_blueprint(eye_cell))
            return
        self.stream.send_blueprint(blueprint(self._object, eye_object, eye_cell))

    def log_calibration(self, time_s: float, calibration: CalibrationResult) -> None:
        """The calibration's fit at `time_s`: every sphere point where the identified model
        puts it (table frame), coloured by its residual from its sphere; the identified
        centres; the residual RMS per view."""
        fitted = calibration.fitted
        if fitted is None:
            return
        used = fitted.used
        rms = float(np.sqrt(np.mean(fitted.residuals_m[used] ** 2)))
        scale = colour_scale(rms)
        residuals = np.where(used, fitted.residuals_m, np.inf)
        self.stream.at(sim_time=time_s)
        self.stream.log(
            f"{TABLE}/calibration/points",
            rr.Points3D(
                fitted.points_table, colors=residual_colours(residuals, scale), radii=0.0004
            ),
        )
        self.stream.log(
            f"{TABLE}/calibration/centres",
            rr.Points3D(calibration.centres_table, colors=[[255, 255, 255]], radii=0.0015),
        )
        views = int(fitted.view.max()) + 1
        n = np.bincount(fitted.view[used], minlength=views)
        sq = np.bincount(fitted.view[used], fitted.residuals_m[used] ** 2, minlength=views)
        per_view = np.sqrt(sq / np.maximum(n, 1))
        self.stream.log(
            "plots/calibration/residual_per_view_mm",
            rr.BarChart(per_view * 1e3, color=[255, 170, 60]),
        )
        label = "sphere point to its sphere, identified model [mm] (inside < 0 < outside)"
        self.stream.log("legend/residual", rr.Image(colour_bar(scale, label)))

    def log_scan_plan(self, time_s: float, plan: ScanPlan) -> None:
        """The scan's plan at `time_s` (table frame): every candidate pass' sweep in grey,
        the chosen ones in colour, numbered, and what each is predicted to see until the
        scan starts; cleared once the scan is done (`log_scan`)."""
        self.stream.at(sim_time=time_s)
        if plan.candidates:
            self.stream.log(
                f"{TABLE}/scan_plan/candidates",
                rr.LineStrips3D(
                    [[c.planned.T_table_start[:3, 3], c.planned.T_table_end[:3, 3]]
                     for c in plan.candidates],
                    colors=[[150, 150, 150, 120]], radii=0.0007,
                ),
            )  # fmt: skip
        colours = [PASS_COLOURS[k % len(PASS_COLOURS)] for k in range(len(plan.passes))]
        self.stream.log(
            f"{TABLE}/scan_plan/chosen",
            rr.LineStrips3D(
                [[p.T_table_start[:3, 3], p.T_table_end[:3, 3]] for p in plan.passes],
                colors=colours, radii=0.002,
                labels=[str(k + 1) for k in range(len(plan.passes))],  # as the log numbers them
            ),
        )  # fmt: skip
        T = self._T_table_nominal
        for k, seen in enumerate(plan.seen_model):
            self.stream.log(
                f"{TABLE}/scan_plan/seen/p{k + 1:02d}",
                rr.Points3D(seen[::3] @ T[:3, :3].T + T[:3, 3], colors=[colours[k]], radii=0.0005),
            )

    def log_scan(self, scan: ScanData, on_object: np.ndarray) -> None:
        """The measured scan building up (see scan.py); the close-up's camera on the object
        where the table held it at the scan's end."""
        if scan.lines:  # what the passes were predicted to see gives way to what they see
            self.stream.at(sim_time=float(scan.line_times_s[0]))
            self.stream.log(f"{TABLE}/scan_plan/seen", rr.Clear(recursive=True))
        log_scan(self.stream, scan, on_object, f"{TABLE}/scan")
        self.stream.log(f"{TABLE}/scan_plan", rr.Clear(recursive=True))  # scanned: done
        if self._scene is not None:
            table = self._scene.latest().get(self._scene.path_of_body("table"))
            if table is not None:
                self._T_world_top = table @ self._T_body_top
                self._aim()

    def log_registration(
        self, time_s: float, result: MatchResult, virtual: ObjectModel,
        points_table: np.ndarray, points_used: np.ndarray,
    ) -> np.ndarray:  # fmt: skip
        """The match at `time_s`: the model registered, the scan coloured by residual; the
        search and the ICP on the `icp` timeline with the cell held. Returns the residuals
        [m] of `points_table` (inf: off the model)."""
        residuals = log_registered(self.stream, time_s, result, virtual, points_table, TABLE)
        if self._scene is not None:
            self._scene.hold(self.stream, ICP)
        log_icp(self.stream, result, virtual, points_used, TABLE)
        return residuals

    def log_targets(
        self,
        time_s: float,
        program: OfflineProgram,
        evaluated: tuple[TargetEvaluation, ...],
        result: MatchResult | None,
        targets_model: np.ndarray | None,
    ) -> None:
        """The targets evaluated at `time_s`, with the predicted TRE of `result` at
        `targets_model` (K, 3) (model frame) if the pose came from a surface match."""
        corrected = np.array([op.T_base_touch[:3, 3] for op in program.operations])
        covariances = None
        if result is not None and targets_model is not None and len(targets_model):
            R = program.T_base_object[:3, :3]
            covariances = R @ target_covariance(result.covariance, targets_model) @ R.T
        T = program.T_base_object
        centre = T[:3, :3] @ self._centre_model + T[:3, 3]
        log_targets(self.stream, time_s, corrected, evaluated, covariances, centre)

    def log_verification(
        self,
        time_s: float,
        verification: Verification,
        targets_table: np.ndarray,
        strip_table: np.ndarray,
    ) -> None:
        """The verification at `time_s`: its targets (K, 3) and strips' points (N, 3) [m]
        in the table frame (see verification.py)."""
        log_verification(self.stream, time_s, verification, targets_table, strip_table, TABLE)

    def log_tool_check(self, time_s: float, check: TcpCheck) -> None:
        """A tool checked at the beam at `time_s` (see verification.py)."""
        log_tool_check(self.stream, time_s, check)

    def log_budget(self, time_s: float, budget: ErrorBudget) -> None:
        """The targets' error budget at `time_s` (see budget.py)."""
        log_budget(self.stream, time_s, budget)

    def close(self, keep: bool = True) -> None:
        """Send what was buffered and close; keep the file only if the run completed."""
        if keep:
            if self._scene is not None:
                self._scene.flush(self.stream)
            self._rays.flush(self.stream)
            self._ir.flush(self.stream)
        self.stream.close(keep)
