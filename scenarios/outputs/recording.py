"""The rerun recording of a run (run.rrd, or a live viewer with --spawn).

Entities (robot base frame = world):
- `world/cell/<body>`: every body of the real cell (links, table, tools, object) with its
  geometry (static, in the body frame) and its pose over the `sim_time` timeline;
- `world/table/scan/points`, `.../rays`: laser points and rays as they were taken (points in
  the nominal table frame at table position 0, where the match works);
- `world/table/icp/model`: the virtual model moving through the final ICP's iterations on a
  timeline of its own, `icp`; `world/table/icp/scan`: the points matched;
- `world/targets/{virtual,corrected,achieved}`: the targets;
- `plots/icp/rms_mm` (timeline `icp`) and `plots/targets/<name>_mm` (timeline `target`).
A RecordingStream object (not the global one) keeps parallel runs apart.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import pinocchio as pin
import rerun as rr
import rerun.blueprint as rrb

from cell import Kinematics, nominal_T_base_table
from models import ObjectModel
from registration import MatchResult, invert
from registration.rigid import R_to_quat_wxyz
from scenarios.offline.program import OfflineProgram
from scenarios.offline.scan import ScanData
from scenarios.realcell.evaluation import TargetEvaluation

#: Geom groups shown: environment, objects, arm visuals, tools (not collision-only ones).
_SHOWN_GROUPS = (0, 1, 2, 4)
#: At most this many laser rays are drawn per line.
_RAYS_PER_LINE = 8


def blueprint() -> rrb.Blueprint:
    """The default layout: the 3D cell beside the ICP rms and the target errors."""
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial3DView(origin="/world", name="cell"),
            rrb.Vertical(
                rrb.TimeSeriesView(origin="/plots/icp", name="ICP rms [mm]"),
                rrb.TimeSeriesView(origin="/plots/targets", name="target errors [mm]"),
            ),
            column_shares=[3, 2],
        ),
        collapse_panels=True,
    )


def _xyzw(R: np.ndarray) -> np.ndarray:
    w, x, y, z = R_to_quat_wxyz(R)
    return np.array([x, y, z, w])


def _transform(T: np.ndarray) -> rr.Transform3D:
    return rr.Transform3D(translation=T[:3, 3], quaternion=_xyzw(T[:3, :3]))


def _rgba(rgba: np.ndarray) -> list[int]:
    return [round(255 * float(c)) for c in rgba]


class Recording:
    """A rerun recording written to `path` (and sent to a spawned viewer if `spawn`)."""

    def __init__(self, path: Path, spawn: bool = False, app_id: str = "twincell") -> None:
        self.path = Path(path)
        # Written under a temporary name, renamed into place by close(keep=True): a failed
        # or interrupted run leaves no half recording.
        self._tmp = self.path.with_name(f".{self.path.name}.partial")
        to_file = rr.RecordingStream(app_id)
        to_file.save(str(self._tmp), default_blueprint=blueprint())
        self._viewer: rr.RecordingStream | None = None
        if spawn:  # a second stream for the live viewer: the file never waits for it
            self._viewer = rr.RecordingStream(app_id, recording_id=to_file.get_recording_id())
            self._viewer.spawn(default_blueprint=blueprint())
        self.rec = _Tee(to_file, self._viewer)
        self._file = to_file
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self.rec.log("world/table", _transform(nominal_T_base_table(0.0)), static=True)

    def close(self, keep: bool = True) -> None:
        """Flush and close the file; move it into place if `keep`, else delete it. A live
        viewer gets 5 s to take the rest, then the run goes on without it."""
        self._file.flush()
        self._file.disconnect()
        if self._viewer is not None:
            with contextlib.suppress(RuntimeError):  # no viewer came up (no display)
                self._viewer.flush(timeout_sec=5.0)
            self._viewer.disconnect()
        if keep:
            os.replace(self._tmp, self.path)
        else:
            self._tmp.unlink(missing_ok=True)

    # -- the cell ---------------------------------------------------------------------------------
    def log_cell_geometry(self, model: mujoco.MjModel) -> None:
        """Every shown geom of the cell, static, in its body's frame."""
        for g in range(model.ngeom):
            if model.geom_group[g] not in _SHOWN_GROUPS:
                continue
            body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])
            if body is None:
                continue
            path = f"world/cell/{body}/geom_{g}"
            T = np.eye(4)
            w, x, y, z = model.geom_quat[g]
            T[:3, :3] = _quat_matrix(np.array([w, x, y, z]))
            T[:3, 3] = model.geom_pos[g]
            color = _rgba(model.geom_rgba[g])
            size = model.geom_size[g]
            kind = model.geom_type[g]
            if kind == mujoco.mjtGeom.mjGEOM_BOX:
                archetype = rr.Boxes3D(half_sizes=[size], colors=[color], fill_mode="solid")
            elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
                archetype = rr.Ellipsoids3D(
                    half_sizes=[[size[0]] * 3], colors=[color], fill_mode="solid"
                )
            elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
                T[:3, 3] -= size[1] * T[:3, 2]  # rerun's capsule starts at its origin
                archetype = rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], colors=[color])
            elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
                archetype = rr.Cylinders3D(
                    lengths=[2 * size[1]], radii=[size[0]], colors=[color], fill_mode="solid"
                )
            elif kind == mujoco.mjtGeom.mjGEOM_MESH:
                m = model.geom_dataid[g]
                v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
                f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
                archetype = rr.Mesh3D(
                    vertex_positions=model.mesh_vert[v0 : v0 + nv],
                    triangle_indices=model.mesh_face[f0 : f0 + nf],
                    albedo_factor=color,
                )
            else:
                continue  # the floor plane
            self.rec.log(path, _transform(T), archetype, static=True)

    def log_bodies(self, time_s: float, poses: dict[str, np.ndarray]) -> None:
        """Poses (4, 4) of the cell's bodies at controller time `time_s` [s]."""
        self.rec.set_time("sim_time", duration=time_s)
        for name, T in poses.items():
            self.rec.log(f"world/cell/{name}", _transform(T))

    # -- scan and match ---------------------------------------------------------------------------
    def log_model(self, virtual: ObjectModel, T_table_nominal: np.ndarray) -> None:
        """The virtual model at its nominal place (static) and its virtual targets."""
        mesh = virtual.mesh
        self.rec.log("world/table/nominal", _transform(T_table_nominal), static=True)
        self.rec.log(
            "world/table/nominal/model",
            rr.Mesh3D(
                vertex_positions=mesh.vertices,
                triangle_indices=mesh.faces,
                albedo_factor=[120, 160, 255, 90],
            ),
            static=True,
        )
        if virtual.burr_holes:
            self.rec.log(
                "world/table/nominal/targets",
                rr.Points3D(
                    [h.p_entry for h in virtual.burr_holes],
                    radii=0.003,
                    colors=[[80, 120, 255]],
                    labels=[h.name for h in virtual.burr_holes],
                ),
                static=True,
            )

    def log_arm(self, time_s: float, kinematics: Kinematics, q: np.ndarray, tool: str) -> None:
        """The arm's links and the tool in hand at joints q (6,) [rad], by the NOMINAL
        kinematics (the pose the encoders report; the truth is logged at move ends)."""
        model = kinematics.model
        data = model.createData()
        pin.forwardKinematics(model, data, np.asarray(q, dtype=float))
        self.rec.set_time("sim_time", duration=time_s)
        for j in range(1, model.njoints):
            M = data.oMi[j]
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = M.rotation, M.translation
            self.rec.log(f"world/cell/link{j}", _transform(T))
        self.rec.log(f"world/cell/tool_{tool}", _transform(kinematics.fk(q)))

    def follow(
        self,
        time_s: float,
        q: np.ndarray,
        kinematics: Kinematics,
        tool: str | None,
        interpolate: bool = True,
        samples: int = 10,
    ) -> None:
        """The arm from the last followed state to joints q (6,) at `time_s` [s]: `samples`
        poses along the quintic joint profile the controller's moves follow (nominal
        kinematics; a straight TCP move is close to it over a short distance)."""
        last = getattr(self, "_last", None)
        self._last = (time_s, np.asarray(q, dtype=float).copy())
        if last is None or not interpolate or tool is None:
            return
        t0, q0 = last
        for tau in np.linspace(0.0, 1.0, samples + 1)[1:]:
            shape = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
            self.log_arm(t0 + tau * (time_s - t0), kinematics, q0 + shape * (q - q0), tool)

    def log_scan(
        self, scan: ScanData, on_object: np.ndarray, kinematics: Kinematics | None = None
    ) -> None:
        """Each laser line at its time: its points, a few of its rays, and (with
        `kinematics`) the arm at every other line."""
        order = np.argsort(scan.line_index, kind="stable")
        starts = np.searchsorted(scan.line_index[order], np.arange(scan.lines + 1))
        for k in range(scan.lines):
            idx = order[starts[k] : starts[k + 1]]
            self.rec.set_time("sim_time", duration=float(scan.line_times_s[k]))
            p = scan.points_table[idx]
            colors = np.where(on_object[idx, None], [[250, 200, 60]], [[130, 130, 130]])
            self.rec.log("world/table/scan/points", rr.Points3D(p, radii=0.0006, colors=colors))
            ends = p[:: max(1, len(p) // _RAYS_PER_LINE)]
            origin = scan.line_origins_table[k]
            self.rec.log(
                "world/table/scan/rays",
                rr.LineStrips3D([[origin, e] for e in ends], colors=[[255, 60, 60]], radii=0.0003),
            )
            if kinematics is not None and k % 2 == 0:
                self.log_arm(float(scan.line_times_s[k]), kinematics, scan.line_q[k], "laser")
        everything = scan.points_table[on_object]
        self.rec.log(
            "world/table/scan/all",
            rr.Points3D(everything, radii=0.0005, colors=[[250, 200, 60]]),
            static=True,
        )

    def log_icp(self, result: MatchResult, virtual: ObjectModel) -> None:
        """The virtual model moving through the final ICP iterations (timeline `icp`): the
        pose of iteration k maps model coordinates into the table frame by inv(T_k)."""
        self.rec.log(
            "world/table/icp/model",
            rr.Mesh3D(
                vertex_positions=virtual.mesh.vertices,
                triangle_indices=virtual.mesh.faces,
                albedo_factor=[90, 220, 120, 140],
            ),
            static=True,
        )
        for k, (T_model_data, rms) in enumerate(
            zip(result.trajectory, result.history, strict=False)
        ):
            self.rec.set_time("icp", sequence=k)
            self.rec.log("world/table/icp/model", _transform(invert(T_model_data)))
            self.rec.log("plots/icp/rms_mm", rr.Scalars(float(rms) * 1e3))

    def log_targets(
        self,
        program: OfflineProgram,
        evaluated: tuple[TargetEvaluation, ...],
    ) -> None:
        """Corrected targets (static), achieved tips and errors per target (timeline
        `target`)."""
        corrected = np.array([op.T_base_touch[:3, 3] for op in program.operations])
        names = [op.operation.name for op in program.operations]
        self.rec.log(
            "world/targets/corrected",
            rr.Points3D(corrected, radii=0.002, colors=[[60, 220, 60]], labels=names),
            static=True,
        )
        if evaluated:
            self.rec.log(
                "world/targets/achieved",
                rr.Points3D(
                    [t.p_achieved_base for t in evaluated], radii=0.0015, colors=[[255, 0, 255]]
                ),
                static=True,
            )
            self.rec.log(
                "world/targets/true",
                rr.Points3D([t.p_true_base for t in evaluated], radii=0.001, colors=[[0, 0, 0]]),
                static=True,
            )
        for k, t in enumerate(evaluated):
            self.rec.set_time("target", sequence=k)
            self.rec.log(f"plots/targets/{t.name}_mm", rr.Scalars(t.error_m * 1e3))

    def log_scalar(self, path: str, timeline: str, step: int, value: float) -> None:
        """One scalar on a sequence timeline."""
        self.rec.set_time(timeline, sequence=step)
        self.rec.log(path, rr.Scalars(value))


class _Tee:
    """Log calls sent to the file stream and, if there is one, the viewer stream."""

    def __init__(self, *streams: rr.RecordingStream | None) -> None:
        self.streams = [s for s in streams if s is not None]

    def log(self, *args: Any, **kwargs: Any) -> None:
        for stream in self.streams:
            stream.log(*args, **kwargs)

    def set_time(self, *args: Any, **kwargs: Any) -> None:
        for stream in self.streams:
            stream.set_time(*args, **kwargs)


def _quat_matrix(q_wxyz: np.ndarray) -> np.ndarray:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, q_wxyz)
    return out.reshape(3, 3)
