"""CAD-like mechanical parts for the assembly job, built in code with exact booleans.

Each part is made of boxes and cylinders joined and drilled with manifold3d's booleans (exact,
watertight results). Its convex contact pieces are the solid primitives it is made of (holes
are ignored for contact), and its operation frames (grasp, insert, screw) are 4x4 transforms
in the part frame: origin at the centre of the part's bottom face, z up, dimensions in metres.
The meshes are refined so that their edges are about 3 mm long (every edge longer than 3 mm is
split; the new diagonals stay under 8 mm): about 17-30k triangles per part.
For insert and screw frames z points along the approach, into the part.
"""

from __future__ import annotations

from dataclasses import dataclass

import manifold3d
import numpy as np
import trimesh

from models.mesh import TriangleMesh
from models.targets import OperationFrame, ProbeLine

MM = 1e-3
_DOWN = np.diag([1.0, -1.0, -1.0])  # z down, x kept: approach from above
_SECTIONS = 48  # facets of cylinders
_MAX_EDGE_MM = 3.0


@dataclass(frozen=True, eq=False)
class Part:
    """A generated part: exact mesh [m], convex contact pieces [m], named operation frames."""

    name: str
    mesh: TriangleMesh
    convex_pieces: tuple[TriangleMesh, ...]
    frames: tuple[OperationFrame, ...]
    probe_lines: tuple[ProbeLine, ...] = ()


def _box(
    size_mm: tuple[float, float, float], centre_mm: tuple[float, float, float]
) -> trimesh.Trimesh:
    return trimesh.creation.box(
        extents=np.array(size_mm) * MM,
        transform=trimesh.transformations.translation_matrix(np.array(centre_mm) * MM),
    )


def _cylinder(
    radius_mm: float, p0_mm: tuple[float, ...], p1_mm: tuple[float, ...]
) -> trimesh.Trimesh:
    return trimesh.creation.cylinder(
        radius=radius_mm * MM, segment=np.array([p0_mm, p1_mm]) * MM, sections=_SECTIONS
    )


def _frame(name: str, kind: str, R: np.ndarray, p_mm: tuple[float, float, float]) -> OperationFrame:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = np.array(p_mm) * MM
    return OperationFrame(name, kind, T)


def _probe(
    name: str,
    inside_mm: tuple[float, float],
    outside_mm: tuple[float, float],
    normal: tuple[float, float],
    offset_mm: float,
    step_mm: float,
) -> ProbeLine:
    return ProbeLine(
        name,
        np.array([*inside_mm, 0.0]) * MM,
        np.array([*outside_mm, 0.0]) * MM,
        np.array([*normal, 0.0]),
        offset_mm * MM,
        step_mm * MM,
    )


def _solid(solids: list[trimesh.Trimesh], holes: list[trimesh.Trimesh]) -> TriangleMesh:
    """Union of `solids` minus `holes`, refined by splitting edges longer than `_MAX_EDGE_MM`:
    a laser scan and the model error need vertices on the large flat faces too."""
    body = trimesh.boolean.union(solids, engine="manifold")
    if holes:
        body = trimesh.boolean.difference([body, *holes], engine="manifold")
    solid = manifold3d.Manifold(
        manifold3d.Mesh(
            vert_properties=np.asarray(body.vertices, dtype=np.float32),
            tri_verts=np.asarray(body.faces, dtype=np.uint32),
        )
    )
    refined = solid.refine_to_length(_MAX_EDGE_MM * MM).to_mesh()
    return TriangleMesh(
        np.asarray(refined.vert_properties[:, :3]), refined.tri_verts.astype(np.int64)
    )


