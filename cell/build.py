"""Build the cell's MuJoCo model from a config: nominal or real (perturbed) arm, objects.

The scene text comes from `models.robot`; the robot-only MJCF is generated with the real arm's
kinematic parameters and passed as the scene's include. Objects are added with MjSpec.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from cell.config import CellConfig, FixedMesh, FixedPrimitive, LooseMesh, LoosePart
from cell.errors import CellConfigError
from cell.mass import MassProperties, mesh_mass_properties
from models.robot import ROBOT_FILE, TABLE_TOP_POS, TOOLS, scene_xml
from registration.rigid import R_to_quat_wxyz, make_T, quat_wxyz_to_R

#: Geom group of objects' exact surfaces (seen by the rays) and of contact-only pieces.
OBJECT_GROUP = 1
CONTACT_ONLY_GROUP = 5
#: Pose of the table frame (`table_top` site) in the `table` body frame.
T_TABLEBODY_TABLE = make_T(np.eye(3), np.array([0.0, 0.0, TABLE_TOP_POS[2]]))
#: Contact of loose mesh objects: soft-constraint parameters as stiff as the fingers' (a
#: 4 ms time constant, critically damped) so that a part neither sinks nor jitters, and
#: friction across the contact plane plus torsion (condim 4): a pinch grasp holds the part's
#: weight by sliding friction and its turning by the torsional term.
LOOSE_SOLREF = (0.004, 1.0)
LOOSE_SOLIMP = (0.95, 0.99, 0.0005, 0.5, 2.0)
LOOSE_CONDIM = 4


@dataclass(frozen=True, eq=False)
class RealParameters:
    """The real cell's hidden parameters drawn from the config (the truth).

    Attributes:
        deviations: the real arm's kinematic deviations from the nominal (see cell.robots).
        table_bias_m: the table axis' constant positioning error [m].
        stiffness_nm_rad: (2,) the real stiffness of joints 2 and 3 [N m/rad] (0: rigid).
        T_tool_tcp: each tool's true TCP in its frame (4, 4) (the laser's: its optical frame,
            where its rays start).
        laser_scale: the laser's relative range scale error.
        table_profile: (4,) the table axis' sideways and vertical bow [m] and its pitch and
            yaw at the travel's positive end [rad] (see cell.devices.table_profile).
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


def _add_fixture(spec: mujoco.MjSpec, obj: FixedMesh | FixedPrimitive) -> None:
    table = spec.body("table")
    T = T_TABLEBODY_TABLE @ obj.T_table_object
    pos, quat = T[:3, 3], R_to_quat_wxyz(T[:3, :3])
    if isinstance(obj, FixedPrimitive):
        kind = mujoco.mjtGeom.mjGEOM_SPHERE if obj.kind == "sphere" else mujoco.mjtGeom.mjGEOM_BOX
        size = [obj.size[0], 0.0, 0.0] if obj.kind == "sphere" else list(obj.size)
        table.add_geom(
            name=obj.name,
            type=kind,
            size=size,
            pos=pos,
            quat=quat,
            rgba=obj.rgba,
            group=OBJECT_GROUP,
            mass=0.5,
        )
        return
    mesh = spec.add_mesh(name=f"{obj.name}_mesh")
    mesh.uservert = obj.vertices.ravel().tolist()
    mesh.userface = obj.faces.ravel().tolist()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    collides = not obj.convex_pieces
    table.add_geom(
        name=obj.name,
        type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname=mesh.name,
        pos=pos,
        quat=quat,
        rgba=obj.rgba,
        group=OBJECT_GROUP,
        contype=int(collides),
        conaffinity=int(collides),
        mass=0.5,
    )
    _add_convex_pieces(spec, table, obj.name, obj.convex_pieces, pos=pos, quat=quat, mass=0.1)


def _add_part(spec: mujoco.MjSpec, part: LoosePart) -> None:
    x, y, z = TABLE_TOP_POS
    body = spec.worldbody.add_body(
        name=part.name, pos=[x + part.xy_table[0], y + part.xy_table[1], z + part.half_size[2]]
    )
    body.add_freejoint(name=f"{part.name}_free")
    body.add_geom(
        name=part.name,
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(part.half_size),
        mass=part.mass,
        friction=[1.0, 0.01, 0.001],
        condim=4,
        rgba=(0.8, 0.3, 0.2, 1.0),
    )


