"""Robot-agnostic kinematics with Pinocchio: FK of any frame, Jacobians, IK, reachability.

The same class loads the cell's arm from its robot-only MJCF and any URDF arm (a UR5 from
example-robot-data in the tests). Configurations `q` are (nq,) arrays [rad or m]; poses are
(4, 4) homogeneous transforms in the robot's base frame.
"""

from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from cell.cell_errors import (
    CellConfigError,
    JointLimitError,
    UnknownNameError,
    UnreachableTargetError,
)
from registration.rigid import invert

if TYPE_CHECKING:
    from models.robot import ArmGeometry


@dataclass(frozen=True)
class IKResult:
    """Outcome of an inverse kinematics solve.

    `q` (nq,) the best configuration found (within the joint limits), `success` whether both
    errors are below the tolerances, `position_error_m` and `rotation_error_rad` the residual
    of `q`, `iterations` summed over all seeds, `seeds_tried`.
    """

    q: np.ndarray
    success: bool
    position_error_m: float
    rotation_error_rad: float
    iterations: int
    seeds_tried: int


class Kinematics:
    """Forward and inverse kinematics of a serial arm (Pinocchio model, fixed base)."""

    def __init__(self, model: pin.Model, tip_frame: str) -> None:
        self.model = model
        self.data = model.createData()
        #: The arm this one restricts to a tool's joint ranges (for_tool), or itself.
        self._base: Kinematics = self
        self.lower = np.array(model.lowerPositionLimit, dtype=float)
        self.upper = np.array(model.upperPositionLimit, dtype=float)
        self.tip_frame = tip_frame
        self._tip_id = self.frame_id(tip_frame)
        #: Joint ranges (lower, upper) the cell allows with a tool in hand, by tool name.
        self.tool_limits: dict[str | None, tuple[np.ndarray, np.ndarray]] = {}
        self._with_tool: dict[str | None, Kinematics] = {}
        self._q_names = [""] * model.nq
        for j in range(1, model.njoints):
            for k in range(model.joints[j].nq):
                self._q_names[model.joints[j].idx_q + k] = model.names[j]

    def for_tool(self, tool: str | None) -> Kinematics:
        """The arm as it moves with `tool` in hand: the same rigid arm, within the joint
        ranges the cell allows with that tool (`tool_limits`: a bulky tool must not fold into
        the arm; a compliant model, scenarios.offline.cell_model, also carries the tool's
        payload)."""
        base: Kinematics = self._base
        limits = base.tool_limits.get(tool)
        if limits is None:
            return base
        variants = base._with_tool
        if tool not in variants:
            other = Kinematics(base.model, base.tip_frame)
            other.lower, other.upper = (np.array(v, dtype=float) for v in limits)
            other._base = base
            variants[tool] = other
        return variants[tool]

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def from_mjcf(cls, path: str | Path, tip_frame: str = "flange") -> Kinematics:
        """Load a robot-only MJCF (the robot is the first body under worldbody)."""
        path = Path(path)
        if not path.is_file():
            raise CellConfigError(f"robot MJCF {str(path)!r} does not exist")
        return cls(pin.buildModelFromMJCF(str(path)), tip_frame)

    @classmethod
    def from_geometry(cls, geometry: ArmGeometry, tip_frame: str = "flange") -> Kinematics:
        """The cell's arm with the kinematic parameters `geometry` (lengths [m], joint zero
        offsets [rad]), e.g. a calibrated arm; `ArmGeometry()` is the nominal arm."""
        from models.robot import arm_xml

        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "arm.xml"
            path.write_text(arm_xml(geometry))
            return cls.from_mjcf(path, tip_frame)

    @classmethod
    def from_urdf(
        cls, path: str | Path, tip_frame: str, package_dirs: list[str] | None = None
    ) -> Kinematics:
        """Load a URDF; `package_dirs` resolve `package://` mesh paths (unused by kinematics)."""
        path = Path(path)
        if not path.is_file():
            raise CellConfigError(f"robot URDF {str(path)!r} does not exist")
        del package_dirs  # meshes are not needed for kinematics; kept for the documented call
        return cls(pin.buildModelFromUrdf(str(path)), tip_frame)

    # -- names --------------------------------------------------------------------------------
    @property
    def nq(self) -> int:
        """Number of configuration variables."""
        return int(self.model.nq)

    @property
    def frame_names(self) -> tuple[str, ...]:
        """Names of every frame of the model (bodies, joints, sites)."""
        return tuple(f.name for f in self.model.frames)

    def frame_id(self, name: str) -> int:
        """Index of frame `name`; an unknown name lists the available frames."""
        if not self.model.existFrame(name):
            raise UnknownNameError(
                f"frame {name!r} is not in the robot model; available frames: "
                f"{', '.join(self.frame_names)}"
            )
        return int(self.model.getFrameId(name))

    def check_limits(self, q: np.ndarray) -> np.ndarray:
        """`q` as a float (nq,) array; raises JointLimitError naming any joint out of limits."""
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.shape != (self.nq,) or not np.all(np.isfinite(q)):
            raise JointLimitError(f"a configuration needs {self.nq} finite values, got {q}")
        bad = np.flatnonzero((q < self.lower - 1e-9) | (q > self.upper + 1e-9))
        if bad.size:
            detail = "; ".join(
                f"{self._q_names[i]} = {q[i]:.6g} outside [{self.lower[i]:.6g}, "
                f"{self.upper[i]:.6g}]"
                for i in bad
            )
            raise JointLimitError(f"joint target outside the joint limits: {detail}")
        return q

    def at_limits(self, q: np.ndarray, tol_rad: float = 1e-6) -> str:
        """ "; joint 4 at its limit -183 deg (cell.robot.limits_deg)" for the joints of q
        (6,) on a limit, "" for none: what stops a solution that a limit cuts off."""
        q = np.asarray(q, dtype=float)
        out = [
            f"joint {k + 1} at its limit {np.rad2deg(bound):.0f} deg"
            for k in range(self.nq)
            for bound in (self.lower[k], self.upper[k])
            if abs(q[k] - bound) <= tol_rad
        ]
        return f"; {', '.join(out)} (cell.robot.limits_deg)" if out else ""

    # -- forward kinematics -------------------------------------------------------------------
    def fk(self, q: np.ndarray, frame: str | None = None) -> np.ndarray:
        """(4, 4) pose of `frame` (default: the tip frame) in the base frame at `q`."""
        fid = self._tip_id if frame is None else self.frame_id(frame)
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        return self.data.oMf[fid].homogeneous.copy()

    def jacobian(self, q: np.ndarray, frame: str | None = None, local: bool = False) -> np.ndarray:
        """(6, nv) frame Jacobian [linear; angular].

        `local=False`: velocity of the frame's origin in base-aligned axes
        (LOCAL_WORLD_ALIGNED); `local=True`: twist in the frame's own axes (LOCAL).
        """
        fid = self._tip_id if frame is None else self.frame_id(frame)
        ref = pin.ReferenceFrame.LOCAL if local else pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
        q = np.asarray(q, dtype=float)
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        return pin.getFrameJacobian(self.model, self.data, fid, ref).copy()

    def random_configuration(self, rng: np.random.Generator, margin: float = 0.0) -> np.ndarray:
        """A uniformly random (nq,) configuration within the limits shrunk by `margin` [rad]."""
        return rng.uniform(self.lower + margin, self.upper - margin)

    # -- inverse kinematics -------------------------------------------------------------------
    def ik(
        self,
        T_base_target: np.ndarray,
        q_seed: np.ndarray,
        T_tip_tcp: np.ndarray | None = None,
        *,
        tol_position_m: float = 1e-9,
        tol_rotation_rad: float = 1e-9,
        max_iterations: int = 60,
        extra_seeds: int = 30,
        rng: np.random.Generator | None = None,
    ) -> IKResult:
        """Solve for q such that the TCP (tip frame times `T_tip_tcp`) is at `T_base_target`.

        Damped least squares on the SE(3) log error (Pinocchio's reference loop), the step
        applied with `pin.integrate` and projected on the joint limits. The first seed is
        `q_seed` (the current configuration); if it fails, `extra_seeds` random seeds follow
        (deterministic `rng`, default seeded from 0). Non-convergence is reported in the result.
        """
        T_target = np.asarray(T_base_target, dtype=float)
        if T_target.shape != (4, 4) or not np.all(np.isfinite(T_target)):
            raise UnreachableTargetError(
                f"a target pose must be a finite (4, 4) array, got {T_target}"
            )
        T_tip_target = T_target
        if T_tip_tcp is not None:
            T_tip_target = T_target @ invert(np.asarray(T_tip_tcp, dtype=float))
        oMdes = pin.SE3(T_tip_target[:3, :3], T_tip_target[:3, 3])
        seed = np.clip(np.asarray(q_seed, dtype=float).reshape(self.nq), self.lower, self.upper)
        best: tuple[float, np.ndarray, float, float] | None = None
        total_iterations = 0
        for attempt in range(extra_seeds + 1):
            if attempt == 0:
                q0 = seed
            else:  # the random seeds' generator, made only when the first seed failed
                rng = rng if rng is not None else np.random.default_rng(0)
                q0 = self.random_configuration(rng)
            q, dp, dr, it = self._dls(oMdes, q0, tol_position_m, tol_rotation_rad, max_iterations)
            total_iterations += it
            score = dp + 0.1 * dr
            if best is None or score < best[0]:
                best = (score, q, dp, dr)
            if dp <= tol_position_m and dr <= tol_rotation_rad:
                q = self.nearest_turns(q, seed) if attempt else q
                return IKResult(q, True, dp, dr, total_iterations, attempt + 1)
        assert best is not None
        return IKResult(best[1], False, best[2], best[3], total_iterations, extra_seeds + 1)

    def nearest_turns(self, q: np.ndarray, q_ref: np.ndarray) -> np.ndarray:
        """`q` (6,) with each joint turned by whole turns (2 pi, the same pose) to the value
        nearest `q_ref` within its limits: a solution found from a random seed, brought back
        next to the arm's configuration."""
        out = np.array(q, dtype=float)
        turns = np.round((np.asarray(q_ref, dtype=float) - out) / (2.0 * np.pi))
        for k in np.flatnonzero(turns):
            for n in (turns[k], turns[k] - np.sign(turns[k])):
                value = out[k] + 2.0 * np.pi * n
                if self.lower[k] <= value <= self.upper[k]:
                    out[k] = value
                    break
        return out

    def _dls(
        self, oMdes: pin.SE3, q: np.ndarray, tol_p: float, tol_r: float, max_iterations: int
    ) -> tuple[np.ndarray, float, float, int]:
        model, data, fid = self.model, self.data, self._tip_id
        lower, upper = self.lower, self.upper
        local = pin.ReferenceFrame.LOCAL
        dp = dr = np.inf
        history: list[float] = []
        for it in range(1, max_iterations + 1):
            pin.framesForwardKinematics(model, data, q)
            iMd = data.oMf[fid].actInv(oMdes)
            err = pin.log6(iMd).vector
            dp = math.sqrt(float(iMd.translation @ iMd.translation))
            dr = math.sqrt(float(err[3:] @ err[3:]))
            if dp <= tol_p and dr <= tol_r:
                return q, dp, dr, it
            # Stalled (typically pinned on a joint limit): give this seed up.
            history.append(dp + dr)
            if it > 15 and history[-1] > 0.5 * history[-6] and history[-1] > 1e-4:
                return q, dp, dr, it
            # The frame placements are those of q (just computed): the Jacobian needs no FK.
            pin.computeJointJacobians(model, data)
            J = -pin.Jlog6(iMd.inverse()) @ pin.getFrameJacobian(model, data, fid, local)
            A = J @ J.T
            A.flat[::7] += 1e-10 + 1e-3 * float(err @ err)
            v = -J.T @ np.linalg.solve(A, err)
            step = math.sqrt(float(v @ v))
            if step > 0.5:
                v *= 0.5 / step
            q = np.clip(pin.integrate(model, q, v), lower, upper)
        return q, dp, dr, max_iterations

    def solve(
        self,
        T_base_target: np.ndarray,
        q_seed: np.ndarray,
        T_tip_tcp: np.ndarray | None = None,
        **kwargs: Any,
    ) -> np.ndarray:
        """Like `ik` but returns q, or raises UnreachableTargetError naming target and residual."""
        result = self.ik(T_base_target, q_seed, T_tip_tcp, **kwargs)
        if not result.success:
            p = np.asarray(T_base_target)[:3, 3]
            raise UnreachableTargetError(
                f"target at p_base = [{p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}] m is not reachable "
                f"within the joint limits: remaining residual {result.position_error_m:.3g} m, "
                f"{result.rotation_error_rad:.3g} rad after {result.seeds_tried} seeds"
            )
        return result.q

    def reachable(
        self, T_base_target: np.ndarray, q_seed: np.ndarray, T_tip_tcp: np.ndarray | None = None
    ) -> bool:
        """Whether an IK solution within the joint limits exists for the TCP at the target."""
        return self.ik(T_base_target, q_seed, T_tip_tcp).success


#: Gravity [m/s^2] in the base frame (z up).
GRAVITY = np.array([0.0, 0.0, -9.81])


def payload_model(kinematics: Kinematics, tool: str | None) -> pin.Model:
    """A copy of the arm's model (its links' inertias) carrying `tool` in its last link: the
    tool's nominal mass at half way to its TCP on the flange's z axis (the tooldata's load);
    the bare arm for None."""
    from models.robot import TOOLS

    model = pin.Model(kinematics.model)
    model.gravity.linear = GRAVITY
    if tool is None:
        return model
    spec = {t.name: t for t in TOOLS}[tool]
    frame = model.frames[model.getFrameId(kinematics.tip_frame)]
    com_joint = frame.placement.act(np.array([0.0, 0.0, spec.p_tool_tcp[2] / 2.0]))
    model.inertias[frame.parentJoint] += pin.Inertia(spec.mass, com_joint, np.eye(3) * 1e-4)
    return model