def make_bracket() -> Part:
    """An L-bracket: base plate 80 x 50 x 6 mm with two M6 clearance holes (6.6 mm) and an
    upright 80 x 6 x 56 mm at the back edge with two more; frames to grasp it by the upright's
    top edge, to place it on a fixture and to drive its four screws."""
    base = _box((80, 50, 6), (0, 0, 3))
    upright = _box((80, 6, 56), (0, -22, 28))
    holes = [_cylinder(3.3, (x, 6, -1), (x, 6, 7)) for x in (-28, 28)]
    holes += [_cylinder(3.3, (x, -26, 38), (x, -18, 38)) for x in (-25, 25)]
    # Screwing into the upright from its front face (y = -19 mm) goes along -y.
    R_front = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # z = -y, x = x
    frames = (
        _frame("grasp", "grasp", _DOWN, (0, -22, 56)),
        _frame("place", "insert", _DOWN, (0, 0, 0)),
        _frame("screw_base_left", "screw", _DOWN, (-28, 6, 6)),
        _frame("screw_base_right", "screw", _DOWN, (28, 6, 6)),
        _frame("screw_upright_left", "screw", R_front, (-25, -19, 38)),
        _frame("screw_upright_right", "screw", R_front, (25, -19, 38)),
    )
    pieces = tuple(TriangleMesh.from_trimesh(m) for m in (base, upright))
    # IR probe lines of the base plate (6 mm high): two across the front edge (y = +25 mm),
    # one across the left edge (x = -40 mm), clear of its holes and of the upright.
    probes = (
        _probe("front 1", (-15, 5), (-15, 50), (0.0, 1.0), 25, 6),
        _probe("front 2", (15, 5), (15, 50), (0.0, 1.0), 25, 6),
        _probe("left", (-15, 16), (-65, 16), (-1.0, 0.0), 40, 6),
    )
    return Part("bracket", _solid([base, upright], holes), pieces, frames, probes)


_HOUSING_SIZE_MM = (100.0, 70.0, 40.0)
_WALL_MM = 4.0
_BOSS_XY_MM = [(sx * 41.0, sy * 26.0) for sx in (-1, 1) for sy in (-1, 1)]


def make_housing() -> Part:
    """An open box 100 x 70 x 40 mm (4 mm walls and floor) with four corner bosses tapped for
    M5 (4.2 mm, 12 mm deep); frames to grasp it, to seat its lid and to screw the lid down."""
    lx, ly, lz = _HOUSING_SIZE_MM
    w = _WALL_MM
    floor = _box((lx, ly, w), (0, 0, w / 2))
    walls = [_box((lx, w, lz), (0, sy * (ly - w) / 2, lz / 2)) for sy in (-1, 1)] + [
        _box((w, ly, lz), (sx * (lx - w) / 2, 0, lz / 2)) for sx in (-1, 1)
    ]
    bosses = [_cylinder(5.0, (x, y, 0), (x, y, lz)) for x, y in _BOSS_XY_MM]
    holes = [_cylinder(2.1, (x, y, lz - 12), (x, y, lz + 1)) for x, y in _BOSS_XY_MM]
    frames = (
        _frame("grasp", "grasp", _DOWN, (0, 0, lz - 10)),
        _frame("lid_seat", "insert", _DOWN, (0, 0, lz)),
        *(
            _frame(f"screw_{i + 1}", "screw", _DOWN, (x, y, lz))
            for i, (x, y) in enumerate(_BOSS_XY_MM)
        ),
    )
    solids = [floor, *walls, *bosses]
    return Part(
        "housing",
        _solid(solids, holes),
        tuple(TriangleMesh.from_trimesh(m) for m in solids),
        frames,
    )


def make_lid() -> Part:
    """The housing's lid: plate 100 x 70 x 4 mm with four M5 clearance holes (5.5 mm) over the
    bosses and a 20 x 20 x 10 mm knob to grasp; its `insert` frame (bottom centre, z down)
    goes onto the housing's `lid_seat`."""
    lx, ly, _ = _HOUSING_SIZE_MM
    plate = _box((lx, ly, 4), (0, 0, 2))
    knob = _box((20, 20, 10), (0, 0, 9))
    holes = [_cylinder(2.75, (x, y, -1), (x, y, 5)) for x, y in _BOSS_XY_MM]
    frames = (
        _frame("grasp", "grasp", _DOWN, (0, 0, 14)),
        _frame("insert", "insert", _DOWN, (0, 0, 0)),
        *(
            _frame(f"screw_{i + 1}", "screw", _DOWN, (x, y, 4))
            for i, (x, y) in enumerate(_BOSS_XY_MM)
        ),
    )
    pieces = tuple(TriangleMesh.from_trimesh(m) for m in (plate, knob))
    return Part("lid", _solid([plate, knob], holes), pieces, frames)
