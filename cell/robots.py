"""The cell's arm: the built-in IRB 2400-class arm, the UR5 of example-robot-data, or any 6-axis
arm given as a URDF or a robot-only MJCF file.

A `Robot` gives what the cell and its planner need of an arm:
- its nominal kinematics (Pinocchio) and, for a vector of deviations of its kinematic
  parameters, the deviated arm's (the real arm, drawn from the cell's seed; the calibrated
  arm, identified in the cell);
- the robot-only MJCF that MuJoCo simulates for those deviations: bodies `link1`..`link6`,
  joints and position servos `joint1`..`joint6`, a `flange` site where the tools lock;
- its home configuration, joint speeds and efforts, and who makes it (RAPID is ABB's).

The kinematic base frame is the cell's world frame: an arm standing elsewhere than the world's
origin (on a pedestal beside the table, say) carries its mount in its first joint's placement.

Deviations: the built-in arm has its twelve (six link lengths, six joint zero offsets, see
models.robot.ArmGeometry); any other arm has four per joint: the joint's zero offset [rad] and
the position of its axis in its parent link [m] (x, y, z), 24 in all.
"""

from __future__ import annotations

import sysconfig
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from cell.errors import CellConfigError
from cell.kinematics import Kinematics
from models.robot import (
    JOINT_NAMES,
    JOINT_SPEED,
    JOINT_TORQUE,
    Q_HOME,
    ROBOT_PATH,
    ArmGeometry,
    arm_xml,
)
from models.robot.arm import LinkXml, arm_document, servo_actuators

#: Deviation names of the built-in arm, in the order of its deviation vectors (12,).
IRB_PARAMETERS: tuple[str, ...] = (
    "d1", "a1", "a2", "a3", "d4", "d6",
    "offset1", "offset2", "offset3", "offset4", "offset5", "offset6",
)  # fmt: skip


@dataclass(frozen=True, eq=False)
class Robot:
    """An arm of the cell (see the module's docstring).

    Attributes:
        name: "irb2400", "ur5" or the file's stem.
        vendor: who makes it ("abb" gets RAPID programs; others the targets as CSV/JSON).
        q_home: (6,) home configuration [rad]: wrist above the table, flange down.
        joint_speed: (6,) speed limits [rad/s]; joint_effort: (6,) [N m].
        parameters: names of the kinematic deviations; lengths: (P,) True where a deviation
            is a length [m] (else an angle [rad]).
        tip_frame: the flange frame of the kinematics.
        T_world_base: (4, 4) where the arm's own base stands in the cell (its mount; the
            kinematics' base frame is the cell's, the mount in the first joint's placement).
        identified: (P,) bool, the deviations an in-cell calibration identifies (default
            all); the others it holds at zero.
    """

    name: str
    vendor: str
    q_home: np.ndarray
    joint_speed: np.ndarray
    joint_effort: np.ndarray
    parameters: tuple[str, ...]
    lengths: np.ndarray
    _kinematics: Callable[[np.ndarray], Kinematics] = field(repr=False)
    _mjcf: Callable[[np.ndarray], str] = field(repr=False)
    tip_frame: str = "flange"
    T_world_base: np.ndarray = field(default_factory=lambda: np.eye(4))
    identified: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.identified is None:
            object.__setattr__(self, "identified", np.ones(len(self.parameters), dtype=bool))

    @property
    def rapid(self) -> bool:
        """Whether the arm's controller runs RAPID (an ABB arm)."""
        return self.vendor.lower() == "abb"

    def zero(self) -> np.ndarray:
        """The nominal arm's deviations (P,) (all zero)."""
        return np.zeros(len(self.parameters))

    def kinematics(self, deviations: np.ndarray | None = None) -> Kinematics:
        """Pinocchio kinematics of the arm with `deviations` (P,) (default: the nominal)."""
        return self._kinematics(self._check(deviations))

    def mjcf(self, deviations: np.ndarray | None = None) -> str:
        """The robot-only MJCF of the arm with `deviations` (P,) (default: the nominal)."""
        return self._mjcf(self._check(deviations))

    def draw_deviations(
        self, rng: np.random.Generator, length_sigma_m: float, angle_sigma_rad: float
    ) -> np.ndarray:
        """Deviations (P,) of a real arm: Gaussian, `length_sigma_m` on lengths and
        `angle_sigma_rad` on angles."""
        return rng.normal(0.0, 1.0, len(self.parameters)) * self.sigmas(
            length_sigma_m, angle_sigma_rad
        )

    def sigmas(self, length_sigma_m: float, angle_sigma_rad: float) -> np.ndarray:
        """(P,) the given sigma of each deviation by its kind (a prior, say)."""
        return np.where(self.lengths, length_sigma_m, angle_sigma_rad)

    def _check(self, deviations: np.ndarray | None) -> np.ndarray:
        if deviations is None:
            return self.zero()
        d = np.asarray(deviations, dtype=float)
        if d.shape != (len(self.parameters),) or not np.isfinite(d).all():
            raise CellConfigError(
                f"{self.name}: deviations must be {len(self.parameters)} finite numbers "
                f"({', '.join(self.parameters)}), got shape {d.shape}"
            )
        return d


