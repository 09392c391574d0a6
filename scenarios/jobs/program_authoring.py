"""A touch program authored on the job's virtual cell, as an offline-programming user writes
one (`twincell author`): the work object on the part's nominal pose, the tool's data, and for
each surface point the user names an approach and a touch, solved on the cell's nominal arm
and followed in the virtual cell before a line of it is written.

A touch is a point of the part (its model's frame) and, optionally, the direction the tool
moves into the part; without one, the tool comes along the inward normal of the mesh's
surface nearest the point. The touch's TCP (the tool's tip ball's centre) stops the ball's
radius and `gap_m` before the surface, along the tool's axis (for a touch oblique to the
surface, farther where that keeps the ball MIN_CLEAR_M off it); the approach lies
`approach_m` back along the tool's axis. Where the
arm cannot make a touch as first solved (out of reach, a collision, a singularity, a joint
limit: the pre-motion check's findings), the tool is spun about its axis, 30 degrees at a
time, and the first spin the virtual cell passes is written: a touch none passes is refused
with what each spin met.

Nothing here reads the simulated truth: the part is its virtual model at its nominal pose.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from cell import nominal_T_base_table
from cell.cell_errors import UnreachableTargetError
from cell.kinematics import Kinematics
from cell.robot_arm import Robot
from models.model import ObjectModel
from models.robot import TABLE_TRAVEL, TOOLS
from models.targets import frame_from_z
from registration.shapes.mesh_shape import MeshModel
from scenarios.configuration.job_config import JobConfig
from scenarios.jobs.authoring_proposal import checked_change
from scenarios.jobs.job_plan import file_arm
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.operations import virtual_model
from scenarios.offline.premotion import check_program
from scenarios.offline.premotion_verdict import PremotionCheck
from scenarios.offline.program_plan import spun
from scenarios.offline.program_proposal import TURNS_DEG
from scenarios.offline.tcp_check import POINTERS
from scenarios.program.program_types import OfflineProgram, Operation, PlannedOperation
from scenarios.rapid.oframe import pose_text
from scenarios.rapid.rapid_text import configuration, rapid_identifier, tooldata_text
from scenarios.scenario_errors import ScenarioError

#: How far along its direction a named point is searched for the part's surface [m].
SEARCH_M = 0.003
#: A named point must lie this close to the surface along its direction [m].
ON_SURFACE_M = 1e-4
#: An oblique touch keeps its tip ball at least this far off the surface [m]; a touch more
#: oblique to the surface than MAX_OBLIQUE_DEG [deg] is refused.
MIN_CLEAR_M = 5e-4
MAX_OBLIQUE_DEG = 70.0
#: The tool's spins about its axis tried for a touch, in order [deg].
SPINS_DEG = (0.0, *TURNS_DEG)
#: Unused external axes of a robtarget (axis A is the table).
_UNUSED_AXES = ",".join(["9E+09"] * 5)


class AuthoringError(ScenarioError, ValueError):
    """A touch program cannot be authored as asked: what was asked, and what to change."""


class VirtualCellRefusalError(AuthoringError):
    """The touches as asked do not pass the virtual cell (another order, table position or
    turn of the part may)."""


@dataclass(frozen=True)
class TouchRequest:
    """A touch the user names: its `name`, a point of the part `point_m` (3,) [m] in the
    model's frame, and the direction the tool moves into the part (3,) (None: along the
    inward normal of the surface nearest the point)."""

    name: str
    point_m: np.ndarray
    direction: np.ndarray | None = None


@dataclass(frozen=True)
class AuthoredTouch:
    """A touch as written: where it meets the surface (3,) [m] and the tool's axis (3,), in
    the model's frame; the tool's spin about its axis the virtual cell passed [deg]; the
    planned approach and touch (poses and joints); and the RAPID names of its robtargets."""

    request: TouchRequest
    p_surface_m: np.ndarray
    axis: np.ndarray
    spin_deg: float
    planned: PlannedOperation
    approach_name: str
    touch_name: str


@dataclass(frozen=True)
class AuthoredProgram:
    """A touch program authored on the virtual cell: its RAPID `text`, the work object's
    uframe T_base_uframe (4, 4) (the part's nominal pose at the table position
    `table_position_m` [m]; oframe identity), the tool, the touches, and the pre-motion
    check of the whole program from the arm's home (passed)."""

    text: str
    T_base_uframe: np.ndarray
    table_position_m: float
    tool: str
    touches: tuple[AuthoredTouch, ...]
    check: PremotionCheck


