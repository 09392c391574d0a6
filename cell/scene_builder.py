"""The cell's MuJoCo scene built from its layout: the arm (nominal, or with the kinematic
deviations and tool TCPs it is given), the table, the rack and tools, the objects.

The scene text comes from `models.robot`; the robot-only MJCF is generated with the arm's
kinematic parameters and passed as the scene's include. Objects are added with MjSpec. The
virtual cell builds its nominal scene here; the simulation builds the real one here too,
with the parameters it drew (cell.sim.real).
"""

from __future__ import annotations

from collections.abc import Mapping

import mujoco
import numpy as np

from cell.cell_errors import CellConfigError
from cell.layout import CellLayout, FixedMesh, FixedPrimitive, LooseMesh, LoosePart
from cell.mass import MassProperties, mesh_mass_properties
from models.robot import ROBOT_FILE, TABLE_TOP_POS, scene_xml
from registration.rigid import R_to_quat_wxyz, make_T, quat_wxyz_to_R

#: Geom group of objects' exact surfaces (seen by the rays) and of contact-only pieces.
OBJECT_GROUP = 1
CONTACT_ONLY_GROUP = 5
#: Geom groups the rays see: environment (0) and objects' exact surfaces (1).
RAY_GROUPS = np.array([1, 1, 0, 0, 0, 0], dtype=np.uint8)
#: Pose of the table frame (`table_top` site) in the `table` body frame.
T_TABLEBODY_TABLE = make_T(np.eye(3), np.array([0.0, 0.0, TABLE_TOP_POS[2]]))
#: Contact of loose mesh objects: soft-constraint parameters as stiff as the fingers' (a
#: 4 ms time constant, critically damped) so that a part neither sinks nor jitters, and
#: friction across the contact plane plus torsion (condim 4): a pinch grasp holds the part's
#: weight by sliding friction and its turning by the torsional term.
LOOSE_SOLREF = (0.004, 1.0)
LOOSE_SOLIMP = (0.95, 0.99, 0.0005, 0.5, 2.0)
LOOSE_CONDIM = 4


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


def build_model(
    layout: CellLayout,
    deviations: np.ndarray | None = None,
    T_tool_tcp: Mapping[str, np.ndarray] | None = None,
    extra_fixtures: tuple[FixedMesh | FixedPrimitive, ...] = (),
    payloads_kg: Mapping[str, float] | None = None,
) -> mujoco.MjModel:
    """Compile the cell's MuJoCo model of `layout`: its arm deviated by `deviations` (None:
    nominal), its tools' TCP sites at `T_tool_tcp` (4, 4 each, in the tool frame; None: the
    data sheet's), `extra_fixtures` on the table beside the layout's, and for each tool in
    `payloads_kg` a mass [kg] on it that its tooldata does not know."""
    spec = mujoco.MjSpec.from_string(
        scene_xml(rack_xyz=layout.rack_xyz),
        include={ROBOT_FILE: layout.robot.mjcf(deviations).encode()},
    )
    for tool, T in (T_tool_tcp or {}).items():
        site = spec.site(f"{tool}_tcp")
        site.pos = T[:3, 3]
        site.quat = R_to_quat_wxyz(T[:3, :3])
    for obj in (*layout.fixtures, *extra_fixtures):
        _add_fixture(spec, obj)
    for tool_name, kg in (payloads_kg or {}).items():
        tool = spec.body(f"tool_{tool_name}")
        extra = tool.add_body(name="payload_extra", pos=[0.0, 0.0, 0.08], gravcomp=0.0)
        extra.mass = kg
        extra.inertia = [1e-4, 1e-4, 1e-4]
        extra.explicitinertial = True
    for part in layout.parts:
        if isinstance(part, LooseMesh):
            _add_loose_mesh(spec, part)
        else:
            _add_part(spec, part)
    try:
        return spec.compile()
    except ValueError as exc:  # MuJoCo's compiler names the element it rejects
        raise CellConfigError(f"the cell does not compile: {exc}") from exc