# -- the built-in arm -------------------------------------------------------------------------
#: The built-in arm's joint 5 range in the cell with the laser in hand [rad]: beyond 100 deg
#: the laser's 12 cm body folds into the forearm (link 4); the arm's own stop is 120 deg.
IRB_LASER_WRIST_BEND_RAD = float(np.deg2rad(100.0))
#: With the screwer in hand [rad]: beyond 110 deg its changer plate comes within 5 mm of the
#: forearm (114 deg: it touches).
IRB_SCREWER_WRIST_BEND_RAD = float(np.deg2rad(110.0))


def _irb_kinematics(geometry: ArmGeometry) -> Kinematics:
    kin = Kinematics.from_geometry(geometry)
    for tool, bend in (
        ("laser", IRB_LASER_WRIST_BEND_RAD),
        ("screwer", IRB_SCREWER_WRIST_BEND_RAD),
    ):
        lower, upper = kin.lower.copy(), kin.upper.copy()
        lower[4], upper[4] = -bend, bend
        kin.tool_limits[tool] = (lower, upper)
    return kin


def irb2400() -> Robot:
    """The cell's IRB 2400-class arm (models.robot.arm), at the world's origin; with the
    laser in hand its joint 5 is kept where the laser does not fold into the forearm
    (IRB_LASER_WRIST_BEND_RAD)."""

    def geometry(d: np.ndarray) -> ArmGeometry:
        return ArmGeometry().perturbed(d[:6], d[6:])

    return Robot(
        name="irb2400",
        vendor="abb",
        q_home=np.array(Q_HOME, dtype=float),
        joint_speed=np.array(JOINT_SPEED, dtype=float),
        joint_effort=np.array(JOINT_TORQUE, dtype=float),
        parameters=IRB_PARAMETERS,
        lengths=np.array([True] * 6 + [False] * 6),
        _kinematics=lambda d: _irb_kinematics(geometry(d)),
        _mjcf=lambda d: arm_xml(geometry(d)),
    )


# -- any 6-axis arm from a file -----------------------------------------------------------------
@dataclass(frozen=True)
class Servo:
    """Position servos of a file arm: stiffness [N m/rad], damping [N m s/rad] and the
    rotor inertia reflected through each gearbox [kg m^2], per joint (6,)."""

    kp: tuple[float, ...]
    kv: tuple[float, ...]
    armature: tuple[float, ...]


def _mount(xyz: tuple[float, float, float], yaw_deg: float) -> pin.SE3:
    c, s = np.cos(np.deg2rad(yaw_deg)), np.sin(np.deg2rad(yaw_deg))
    return pin.SE3(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array(xyz, float))