def surface_touch(
    surface: MeshModel, request: TouchRequest, search_m: float = SEARCH_M
) -> tuple[np.ndarray, np.ndarray]:
    """Where `request` meets the part's `surface` and the tool's axis into it, in the model's
    frame: along its direction, the surface point within `search_m` [m] of the named point
    (sampled every 10 um); without a direction, the nearest surface point and the inward
    normal there. Raises AuthoringError for a point off the surface."""
    p = np.asarray(request.point_m, dtype=float)
    if request.direction is None:
        closest = surface.closest(p[None])
        assert closest.normals is not None  # a mesh has normals
        normal: np.ndarray = np.array(closest.normals[0], dtype=np.float64)
        if float(closest.distances[0]) > search_m:
            raise AuthoringError(
                f"touch {request.name}: the point {_mm(p)} mm lies "
                f"{closest.distances[0] * 1e3:.1f} mm from the part's surface; name a point "
                f"within {search_m * 1e3:g} mm of it (the model's frame and units)"
            )
        inward = normal / -float(np.linalg.norm(normal))
        return np.array(closest.points[0], dtype=np.float64), inward
    axis = np.asarray(request.direction, dtype=float)
    axis = axis / np.linalg.norm(axis)
    steps = np.linspace(-search_m, search_m, round(2 * search_m / 1e-5) + 1)
    distances = surface.closest(p + steps[:, None] * axis).distances
    best = int(np.argmin(distances))
    if distances[best] > ON_SURFACE_M:
        raise AuthoringError(
            f"touch {request.name}: the line through {_mm(p)} mm along {_unit(axis)} does not "
            f"meet the part's surface within {search_m * 1e3:g} mm of the point (it passes "
            f"{distances[best] * 1e3:.2f} mm from it); name a point on the surface, or no "
            "direction to touch along the surface's normal"
        )
    return p + steps[best] * axis, axis


def _mm(p: np.ndarray) -> str:
    return "(" + ", ".join(f"{v * 1e3:.1f}" for v in p) + ")"


def _unit(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{x:.3f}" for x in v) + ")"


@dataclass(frozen=True, eq=False)
class _Cell:
    """What a touch is solved and checked against: the tool's kinematics and TCP, the part's
    nominal pose in the base frame, and the check of a program from given joints."""

    kin: Kinematics
    T_flange_tcp: np.ndarray
    T_base_object: np.ndarray
    check: Callable[[tuple[PlannedOperation, ...], np.ndarray], PremotionCheck]


def _plan_touch(
    cell: _Cell, operation: Operation, spin_deg: float, q_from: np.ndarray
) -> PlannedOperation:
    """The operation solved on the nominal arm, seeded from the joints `q_from` (6,) [rad]."""
    T_touch = operation.T_object_touch
    T_app = operation.T_object_approach
    q_app = cell.kin.solve(cell.T_base_object @ T_app, q_from, cell.T_flange_tcp, extra_seeds=30)
    q_touch = cell.kin.solve(cell.T_base_object @ T_touch, q_app, cell.T_flange_tcp, extra_seeds=30)
    return PlannedOperation(
        operation,
        np.radians(spin_deg),
        T_touch,
        T_app,
        cell.T_base_object @ T_app,
        cell.T_base_object @ T_touch,
        q_app,
        q_touch,
    )


def _along_axis_m(surface: MeshModel, p_surface: np.ndarray, axis: np.ndarray, ball_m: float,
                  gap_m: float, name: str) -> float:  # fmt: skip
    """How far back along `axis` from the surface point the tip ball's centre stops [m]:
    ball + gap, or for a touch oblique to the surface (its inward normal at the point) the
    distance that keeps the ball MIN_CLEAR_M off the surface, if that is more. Raises
    AuthoringError for a touch more oblique than MAX_OBLIQUE_DEG."""
    _, face, _ = surface.tree.squared_distance(surface.vertices, surface.faces, p_surface[None])
    normal = np.asarray(surface.face_normals[int(face[0])], dtype=float)  # of the face there
    cos = abs(float(axis @ normal))
    if cos < np.cos(np.radians(MAX_OBLIQUE_DEG)):
        raise AuthoringError(
            f"touch {name}: its direction {_unit(axis)} meets the surface "
            f"{np.degrees(np.arccos(cos)):.0f} deg from its normal, more than "
            f"{MAX_OBLIQUE_DEG:g}: give a direction nearer the surface's normal, or none"
        )
    return max(ball_m + gap_m, (ball_m + MIN_CLEAR_M) / cos)


