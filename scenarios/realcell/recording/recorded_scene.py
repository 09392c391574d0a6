"""The real cell in the recording: every shown geom under a named entity, and every body's
true pose at every time.

A body that never moves (the arm's base, the rail, the rack) is logged once, static. A body
that moves (the links, the table, the tools, a loose part) is witnessed while the physics
runs (`sample`) and its poses are sent in one column per entity at the end (`flush`), each
pose kept only when it changed: rerun shows the latest pose at any time, which is then the
true one to within a sample period. A fixture on the table (the object, the calibration
spheres) is an entity of its own with its own true pose.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import rerun as rr
import trimesh
from scipy.spatial.transform import Rotation

from models.robot.visuals import LinkVisual
from scenarios.realcell.recording.stream import Stream, pose

#: Geom groups shown: environment, objects, arm visuals, tools (not collision-only ones).
SHOWN_GROUPS = (0, 1, 2, 4)
#: A pose is logged again when it moved by more than this [m] or [rad].
MOVED = 1e-6


@dataclass(frozen=True)
class Thing:
    """One entity with a world pose: a body, or a named fixture geom (then `geom` >= 0)."""

    path: str
    body: int
    geom: int
    static: bool


def body_path(name: str, aliases: dict[str, str]) -> str:
    """The entity of a MuJoCo body: the arm's links under `arm/`, tools under `tools/`."""
    if name in aliases:
        return f"world/cell/{aliases[name]}"
    if name == "base" or name.startswith("link"):
        return f"world/cell/arm/{name}"
    if name.startswith("tool_"):
        return f"world/cell/tools/{name.removeprefix('tool_')}"
    if name.startswith(("finger_", "screwer_")):
        return f"world/cell/tools/{name}"
    return f"world/cell/{name}"


def _rgba(rgba: np.ndarray) -> list[int]:
    return [round(255 * float(c)) for c in rgba]


def _body_names(model: mujoco.MjModel) -> set[str]:
    return {mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(model.nbody)}


def _zero_pose(
    model: mujoco.MjModel, data: mujoco.MjData, bodies: list[str]
) -> dict[int, np.ndarray]:
    """(4, 4) world pose of every body with the joints of `bodies` at zero (the rest as
    now)."""
    scratch = mujoco.MjData(model)
    scratch.qpos[:] = data.qpos
    for name in bodies:
        b = model.body(name).id
        for j in range(model.body_jntadr[b], model.body_jntadr[b] + model.body_jntnum[b]):
            scratch.qpos[model.jnt_qposadr[j]] = 0.0
    mujoco.mj_kinematics(model, scratch)
    out = {}
    for b in range(model.nbody):
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = scratch.xmat[b].reshape(3, 3), scratch.xpos[b]
        out[b] = T
    return out


def _local(model: mujoco.MjModel, g: int) -> np.ndarray:
    T = np.eye(4)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, model.geom_quat[g])
    T[:3, :3], T[:3, 3] = R.reshape(3, 3), model.geom_pos[g]
    return T


def geom_archetype(model: mujoco.MjModel, g: int) -> tuple[np.ndarray, object] | None:
    """(local offset (4, 4), rerun archetype) of geom `g` in its own frame, or None (plane)."""
    T = np.eye(4)
    color = _rgba(model.geom_rgba[g])
    size = model.geom_size[g]
    kind = model.geom_type[g]
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return T, rr.Boxes3D(half_sizes=[size], colors=[color], fill_mode="solid")
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return T, rr.Ellipsoids3D(half_sizes=[[size[0]] * 3], colors=[color], fill_mode="solid")
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        T[2, 3] = -size[1]  # rerun's capsule starts at its origin
        return T, rr.Capsules3D(lengths=[2 * size[1]], radii=[size[0]], colors=[color])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return T, rr.Cylinders3D(
            lengths=[2 * size[1]], radii=[size[0]], colors=[color], fill_mode="solid"
        )
    if kind == mujoco.mjtGeom.mjGEOM_MESH:
        m = model.geom_dataid[g]
        v0, nv = model.mesh_vertadr[m], model.mesh_vertnum[m]
        f0, nf = model.mesh_faceadr[m], model.mesh_facenum[m]
        return T, mesh_archetype(
            model.mesh_vert[v0 : v0 + nv], model.mesh_face[f0 : f0 + nf], color
        )
    return None


