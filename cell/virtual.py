"""The virtual cell: the cell's nominal MuJoCo model, posed kinematically, for collision checks.

An offline-programming tool checks a program in its own model of the cell before the program
moves the robot. This is that model: built from NOMINAL data only (a `CellLayout`: the
robot's nominal arm, the tools' nominal TCPs, the rack at its layout place, the table, and
the objects at the poses the planner believes, e.g. the virtual model at its estimated pose
with its convex pieces for contact). Nothing is stepped: the arm's joints, the table's
position and the tool on the flange are written into the state, the tool body is placed on
the flange as the changer's weld would hold it, and MuJoCo's collision detection lists what
touches or comes within a margin.

Near a fixed mesh object with convex pieces (a bone from a CT: pieces that stand millimetres
proud of its rough surface), a geom of the moving side that the pieces put within
`EXACT_BAND_M` of it is measured against the object's own surface instead
(cell.surface_distance: libigl's signed distance to its triangles for points standing for the
geom, at most their stated deviation, 0.7 mm or less, short of the true distance; exact
less 0.03 mm for spheres and capsules such as the tools' tips).

Only the moving side is reported: the arm's links and the tool in hand (with its fingers or
spindle), against everything else (the table, the rack, the tools in the rack, the objects
and fixtures, the floor, the arm's base) and the tool in hand against the arm's own links.
The pairs the real scene excludes stay excluded (a tool against the rack and the wrist it is
seated on, the arm's links among themselves).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from cell.cell_errors import CellConfigError, JointLimitError, UnknownNameError
from cell.layout import CellLayout, FixedMesh, FixedPrimitive
from cell.robot_arm import Robot
from cell.scene_builder import RAY_GROUPS, T_TABLEBODY_TABLE, build_model
from cell.surface_distance import GeomPoints, SurfaceDistance, geom_points
from models.robot import FINGER_TRAVEL, FLANGE_SITE, JOINT_NAMES, TABLE_TRAVEL, TOOLS
from registration.rigid import R_to_quat_wxyz

#: Name of the world's own geoms that have none.
_WORLD = "world"
#: A moving geom that an object's convex pieces put within this distance of it is measured
#: against the object's own surface [m] (the pieces stand a few millimetres proud of it).
EXACT_BAND_M = 0.02


@dataclass(frozen=True)
class Contact:
    """Something of the moving side near or into something else.

    `body`: the moving side, an arm link ("link5") or the tool in hand ("tool_screwer");
    `other`: what it meets, by a name a user knows ("table", "rack", "tool_laser", "object",
    "calibration_sphere1", "floor", "link4"); `distance_m` [m]: the smallest signed distance
    between their geoms (negative: they penetrate by that much), near a fixed mesh object
    to its own surface (the module's docstring).
    """

    body: str
    other: str
    distance_m: float

    @property
    def penetrating(self) -> bool:
        """Whether the two overlap."""
        return self.distance_m < 0.0


class VirtualCell:
    """The nominal cell of `layout` (the data sheets' arm and TCPs), posed by
    `set_joints`, `set_table` and `set_tool`, asked for `contacts`; `exact_band_m` [m]: how
    near an object's convex pieces a moving geom is measured against its own surface (0:
    the pieces only, as MuJoCo's contacts see the object)."""

    def __init__(self, layout: CellLayout, exact_band_m: float = EXACT_BAND_M) -> None:
        if not (np.isfinite(exact_band_m) and 0.0 <= exact_band_m <= 0.5):
            raise CellConfigError(f"exact_band_m must be in [0, 0.5] m, got {exact_band_m!r}")
        self.layout = layout
        self.exact_band_m = float(exact_band_m)
        self.model = build_model(layout)  # the nominal arm and TCPs
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._arm_qadr = np.array([m.joint(n).qposadr[0] for n in JOINT_NAMES])
        self._table_qadr = int(m.joint("table_slide").qposadr[0])
        self._flange = int(m.site(FLANGE_SITE).id)
        self._tool_body = {t.name: int(m.body(t.body).id) for t in TOOLS}
        self._tool_qadr = {t.name: int(m.joint(f"{t.body}_free").qposadr[0]) for t in TOOLS}
        root = m.body_rootid
        # Loose parts on the table: free bodies other than the tools, carried with the table.
        tool_ids = set(self._tool_body.values())
        self._loose_qadr = np.array(
            [
                int(m.jnt_qposadr[j])
                for j in range(m.njnt)
                if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE
                and int(m.jnt_bodyid[j]) not in tool_ids
            ],
            dtype=int,
        )
        arm_joint_bodies = {int(m.jnt_bodyid[m.joint(n).id]) for n in JOINT_NAMES}
        self._arm_body = np.array([_descends(m, b, arm_joint_bodies) for b in range(m.nbody)])
        by_id = {b: name for name, b in self._tool_body.items()}
        #: The tool each body belongs to (a tool's body, its fingers, its spindle), or None.
        self._tool_of_body = [by_id.get(int(root[b])) for b in range(m.nbody)]
        self._geom_name = _geom_names(m, layout, self._tool_of_body)
        self._geom_body = m.geom_bodyid.copy()
        self._named: dict[str, np.ndarray] = {}
        # Fixed mesh objects whose contact is a proxy (convex pieces): their own surfaces.
        self._surfaces = {
            o.name: (SurfaceDistance(o.vertices, o.faces), T_TABLEBODY_TABLE @ o.T_table_object)
            for o in layout.fixtures
            if isinstance(o, FixedMesh) and o.convex_pieces
        }
        self._table_body = int(m.body("table").id)
        self._points: dict[int, GeomPoints | None] = {}
        for name in ("finger_left", "finger_right"):
            self.data.qpos[m.joint(name).qposadr[0]] = FINGER_TRAVEL  # open, as the cell starts
        self._margin = -1.0
        self.q = np.array(layout.robot.q_home, dtype=float)
        self.table_position_m = 0.0
        self.tool_in_hand: str | None = None
        self.set_joints(self.q)

    @classmethod
    def of(
        cls,
        robot: Robot,
        rack_xyz: tuple[float, float, float],
        fixtures: tuple[FixedMesh | FixedPrimitive, ...] = (),
        exact_band_m: float = EXACT_BAND_M,
    ) -> VirtualCell:
        """The nominal cell of `robot` with its rack at `rack_xyz` [m] and `fixtures` on the
        table at the poses the planner believes."""
        return cls(CellLayout(robot=robot, rack_xyz=rack_xyz, fixtures=fixtures), exact_band_m)

    @property
    def tools(self) -> tuple[str, ...]:
        """Names of the cell's tools."""
        return tuple(self._tool_body)

    # -- posing -------------------------------------------------------------------------------
    def set_joints(self, q: np.ndarray) -> None:
        """The arm's joints `q` (6,) [rad] (not checked against the limits: a checker asks
        about poses a controller would refuse too)."""
        q = np.asarray(q, dtype=float).reshape(-1)
        if q.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(q)):
            raise JointLimitError(f"the arm's joints must be 6 finite angles [rad], got {q}")
        self.q = q.copy()
        self.data.qpos[self._arm_qadr] = q

    def set_table(self, position_m: float) -> None:
        """The table at `position_m` [m] of its travel (objects fixed on it and loose parts
        lying on it move along)."""
        lo, hi = TABLE_TRAVEL
        if not (np.isfinite(position_m) and lo <= position_m <= hi):
            raise JointLimitError(
                f"table position {position_m!r} m is outside its travel [{lo}, {hi}] m"
            )
        d, m = self.data, self.model
        d.qpos[self._table_qadr] = position_m
        for adr in self._loose_qadr:
            d.qpos[adr + 1] = m.qpos0[adr + 1] + position_m
        self.table_position_m = float(position_m)

    def set_tool(self, tool: str | None) -> None:
        """`tool` on the flange (its rack slot empty), or None: every tool in its slot."""
        if tool is not None and tool not in self._tool_body:
            raise UnknownNameError(
                f"unknown tool {tool!r}; available tools: {', '.join(self._tool_body)}"
            )
        if self.tool_in_hand is not None:  # back to its slot
            adr = self._tool_qadr[self.tool_in_hand]
            self.data.qpos[adr : adr + 7] = self.model.qpos0[adr : adr + 7]
        self.tool_in_hand = tool

    def _place(self) -> None:
        """Forward kinematics, the tool in hand seated on the flange (tool frame = flange)."""
        m, d = self.model, self.data
        mujoco.mj_kinematics(m, d)
        if self.tool_in_hand is None:
            return
        adr = self._tool_qadr[self.tool_in_hand]
        d.qpos[adr : adr + 3] = d.site_xpos[self._flange]
        d.qpos[adr + 3 : adr + 7] = R_to_quat_wxyz(d.site_xmat[self._flange].reshape(3, 3))
        mujoco.mj_kinematics(m, d)

    def posed(self) -> mujoco.MjData:
        """The state in the current pose (forward kinematics done, the tool in hand on the
        flange): for drawing the cell as posed."""
        self._place()
        return self.data

    def T_world_body(self, name: str) -> np.ndarray:
        """(4, 4) world pose of body `name` in the current pose (the tool in hand on the
        flange)."""
        self._place()
        b = int(self.model.body(name).id)
        return _pose(self.data.xpos[b], self.data.xmat[b])

    def T_world_site(self, name: str) -> np.ndarray:
        """(4, 4) world pose of site `name` in the current pose (e.g. "table_top", the table
        frame)."""
        self._place()
        i = int(self.model.site(name).id)
        return _pose(self.data.site_xpos[i], self.data.site_xmat[i])

    # -- rays ---------------------------------------------------------------------------------
    def cast(
        self, origin: np.ndarray, directions: np.ndarray, range_m: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rays from `origin` (3,) along unit `directions` (n, 3) in the world frame against
        what a laser sees (the table, the fixtures and objects' exact surfaces; not the arm
        or the tools), as far as `range_m` [m]: distances (n,) [m] (inf: nothing), surface
        normals (n, 3), and the name of the fixture or part hit (n,) ("" for none)."""
        self._place()
        m, d = self.model, self.data
        dirs = np.ascontiguousarray(directions, dtype=float).reshape(-1, 3)
        n = len(dirs)
        geom = np.zeros(n, dtype=np.int32)
        dist = np.zeros(n)
        normal = np.zeros(3 * n)
        mujoco.mj_multiRay(
            m, d, np.asarray(origin, dtype=float), dirs.reshape(-1), RAY_GROUPS, 1, -1,
            geom, dist, normal, n, range_m,
        )  # fmt: skip
        hit = (geom >= 0) & (dist <= range_m)  # the cutoff only culls geoms beyond it
        dist = np.where(hit, dist, np.inf)
        geom = np.where(hit, geom, -1)
        names = np.array(["" if g < 0 else self._geom_name[g] for g in geom], dtype=object)
        return dist, normal.reshape(-1, 3), names

    # -- contacts -----------------------------------------------------------------------------
    def contacts(self, margin_m: float = 0.0, other: str | None = None) -> tuple[Contact, ...]:
        """What the moving side (the arm's links, the tool in hand) touches or comes within
        `margin_m` [m] of in the current pose: one `Contact` per pair of names, the smallest
        distance, the deepest first; with `other`, only the contacts with it (the same ones,
        found sooner: a path checked clear of the object asks this at every step)."""
        if not (np.isfinite(margin_m) and 0.0 <= margin_m <= 0.5):
            raise CellConfigError(f"the contact margin must be in [0, 0.5] m, got {margin_m!r}")
        m, d = self.model, self.data
        if margin_m != self._margin:
            m.geom_margin[:] = margin_m
            m.body_margin[:] = margin_m  # the broadphase's bodies: the largest of their geoms'
            self._margin = margin_m
        self._place()
        mujoco.mj_collision(m, d)
        n = d.ncon
        if n == 0:
            return ()
        geoms, dist = self._pairs(d.contact.geom[:n], d.contact.dist[:n], margin_m, other)
        held = self.tool_in_hand
        closest: dict[tuple[str, str], float] = {}
        near_surface: set[tuple[int, str]] = set()  # (moving geom, object) to measure exactly
        for (g1, g2), dk in zip(geoms, dist, strict=True):
            if dk > margin_m:
                continue
            sides = []
            for g in (g1, g2):
                b = int(self._geom_body[g])
                held_here = held is not None and self._tool_of_body[b] == held
                rank = 0 if held_here else 1 if self._arm_body[b] else 2
                sides.append((rank, self._geom_name[g], int(g)))
            (rank_a, a, g_a), (rank_b, b_name, _g_b) = sorted(sides)
            if rank_a == 2 or rank_a == rank_b == 0:  # no moving side; the tool's own parts
                continue
            if self.exact_band_m > 0.0 and b_name in self._surfaces and dk < self.exact_band_m:
                near_surface.add((g_a, b_name))
                continue
            key = (a, b_name)
            closest[key] = min(closest.get(key, np.inf), float(dk))
        for g, name in near_surface:
            key = (self._geom_name[g], name)
            closest[key] = min(closest.get(key, np.inf), self._surface_distance(g, name))
        found = [Contact(a, b, dk) for (a, b), dk in closest.items() if dk <= margin_m]
        if other is not None:
            found = [c for c in found if c.other == other]
        return tuple(sorted(found, key=lambda c: c.distance_m))

    def _pairs(
        self, geoms: np.ndarray, dist: np.ndarray, margin_m: float, other: str | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The contact pairs (n, 2) and their distances (n,) [m] to look at: all, or those
        with a geom of `other` within the margin."""
        if other is None:
            return geoms, dist
        rows = (dist <= margin_m) & self._geoms_named(other)[geoms].any(axis=1)
        return geoms[rows], dist[rows]

    def _geoms_named(self, name: str) -> np.ndarray:
        """(ngeom,) bool: the geoms a contact calls `name` (a lookup by geom id, as fast as
        the path checks that ask it at every step need)."""
        if name not in self._named:
            self._named[name] = np.array(self._geom_name, dtype=object) == name
        return self._named[name]

    def _surface_distance(self, geom: int, name: str) -> float:
        """Signed distance [m] of moving geom `geom` to the own surface of object `name`
        (cell.surface_distance), in the current pose."""
        if geom not in self._points:
            self._points[geom] = geom_points(self.model, geom)
        points = self._points[geom]
        if points is None:  # a geom with no extent: never on the moving side
            raise CellConfigError(f"geom {geom} of the moving side has no extent to measure")
        surface, T_tablebody_object = self._surfaces[name]
        d = self.data
        T_world_object = _pose(d.xpos[self._table_body], d.xmat[self._table_body]) @ (
            T_tablebody_object
        )
        T_world_geom = _pose(d.geom_xpos[geom], d.geom_xmat[geom])
        return surface.geom_distance(points, np.linalg.inv(T_world_object) @ T_world_geom)


def _pose(position: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(4, 4) of MuJoCo's world position (3,) and flat rotation matrix (9,)."""
    T = np.eye(4)
    T[:3, :3] = np.asarray(matrix).reshape(3, 3)
    T[:3, 3] = position
    return T


def _descends(m: mujoco.MjModel, body: int, ancestors: set[int]) -> bool:
    """Whether `body` is one of `ancestors` or below one."""
    while body > 0:
        if body in ancestors:
            return True
        body = int(m.body_parentid[body])
    return False


def _geom_names(m: mujoco.MjModel, layout: CellLayout, tool_of_body: list[str | None]) -> list[str]:
    """A name a user knows for every geom: the object or fixture it belongs to (its exact
    surface and its convex pieces alike), else its tool, else its body (an arm's link),
    else its own name (the world's: the floor)."""
    fixtures = {o.name for o in layout.fixtures}
    names = []
    for g in range(m.ngeom):
        geom = m.geom(g).name
        owner = geom.rsplit("_hull", 1)[0] if "_hull" in geom else geom
        body = int(m.geom_bodyid[g])
        tool = tool_of_body[body]
        if owner in fixtures:
            names.append(owner)
        elif tool is not None:
            names.append(f"tool_{tool}")
        elif body == 0:
            names.append(geom or _WORLD)
        else:
            names.append(m.body(body).name)
    return names