def _author_touch(
    cell: _Cell,
    request: TouchRequest,
    surface: MeshModel,
    ball_gap_m: tuple[float, float],
    approach_m: float,
    q_seed: np.ndarray,
    q_from: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, float, PlannedOperation]:
    """The touch's surface point, axis, the first spin the virtual cell passes (the joint
    move to its approach from `q_from` (6,) [rad] too) and its plan, solved from the seed
    `q_seed` (6,) [rad]; raises AuthoringError with what each spin met."""
    p_surface, axis = surface_touch(surface, request)
    along = _along_axis_m(surface, p_surface, axis, *ball_gap_m, request.name)
    T_first = frame_from_z(p_surface - along * axis, axis)
    met: list[str] = []
    for spin in SPINS_DEG:
        operation = Operation(request.name, spun(T_first, np.radians(spin)), approach_m)
        try:
            planned = _plan_touch(cell, operation, spin, q_seed)
        except UnreachableTargetError as exc:
            met.append(f"spin {spin:+.0f} deg: {exc}")
            continue
        check = cell.check((planned,), q_from)
        if check.ok:
            return p_surface, axis, spin, planned
        met.append(f"spin {spin:+.0f} deg: {check.problems[0]}")
    raise VirtualCellRefusalError(
        f"touch {request.name} at {_mm(p_surface)} mm along {_unit(axis)}: no spin of the tool "
        f"about its axis ({len(SPINS_DEG)} tried) passes the virtual cell; first {met[0]}; "
        "name another direction (NAME=X,Y,Z@DX,DY,DZ), another point, or another table "
        "position"
    )


def part_model(config: JobConfig) -> ObjectModel:
    """The job's part as the virtual cell has it (its model file, in SI units)."""
    obj = config.cell.object
    return virtual_model(obj.model, obj.units, None, config.operations.kind, config.seed)


def _job_cell(
    config: JobConfig, table_position_m: float, say: Callable[[str], None], virtual: ObjectModel
) -> tuple[Robot, _Cell]:
    """The job's arm and the tool's cell the touches are solved and checked in, the part's
    `virtual` model at its nominal pose."""
    lo, hi = TABLE_TRAVEL
    if not lo <= table_position_m <= hi:
        raise AuthoringError(
            f"table position {table_position_m:g} m is outside the table's travel "
            f"[{lo:g}, {hi:g}] m"
        )
    section, settings = config.operations, config.planning()
    T_table_object = nominal_pose(settings.placement, virtual.mesh.vertices)
    robot = file_arm(config, virtual, T_table_object, say)
    if not robot.rapid:
        raise AuthoringError(
            f"the cell's arm, the {robot.name}, runs no RAPID (an ABB arm does): write its "
            "program in its own language from `twincell author JOB --numbers`"
        )
    if section.tool not in POINTERS:
        raise AuthoringError(
            f"operations.tool {section.tool!r} has no pointer to touch with; the tools that "
            f"touch: {', '.join(POINTERS)}"
        )
    spec = next(t for t in TOOLS if t.name == section.tool)
    virtual_cell = job_virtual_cell(
        robot,
        config.cell.rack_xyz,
        virtual,
        T_table_object,
        config.calibration.enabled,
        settings.object_name,
    )
    kin = robot.kinematics().for_tool(section.tool)
    T_base_object = nominal_T_base_table(table_position_m) @ T_table_object

    def check(planned: tuple[PlannedOperation, ...], q_from: np.ndarray) -> PremotionCheck:
        program = OfflineProgram(section.tool, table_position_m, T_table_object, planned)
        return check_program(
            program,
            kin,
            virtual_cell,
            q_from,
            spec.T_tool_tcp,
            object_name=settings.object_name,
        )

    return robot, _Cell(kin, spec.T_tool_tcp, T_base_object, check)


def author_program(
    config: JobConfig,
    touches: Sequence[TouchRequest],
    approach_m: float = 0.06,
    gap_m: float = 0.001,
    table_position_m: float = 0.0,
    module: str = "Touches",
    say: Callable[[str], None] = lambda _msg: None,
) -> AuthoredProgram:
    """The touch program of `touches` for the job `config` (its cell, its part at its nominal
    pose, its tool: `operations.tool`), the table at `table_position_m` [m]: each touch's tip
    ball stopping `gap_m` [m] before the surface, its approach `approach_m` [m] back along the
    tool's axis, every move solved on the nominal arm and followed in the virtual cell (see
    the module's docstring). Raises AuthoringError naming the touch and what to change."""
    if not touches:
        raise AuthoringError("no touch named: give at least one (NAME=X,Y,Z)")
    names = [t.name for t in touches]
    if len(set(names)) != len(names):
        raise AuthoringError(f"touch names must differ, got {names}")
    if not (0.0 < approach_m <= 0.3 and 0.0 <= gap_m <= 0.05):
        raise AuthoringError(
            f"approach {approach_m * 1e3:g} mm and gap {gap_m * 1e3:g} mm: the approach must be "
            "in (0, 300] mm and the gap in [0, 50] mm"
        )
    virtual = part_model(config)
    try:
        return _authored(config, touches, approach_m, gap_m, table_position_m, module, virtual, say)
    except VirtualCellRefusalError as exc:
        say("the touches do not pass: looking for an order, a table position or a turn of the "
            "part that does")  # fmt: skip

        def attempt(job: JobConfig, table_m: float, order: Sequence[TouchRequest]) -> bool:
            return _passes(job, table_m, order, approach_m, gap_m, virtual)

        change = checked_change(config, table_position_m, touches, attempt, say)
        if change is None:
            raise
        raise AuthoringError(
            f"{exc}; proposed: {change} (with it every touch passes the virtual cell)"
        ) from None