def load_arm_model(path: str | Path, tip_frame: str) -> pin.Model:
    """The Pinocchio model of a 6-axis arm file (URDF or robot-only MJCF), joints that do not
    move the flange (a gripper's) locked at their neutral value; raises
    CellConfigError for a missing file, another format, a missing tip frame, or other than
    six revolute joints."""
    p = Path(path)
    if not p.is_file():
        raise CellConfigError(f"robot file not found: {p}")
    suffix = p.suffix.lower()
    try:
        if suffix == ".urdf":
            model = pin.buildModelFromUrdf(str(p))
        elif suffix in (".xml", ".mjcf"):
            model = pin.buildModelFromMJCF(str(p))
        else:
            raise CellConfigError(
                f"robot file {p} has unknown format {p.suffix!r}; valid: .urdf, .xml (MJCF)"
            )
    except (RuntimeError, ValueError) as exc:
        raise CellConfigError(f"{p}: cannot be read as a robot: {exc}") from None
    if model.existFrame(tip_frame) and model.nq != 6:
        model = _chain_to(model, tip_frame)
    revolute = [
        model.names[j]
        for j in range(1, model.njoints)
        if model.joints[j].shortname().startswith(("JointModelR", "JointModelRevolute"))
    ]
    if model.nq != 6 or len(revolute) != 6:
        raise CellConfigError(
            f"{p}: the cell needs a 6-axis arm (six revolute joints); this one has {model.nq} "
            f"position variables and revolute joints {revolute}"
        )
    frames = [
        f.name for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)
    ]
    if not model.existFrame(tip_frame):
        raise CellConfigError(
            f"{p}: no frame {tip_frame!r} for the flange; its frames are {frames}"
        )
    cosine = _flange_axis_cosine(model, tip_frame)
    if abs(cosine) < np.cos(np.deg2rad(5.0)):
        raise CellConfigError(
            f"{p}: the flange frame {tip_frame!r} has its z axis "
            f"{np.rad2deg(np.arccos(np.clip(abs(cosine), 0.0, 1.0))):.0f} deg off the last "
            "joint's axis; the tools mount along the flange's z axis, so name a frame whose z "
            f"axis points out of the wrist (cell.robot.flange; its frames are {frames})"
        )
    return model


