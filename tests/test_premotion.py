"""The pre-motion check: the skull job's corrected program in the virtual cell, and programs
broken on purpose (an object higher than believed, an approach in the table, a target out of
reach or beyond a joint limit, a straight wrist). Ground truth comes from the cell's geometry
(tool and arm dimensions, the job's offsets), the exact virtual mesh and Pinocchio, not from
the checker."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from igl import point_mesh_squared_distance

from cell.cell_errors import UnknownNameError
from cell.irb2400_arm import irb2400
from cell.virtual import VirtualCell
from models.robot import RACK_POS, SCREWER, TABLE_TOP_POS, ArmGeometry
from registration import transform_points
from scenarios.configuration.config_files import load_config
from scenarios.jobs.job_plan import object_models
from scenarios.offline.job_cell import job_virtual_cell
from scenarios.offline.nominal_placement import nominal_pose
from scenarios.offline.operations import target_operations
from scenarios.offline.premotion import check_program
from scenarios.offline.premotion_verdict import PremotionError, PremotionLimits
from scenarios.offline.program_plan import plan_program
from scenarios.program.program_types import OfflineProgram, Operation, PlannedOperation

#: The screwer's solids along its axis (models/robot/tools.py): the changer plate every tool
#: has (radius 32 mm, 16 mm thick at the flange), then its body (radius 30 mm, to 136 mm);
#: its pointer is a 3 mm ball whose centre is the TCP.
PLATE = (0.0, 0.016, 0.032)
BODY = (0.016, 0.136, 0.03)
TIP_RADIUS_M = 0.003
#: The forearm's collision capsule (models/robot/arm.py, link4): radius 70 mm, along x from
#: 0.2 m to 90 mm before the wrist centre.
FOREARM_RADIUS_M = 0.07
FOREARM_FROM_M = 0.2
FOREARM_SHORT_M = 0.09


def _cylinder_distance(
    p: np.ndarray, origin: np.ndarray, axis: np.ndarray, solid: tuple[float, float, float]
) -> float:
    """Signed distance [m] from point p to a solid cylinder along `axis` from `origin`."""
    s0, s1, radius = solid
    v = p - origin
    a = float(v @ axis)
    radial = float(np.linalg.norm(v - a * axis))
    da, dr = max(s0 - a, 0.0, a - s1), max(radial - radius, 0.0)
    if da == 0.0 and dr == 0.0:
        return -min(radius - radial, a - s0, s1 - a)
    return float(np.hypot(da, dr))


def plate_to_forearm_m(q5: float) -> float:
    """The screwer's signed distance [m] to the forearm at wrist bend q5 [rad], by geometry
    in the forearm's frame (the wrist centre at d4 along x, the tool axis turned by q5 about
    y; the other joints do not change it)."""
    g = ArmGeometry()
    axis = np.array([np.cos(q5), 0.0, -np.sin(q5)])
    flange = np.array([g.d4, 0.0, 0.0]) + g.d6 * axis
    segment = np.linspace([FOREARM_FROM_M, 0, 0], [g.d4 - FOREARM_SHORT_M, 0, 0], 3000)
    return (
        min(
            min(
                _cylinder_distance(p, flange, axis, PLATE),
                _cylinder_distance(p, flange, axis, BODY),
            )
            for p in segment
        )
        - FOREARM_RADIUS_M
    )


@pytest.fixture(scope="module")
def skull() -> dict:
    """The shipped skull job planned in a cell without errors: the virtual model at its
    nominal pose, the program as the pipeline's program stage solves it (from home), and the
    virtual cell the program is checked in."""
    config = load_config("skull")
    virtual, _real = object_models(config)
    T_table_object = nominal_pose(config.cell.object.placement, virtual.mesh.vertices)
    robot = irb2400()
    kin = robot.kinematics()
    section = config.operations
    program = plan_program(
        kin.for_tool(section.tool),
        SCREWER.T_tool_tcp,
        section.tool,
        target_operations(virtual, section),
        T_table_object,
        robot.q_home,
        section.spins,
    )
    cell = job_virtual_cell(
        robot, RACK_POS, virtual, T_table_object, calibrates=config.calibration.enabled
    )
    return {
        "config": config,
        "virtual": virtual,
        "T_table_object": T_table_object,
        "robot": robot,
        "kin": kin,
        "program": program,
        "cell": cell,
    }


def _check(skull: dict, program: OfflineProgram, **limits: float):
    return check_program(
        program,
        skull["kin"],
        skull["cell"],
        skull["robot"].q_home,
        SCREWER.T_tool_tcp,
        PremotionLimits(**limits),
    )


# -- the virtual cell ---------------------------------------------------------------------------
def test_virtual_cell_holds_the_tool_on_the_flange_and_measures_as_the_geometry_says(
    skull: dict,
) -> None:
    cell, robot, kin = skull["cell"], skull["robot"], skull["kin"]
    cell.set_tool("screwer")
    cell.set_table(0.0)
    q = robot.q_home.copy()
    for q5_deg in (95.0, 100.0, 104.0, 106.0, 108.0, 110.0, 112.0):
        q[4] = np.deg2rad(q5_deg)
        q[3], q[5] = 0.3, -1.1  # neither changes the tool against the forearm
        cell.set_joints(q)
        # The tool frame is the flange's (Pinocchio's nominal arm): 1 um, 1 urad.
        T_tool, T_flange = cell.T_world_body("tool_screwer"), kin.fk(q)
        assert np.linalg.norm(T_tool[:3, 3] - T_flange[:3, 3]) < 1e-6
        assert np.linalg.norm(T_tool[:3, :3] - T_flange[:3, :3]) < 1e-6
        near = {(c.body, c.other): c.distance_m for c in cell.contacts(0.05)}
        expected = plate_to_forearm_m(np.deg2rad(q5_deg))
        if expected < 0.05:  # reported within the margin, to 0.05 mm of the geometry
            assert near[("tool_screwer", "link4")] == pytest.approx(expected, abs=5e-5)
        else:
            assert ("tool_screwer", "link4") not in near
        # The wrist's own bodies hold the tool: never reported.
        assert ("tool_screwer", "link5") not in near and ("tool_screwer", "link6") not in near
    # Bad input raises, naming what is valid.
    with pytest.raises(UnknownNameError, match="available tools"):
        cell.set_tool("drill")
    with pytest.raises(ValueError, match="travel"):
        cell.set_table(0.7)
    with pytest.raises(ValueError, match="margin"):
        cell.contacts(-1e-3)


def test_virtual_cell_sees_the_object_where_the_exact_mesh_is(skull: dict) -> None:
    """At each approach and touch of the program, the tool's distance to the object is the
    tip ball's distance to the exact virtual mesh, to 0.05 mm (near the object the cell
    measures its own surface, not its convex pieces)."""
    cell, program, kin, virtual = skull["cell"], skull["program"], skull["kin"], skull["virtual"]
    cell.set_tool("screwer")
    cell.set_table(program.table_position_m)
    T_base_object = program.T_base_object
    touch_gap = skull["config"].operations.touch_offset_m - TIP_RADIUS_M  # 1 mm
    for planned in program.operations[:3]:
        for q, T_tcp in (
            (planned.q_approach, planned.T_base_approach),
            (planned.q_touch, planned.T_base_touch),
        ):
            cell.set_joints(q)
            near = {(c.body, c.other): c.distance_m for c in cell.contacts(0.1)}
            tip = transform_points(np.linalg.inv(T_base_object), T_tcp[None, :3, 3])
            d2, _, _ = point_mesh_squared_distance(tip, virtual.mesh.vertices, virtual.mesh.faces)
            exact = float(np.sqrt(d2[0])) - TIP_RADIUS_M
            assert near[("tool_screwer", "object")] == pytest.approx(exact, abs=5e-5)
            assert np.allclose(kin.fk(q) @ SCREWER.T_tool_tcp, T_tcp, atol=1e-6)
        assert exact == pytest.approx(touch_gap, abs=2e-4)  # the touch: the ball 1 mm short


# -- (a) a program that passes, and not vacuously -----------------------------------------------
def test_skull_program_passes(skull: dict) -> None:
    program = skull["program"]
    check = _check(skull, program)
    assert check.ok and check.problems == (), check.summary
    assert check.summary.startswith("the corrected program passes the pre-motion check")
    steps = ("approach", "approach -> touch", "touch -> approach")
    names = [f"{p.operation.name}: {m}" for p in program.operations for m in steps]
    assert [m.name for m in check.moves] == names
    # Sampled as finely as asked: a 60 mm approach line at 5 mm steps has >= 12 poses; a joint
    # move at least one pose per 0.02 rad of its largest joint's turn.
    approach_m = skull["config"].operations.approach_m
    q = skull["robot"].q_home
    for k, planned in enumerate(program.operations):
        joint, line_in, line_out = check.moves[3 * k : 3 * k + 3]
        turn = float(np.max(np.abs(planned.q_approach - q)))
        assert joint.kind == "joint" and joint.samples >= turn / 0.02
        assert line_in.samples >= approach_m / 0.005 - 1e-9
        assert line_out.samples >= approach_m / 0.005 - 1e-9
        # The touch lines come to the object's surface: the ball's 1 mm short of the entry.
        assert line_in.touch_gap_m == pytest.approx(1e-3, abs=3e-4)
        q = planned.q_approach
    # The clearance matters: asked for 1 mm more than the closest approach, the same program
    # collides there; asked for a 2 mm gap at the touch, every line into a touch is refused
    # (a line out of it starts at the touch, which the line in has checked).
    move, closest = check.closest
    assert closest.distance_m > check.limits.clearance_m
    stricter = _check(skull, program, clearance_m=closest.distance_m + 1e-3)
    assert not stricter.ok and stricter.kinds() == ("collision",)
    assert any(
        p.move == move and f"{closest.body} comes within" in p.detail and closest.other in p.detail
        for p in stricter.problems
    ), stricter.summary
    gap = _check(skull, program, touch_clearance_m=2e-3)
    refused = {p.move for p in gap.problems if "tool_screwer comes within" in p.detail}
    assert refused == {m.name for m in check.moves if m.name.endswith("approach -> touch")}


def test_the_wrist_bend_of_the_skull_job_is_measured_as_the_geometry_says(
    skull: dict,
) -> None:
    """The shipped job's hole that needs the wrist bent most (about 88 deg, the parietal
    hole): at its approach the changer plate comes closest to the forearm, at the distance
    the geometry gives; a clearance beyond it refuses the program there, naming the tool and
    the forearm."""
    program = skull["program"]
    planned = max(program.operations, key=lambda op: abs(op.q_approach[4]))
    name = planned.operation.name
    assert np.rad2deg(abs(planned.q_approach[4])) > 80.0
    gap = plate_to_forearm_m(planned.q_approach[4])
    check = _check(skull, program)
    back = next(m for m in check.moves if m.name == f"{name}: touch -> approach")
    assert back.closest.distance_m == pytest.approx(gap, abs=5e-5)
    assert (back.closest.body, back.closest.other) == ("tool_screwer", "link4")
    stricter = _check(skull, program, clearance_m=gap + 1e-3)
    assert not stricter.ok
    there = [p for p in stricter.problems if p.move.split(":")[0] == name]
    assert there, stricter.summary
    assert all("tool_screwer comes within" in p.detail and "link4" in p.detail for p in there)


# -- (b) collisions -----------------------------------------------------------------------------
def test_object_higher_than_believed_collides(skull: dict) -> None:
    """The program checked against the object 0.1 m higher than it was corrected for: the
    tool runs into the object on the way to the first approach (60 mm off the surface)."""
    T = skull["T_table_object"].copy()
    T[2, 3] += 0.1
    cell = job_virtual_cell(skull["robot"], RACK_POS, skull["virtual"], T)
    program = skull["program"]
    check = check_program(program, skull["kin"], cell, skull["robot"].q_home, SCREWER.T_tool_tcp)
    assert not check.ok and "collision" in check.kinds()
    hits = [p for p in check.problems if p.kind == "collision" and "touches object" in p.detail]
    assert any(p.move == "kocher_right: approach" for p in hits), check.summary
    assert any(p.move == "kocher_right: approach -> touch" for p in hits)
    assert "collides" in check.summary and "object" in check.summary


def test_approach_in_the_table_collides(skull: dict) -> None:
    """The first approach moved beside the object, 1 cm below the table top: the joint move
    puts the tool into the table."""
    program, kin = skull["program"], skull["kin"]
    first = program.operations[0]
    T_app = first.T_base_approach.copy()
    T_app[:2, 3] = [TABLE_TOP_POS[0] - 0.25, program.table_position_m - 0.2]
    T_app[2, 3] = TABLE_TOP_POS[2] - 0.01
    q_app = kin.for_tool("screwer").solve(T_app, first.q_approach, SCREWER.T_tool_tcp)
    moved = replace(first, T_base_approach=T_app, q_approach=q_app)
    broken = replace(program, operations=(moved, *program.operations[1:]))
    check = _check(skull, broken)
    assert not check.ok
    table = [p for p in check.problems if p.kind == "collision" and "table" in p.detail]
    assert any(p.move == "kocher_right: approach" for p in table), check.summary
    assert "tool_screwer touches table" in check.summary


# -- (c) reach and joint limits -----------------------------------------------------------------
def test_touch_beyond_reach_is_refused(skull: dict) -> None:
    program = skull["program"]
    first = program.operations[0]
    T_far = first.T_base_touch.copy()
    T_far[0, 3] += 1.0  # 2.2 m from the base: the arm reaches 1.55 m
    broken = replace(program, operations=(replace(first, T_base_touch=T_far),))
    check = _check(skull, broken)
    reach = [p for p in check.problems if p.kind == "reach"]
    assert [p.move for p in reach] == ["kocher_right: approach -> touch"], check.summary
    assert "no IK solution" in reach[0].detail
    assert "leaves the arm's reach" in check.summary


def test_joints_beyond_or_at_their_limits_are_refused(skull: dict) -> None:
    program, kin = skull["program"], skull["kin"]
    first = program.operations[0]
    # With the screwer in hand joint 5 stops at 110 deg (the arm's own stop is 120 deg).
    upper5 = float(kin.for_tool("screwer").upper[4])
    assert np.rad2deg(upper5) == pytest.approx(110.0)
    for q5, words in ((upper5 + 0.05, "beyond its limit"), (upper5 - 0.005, "within 1 deg of")):
        q = first.q_approach.copy()
        q[4] = q5
        T_app = kin.fk(q) @ SCREWER.T_tool_tcp
        T_touch = T_app.copy()
        T_touch[:3, 3] += 0.02 * T_app[:3, 2]
        bent = replace(first, q_approach=q, T_base_approach=T_app, T_base_touch=T_touch)
        check = _check(skull, replace(program, operations=(bent,)))
        limits = [p for p in check.problems if p.kind == "joint_limit"]
        assert limits and limits[0].move == "kocher_right: approach", check.summary
        assert f"joint5 at {np.rad2deg(q5):.1f} deg, {words}" in limits[0].detail
        assert f"its limit {np.rad2deg(upper5):.1f} deg" in limits[0].detail


# -- (d) singularity ----------------------------------------------------------------------------
def _single(skull: dict, q_approach: np.ndarray) -> OfflineProgram:
    """One touch 50 mm along the tool axis from the approach at joints q_approach."""
    kin = skull["kin"]
    T_app = kin.fk(q_approach) @ SCREWER.T_tool_tcp
    T_touch = T_app.copy()
    T_touch[:3, 3] += 0.05 * T_app[:3, 2]
    op = Operation("straight_wrist", np.eye(4), 0.05)
    planned = PlannedOperation(
        op, 0.0, np.eye(4), np.eye(4), T_app, T_touch, q_approach, q_approach
    )
    return OfflineProgram("screwer", 0.0, np.eye(4), (planned,))


def test_straight_wrist_is_flagged_as_a_singularity(skull: dict) -> None:
    q = np.array([0.0, 0.0, 0.0, 0.0, np.deg2rad(2.0), 0.0])  # the flange forward, high up
    check = _check(skull, _single(skull, q))
    assert check.kinds() == ("singularity",), check.summary
    # Both lines, over their whole length; the joint move there is no line: not flagged.
    assert [(p.move, p.detail[-18:]) for p in check.problems] == [
        ("straight_wrist: approach -> touch", "from 10 % to 100 %"),
        ("straight_wrist: touch -> approach", "from 10 % to 100 %"),
    ]
    # The same lines with the wrist bent 30 deg pass.
    q[4] = np.deg2rad(30.0)
    assert _check(skull, _single(skull, q)).ok
    # The measure: the smallest singular value of the flange's Jacobian, 0.44 sin(q5) near
    # the straight wrist on this arm (0.04 is about 5 deg).
    kin = skull["kin"]
    for q5_deg in (1.0, 3.0, 5.0, 8.0):
        q[4] = np.deg2rad(q5_deg)
        sigma = np.linalg.svd(kin.jacobian(q), compute_uv=False)[-1]
        assert sigma == pytest.approx(0.44 * np.sin(q[4]), rel=0.03)


def test_bad_settings_raise(skull: dict) -> None:
    with pytest.raises(PremotionError, match="step_m"):
        PremotionLimits(step_m=0.0)
    with pytest.raises(PremotionError, match="clearance_m"):
        PremotionLimits(clearance_m=-1e-3)
    with pytest.raises(PremotionError, match="q_start"):
        check_program(
            skull["program"], skull["kin"], skull["cell"], np.zeros(5), SCREWER.T_tool_tcp
        )
    with pytest.raises(UnknownNameError, match="available tools"):
        check_program(
            replace(skull["program"], tool="drill"),
            skull["kin"],
            VirtualCell.of(skull["robot"], RACK_POS),
            skull["robot"].q_home,
            SCREWER.T_tool_tcp,
        )