def mesh_archetype(vertices: np.ndarray, faces: np.ndarray, color: list[int]) -> rr.Mesh3D:
    """A triangle mesh with its vertex normals (shaded, not a flat silhouette)."""
    mesh = trimesh.Trimesh(vertices, faces, process=False)
    return rr.Mesh3D(
        vertex_positions=mesh.vertices,
        triangle_indices=mesh.faces,
        vertex_normals=mesh.vertex_normals,
        albedo_factor=color,
    )


class CellScene:
    """The cell's entities, its static geometry and the witnessed poses of what moves.

    `aliases` names bodies and fixture geoms for the user (e.g. {"object": "skull"}); a
    fixture geom not in it goes under `world/cell/fixtures/`. The arm's bodies that have a
    mesh in `visuals` are drawn with it instead of their simple shapes."""

    def __init__(
        self,
        model: mujoco.MjModel,
        aliases: dict[str, str],
        visuals: tuple[LinkVisual, ...] = (),
    ) -> None:
        self.model = model
        self.visuals = {v.body: v for v in visuals if v.body in _body_names(model)}
        moves = model.body_weldid != 0
        things: list[Thing] = []
        for b in range(1, model.nbody):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body_{b}"
            things.append(Thing(body_path(name, aliases), b, -1, not moves[b]))
        for g in range(model.ngeom):
            name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
            if name and model.geom_group[g] in SHOWN_GROUPS and model.geom_bodyid[g] > 0:
                b = int(model.geom_bodyid[g])
                path = (
                    f"world/cell/{aliases[name]}"
                    if name in aliases
                    else f"world/cell/fixtures/{name}"
                )
                if name == mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b):
                    continue  # a body's own geom (a loose part): drawn with its body
                things.append(Thing(path, b, g, not moves[b]))
        self.things = tuple(things)
        self._moving = [t for t in things if not t.static]
        self._bodies = np.array([t.body for t in self._moving if t.geom < 0], dtype=int)
        self._geoms = np.array([t.geom for t in self._moving if t.geom >= 0], dtype=int)
        self._times: list[float] = []
        self._xpos: list[np.ndarray] = []
        self._xquat: list[np.ndarray] = []
        self._gpos: list[np.ndarray] = []
        self._gmat: list[np.ndarray] = []

    def path_of_body(self, name: str) -> str:
        b = self.model.body(name).id
        return next(t.path for t in self.things if t.body == b and t.geom < 0)

    # -- geometry ---------------------------------------------------------------------------
    def log_geometry(self, stream: Stream, data: mujoco.MjData) -> None:
        """Every shown geom (static, in its entity's frame) and the static bodies' poses."""
        model = self.model
        own = {t.geom: t for t in self.things if t.geom >= 0}
        by_body = {t.body: t for t in self.things if t.geom < 0}
        counts: dict[tuple[int, int], int] = {}
        for g in range(model.ngeom):
            if model.geom_group[g] not in SHOWN_GROUPS or model.geom_bodyid[g] == 0:
                continue
            made = geom_archetype(model, g)
            if made is None:
                continue
            T, archetype = made
            if g in own:
                stream.static(own[g].path, archetype)
                continue
            thing = by_body[int(model.geom_bodyid[g])]
            body = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, thing.body)
            if body in self.visuals and model.geom_group[g] == 2:
                continue  # drawn with its mesh
            kind = int(model.geom_type[g])
            k = counts.get((thing.body, kind), 0)
            counts[(thing.body, kind)] = k + 1
            label = mujoco.mjtGeom(kind).name.removeprefix("mjGEOM_").lower()
            stream.static(f"{thing.path}/{label}_{k}", pose(_local(model, g) @ T), archetype)
        for t in self.things:
            if t.static:
                stream.static(t.path, pose(self._world(data, t)))
        if self.visuals:
            zero = _zero_pose(model, data, list(self.visuals))
            for body, v in self.visuals.items():
                b = model.body(body).id
                T_link = np.eye(4)
                T_link[:3, 3] = v.origin_zero
                T_body_mesh = np.linalg.solve(zero[b], T_link)
                stream.static(
                    f"{by_body[b].path}/visual",
                    pose(T_body_mesh),
                    mesh_archetype(v.vertices, v.faces, list(v.rgba)),
                )

    def _world(self, data: mujoco.MjData, t: Thing) -> np.ndarray:
        T = np.eye(4)
        if t.geom >= 0:
            T[:3, :3], T[:3, 3] = data.geom_xmat[t.geom].reshape(3, 3), data.geom_xpos[t.geom]
        else:
            T[:3, :3], T[:3, 3] = data.xmat[t.body].reshape(3, 3), data.xpos[t.body]
        return T

    # -- the witness ------------------------------------------------------------------------
    def sample(self, data: mujoco.MjData) -> None:
        """The moving things' poses now (a witness of the physics: cheap, buffered)."""
        self._times.append(float(data.time))
        self._xpos.append(data.xpos[self._bodies].copy())
        self._xquat.append(data.xquat[self._bodies].copy())
        self._gpos.append(data.geom_xpos[self._geoms].copy())
        self._gmat.append(data.geom_xmat[self._geoms].copy())

    def latest(self) -> dict[str, np.ndarray]:
        """The last sampled pose (4, 4) of every moving thing, by entity path."""
        if not self._times:
            return {}
        out = {}
        bodies = [t for t in self._moving if t.geom < 0]
        geoms = [t for t in self._moving if t.geom >= 0]
        for i, t in enumerate(bodies):
            T = np.eye(4)
            w, x, y, z = self._xquat[-1][i]
            T[:3, :3] = Rotation.from_quat([x, y, z, w]).as_matrix()
            T[:3, 3] = self._xpos[-1][i]
            out[t.path] = T
        for i, t in enumerate(geoms):
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = self._gmat[-1][i].reshape(3, 3), self._gpos[-1][i]
            out[t.path] = T
        return out

    def hold(self, stream: Stream, timeline: str) -> None:
        """The cell as last sampled, on `timeline` at sequence 0 only (the cell held still
        while something else, like the ICP, runs on that timeline)."""
        stream.at(**{timeline: 0})
        for path, T in self.latest().items():
            stream.log(path, pose(T))

    def flush(self, stream: Stream) -> None:
        """Send the witnessed poses: one column per moving entity, changes only."""
        if not self._times:
            return
        t = np.asarray(self._times)
        order = np.argsort(t, kind="stable")
        t = t[order]
        bodies = [x for x in self._moving if x.geom < 0]
        geoms = [x for x in self._moving if x.geom >= 0]
        if bodies:
            pos = np.asarray(self._xpos)[order]
            wxyz = np.asarray(self._xquat)[order]
            for i, thing in enumerate(bodies):
                xyzw = np.roll(wxyz[:, i], -1, axis=1)
                self._send(stream, thing.path, t, pos[:, i], xyzw)
        if geoms:
            pos = np.asarray(self._gpos)[order]
            mats = np.asarray(self._gmat)[order]
            for i, thing in enumerate(geoms):
                xyzw = Rotation.from_matrix(mats[:, i].reshape(-1, 3, 3)).as_quat()
                self._send(stream, thing.path, t, pos[:, i], xyzw)
        self._times.clear()
        self._xpos.clear()
        self._xquat.clear()
        self._gpos.clear()
        self._gmat.clear()

    @staticmethod
    def _send(stream: Stream, path: str, t: np.ndarray, pos: np.ndarray, xyzw: np.ndarray) -> None:
        # A sample is kept if it moved from the one before, and once a second (at 30 Hz)
        # so that a slow creep is never lost.
        xyzw = xyzw * np.where(np.einsum("ij,j->i", xyzw, xyzw[0]) < 0, -1.0, 1.0)[:, None]
        step = np.maximum(
            np.abs(np.diff(pos, axis=0)).max(axis=1), np.abs(np.diff(xyzw, axis=0)).max(axis=1)
        )
        keep = np.concatenate([[True], step > MOVED])
        keep[::30] = True
        stream.columns(
            path,
            t[keep],
            rr.Transform3D.columns(translation=pos[keep], quaternion=xyzw[keep]),
        )