def _flange_axis_cosine(model: pin.Model, tip_frame: str) -> float:
    """Cosine between the flange frame's z axis and the last joint's axis."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    last = model.njoints - 1
    axis = data.oMi[last].rotation @ motion_axis(model, last)
    return float(data.oMf[model.getFrameId(tip_frame)].rotation[:, 2] @ axis)


def _chain_to(model: pin.Model, tip_frame: str) -> pin.Model:
    """`model` with the joints that do not move `tip_frame` (a gripper's fingers, say)
    locked at their neutral value: the arm that carries the flange."""
    parent = model.frames[model.getFrameId(tip_frame)].parentJoint
    chain = set(model.supports[parent])
    locked = [j for j in range(1, model.njoints) if j not in chain]
    if not locked:
        return model
    return pin.buildReducedModel(model, locked, pin.neutral(model))


def motion_axis(model: pin.Model, j: int) -> np.ndarray:
    """Unit axis (3,) of revolute joint j in its own frame (its constant motion subspace)."""
    data = model.createData()
    pin.forwardKinematics(model, data, pin.neutral(model))
    S = np.asarray(data.joints[j].S).reshape(6)
    return S[3:] / np.linalg.norm(S[3:])


def _deviated(model: pin.Model, axes: list[np.ndarray], d: np.ndarray) -> pin.Model:
    """A copy of `model` with each joint's zero offset d[4k] [rad] and axis position
    d[4k+1:4k+4] [m] (in its parent) changed."""
    out = pin.Model(model)
    for k in range(6):
        j = k + 1
        M = out.jointPlacements[j]
        offset = pin.SE3(pin.exp3(axes[k] * d[4 * k]), np.zeros(3))
        shifted = pin.SE3(M.rotation, M.translation + d[4 * k + 1 : 4 * k + 4])
        out.jointPlacements[j] = shifted * offset
    return out


def _f(values: np.ndarray | tuple[float, ...]) -> str:
    return " ".join(f"{float(v):.12g}" for v in values)


def _six(inertia: np.ndarray) -> tuple[float, ...]:
    """MJCF's fullinertia order: Ixx, Iyy, Izz, Ixy, Ixz, Iyz."""
    i = np.asarray(inertia)
    return (i[0, 0], i[1, 1], i[2, 2], i[0, 1], i[0, 2], i[1, 2])


def _quat(R: np.ndarray) -> str:
    q = pin.Quaternion(R)
    return _f((q.w, q.x, q.y, q.z))


def arm_mjcf(
    model: pin.Model,
    tip_frame: str,
    servo: Servo,
    effort: np.ndarray,
    q_home: np.ndarray,
    radius_m: float,
    name: str,
) -> str:
    """The robot-only MJCF of a 6-axis Pinocchio model, named as the cell expects: bodies
    `base`, `link1`..`link6`, joints and servos `joint1`..`joint6`, a `flange` site at the
    tip frame. Each link's geometry is a capsule of `radius_m` from its joint to the next
    (kinematics and inertias are the model's; no meshes); a pedestal stands under the
    mount."""
    tip = model.frames[model.getFrameId(tip_frame)]
    lower, upper = model.lowerPositionLimit, model.upperPositionLimit
    mount = model.jointPlacements[1].translation

    def link(k: int) -> LinkXml:
        j = k + 1
        M = model.jointPlacements[j]
        inertia = model.inertias[j]
        inertia_com = inertia.inertia  # about the centre of mass, joint frame
        inertial = (
            f'<inertial pos="{_f(inertia.lever)}" mass="{inertia.mass:.12g}" '
            f'fullinertia="{_f(_six(inertia_com))}"/>'
            if inertia.mass > 0
            else '<inertial pos="0 0 0" mass="1e-6" diaginertia="1e-9 1e-9 1e-9"/>'
        )
        child = model.jointPlacements[j + 1].translation if j < 6 else tip.placement.translation
        geoms: tuple[str, ...] = ()
        if np.linalg.norm(child) > 1e-3:
            geoms = tuple(
                f'<geom class="{cls}" type="capsule" size="{radius_m:g}" '
                f'fromto="0 0 0 {_f(child)}"/>'
                for cls in ("collision", "visual")
            )
        return LinkXml(
            f"link{j}",
            f' pos="{_f(M.translation)}" quat="{_quat(M.rotation)}"',
            inertial,
            f'<joint name="{JOINT_NAMES[k]}" axis="{_f(motion_axis(model, j))}" '
            f'range="{lower[k]:.12g} {upper[k]:.12g}" armature="{servo.armature[k]:g}"/>',
            geoms,
        )

    height = max(float(mount[2]), 0.01)
    pedestal = (
        f'type="cylinder" size="0.1 {height / 2:.6g}"\n'
        f'            pos="{mount[0]:.6g} {mount[1]:.6g} {height / 2:.6g}"/>'
    )
    P = tip.placement
    return arm_document(
        name,
        [link(k) for k in range(6)],
        (
            '<inertial pos="0 0 0.1" mass="50" diaginertia="1 1 1"/>',
            f'<geom class="collision" {pedestal}',
            f'<geom class="visual" {pedestal}',
        ),
        f'<site name="flange" pos="{_f(P.translation)}" quat="{_quat(P.rotation)}" size="0.01"/>',
        servo_actuators(lower, upper, effort, servo.kp, servo.kv),
        q_home,
        "0.35 0.55 0.75 1",
        # The first link turns on the base bolted to the floor: its capsule's end (a radius
        # below the joint-1 origin) stands for the base casting, not for a link that could
        # meet the floor; an arm mounted at floor level would otherwise touch it everywhere.
        on_floor=("link1",),
    )


def _limit(model: pin.Model, limits: tuple[np.ndarray, np.ndarray], path: str | Path) -> None:
    """Narrow `model`'s joint ranges to `limits` (lower, upper) (6,) [rad], which must lie
    within the file's."""
    lower, upper = (np.asarray(v, dtype=float) for v in limits)
    if (
        lower.shape != (6,)
        or upper.shape != (6,)
        or (lower >= upper).any()
        or (lower < model.lowerPositionLimit - 1e-9).any()
        or (upper > model.upperPositionLimit + 1e-9).any()
    ):
        raise CellConfigError(
            f"{path}: joint ranges {lower.tolist()} .. {upper.tolist()} rad must be six "
            f"increasing pairs within the arm's {model.lowerPositionLimit.tolist()} .. "
            f"{model.upperPositionLimit.tolist()}"
        )
    model.lowerPositionLimit, model.upperPositionLimit = lower, upper


def _mjcf_efforts(path: str | Path, model: pin.Model) -> np.ndarray:
    """The arm's joints' effort limits [N m] (6,) as its MJCF file states them (inf where
    it does not): a joint's actuator force range, else the largest force range of the
    actuators driving it (MuJoCo's own parser, its default classes applied; the meshes are
    not read)."""
    import mujoco

    spec = mujoco.MjSpec.from_file(str(path))
    joints = {j.name: j for j in spec.joints}
    out = np.full(6, np.inf)
    for k in range(6):
        name = model.names[k + 1]
        joint = joints.get(name)
        if joint is not None and joint.actfrclimited == mujoco.mjtLimited.mjLIMITED_TRUE:
            out[k] = float(np.max(np.abs(joint.actfrcrange)))
            continue
        ranges = [
            float(np.max(np.abs(a.forcerange)))
            for a in spec.actuators
            if a.target == name
            and a.forcelimited != mujoco.mjtLimited.mjLIMITED_FALSE
            and np.any(a.forcerange)
        ]
        if ranges:
            out[k] = max(ranges)
    return out


#: The joints' speed limits [rad/s] a file arm gets where its file has none (an MJCF file):
#: 90 deg/s for the main axes and 180 deg/s for the wrist, below the data sheets of 6-axis
#: arms of 0.5-1.3 m reach (a cautious choice: cell.robot.speed_deg_s gives the real ones).
DEFAULT_SPEED_RAD_S = np.deg2rad([90.0, 90.0, 90.0, 180.0, 180.0, 180.0])


def _speeds_and_efforts(
    model: pin.Model, speed: np.ndarray | None, effort: np.ndarray | None, path: str | Path
) -> tuple[np.ndarray, np.ndarray]:
    """The joints' speed [rad/s] and effort [N m] limits (6,) each: those given, else the
    file's (a speed the file does not give: DEFAULT_SPEED_RAD_S; an MJCF file's efforts from
    its joints' and actuators' force ranges); every one finite and positive."""
    if speed is None:
        file_speed = np.asarray(model.velocityLimit, dtype=float)
        given = np.isfinite(file_speed) & (file_speed > 0)
        speed = np.where(given, file_speed, DEFAULT_SPEED_RAD_S)
    speed = np.asarray(speed, dtype=float)
    if effort is None:
        effort = np.asarray(model.effortLimit, dtype=float)
        if Path(path).suffix.lower() != ".urdf" and not np.isfinite(effort).all():
            effort = np.where(np.isfinite(effort), effort, _mjcf_efforts(path, model))
    effort = np.asarray(effort, dtype=float)
    if (
        speed.shape != (6,)
        or effort.shape != (6,)
        or not (np.isfinite(speed).all() and np.isfinite(effort).all())
        or (speed <= 0).any()
        or (effort <= 0).any()
    ):
        raise CellConfigError(
            f"{path}: every joint needs a finite positive speed and effort limit (got "
            f"{speed.tolist()} rad/s, {effort.tolist()} N m); give them in the cell "
            "(cell.robot.speed_deg_s, cell.robot.effort_nm) where the file has none or they "
            "are wrong"
        )
    return speed, effort


#: The radius [m] of a file arm's links (capsules from each joint to the next).
FILE_ARM_RADIUS_M = 0.05


@dataclass(frozen=True, eq=False)
class JointLimits:
    """The cell's limits of a file arm's joints, each replacing the file's where given (None:
    the file's).

    Attributes:
        ranges_rad: (lower, upper) (6,) each [rad], within the file's: the cell's joint
            ranges (its safety configuration: e.g. the upper arm kept above the shoulder).
        speed_rad_s: (6,) the joints' speed limits [rad/s] (an MJCF file has none).
        effort_nm: (6,) the joints' effort limits [N m] (an MJCF file has none).
    """

    ranges_rad: tuple[np.ndarray, np.ndarray] | None = None
    speed_rad_s: np.ndarray | None = None
    effort_nm: np.ndarray | None = None


def robot_from_file(
    path: str | Path,
    tip_frame: str,
    *,
    mount_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0),
    mount_yaw_deg: float = 0.0,
    q_home: np.ndarray | None = None,
    servo: Servo | None = None,
    radius_m: float = FILE_ARM_RADIUS_M,
    vendor: str = "",
    name: str | None = None,
    joint_limits: JointLimits | None = None,
) -> Robot:
    """A 6-axis arm from a URDF or robot-only MJCF file, its base at `mount_xyz` [m] turned
    `mount_yaw_deg` about the vertical in the cell, the flange at frame `tip_frame`;
    `joint_limits` replace the file's joint ranges, speed and effort limits (default: the
    file's)."""
    limits = joint_limits or JointLimits()
    model = load_arm_model(path, tip_frame)
    if limits.ranges_rad is not None:
        _limit(model, limits.ranges_rad, path)
    model.jointPlacements[1] = _mount(mount_xyz, mount_yaw_deg) * model.jointPlacements[1]
    axes = [motion_axis(model, j) for j in range(1, 7)]
    speed, effort = _speeds_and_efforts(model, limits.speed_rad_s, limits.effort_nm, path)
    home = np.zeros(6) if q_home is None else np.asarray(q_home, dtype=float)
    servo = servo or Servo(
        (2e4,) * 3 + (2e3,) * 3, (4e2,) * 3 + (4e1,) * 3, (1.0,) * 3 + (0.1,) * 3
    )
    label = name or Path(path).stem
    parameters = tuple(f"{kind}{k + 1}" for k in range(6) for kind in ("offset", "x", "y", "z"))
    lengths = np.array([kind != "offset" for _ in range(6) for kind in ("offset", "x", "y", "z")])

    def kinematics(d: np.ndarray) -> Kinematics:
        return Kinematics(_deviated(model, axes, d), tip_frame)

    def mjcf(d: np.ndarray) -> str:
        return arm_mjcf(_deviated(model, axes, d), tip_frame, servo, effort, home, radius_m, label)

    return Robot(
        label,
        vendor,
        home,
        speed,
        effort,
        parameters,
        lengths,
        kinematics,
        mjcf,
        tip_frame,
        _mount(mount_xyz, mount_yaw_deg).homogeneous,
        # Joint 1's axis position shifts the whole arm: the spheres' free centres take any
        # shift, and every tool, locked where the shifted flange meets its slot (all slots
        # face down), carries the same shift back: the calibration cannot see it and the
        # job does not need it; fitted, it only combines with joint 1's offset into a turn
        # about the spheres that the noise pulls about.
        np.array([k not in (1, 2, 3) for k in range(24)]),
    )