def _add_loose_mesh(spec: mujoco.MjSpec, obj: LooseMesh) -> MassProperties:
    """A free body at the object's pose (the table at position 0): the exact mesh for the rays
    (group 1, no contact, no mass), the convex pieces for contact (group 5), the inertia of
    the solid mesh."""
    table = spec.body("table")
    T_world_tablebody = make_T(quat_wxyz_to_R(np.array(table.quat)), np.array(table.pos))
    T = T_world_tablebody @ T_TABLEBODY_TABLE @ obj.T_table_object
    mass = mesh_mass_properties(obj.vertices, obj.faces, obj.density_kg_m3, obj.mass_kg)
    body = spec.worldbody.add_body(name=obj.name, pos=T[:3, 3], quat=R_to_quat_wxyz(T[:3, :3]))
    body.add_freejoint(name=f"{obj.name}_free")
    body.explicitinertial = True
    body.mass = mass.mass_kg
    body.ipos = mass.p_object_com
    body.fullinertia = mass.fullinertia()
    mesh = spec.add_mesh(name=f"{obj.name}_mesh")
    mesh.uservert = obj.vertices.ravel().tolist()
    mesh.userface = obj.faces.ravel().tolist()
    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
    contact = {
        "friction": [obj.friction, 0.01, 0.0001],
        "condim": LOOSE_CONDIM,
        "solref": list(LOOSE_SOLREF),
        "solimp": list(LOOSE_SOLIMP),
    }
    collides = not obj.convex_pieces
    body.add_geom(
        name=obj.name,
        type=mujoco.mjtGeom.mjGEOM_MESH,
        meshname=mesh.name,
        rgba=obj.rgba,
        group=OBJECT_GROUP,
        contype=int(collides),
        conaffinity=int(collides),
        **contact,
    )
    _add_convex_pieces(spec, body, obj.name, obj.convex_pieces, **contact)
    return mass


def _add_convex_pieces(
    spec: mujoco.MjSpec,
    parent: mujoco.MjsBody,
    name: str,
    pieces: tuple[np.ndarray, ...],
    **geom: object,
) -> None:
    """The contact geoms of an object: one convex mesh per piece ((K, 3) vertices in the
    object frame), in the group that rays do not see; `geom` adds attributes (pose, mass,
    contact parameters)."""
    for i, piece in enumerate(pieces):
        hull = spec.add_mesh(name=f"{name}_hull{i}")
        hull.uservert = np.asarray(piece, dtype=float).ravel().tolist()
        hull.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_CONVEX
        parent.add_geom(
            name=f"{name}_hull{i}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=hull.name,
            group=CONTACT_ONLY_GROUP,
            rgba=(0.5, 0.5, 0.5, 0.3),
            **geom,
        )


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


def build_model(config: CellConfig, params: RealParameters | None = None) -> mujoco.MjModel:
    """Compile the cell's MuJoCo model: its robot's arm deviated by `params.deviations` and
    its tools' TCP sites at their true places (default: the nominal cell)."""
    deviations = None if params is None else params.deviations
    spec = mujoco.MjSpec.from_string(
        scene_xml(rack_xyz=config.rack_xyz),
        include={ROBOT_FILE: config.robot.mjcf(deviations).encode()},
    )
    if params is not None:
        for tool, T in params.T_tool_tcp.items():
            site = spec.site(f"{tool}_tcp")
            site.pos = T[:3, 3]
            site.quat = R_to_quat_wxyz(T[:3, :3])
    for obj in (*config.fixtures, *fault_fixtures(config)):
        _add_fixture(spec, obj)
    for fault in config.faults:
        if fault.name == "payload":  # a mass the tool's gravity compensation does not know
            tool = spec.body(f"tool_{fault.option or 'screwer'}")
            extra = tool.add_body(name="payload_extra", pos=[0.0, 0.0, 0.08], gravcomp=0.0)
            extra.mass = fault.amount
            extra.inertia = [1e-4, 1e-4, 1e-4]
            extra.explicitinertial = True
    for part in config.parts:
        if isinstance(part, LooseMesh):
            _add_loose_mesh(spec, part)
        else:
            _add_part(spec, part)
    try:
        return spec.compile()
    except ValueError as exc:  # MuJoCo's compiler names the element it rejects
        raise CellConfigError(f"the cell does not compile: {exc}") from exc