def _passes(
    config: JobConfig,
    table_position_m: float,
    touches: Sequence[TouchRequest],
    approach_m: float,
    gap_m: float,
    virtual: ObjectModel,
) -> bool:
    try:
        _authored(config, touches, approach_m, gap_m, table_position_m, "Touches", virtual)
    except AuthoringError:
        return False
    return True


def _authored(
    config: JobConfig,
    touches: Sequence[TouchRequest],
    approach_m: float,
    gap_m: float,
    table_position_m: float,
    module: str,
    virtual: ObjectModel,
    say: Callable[[str], None] = lambda _msg: None,
) -> AuthoredProgram:
    """author_program's program for the part's `virtual` model, or AuthoringError naming the
    touch that does not pass."""
    robot, cell = _job_cell(config, table_position_m, say, virtual)
    surface = MeshModel(virtual.mesh.vertices, virtual.mesh.faces)
    ball_gap_m = (POINTERS[config.operations.tool][0], gap_m)
    q_seed = q_from = robot.q_home
    written: list[AuthoredTouch] = []
    for request in touches:
        p, axis, spin, planned = _author_touch(
            cell, request, surface, ball_gap_m, approach_m, q_seed, q_from
        )
        say(f"touch {request.name}: at {_mm(p)} mm, spun {spin:+.0f} deg, passes the virtual cell")
        base = rapid_identifier(request.name, "p")[:29]
        written.append(AuthoredTouch(request, p, axis, spin, planned, f"{base}App", base))
        q_seed, q_from = planned.q_touch, planned.q_approach
    check = cell.check(tuple(t.planned for t in written), robot.q_home)
    if not check.ok:
        raise VirtualCellRefusalError(
            f"the touches together do not pass the virtual cell: {check.summary}"
        )
    text = _module_text(config, cell, written, table_position_m, module, approach_m, gap_m)
    return AuthoredProgram(
        text, cell.T_base_object, table_position_m, config.operations.tool, tuple(written), check
    )


def _module_text(
    config: JobConfig,
    cell: _Cell,
    touches: list[AuthoredTouch],
    table_position_m: float,
    module: str,
    approach_m: float,
    gap_m: float,
) -> str:
    """The RAPID module of the authored touches (mm, quaternions scalar first)."""
    tool = rapid_identifier(config.operations.tool, "t")
    eax = f"[{table_position_m * 1e3:g},{_UNUSED_AXES}]"
    lines = [
        f"MODULE {module}",
        f"  ! Touches of the job {config.name} authored on its virtual cell (twincell author):",
        "  ! the work object's uframe on the part's nominal pose, the table at "
        f"{table_position_m * 1e3:g} mm;",
        f"  ! each touch's tip {gap_m * 1e3:g} mm before the surface, its approach "
        f"{approach_m * 1e3:g} mm back along the tool's axis.",
        f"  {tooldata_text(config.operations.tool)}",
        f'  PERS wobjdata wobjPart := [FALSE,TRUE,"",{pose_text(cell.T_base_object)},'
        "[[0,0,0],[1,0,0,0]]];",
        "  CONST speeddata vTouch := [20,500,5000,1000];",
    ]
    for touch in touches:
        planned = touch.planned
        for name, T, q in (
            (touch.approach_name, planned.T_object_approach, planned.q_approach),
            (touch.touch_name, planned.T_object_touch, planned.q_touch),
        ):
            conf = ",".join(str(v) for v in configuration(cell.kin, q))
            lines.append(f"  CONST robtarget {name} := [{pose_text(T)[1:-1]},[{conf}],{eax}];")
    lines += ["  PROC main()", "    ConfJ\\Off;", "    ConfL\\Off;"]
    for touch in touches:
        app, hit = touch.approach_name, touch.touch_name
        lines += [
            f"    ! {touch.request.name}",
            f"    MoveJ {app}, v500, z10, {tool}\\WObj:=wobjPart;",
            f"    MoveL {hit}, vTouch, fine, {tool}\\WObj:=wobjPart;",
            f"    MoveL {app}, v100, z10, {tool}\\WObj:=wobjPart;",
        ]
    lines += ["  ENDPROC", "ENDMODULE", ""]
    return "\n".join(lines)