def example_robot_data_share() -> Path:
    """The `share` folder of example-robot-data (it ships data only, under cmeel.prefix)."""
    share = Path(sysconfig.get_paths()["purelib"]) / "cmeel.prefix" / "share"
    if not (share / "example-robot-data").is_dir():
        raise CellConfigError(
            f"example-robot-data is not installed: {share / 'example-robot-data'} is missing; "
            "pip install example-robot-data"
        )
    return share


def ur5_urdf() -> Path:
    """The UR5's URDF in example-robot-data."""
    return (
        example_robot_data_share()
        / "example-robot-data" / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    )  # fmt: skip


#: Where the UR5 stands in the cell: on a pedestal at the table's near corner (clear of the
#: table's sweep), the table and the rack (cell ur5) within its 0.85 m reach.
UR5_MOUNT_XYZ = (0.55, -0.1, 0.45)
UR5_MOUNT_YAW_DEG = 0.0
UR5_HOME = np.array([0.0, -1.2, 1.6, -1.97, -1.5708, 0.0])
#: The UR5's joint ranges in the cell [rad], its safety configuration: the upper arm above
#: the shoulder and the elbow bent up (no pose reaches down through the pedestal or the
#: table), one wrist configuration (wrist 2 negative), and wrist 1 kept where no tool on the
#: flange folds back into the forearm or the upper arm (over those ranges the tools' bodies
#: stay clear of both by the arm's and the tools' radii).
UR5_LIMITS = (
    np.array([-np.pi, -np.pi, 0.0, -4.5, -2.6, -2 * np.pi]),
    np.array([np.pi, 0.0, np.pi, -0.2, -0.05, 2 * np.pi]),
)


def ur5(
    mount_xyz: tuple[float, float, float] = UR5_MOUNT_XYZ,
    mount_yaw_deg: float = UR5_MOUNT_YAW_DEG,
    q_home: np.ndarray | None = None,
) -> Robot:
    """The UR5 of example-robot-data (URDF, flange `tool0`) mounted for the cell, its servos
    sized for its 3 kg payload class."""
    return robot_from_file(
        ur5_urdf(),
        "tool0",
        mount_xyz=mount_xyz,
        mount_yaw_deg=mount_yaw_deg,
        q_home=UR5_HOME if q_home is None else q_home,
        servo=Servo(
            kp=(1e4, 1e4, 6e3, 1e3, 1e3, 5e2),
            kv=(2e2, 2e2, 1.2e2, 2e1, 2e1, 1e1),
            armature=(0.5, 0.5, 0.3, 0.05, 0.05, 0.03),
        ),
        radius_m=0.045,
        vendor="universal robots",
        name="ur5",
        joint_limits=JointLimits(ranges_rad=UR5_LIMITS),
    )


#: The built-in arms by name.
BUILTIN: tuple[str, ...] = ("irb2400", "ur5")


def make_robot(
    model: str,
    flange: str | None = None,
    mount_xyz: tuple[float, float, float] | None = None,
    mount_yaw_deg: float = 0.0,
    q_home: np.ndarray | None = None,
    vendor: str | None = None,
    limits: tuple[np.ndarray, np.ndarray] | None = None,
    speed: np.ndarray | None = None,
    effort: np.ndarray | None = None,
) -> Robot:
    """The arm `model`: a built-in one by name (BUILTIN) or a 6-axis URDF / robot-only MJCF
    file with its flange frame `flange`, mounted at `mount_xyz` [m] turned `mount_yaw_deg`,
    home `q_home` (6,) [rad], joint ranges `limits` (lower, upper) (6,) [rad] (a file arm;
    default the file's). Raises CellConfigError naming what is wrong."""
    if q_home is not None:
        q_home = np.asarray(q_home, dtype=float)
        if q_home.shape != (6,) or not np.isfinite(q_home).all():
            raise CellConfigError(f"home must be 6 finite joint values, got {q_home.tolist()}")
    if model in BUILTIN and limits is not None:
        raise CellConfigError(
            f"the {model} is built in with its joint ranges; limits are for a robot file"
        )
    if model == "irb2400":
        if flange is not None or mount_xyz is not None or mount_yaw_deg:
            raise CellConfigError(
                "the irb2400 is built in: it has its flange and stands at the cell's origin "
                "(flange and mount are for a robot file or the ur5)"
            )
        robot = irb2400()
        if q_home is not None:
            robot = replace(robot, q_home=q_home)
    elif model == "ur5":
        if flange is not None:
            raise CellConfigError("the ur5 is built in: its flange is tool0")
        robot = ur5(
            UR5_MOUNT_XYZ if mount_xyz is None else mount_xyz,
            mount_yaw_deg,
            q_home,
        )
    else:
        if not flange:
            raise CellConfigError(
                f"robot file {model}: name its flange frame (built-in arms: {', '.join(BUILTIN)})"
            )
        robot = robot_from_file(
            model,
            flange,
            mount_xyz=(0.0, 0.0, 0.0) if mount_xyz is None else mount_xyz,
            mount_yaw_deg=mount_yaw_deg,
            q_home=q_home,
            joint_limits=JointLimits(limits, speed, effort),
        )
    if q_home is not None:
        kin = robot.kinematics()
        if (q_home < kin.lower).any() or (q_home > kin.upper).any():
            raise CellConfigError(
                f"{robot.name}: home {np.round(q_home, 4).tolist()} rad is outside the joint "
                f"limits {np.round(kin.lower, 4).tolist()} .. {np.round(kin.upper, 4).tolist()}"
            )
    return robot if vendor is None else replace(robot, vendor=vendor)


def ur5_kinematics() -> Kinematics:
    """Kinematics of the UR5 (ur5_robot.urdf) at the origin, tip frame `tool0`."""
    share = example_robot_data_share()
    return Kinematics.from_urdf(ur5_urdf(), "tool0", package_dirs=[str(share)])


def nominal_kinematics() -> Kinematics:
    """Pinocchio kinematics of the built-in arm (its robot-only MJCF), tip frame `flange`."""
    return Kinematics.from_mjcf(ROBOT_PATH, "flange")
